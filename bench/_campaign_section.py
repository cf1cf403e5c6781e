"""The "Campaigns on Dask" section of ``docs/performance.md``, from
``bench/results/campaign/throughput*.json`` (``bench/campaign_throughput.py --json``: one
table per file, e.g. 200 and 1000 steps per run).

Used by ``bench/performance_report.py``.
"""

from __future__ import annotations

from typing import List

TARGET_OVERHEAD = 0.15


def campaign_section(results: List[dict]) -> List[str]:
    """Markdown lines: per result, the table of times and the overhead and scaling."""
    if not results:
        return []
    lines = ['## Campaigns on Dask (`campaign`)', '']
    for result in results:
        lines += _result_lines(result)
    lines += [
        'What a campaign adds to the engine is a cost per run (drawing its parameters, its '
        'metrics at the output times, its Parquet row written and read back) and the CPU of '
        'Dask\'s own processes while it runs, not a cost per step: '
        'its share falls as runs get longer, as the tables with more steps per run show. '
        'Scaling to 2 workers is bounded by the machine: both of its CPUs are shared with '
        'other users, and the client (writing the chunks) runs beside the workers.', '']
    return lines


def _result_lines(result: dict) -> List[str]:
    body_steps = result['body_steps']
    lines = [
        f'`python bench/campaign_throughput.py --steps {result["steps"]}`: '
        f'{result["runs"]} runs of the batch-with-effects scene (gravity gradient and viscous '
        f'damping, 1 ms RK4 steps), each with its own inertia tensor (axes uniform on SO(3)), '
        f'attitude, rates and damping, {result["steps"]} steps with {result["outputs"]} output '
        f'times. "bare batch": one `SceneBatch` of every run in one process, parameters drawn '
        f'beforehand. "campaign": `run_campaign` on a `LocalCluster` of single-threaded worker '
        f'processes started beforehand: drawing the parameters, the chunk tasks (8 192 runs '
        f'each), the results sent back and written as Parquet, read back, checked and '
        f'summarised (the PNG apart). {_repeats(len(result["times_s"]["bare"]))}, '
        f'wall-clock and CPU seconds (a campaign\'s: its workers\' and the client\'s, '
        f'which also holds the scheduler); {result["cpus"]} CPUs shared with other '
        f'users (load average {result["load_average_1min"]:.1f} at the end), so wall-clock '
        f'times are those of a busy machine and CPU seconds the steadier measure.', '',
        '| engine | best [s] | median [s] | body-steps/s (best) | CPU [s] (best) |',
        '|---|---:|---:|---:|---:|']
    for name, values in result['times_s'].items():
        ordered = sorted(values)
        median = ordered[len(ordered) // 2] if len(ordered) % 2 else \
            0.5 * (ordered[len(ordered) // 2 - 1] + ordered[len(ordered) // 2])
        label = 'bare batch' if name == 'bare' else f'campaign, {name}'
        lines.append(f'| {label} | {min(values):.2f} | {median:.2f} | '
                     f'{body_steps / min(values):.3g} | {min(result["cpu_s"][name]):.2f} |')
    overhead, cpu_overhead = result['overhead'], result['cpu_overhead']
    verdict = 'met' if cpu_overhead <= TARGET_OVERHEAD else 'NOT met'
    startup = ', '.join(f'{name} {seconds:.1f} s'
                        for name, seconds in result['cluster_startup_s'].items())
    lines += [
        '',
        f'- campaign overhead on 1 worker against the bare batch at {result["runs"]} runs: '
        f'{cpu_overhead * 100:.1f} % in CPU seconds (target at most '
        f'{TARGET_OVERHEAD * 100:.0f} %: {verdict}), {overhead * 100:.1f} % in wall-clock '
        f'seconds on the busy machine',
        f'- scaling from 1 to 2 local workers: ×{result["scaling_1_to_2"]:.2f}',
        f'- runs identical bit for bit on 1 and 2 workers: {result["identical"]}',
        f'- fixed costs outside the table: cluster start-up ({startup}) and the summary PNG '
        f'({result["plot_s"]:.1f} s)', '']
    return lines


def _repeats(count: int) -> str:
    return 'One run of each' if count == 1 else f'Best of {count} interleaved repetitions'
