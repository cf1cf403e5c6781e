"""Campaign throughput: a Dask campaign against the bare batch engine, and 1 vs 2 workers.

The scene is ``bench/batch_throughput.py``'s batch with effects (gravity gradient on a 7000 km
orbit and viscous damping, 1 ms RK4 steps); every run has its own inertia tensor (second
moments dispersed 5 %, principal axes uniform on SO(3)), attitude (uniform on SO(3)), rates and
damping coefficients. ``--runs`` runs (default 10⁵) are advanced ``--steps`` steps with
``--outputs`` output times.

* **bare batch**: one :class:`SceneBatch` of every run in this process, the parameters drawn
  beforehand (not timed), advanced through the output times: the engine alone.
* **campaign, N workers**: :func:`run_campaign` on a ``LocalCluster`` of N single-threaded
  worker processes, started beforehand (its start-up is reported apart): drawing the
  parameters, the chunk tasks, sending results back, the Parquet files, reading them back and
  the statistics (the PNG is timed apart: a fixed cost of matplotlib).

Each is timed ``--repeats`` times, interleaved, in wall-clock and CPU seconds (a campaign's:
its worker processes' and this process's, which holds the client and the scheduler); the best
of each gives the ratios: the campaign's overhead on one worker against the bare batch (the
issue asks for at most 15 % at 10⁵ runs), and the speed-up from 1 to 2 workers. CPU seconds
are what other processes on a shared machine disturb least (the load average is printed).
The runs of both campaigns are checked to be identical bit for bit (exit 1 otherwise).

Usage: ``python bench/campaign_throughput.py [--runs 100000] [--steps 200] [--outputs 4]
[--repeats 3] [--json PATH]``.
"""

from __future__ import annotations

import argparse
import json
import logging
import os
from pathlib import Path
import shutil
import sys
import tempfile
import time
from typing import Any

import numpy as np

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO))

from distributed import Client, LocalCluster  # noqa: E402

from rigid_body_attitude.core.batch import SceneBatch  # noqa: E402
from rigid_body_attitude.tools.campaign import (  # noqa: E402
    read_runs, run_campaign, sample_runs, spec_from_mapping)
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
    start, cpu = time.perf_counter(), time.process_time()
    batch = SceneBatch(spec.scene, parameters.attitude, parameters.omega_body,
                       inertia=parameters.inertia, effect_parameters=parameters.effects)
    for output_time in spec.output_times:
        batch.advance_to(output_time)
    return time.perf_counter() - start, time.process_time() - cpu


def _workers_cpu(client: Any) -> float:
    """CPU seconds the cluster's worker processes have used so far."""
    return float(sum(client.run(time.process_time).values()))


def campaign(spec: Any, client: Any, folder: Path) -> tuple[float, float]:
    """Wall and CPU seconds (workers, and this process: client and scheduler) of a whole
    campaign (without the PNG) on ``client``'s workers."""
    shutil.rmtree(folder, ignore_errors=True)
    workers = _workers_cpu(client)
    start, cpu = time.perf_counter(), time.process_time()
    run_campaign(spec, folder, client=client, plot=False)
    wall, own = time.perf_counter() - start, time.process_time() - cpu
    return wall, own + _workers_cpu(client) - workers


def main(argv: list[str] | None = None) -> int:
    """Measure, print a Markdown table, optionally save JSON; 1 if the runs differ."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--runs', type=int, default=100_000)
    parser.add_argument('--steps', type=int, default=200)
    parser.add_argument('--outputs', type=int, default=4)
    parser.add_argument('--repeats', type=int, default=3)
    parser.add_argument('--json', type=Path, default=None)
    args = parser.parse_args(argv)
    spec = campaign_spec(args.runs, args.steps, args.outputs)
    work = Path(tempfile.mkdtemp(prefix='campaign_bench_'))
    times: dict[str, list[float]] = {'bare': [], '1 worker': [], '2 workers': []}
    cpu: dict[str, list[float]] = {name: [] for name in times}
    startup: dict[str, float] = {}
    clusters = {}
    try:
        for workers in (1, 2):
            begin = time.perf_counter()
            cluster = LocalCluster(n_workers=workers, threads_per_worker=1, processes=True,
                                   dashboard_address=':0', silence_logs=logging.ERROR)
            clusters[workers] = (cluster, Client(cluster))
            clusters[workers][1].run(lambda: __import__('rigid_body_attitude.tools.campaign'))
            startup[f'{workers} worker{"s" if workers > 1 else ""}'] = \
                time.perf_counter() - begin
        for _ in range(args.repeats):
            for name, (wall, seconds) in [('bare', bare_batch(spec))] + [
                    (f'{n} worker{"s" if n > 1 else ""}',
                     campaign(spec, clusters[n][1], work / f'{n} workers')) for n in (1, 2)]:
                times[name].append(wall)
                cpu[name].append(seconds)
        one, two = read_runs(work / '1 workers', spec), read_runs(work / '2 workers', spec)
        identical = all(np.array_equal(one[k], two[k], equal_nan=one[k].dtype.kind == 'f')
                        for k in one)
        begin = time.perf_counter()
        write_envelopes(work / 'summary.png', np.linspace(0, 1, args.outputs + 1),
                        spec.percentiles, {name: np.zeros((3, args.outputs + 1))
                                           for name in one if name in (
                                               'pointing_error_deg', 'nutation_deg',
                                               'momentum_change', 'energy_change', 'rate')},
                        'bench')
        plot_seconds = time.perf_counter() - begin
    finally:
        for cluster, client in clusters.values():
            client.close()
            cluster.close()
        shutil.rmtree(work, ignore_errors=True)
    best = {name: min(values) for name, values in times.items()}
    body_steps = args.runs * args.steps
    overhead = best['1 worker'] / best['bare'] - 1.0
    cpu_overhead = min(cpu['1 worker']) / min(cpu['bare']) - 1.0
    scaling = best['1 worker'] / best['2 workers']
    print(f'{args.runs} runs x {args.steps} steps ({args.outputs} output times), '
          f'{len(clusters)} clusters; load average {os.getloadavg()[0]:.2f}')
    print('| engine | best s | median s | body-steps/s (best) | CPU s (best) |')
    print('|---|---:|---:|---:|---:|')
    for name, values in times.items():
        print(f'| {name} | {min(values):.2f} | {float(np.median(values)):.2f} | '
              f'{body_steps / min(values):.3g} | {min(cpu[name]):.2f} |')
    print(f'\ncampaign CPU overhead on 1 worker vs the bare batch: {cpu_overhead * 100:.1f} %; '
          f'wall-clock overhead: {overhead * 100:.1f} % '
          f'(target <= {TARGET_OVERHEAD * 100:.0f} %); 2 workers vs 1: x{scaling:.2f}; '
          f'cluster start-up {startup}; PNG {plot_seconds:.2f} s; runs identical on 1 and '
          f'2 workers: {identical}')
    if args.json is not None:
        args.json.parent.mkdir(parents=True, exist_ok=True)
        args.json.write_text(json.dumps({
            'runs': args.runs, 'steps': args.steps, 'outputs': args.outputs,
            'times_s': times, 'cpu_s': cpu, 'best_s': best, 'overhead': overhead,
            'cpu_overhead': cpu_overhead, 'scaling_1_to_2': scaling,
            'cluster_startup_s': startup, 'plot_s': plot_seconds, 'identical': identical,
            'body_steps': body_steps, 'cpus': len(os.sched_getaffinity(0)),
            'load_average_1min': os.getloadavg()[0]}, indent=1))
    return 0 if identical else 1


if __name__ == '__main__':
    sys.exit(main())
