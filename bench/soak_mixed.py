"""Mixed-traffic soak of the installed node: RSS growth and loss over N minutes.

Starts, as a user would, ``propagation_node --ros-args -p scene:=strapdown`` (``--node-cmd``
to change it), a ``pose`` subscriber (``bench/_subscriber.py``), an ``imu`` publisher at
``--gyro-rate`` (default 1 kHz, ``bench/_publisher.py``, RELIABLE) and the mixed traffic of
``bench/_mixed_traffic.py`` at ``--mixed-rate`` (default 100 Hz: one ``set_pose``, one
``set_parameters`` request and one ``~/reset`` call per tick). It samples the node's RSS
(/proc/<pid>/status VmRSS) every ``--sample-every`` seconds and reports:

* RSS growth from minute 1 to the end (the target of issue 11: at most 1 MiB over 10
  minutes), and the growth rate over that span (least squares, KiB per minute);
* gyro samples sent in the window and poses received within ``--drain`` s (lost = the
  difference), the mixed ticks sent and the replies received;
* the node's CPU over the whole soak (its threads' run times in ns) and the other load: the
  run time of every process but the node, its peers and this script.

Results go to ``bench/results/node/soak_mixed.json`` (``bench/performance_report.py`` puts them in
``docs/performance.md``). Exit code 0 unless a process crashed or hung on SIGINT.

Example::

    python bench/soak_mixed.py                  # 10 minutes
    python bench/soak_mixed.py --minutes 2
"""

import argparse
import json
import os
from pathlib import Path
import shlex
import sys
import tempfile
import time
from typing import Callable, Dict, List, Optional

BENCH = Path(__file__).resolve().parent
sys.path.insert(0, str(BENCH))

from _common import cpu_seconds, other_load_ticks, process_ticks, rss_kib  # noqa: E402
import _report  # noqa: E402
from node_throughput import (add_endpoint_profile_argument, CLOCK_TICKS,  # noqa: E402
                             delivery, display, endpoint_environment, NODE_ARGS,
                             PACKAGE_PROFILE, ProcessCrashed, Session, start_processes)


def default_node() -> List[str]:
    """``propagation_node`` next to this interpreter (a venv's bin), else on PATH."""
    beside = Path(sys.executable).parent / 'propagation_node'
    return [str(beside) if beside.is_file() else 'propagation_node'] + NODE_ARGS


def growth_rate_kib_per_minute(samples: List[Dict[str, float]]) -> float:
    """Least-squares slope of RSS (KiB) against time (minutes) over ``samples``."""
    n = len(samples)
    if n < 2:
        return 0.0
    mean_t = sum(s['minute'] for s in samples) / n
    mean_r = sum(s['rss_kib'] for s in samples) / n
    covariance = sum((s['minute'] - mean_t) * (s['rss_kib'] - mean_r) for s in samples)
    variance = sum((s['minute'] - mean_t) ** 2 for s in samples)
    return covariance / variance if variance else 0.0


def sample_rss(target, pid: int, seconds: float, every: float) -> List[Dict[str, float]]:
    """RSS of ``pid`` every ``every`` seconds for ``seconds``; stops if the target dies."""
    samples = []
    started = time.monotonic()
    next_at = started + every
    while next_at <= started + seconds + 1e-6:
        time.sleep(max(0.0, next_at - time.monotonic()))
        target.check_alive()
        minute = (time.monotonic() - started) / 60.0
        samples.append({'minute': round(minute, 3), 'rss_kib': rss_kib(pid)})
        if abs(minute - round(minute)) * 60.0 < every / 2:
            print(f'soak: minute {minute:.1f} RSS {samples[-1]["rss_kib"]} KiB', flush=True)
        next_at += every
    return samples


def run(argv: List[str], args: argparse.Namespace) -> dict:
    """Run the soak; return the results document."""
    seconds = args.minutes * 60.0
    with tempfile.TemporaryDirectory(prefix='bench_soak_mixed_') as tmp:
        session = Session(args.domain_id, args.depth, Path(tmp))
        try:
            processes = start_processes(session, argv, args.gyro_rate, seconds, 0.0, args)
            target, publisher = processes['target'], processes['publisher']
            mixed = session.start('mixed', [sys.executable, str(BENCH / '_mixed_traffic.py'),
                                            '--rate', str(args.mixed_rate)], json_stdout=True,
                                  extra_env=endpoint_environment(args.mixed_profile))
            mixed.wait_event('matched', args.match_timeout, watch=[target])
            mixed_matched_ns = time.time_ns()
            publisher.wait_event('start', args.match_timeout + 5, watch=[target])
            pid = target.popen.pid
            seconds0, machine0, wall0 = cpu_seconds(pid), process_ticks(), time.monotonic()
            samples = sample_rss(target, pid, seconds, args.sample_every)
            end = publisher.wait_event('end', 60.0, watch=[target])
            seconds1, machine1 = cpu_seconds(pid), process_ticks()
            ours = {os.getpid()} | {process.popen.pid for process in session.processes}
            window = time.monotonic() - wall0
            mixed.popen.send_signal(2)
            mixed_counts = mixed.wait_event('counts', 10.0)
            time.sleep(args.drain)
            counts = delivery(session, processes['subscriber'], end, args.drain)
        finally:
            problems = session.close()
    after_first = [s for s in samples if s['minute'] >= 1.0 - 1e-9]
    first, last = after_first[0], after_first[-1]
    return {
        'command': display(argv), 'minutes': args.minutes, 'gyro_rate_hz': args.gyro_rate,
        'mixed_rate_hz': args.mixed_rate, 'samples': samples,
        'rss_minute_1_kib': first['rss_kib'], 'rss_end_kib': last['rss_kib'],
        'growth_kib': last['rss_kib'] - first['rss_kib'],
        'growth_kib_per_minute': growth_rate_kib_per_minute(after_first),
        'rss_max_kib': max(s['rss_kib'] for s in after_first),
        'publisher_hz': end['achieved_hz'], 'publisher_max_lag_ms': end['max_lag_ms'],
        **counts, 'mixed': mixed_counts,
        'mixed_profile': args.mixed_profile,
        'mixed_matched_at_s': (mixed_matched_ns - end['first_stamp_ns']) * 1e-9,
        'cpu_percent': 100.0 * (seconds1 - seconds0) / window,
        'other_load_cores': other_load_ticks(machine0, machine1, ours) / CLOCK_TICKS / window,
        'problems': problems, 'machine': _report.machine_description(),
        'invocation': display([sys.executable] + sys.argv),
    }


def summary(result: dict) -> str:
    """Human-readable lines for the terminal."""
    mixed = result['mixed']
    return '\n'.join([
        f'RSS minute 1 -> {result["minutes"]}: {result["rss_minute_1_kib"]} -> '
        f'{result["rss_end_kib"]} KiB ({result["growth_kib"]:+d} KiB; slope '
        f'{result["growth_kib_per_minute"]:+.1f} KiB/min; max {result["rss_max_kib"]} KiB)',
        f'gyro: sent {result["sent"]}, received {result["received"]}, lost {result["lost"]} '
        f'(publisher {result["publisher_hz"]:.1f} Hz, at most '
        f'{result["publisher_max_lag_ms"]:.1f} ms late); latency p50 '
        f'{result["latency_p50_ms"]:.2f} ms, p99 {result["latency_p99_ms"]:.2f} ms, max '
        f'{result["latency_max_ms"]:.1f} ms at {result["latency_max_at_s"]:.2f} s (mixed '
        f'traffic matched at {result["mixed_matched_at_s"]:.2f} s)',
        f'mixed: {mixed["ticks"]} ticks; set_pose {mixed["set_pose"]}, parameter replies '
        f'{mixed["parameter_replies"]} (refused {mixed["parameters_refused"]}), reset '
        f'replies {mixed["reset_replies"]} (failed {mixed["resets_failed"]})',
        f'node CPU {result["cpu_percent"]:.1f} % of a core; other processes '
        f'{result["other_load_cores"]:.2f} cores',
    ])


def parse_args(argv: Optional[List[str]] = None) -> argparse.Namespace:
    """Parse the command line."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--minutes', type=float, default=10.0,
                        help='soak length (default %(default)s; at least 2)')
    parser.add_argument('--gyro-rate', type=float, default=1000.0)
    parser.add_argument('--mixed-rate', type=float, default=100.0)
    parser.add_argument('--sample-every', type=float, default=10.0,
                        help='seconds between RSS samples (default %(default)s)')
    parser.add_argument('--drain', type=float, default=1.0)
    parser.add_argument('--depth', type=int, default=10000,
                        help='KEEP_LAST depth of the publisher and subscriber')
    parser.add_argument('--node-cmd', default=shlex.join(default_node()))
    parser.add_argument('--domain-id', type=int,
                        default=int(os.environ.get('ROS_DOMAIN_ID', '71')))
    parser.add_argument('--match-timeout', type=float, default=30.0)
    add_endpoint_profile_argument(parser)
    parser.add_argument('--mixed-profile', default=PACKAGE_PROFILE,
                        help='Fast DDS profile of the mixed-traffic process (default the '
                        'package\'s, like the publisher and subscriber; "none" = Fast DDS '
                        'defaults: see bench/NOTES.md section 12)')
    parser.add_argument('--results', type=Path,
                        default=BENCH / 'results' / 'node' / 'soak_mixed.json')
    args = parser.parse_args(argv)
    if args.minutes < 2:
        parser.error(f'expected --minutes >= 2 (RSS from minute 1 on), got {args.minutes}')
    return args


def main(argv: Optional[List[str]] = None) -> int:
    """Run the soak, save and print the results."""
    return run_and_save(run, summary, parse_args(argv))


def run_and_save(run_node: Callable[[List[str], argparse.Namespace], dict],
                 describe: Callable[[dict], str], args: argparse.Namespace) -> int:
    """``run_node(node command, args)``; its results to ``args.results``, ``describe``'s
    lines to stdout, problems to stderr; the exit code (also for ``peer_first_contact.py``)."""
    try:
        result = run_node(shlex.split(args.node_cmd), args)
    except ProcessCrashed as err:
        print(f'error: {err}', file=sys.stderr)
        return 1
    args.results.parent.mkdir(parents=True, exist_ok=True)
    args.results.write_text(json.dumps(result, indent=1))
    print(describe(result))
    for problem in result['problems']:
        print(f'error: {problem}', file=sys.stderr)
    return 1 if result['problems'] else 0


if __name__ == '__main__':
    sys.exit(main())
