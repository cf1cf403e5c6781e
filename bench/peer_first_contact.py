"""The node's gyro latency while peers come and go: the first contact with each new process.

Starts, as ``bench/soak_mixed.py`` does, the installed node (``scene:=strapdown``), the bench's
``pose`` subscriber and its ``imu`` publisher at ``--gyro-rate`` (both with the package's Fast
DDS profile), then ``--peers`` times one ``bench/_mixed_traffic.py`` process on
``--peer-profile`` (default ``none``: Fast DDS's defaults), which sends ``set_pose``, parameter
sets and ``~/reset`` calls for ``--peer-seconds`` and is stopped. It reports, per peer, the
largest gyro latency among the samples stamped from its start to 3 s after, and over the whole
window p99 and maximum. With ``--perf-trace`` it also records, with ``perf trace``, every
``clock_nanosleep``/``nanosleep`` of the node, the subscriber and the publisher that lasted
over 100 ms, with the name of the thread that slept (``bench/NOTES.md``, section 12).

Example::

    python bench/peer_first_contact.py --peers 20 --perf-trace
"""

import argparse
import os
from pathlib import Path
import re
import shlex
import signal
import subprocess
import sys
import tempfile
import time
from typing import Dict, List, Optional

BENCH = Path(__file__).resolve().parent
sys.path.insert(0, str(BENCH))

import _report  # noqa: E402
from _common import thread_run_ns  # noqa: E402
from node_throughput import (add_endpoint_profile_argument, delivery,  # noqa: E402
                             display, endpoint_environment, Session, start_processes)
from soak_mixed import default_node, run_and_save  # noqa: E402

AFTER_START_S = 3.0


def peer_runs(session: Session, args: argparse.Namespace, target) -> List[Dict[str, float]]:
    """Start and stop ``--peers`` mixed-traffic processes one after the other."""
    peers = []
    for number in range(args.peers):
        started_ns = time.time_ns()
        peer = session.start(f'peer_{number}', [
            sys.executable, str(BENCH / '_mixed_traffic.py'), '--rate', str(args.mixed_rate)],
            json_stdout=True, extra_env=endpoint_environment(args.peer_profile))
        peer.wait_event('matched', args.match_timeout, watch=[target])
        matched_ns = time.time_ns()
        time.sleep(args.peer_seconds)
        peer.popen.send_signal(signal.SIGINT)
        peer.wait_event('counts', 10.0)
        peer.popen.wait(10.0)
        peers.append({'started_ns': started_ns,
                      'matched_after_s': (matched_ns - started_ns) * 1e-9})
        time.sleep(args.pause)
    return peers


def worst_after_each(poses: Path, peers: List[Dict[str, float]], first_ns: int) -> None:
    """Add to each peer the worst latency of the samples stamped within 3 s of its start."""
    import numpy as np
    data = np.fromfile(poses, dtype='<i8')
    stamps, received = data[:data.size // 2], data[data.size // 2:]
    for peer in peers:
        begin = peer['started_ns']
        near = (stamps >= begin) & (stamps < begin + AFTER_START_S * 1e9)
        latency_ms = (received[near] - stamps[near]) * 1e-6
        worst = int(np.argmax(latency_ms)) if latency_ms.size else None
        peer['worst_ms'] = float(latency_ms[worst]) if worst is not None else None
        peer['worst_at_s'] = (float(stamps[near][worst] - peer['started_ns']) * 1e-9
                              if worst is not None else None)
        peer['started_at_s'] = (peer.pop('started_ns') - first_ns) * 1e-9


def start_perf_trace(pid: int, out: Path) -> subprocess.Popen:
    """``perf trace`` of the node's sleeps longer than 100 ms, into ``out``."""
    return subprocess.Popen(['perf', 'trace', '--duration', '100', '-e',
                             'clock_nanosleep,nanosleep', '-p', str(pid), '-o', str(out)],
                            stdout=subprocess.DEVNULL, stderr=subprocess.STDOUT)


def long_sleeps(out: Path, names: Dict[int, str]) -> List[str]:
    """The lines of a ``perf trace`` output (``... name/tid clock_nanosleep(...)``), each
    with its thread's name."""
    lines = []
    for line in out.read_text(errors='replace').splitlines():
        match = re.search(r'/(\d+) ', line)
        thread = int(match.group(1)) if match else -1
        lines.append(f'{names.get(thread, "?")}: {line.strip()}')
    return lines


def thread_names(pid: int) -> Dict[int, str]:
    """Thread id → name, for process ``pid``."""
    return {thread: name for thread, (name, _) in thread_run_ns(pid).items()}


def run(argv: List[str], args: argparse.Namespace) -> dict:
    """Run the node and the peers; return the results document."""
    seconds = args.peers * (args.peer_seconds + args.pause + 3.0) + 5.0
    with tempfile.TemporaryDirectory(prefix='bench_peer_contact_') as tmp:
        session = Session(args.domain_id, 10000, Path(tmp))
        traces: Dict[str, subprocess.Popen] = {}
        try:
            processes = start_processes(session, argv, args.gyro_rate, seconds, 0.0, args)
            target, publisher = processes['target'], processes['publisher']
            pids = {name: process.popen.pid for name, process in processes.items()}
            if args.perf_trace:
                traces = {name: start_perf_trace(pid, Path(tmp) / f'perf_trace_{name}.txt')
                          for name, pid in pids.items()}
            publisher.wait_event('start', args.match_timeout + 5, watch=[target])
            peers = peer_runs(session, args, target)
            names = {name: thread_names(pid) for name, pid in pids.items()}
            end = publisher.wait_event('end', seconds + 60.0, watch=[target])
            counts = delivery(session, processes['subscriber'], end, 1.0)
            worst_after_each(Path(tmp) / 'poses.bin', peers, end['first_stamp_ns'])
        finally:
            for trace in traces.values():
                trace.send_signal(signal.SIGINT)
                trace.wait(10.0)
            problems = session.close()
        sleeps = ([f'{name} {line}' for name in traces
                   for line in long_sleeps(Path(tmp) / f'perf_trace_{name}.txt', names[name])]
                  if traces else None)
        moves = [line.strip() for line in (Path(tmp) / 'target.log').read_text(
            errors='replace').splitlines() if 'Fast DDS sender thread' in line]
    return {'command': display(argv), 'gyro_rate_hz': args.gyro_rate,
            'peer_profile': args.peer_profile, 'peer_seconds': args.peer_seconds,
            'peers': peers, **counts, 'sleeps_over_100_ms': sleeps,
            'sender_policy_lines': moves,
            'problems': problems, 'machine': _report.machine_description(),
            'invocation': display([sys.executable] + sys.argv)}


def summary(result: dict) -> str:
    """Human-readable lines for the terminal."""
    worst = [peer['worst_ms'] for peer in result['peers'] if peer['worst_ms'] is not None]
    stalled = [f'{peer["worst_ms"]:.0f} ms {peer["worst_at_s"]:.2f} s after peer {number} '
               f'started (matched after {peer["matched_after_s"]:.2f} s)'
               for number, peer in enumerate(result['peers'])
               if peer['worst_ms'] is not None and peer['worst_ms'] > 100.0]
    lines = [f'{len(result["peers"])} peers ({result["peer_profile"]}): worst latency after '
             f'each, ms: ' + ' '.join(f'{value:.1f}' for value in worst),
             f'over 100 ms: {len(stalled)}' + ''.join(f'\n  {line}' for line in stalled),
             f'gyro: sent {result["sent"]}, lost {result["lost"]}; p99 '
             f'{result["latency_p99_ms"]:.2f} ms, max {result["latency_max_ms"]:.1f} ms']
    lines += [f'node: {line}' for line in result['sender_policy_lines']]
    if result['sleeps_over_100_ms'] is not None:
        lines.append('sleeps over 100 ms (perf trace):')
        lines += [f'  {line}' for line in result['sleeps_over_100_ms']] or ['  none']
    return '\n'.join(lines)


def parse_args(argv: Optional[List[str]] = None) -> argparse.Namespace:
    """Parse the command line."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--peers', type=int, default=20)
    parser.add_argument('--peer-seconds', type=float, default=1.0)
    parser.add_argument('--pause', type=float, default=0.5)
    parser.add_argument('--peer-profile', default='none',
                        help='Fast DDS profile of the peers ("none" = Fast DDS defaults)')
    add_endpoint_profile_argument(parser)
    parser.add_argument('--gyro-rate', type=float, default=1000.0)
    parser.add_argument('--mixed-rate', type=float, default=100.0)
    parser.add_argument('--node-cmd', default=shlex.join(default_node()))
    parser.add_argument('--domain-id', type=int,
                        default=int(os.environ.get('ROS_DOMAIN_ID', '73')))
    parser.add_argument('--match-timeout', type=float, default=30.0)
    parser.add_argument('--perf-trace', action='store_true')
    parser.add_argument('--results', type=Path,
                        default=BENCH / 'results' / 'node' / 'peer_first_contact.json')
    return parser.parse_args(argv)


def main(argv: Optional[List[str]] = None) -> int:
    """Run, save and print the results."""
    return run_and_save(run, summary, parse_args(argv))


if __name__ == '__main__':
    sys.exit(main())
