"""Idle-policy sender threads with and without other load: what their run-queue waits say
(``bench/NOTES.md``, section 13: a contention rule built on them was tried and not kept).

Runs ``bench/node_throughput.py`` on one target at one rate, ``--runs`` times on a quiet
machine and ``--runs`` times beside ``bench/cpu_bursts.py`` (``--busy-ms`` of one CPU in every
``--period-ms``). The default target is the node with its senders on ``SCHED_IDLE`` and no
guard (``bench/node_thread_policies.py --policies dds.asyn=idle,*=batch``), so that what the
senders go through is not cut short by a guard. Meanwhile a thread of this script reads
every ``--sample-ms`` the ``/proc/<pid>/task/<tid>/schedstat`` of the target's Fast DDS sender
threads (``dds.asyn.*``). Per window of ``--window-ms`` while the busiest sender was on
``SCHED_IDLE``: its mean run-queue wait per run, the fraction of the window it waited, and
the worst latency of the poses received in the window. The report groups the windows by that
latency, quiet and with bursts, and counts the windows a candidate rule flags: a mean wait
per run over ``--mean-wait-ms`` and a waiting fraction over ``--fraction``.

Example::

    python bench/sender_contention.py --rate 20000 --runs 2 \\
        --out bench/results/node/contention/waits.json
"""

import argparse
import json
import os
from pathlib import Path
import signal
import subprocess
import sys
import tempfile
import threading
import time
from typing import Dict, List, Optional

import numpy as np

from rigid_body_attitude.ros.sender_threads import read_schedstat, sender_thread_ids

BENCH = Path(__file__).resolve().parent
DEFAULT_TARGET = (f'{sys.executable} {BENCH / "node_thread_policies.py"} '
                  f'--policies dds.asyn=idle,*=batch --ros-args -p scene:=strapdown')
LATENCY_CLASSES_MS = ((0.0, 1.0), (1.0, 2.0), (2.0, 5.0), (5.0, float('inf')))


def _target_pid(marker: bytes) -> Optional[int]:
    """The newest process whose command line holds ``marker`` (not this script)."""
    newest = None
    for entry in os.listdir('/proc'):
        if not entry.isdigit() or int(entry) == os.getpid():
            continue
        try:
            command = Path(f'/proc/{entry}/cmdline').read_bytes()
        except OSError:
            continue
        if marker in command and b'node_throughput' not in command:
            newest = max(newest or 0, int(entry))
    return newest


def sample(marker: bytes, period_s: float, stop: threading.Event, rows: Dict[int, list]) -> None:
    """Thread body: every ``period_s``, (wall ns, then per sender: run ns, wait ns, runs,
    policy) of the newest target process, into ``rows[pid]``."""
    pid, senders, next_search = None, [], 0.0
    while not stop.is_set():
        if time.monotonic() >= next_search:  # a scan of /proc costs ms: 5 times a second
            next_search = time.monotonic() + 0.2
            found = _target_pid(marker)
            if found != pid:
                pid, senders = found, []
        if pid is not None and not senders:
            try:
                senders = sender_thread_ids(Path(f'/proc/{pid}/task'))
            except OSError:  # the process ended meanwhile
                pid = None
        row: Optional[list] = [time.time_ns()] if senders else None
        for thread_id in senders:
            reading = read_schedstat(Path(f'/proc/{pid}/task/{thread_id}/schedstat'))
            try:
                policy = os.sched_getscheduler(thread_id)
            except OSError:
                reading = None
            if reading is None or row is None:
                row = None
                break
            row += [*reading, policy]
        if pid is not None and row is not None:
            rows.setdefault(pid, []).append(row)
        time.sleep(period_s)


def windows(rows: list, poses: Path, window_ms: float, sample_ms: float) -> List[dict]:
    """Per window while the busiest sender was idle: mean wait per run (ms), waiting
    fraction, worst latency (ms) of the poses received in it, and the raw deltas."""
    width = len(rows[0])
    table = np.array([row for row in rows if len(row) == width], dtype=np.int64)
    senders = (width - 1) // 4
    busiest = int(np.argmax([table[-1, 1 + 4 * k] - table[0, 1 + 4 * k]
                             for k in range(senders)]))
    wall = table[:, 0]
    run_ns, wait_ns, runs, policy = table[:, 1 + 4 * busiest:5 + 4 * busiest].T
    data = np.fromfile(poses, dtype='<i8')
    stamps, received = data[:data.size // 2], data[data.size // 2:]
    step = max(1, round(window_ms / sample_ms))
    found = []
    for first in range(0, len(wall) - step, step):
        last = first + step
        if policy[first] != os.SCHED_IDLE or policy[last] != os.SCHED_IDLE:
            continue
        inside = (received >= wall[first]) & (received < wall[last])
        if not inside.any():
            continue
        found.append({
            'elapsed_ns': int(wall[last] - wall[first]),
            'run_ns': int(run_ns[last] - run_ns[first]),
            'wait_ns': int(wait_ns[last] - wait_ns[first]),
            'runs': int(runs[last] - runs[first]),
            'latency_ms': float((received[inside] - stamps[inside]).max() * 1e-6)})
    return found


def summary(found: List[dict], mean_wait_ms: float, fraction_over: float) -> List[dict]:
    """The windows grouped by latency: counts, mean wait per run and waiting fraction
    (median, 90th percentile, maximum), and how many the candidate rule flags."""
    groups = []
    for low, high in LATENCY_CLASSES_MS:
        chosen = [w for w in found if low <= w['latency_ms'] < high]
        if not chosen:
            continue
        mean_wait = np.array([w['wait_ns'] / max(w['runs'], 1) * 1e-6 for w in chosen])
        fraction = np.array([w['wait_ns'] / w['elapsed_ns'] for w in chosen])
        flagged = int(np.sum((mean_wait > mean_wait_ms) & (fraction > fraction_over)))
        groups.append({
            'latency_ms': [low, high], 'windows': len(chosen), 'flagged': flagged,
            'mean_wait_per_run_ms': _spread(mean_wait), 'waiting_fraction': _spread(fraction)})
    return groups


def _spread(values: np.ndarray) -> List[float]:
    """Median, 90th percentile and maximum."""
    return [float(np.median(values)), float(np.percentile(values, 90)), float(values.max())]


def one_run(args: argparse.Namespace, workdir: Path, name: str) -> List[dict]:
    """One ``node_throughput.py`` run of the target, sampled; its idle windows."""
    rows: Dict[int, list] = {}
    stop = threading.Event()
    sampler = threading.Thread(target=sample, args=(
        args.marker.encode(), args.sample_ms * 1e-3, stop, rows), daemon=True)
    sampler.start()
    traces = workdir / name
    command = [sys.executable, str(BENCH / 'node_throughput.py'), '--domain-id',
               str(args.domain_id), '--rates', str(args.rate), '--targets', 'node',
               '--node-cmd', args.target, '--results-dir', str(traces),
               '--report', str(traces / 'report.md'), '--keep-traces', str(traces)]
    completed = subprocess.run(command, capture_output=True, text=True)
    stop.set()
    sampler.join()
    print(completed.stdout.strip().splitlines()[0] if completed.stdout.strip() else '',
          flush=True)
    if completed.returncode != 0 or not rows:
        raise SystemExit(f'error: run {name} failed: {completed.stderr[-500:]}')
    pid = max(rows)
    return windows(rows[pid], traces / f'node_{args.rate:.0f}.poses.bin', args.window_ms,
                   args.sample_ms)


def _line(condition: str, group: dict) -> str:
    """One latency class of one condition, as a line."""
    low, high = group['latency_ms']
    waits = '/'.join(f'{value:.3f}' for value in group['mean_wait_per_run_ms'])
    fractions = '/'.join(f'{value:.2f}' for value in group['waiting_fraction'])
    return (f'{condition:6s} latency {low:g}-{high:g} ms: {group["windows"]:4d} windows, '
            f'{group["flagged"]:3d} flagged; mean wait per run (ms) median/p90/max '
            f'{waits}; waiting fraction {fractions}')


def parse_args(argv: Optional[List[str]] = None) -> argparse.Namespace:
    """Parse the command line."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--rate', type=float, default=20000.0)
    parser.add_argument('--runs', type=int, default=2, help='runs per condition')
    parser.add_argument('--busy-ms', type=float, default=100.0)
    parser.add_argument('--period-ms', type=float, default=1000.0)
    parser.add_argument('--window-ms', type=float, default=20.0)
    parser.add_argument('--sample-ms', type=float, default=5.0)
    parser.add_argument('--mean-wait-ms', type=float, default=0.15,
                        help='candidate rule: mean run-queue wait per run over this (ms)')
    parser.add_argument('--fraction', type=float, default=0.75,
                        help='candidate rule: and waiting over this fraction of the window')
    parser.add_argument('--target', default=DEFAULT_TARGET, help='the node command line')
    parser.add_argument('--marker', default='node_thread_policies.py',
                        help='a word of the target process\'s command line')
    parser.add_argument('--domain-id', type=int, default=78)
    parser.add_argument('--out', type=Path, default=None, help='JSON results file')
    args = parser.parse_args(argv)
    if args.runs < 1 or args.window_ms < args.sample_ms:
        parser.error('expected --runs >= 1 and --window-ms >= --sample-ms')
    return args


def main(argv: Optional[List[str]] = None) -> int:
    """Both conditions, ``--runs`` each; print and save the grouped windows."""
    args = parse_args(argv)
    result = {'invocation': ' '.join(sys.argv), 'rate_hz': args.rate,
              'rule': {'mean_wait_ms': args.mean_wait_ms, 'fraction': args.fraction},
              'conditions': {}}
    with tempfile.TemporaryDirectory(prefix='contention_') as tmp:
        for condition in ('quiet', 'bursts'):
            found: List[dict] = []
            for run in range(args.runs):
                bursts = None
                if condition == 'bursts':
                    bursts = subprocess.Popen([
                        sys.executable, str(BENCH / 'cpu_bursts.py'), '--processes', '1',
                        '--busy-ms', str(args.busy_ms), '--period-ms', str(args.period_ms)])
                try:
                    found += one_run(args, Path(tmp), f'{condition}_{run}')
                finally:
                    if bursts is not None:
                        bursts.send_signal(signal.SIGTERM)
                        bursts.wait()
            result['conditions'][condition] = summary(found, args.mean_wait_ms, args.fraction)
            for group in result['conditions'][condition]:
                print(_line(condition, group), flush=True)
    if args.out is not None:
        args.out.parent.mkdir(parents=True, exist_ok=True)
        args.out.write_text(json.dumps(result, indent=1))
    return 0


if __name__ == '__main__':
    sys.exit(main())
