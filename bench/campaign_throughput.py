"""Campaign throughput: a Dask campaign against the bare batch engine, and 1 vs 2 workers.

The scene is ``bench/batch_throughput.py``'s batch with effects (gravity gradient on a 7000 km
orbit and viscous damping, 1 ms RK4 steps); every run has its own inertia tensor (second
moments dispersed 5 %, principal axes uniform on SO(3)), attitude (uniform on SO(3)), rates and
damping coefficients. ``--runs`` runs (default 10⁵) are advanced ``--steps`` steps with
``--outputs`` output times.

* **bare batch**: one :class:`SceneBatch` of every run in this process, the parameters drawn
  beforehand (not timed), advanced through the output times: the engine alone, in the CPU
  seconds of the thread that runs it (the idle cluster's scheduler threads in this process
  are not the engine's).
* **campaign, N workers**: :func:`run_campaign` on a :func:`local_cluster` of N
  single-threaded worker processes (what ``campaign`` starts), started beforehand (its
  start-up is reported apart): drawing the parameters, the chunk tasks, sending results
  back, the Parquet files, gathering the runs and the statistics (the PNG is timed apart: a
  fixed cost of matplotlib).

One cluster is alive at a time (the 1-worker one, then the 2-worker one), so a campaign is
billed for its own cluster only. The bare batch and the 1-worker campaign are timed
``--repeats`` times, interleaved, then the 2-worker campaign, in wall-clock and CPU seconds
(a campaign's: this process's, which holds the client and the scheduler, and every process it
started: the workers and their nannies); the best
of each gives the ratios: the campaign's overhead on one worker against the bare batch (at
most 15 % at 10⁵ runs is the target), and the speed-up from 1 to 2 workers. CPU seconds
are what other processes on a shared machine disturb least (the load average is printed).
The runs of both campaigns are checked to be identical bit for bit (exit 1 otherwise).

Prints one Markdown summary (or writes it to ``--output PATH``); keeps no files.

Usage: ``python bench/campaign_throughput.py [--runs 100000] [--steps 200] [--outputs 4]
[--repeats 3] [--output PATH]``.
"""

from __future__ import annotations

import argparse
import os
from pathlib import Path
import shutil
import sys
import tempfile
import time
from typing import Any

import numpy as np
import psutil

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO))

from rigid_body_attitude.core.dynamics.batch import SceneBatch  # noqa: E402
from rigid_body_attitude.tools.campaign import (  # noqa: E402
    dask_client, METRICS, read_runs, run_campaign, sample_runs, spec_from_mapping)
from rigid_body_attitude.tools.campaign.plot import write_envelopes  # noqa: E402

STEP = 1e-3
SCENE = {'name': 'gravity_gradient_damped', 'rate_source': 'dynamics', 'integrator': 'rk4',
         'step': STEP,
         'body': {'mass': 500.0, 'inertia': {'moments': [400.0, 200.0, 300.0]}},
         'effects': [{'gravity_gradient': {'orbit_radius': 7.0e6}},
                     {'viscous_damping': {'coefficient': 0.5}}]}
TARGET_OVERHEAD = 0.15


def campaign_spec(runs: int, steps: int, outputs: int) -> Any:
    """The benchmark's campaign."""
    duration = steps * STEP
    return spec_from_mapping({
        'name': 'bench', 'scene': SCENE, 'runs': runs, 'seed': 2026, 'duration': duration,
        'output_times': [duration * (k + 1) / outputs for k in range(outputs)],
        'dispersions': {'inertia': {'second_moments_sigma': 0.05, 'axes': 'uniform'},
                        'attitude': 'uniform',
                        'omega_body': {'sigma': [0.01, 0.01, 0.01]},
                        'effects': {'viscous_damping': {'coefficient': {
                            'uniform': [0.0, 1.0]}}}}})


def bare_batch(spec: Any) -> tuple[float, float]:
    """Wall and CPU seconds of the batch engine alone on every run (parameters drawn
    beforehand)."""
    parameters = sample_runs(spec, np.arange(spec.runs))
    start, cpu = time.perf_counter(), time.thread_time()
    batch = SceneBatch(spec.scene, parameters.attitude, parameters.omega_body,
                       inertia=parameters.inertia, effect_parameters=parameters.effects)
    for output_time in spec.output_times:
        batch.advance_to(output_time)
    return time.perf_counter() - start, time.thread_time() - cpu


def _children_cpu() -> float:
    """CPU seconds the living processes started by this one (workers, nannies) have used."""
    total = 0.0
    for child in psutil.Process().children(recursive=True):
        try:
            times = child.cpu_times()
        except psutil.Error:
            continue
        total += times.user + times.system
    return total


def campaign(spec: Any, client: Any, folder: Path) -> tuple[float, float]:
    """Wall and CPU seconds (this process: client and scheduler; its workers and nannies)
    of a whole campaign (without the PNG) on ``client``'s workers."""
    shutil.rmtree(folder, ignore_errors=True)
    children = _children_cpu()
    start, cpu = time.perf_counter(), time.process_time()
    run_campaign(spec, folder, client=client, plot=False)
    wall, own = time.perf_counter() - start, time.process_time() - cpu
    return wall, own + _children_cpu() - children


def _median(values: list[float]) -> float:
    return float(np.median(values))


def markdown(args: argparse.Namespace, times: dict[str, list[float]],
             cpu: dict[str, list[float]], startup: dict[str, float], plot_seconds: float,
             identical: bool) -> list[str]:
    """The Markdown summary: what was measured, the table, the overhead and the scaling."""
    best = {name: min(values) for name, values in times.items()}
    best_cpu = {name: min(values) for name, values in cpu.items()}
    body_steps = args.runs * args.steps
    cpu_overhead = best_cpu['1 worker'] / best_cpu['bare'] - 1.0
    wall_overhead = best['1 worker'] / best['bare'] - 1.0
    repeats = 'One run of each' if args.repeats == 1 else \
        f'Best of {args.repeats} interleaved repetitions'
    load = ', '.join(f'{value:.1f}' for value in os.getloadavg())
    lines = [
        f'`python bench/campaign_throughput.py --steps {args.steps}`: {args.runs} runs of '
        f'the batch-with-effects scene (gravity gradient and viscous damping, 1 ms RK4 steps), '
        f'each with its own inertia tensor (axes uniform on SO(3)), attitude, rates and '
        f'damping, {args.steps} steps with {args.outputs} output times. "bare batch": one '
        f'`SceneBatch` of every run in one process, parameters drawn beforehand. "campaign": '
        f'`run_campaign` on a `local_cluster` of single-threaded worker processes started '
        f'beforehand: drawing the parameters, the chunk tasks (8192 runs each), the results '
        f'sent back, written as Parquet, checked and summarised (the PNG apart). {repeats}, '
        f'wall-clock and CPU seconds (the bare batch\'s: its thread\'s; a campaign\'s: the '
        f'client process, which also holds the scheduler, and the workers and nannies, one '
        f'cluster alive at a time); {len(os.sched_getaffinity(0))} CPUs shared with other '
        f'users (load average {load} over 1, 5 and 15 minutes at the end), so wall-clock '
        f'times are those of a busy machine and CPU seconds the steadier measure.', '',
        '| engine | best [s] | median [s] | body-steps/s (best) | CPU [s] (best) |',
        '|---|---:|---:|---:|---:|']
    for name, values in times.items():
        label = 'bare batch' if name == 'bare' else f'campaign, {name}'
        lines.append(f'| {label} | {best[name]:.2f} | {_median(values):.2f} | '
                     f'{body_steps / best[name]:.3g} | {best_cpu[name]:.2f} |')
    verdict = 'met' if cpu_overhead <= TARGET_OVERHEAD else 'NOT met'
    started = ', '.join(f'{name} {seconds:.1f} s' for name, seconds in startup.items())
    lines += [
        '',
        f'- campaign overhead on 1 worker against the bare batch at {args.runs} runs: '
        f'{cpu_overhead * 100:.1f} % in CPU seconds (target at most '
        f'{TARGET_OVERHEAD * 100:.0f} %: {verdict}), {wall_overhead * 100:.1f} % in '
        f'wall-clock seconds on the busy machine',
        f'- scaling from 1 to 2 local workers: x{best["1 worker"] / best["2 workers"]:.2f} '
        f'(wall-clock)',
        f'- runs identical bit for bit on 1 and 2 workers: {identical}',
        f'- fixed costs outside the table: cluster start-up ({started}) and the summary PNG '
        f'({plot_seconds:.1f} s)']
    return lines


def main(argv: list[str] | None = None) -> int:
    """Measure; print the Markdown summary (or write it to ``--output``); 1 if the runs
    differ."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--runs', type=int, default=100_000)
    parser.add_argument('--steps', type=int, default=200)
    parser.add_argument('--outputs', type=int, default=4)
    parser.add_argument('--repeats', type=int, default=3)
    parser.add_argument('--output', type=Path, default=None,
                        help='write the Markdown summary to this file instead of printing it')
    args = parser.parse_args(argv)
    spec = campaign_spec(args.runs, args.steps, args.outputs)
    work = Path(tempfile.mkdtemp(prefix='campaign_bench_'))
    times: dict[str, list[float]] = {'bare': [], '1 worker': [], '2 workers': []}
    cpu: dict[str, list[float]] = {name: [] for name in times}
    startup: dict[str, float] = {}
    try:
        for workers, name in ((1, '1 worker'), (2, '2 workers')):
            begin = time.perf_counter()
            with dask_client(workers=workers) as client:
                client.run(lambda: __import__('rigid_body_attitude.tools.campaign'))
                startup[name] = time.perf_counter() - begin
                for _ in range(args.repeats):
                    measured = [('bare', bare_batch(spec))] if workers == 1 else []
                    measured.append((name, campaign(spec, client, work / f'{workers} workers')))
                    for label, (wall, seconds) in measured:
                        times[label].append(wall)
                        cpu[label].append(seconds)
        one, two = read_runs(work / '1 workers', spec), read_runs(work / '2 workers', spec)
        identical = all(np.array_equal(one[k], two[k], equal_nan=one[k].dtype.kind == 'f')
                        for k in one)
        begin = time.perf_counter()
        write_envelopes(work / 'summary.png', np.linspace(0, 1, args.outputs + 1),
                        spec.percentiles, {name: np.zeros((3, args.outputs + 1))
                                           for name in one if name in METRICS}, 'bench')
        plot_seconds = time.perf_counter() - begin
    finally:
        shutil.rmtree(work, ignore_errors=True)
    text = '\n'.join(markdown(args, times, cpu, startup, plot_seconds, identical)) + '\n'
    if args.output is None:
        print(text, end='')
    else:
        args.output.write_text(text)
    return 0 if identical else 1


if __name__ == '__main__':
    sys.exit(main())
