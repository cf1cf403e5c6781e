"""The summary of ``bench/node_throughput.py``: Markdown tables and the node against the fast
relay of the same run.
"""

import importlib.metadata
import os
from pathlib import Path
import platform
from typing import List, Optional

#: A row counts only if the publisher achieved at least this fraction of the asked rate.
PUBLISHER_SHORTFALL = 0.97
#: The node's CPU at 1 kHz may be at most this multiple of the fast relay's in the same run,
#: by node target: ``node_nocov`` (levelled, mount, calibration) as the default node,
#: ``node_full`` (the same with the covariance) 1.2×.
CPU_FACTOR_1KHZ = {'node': 1.15, 'node_nocov': 1.15, 'node_full': 1.2, 'node_filter': 1.3}
#: The node loses nothing up to this rate, and its p99 is at most ``P99_LIMIT_MS`` up to
#: ``P99_LIMIT_HZ``.
ZERO_LOSS_HZ = 5000.0
P99_LIMIT_MS = 1.0
P99_LIMIT_HZ = 2000.0


def _cpu_model() -> str:
    with open('/proc/cpuinfo') as cpuinfo:
        for line in cpuinfo:
            if line.startswith('model name'):
                return line.split(':', 1)[1].strip()
    return platform.processor() or 'unknown'


def _memory_gib() -> float:
    with open('/proc/meminfo') as meminfo:
        for line in meminfo:
            if line.startswith('MemTotal:'):
                return int(line.split()[1]) / 2**20
    return float('nan')


def _version(distribution: str) -> str:
    try:
        return importlib.metadata.version(distribution)
    except importlib.metadata.PackageNotFoundError:
        return 'not installed'


def machine_description() -> dict:
    """Return cores, CPU model, memory, OS, Python/rclpy/rmw versions and the load average."""
    from rclpy.utilities import get_rmw_implementation_identifier
    return {
        'cores': os.cpu_count(), 'cpu_model': _cpu_model(),
        'memory_gib': round(_memory_gib(), 1), 'kernel': platform.release(),
        'python': platform.python_version(), 'rclpy': _version('ros-jazzy-rclpy'),
        'rmw': get_rmw_implementation_identifier(),
        'rmw_fastrtps_cpp': _version('ros-jazzy-rmw-fastrtps-cpp'),
        'load_average_at_start': [round(load, 2) for load in os.getloadavg()],
    }


def _fmt(value: Optional[float], digits: int = 2) -> str:
    return '–' if value is None else f'{value:.{digits}f}'


def row_line(label: str, row: dict) -> str:
    """Return one progress line for a measured row."""
    return (f'{label:>12} {row["rate_hz"]:>8.0f} Hz  sent {row["sent"]:>6}  '
            f'lost {row["lost"]:>6}  pub {row["publisher_hz"]:>8.0f} Hz  '
            f'cpu {row["cpu_percent"]:5.1f} %  others {row["other_load_cores"]:4.2f}  '
            f'p50 {_fmt(row["latency_p50_ms"])} ms  '
            f'p99 {_fmt(row["latency_p99_ms"])} ms  max {_fmt(row.get("latency_max_ms"))} ms')


def publisher_kept_up(row: dict) -> bool:
    """Return whether the publisher achieved the asked rate closely enough to trust the row."""
    return row['publisher_hz'] >= PUBLISHER_SHORTFALL * row['rate_hz']


def highest_zero_loss_rate(rows: List[dict]) -> float:
    """Return the highest rate at which it and every lower rate lost nothing (0 if none).

    A rate whose publisher fell short counts as a failure: its zero loss proves nothing.
    """
    best = 0.0
    for row in sorted(rows, key=lambda r: r['rate_hz']):
        if row['lost'] != 0 or not publisher_kept_up(row):
            break
        best = row['rate_hz']
    return best


def _row_at(rows: List[dict], rate_hz: float) -> Optional[dict]:
    return next((row for row in rows if row['rate_hz'] == rate_hz), None)


def _table(rows: List[dict]) -> List[str]:
    lines = ['| rate (Hz) | sent | received | lost | publisher (Hz) | CPU (% core) | '
             'p50 (ms) | p99 (ms) | RSS (MiB) | other load (cores) |',
             '|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|']
    for row in rows:
        short = '' if publisher_kept_up(row) else ' (short)'
        lines.append(
            f'| {row["rate_hz"]:.0f} | {row["sent"]} | {row["received"]} | {row["lost"]} | '
            f'{row["publisher_hz"]:.0f}{short} | {row["cpu_percent"]:.1f} | '
            f'{_fmt(row["latency_p50_ms"], 3)} | {_fmt(row["latency_p99_ms"], 3)} | '
            f'{row["rss_kib"] / 1024:.1f} | {row["other_load_cores"]:.2f} |')
    return lines


def _summary(targets: dict) -> List[str]:
    lines = ['| target | highest zero-loss rate (Hz) | CPU at 1 kHz (% core) | '
             'p99 at 1 kHz (ms) | command |', '|---|---:|---:|---:|---|']
    for label, target in targets.items():
        at_1khz = _row_at(target['rows'], 1000.0)
        lines.append(
            f'| {label} | {highest_zero_loss_rate(target["rows"]):.0f} | '
            f'{_fmt(at_1khz and at_1khz["cpu_percent"], 1)} | '
            f'{_fmt(at_1khz and at_1khz["latency_p99_ms"], 3)} | `{target["command"]}` |')
    return lines


def _threads_at_1khz(targets: dict) -> List[str]:
    """One line per target: its CPU by thread at 1 kHz (where the middleware's share shows)."""
    lines = []
    for label, target in targets.items():
        row = _row_at(target['rows'], 1000.0)
        if row is not None and row.get('cpu_by_thread'):
            parts = ', '.join(f'{name} {percent:.1f} %'
                              for name, percent in row['cpu_by_thread'].items())
            lines.append(f'- {label}: {parts}')
    if not lines:
        return []
    return ['CPU by thread at 1 kHz (% of one core; `python` = the interpreter\'s threads, '
            '`dds.*` = Fast DDS):', ''] + lines + ['']


def _node_verdict(targets: dict) -> List[str]:
    """The node against the fast relay of the same run, and its own loss and latency."""
    node, relay = targets.get('node'), targets.get('fast_relay')
    if node is None:
        return ['The node was not part of this run.']

    def verdict(ok: bool) -> str:
        return 'met' if ok else 'NOT met'
    lines = []
    relay_1khz = relay and _row_at(relay['rows'], 1000.0)
    for label, factor in CPU_FACTOR_1KHZ.items():
        node_1khz = _row_at(targets[label]['rows'], 1000.0) if label in targets else None
        if node_1khz is not None and relay_1khz:
            ratio = node_1khz['cpu_percent'] / relay_1khz['cpu_percent']
            lines.append(f'- {label}: CPU at 1 kHz ≤ {factor:g}× the fast relay\'s: '
                         f'{node_1khz["cpu_percent"]:.1f} / {relay_1khz["cpu_percent"]:.1f} % '
                         f'= {ratio:.2f}× — {verdict(ratio <= factor)}')
    lossless = [row for row in node['rows'] if row['rate_hz'] <= ZERO_LOSS_HZ]
    lost = sum(row['lost'] for row in lossless)
    reached = max((row['rate_hz'] for row in lossless), default=0.0)
    lines.append(f'- zero loss up to {ZERO_LOSS_HZ:.0f} Hz: lost {lost} (rates measured up to '
                 f'{reached:.0f} Hz) — {verdict(lost == 0 and reached >= ZERO_LOSS_HZ)}')
    low = [row['latency_p99_ms'] or 1e9 for row in node['rows'] if row['rate_hz'] <= P99_LIMIT_HZ]
    if low:
        lines.append(f'- p99 ≤ {P99_LIMIT_MS:g} ms up to {P99_LIMIT_HZ:.0f} Hz: at most '
                     f'{max(low):.3f} ms — {verdict(max(low) <= P99_LIMIT_MS)}')
    return lines


def _machine(machine: dict) -> List[str]:
    return [f'- {machine["cores"]} cores, {machine["cpu_model"]}, '
            f'{machine["memory_gib"]} GiB RAM, Linux {machine["kernel"]}',
            f'- Python {machine["python"]}, rclpy {machine["rclpy"]}, rmw '
            f'{machine["rmw"]} {machine["rmw_fastrtps_cpp"]}',
            f'- load average when the run started: {machine["load_average_at_start"]} '
            '(the machine is shared)']


def _problems(problems: List[str]) -> List[str]:
    """Crashes and hangs of the run (first line of each), or nothing."""
    if not problems:
        return []
    return ['Problems in this run:', ''] + [
        f'- {problem.splitlines()[0]}' for problem in problems] + ['']


def render(throughput: dict) -> str:
    """Return the Markdown summary of one run."""
    lines = ['## Machine', ''] + _machine(throughput['machine']) + ['']
    lines += [f'Run: `{throughput["invocation"]}`', '', '## Throughput', '',
              f'Each row: fresh processes (target, `pose` subscriber, `imu` publisher; RELIABLE, '
              f'KEEP_LAST {throughput["depth"]}), {throughput["warmup_s"]} s warm-up, '
              f'{throughput["duration_s"]} s measured. *Lost* = published in the window but not '
              f'received within {throughput["drain_s"]} s after the last publish. CPU = '
              'run time of all threads (ns, /proc/<pid>/task/*/schedstat) of the target '
              'process over the window. '
              f'{_windows(throughput)}Latency = receive wall time − pose '
              'stamp (the publish wall time). "(short)" marks a publisher that fell more than '
              f'{100 * (1 - PUBLISHER_SHORTFALL):.0f} % short of the asked rate.', '']
    lines += _summary(throughput['targets']) + ['']
    lines += _threads_at_1khz(throughput['targets']) + ['### The node against the fast relay', '']
    lines += _node_verdict(throughput['targets']) + ['']
    lines += _problems(throughput.get('problems', []))
    for label, target in throughput['targets'].items():
        lines += [f'### {label}', '', f'`{target["command"]}`', '']
        lines += _table(target['rows']) + ['']
    return '\n'.join(lines)


def _windows(throughput: dict) -> str:
    """What a row is made of when ``--repeats`` gave several windows per row."""
    repeats = throughput.get('repeats', 1)
    if repeats == 1:
        return ''
    return (f'Each row pools {repeats} such windows, the targets interleaved: latency '
            'percentiles over all their poses, the median window\'s CPU. ')


def write(throughput: dict, report_path: Optional[Path]) -> None:
    """Print the summary, or write it to ``report_path``."""
    if report_path is None:
        print(render(throughput))
        return
    report_path.write_text(render(throughput))
    print(f'wrote {report_path}')
