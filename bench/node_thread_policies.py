"""The node with a scheduling policy of your choice per thread: the A/B harness of NOTES.md §11.

Starts the node as ``propagation_node`` does (``rigid_body_attitude.ros.serve.main``), but
instead of the ``cpu_scheduling`` rule it gives each thread the policy of the first
``--policies`` entry whose prefix its name starts with (``main`` = the gyro loop's thread,
``*`` = any thread). With ``--sender-waits FILE`` a thread of its own writes, every 0.1 s, each
Fast DDS sender thread's CPU time, run-queue wait (ms in that 0.1 s, from
``/proc/self/task/<tid>/schedstat``) and number of runs: the figures behind
``rigid_body_attitude.ros.sender_threads``'s starvation rule.

Examples (as ``bench/node_throughput.py`` targets)::

    python bench/node_throughput.py --rates 15000 --targets node,fast_relay \\
        --target "idle=python bench/node_thread_policies.py --policies dds.asyn=idle,*=batch \\
        --ros-args -p scene:=strapdown"
    ... --policies main=other,dds.shm=other,*=batch   # loop and receive threads preempt
    ... --policies dds.asyn=batch,*=other             # only the senders on SCHED_BATCH
    ... --policies *=batch --slices dds.asyn=100      # senders with a 0.1 ms slice (EEVDF)

``--slices prefix=µs,...`` also gives the matching threads a custom time slice (Linux 6.12+:
``sched_setattr``'s ``sched_runtime`` for fair-class threads, 100–100 000 µs), their policy
unchanged.
"""

import argparse
import os
from pathlib import Path
import sys
import threading
import time
from typing import Iterator, List, Optional, Tuple

POLICIES = {'batch': os.SCHED_BATCH, 'other': os.SCHED_OTHER, 'idle': os.SCHED_IDLE}
TASKS = Path('/proc/self/task')


def parse_policies(text: str) -> List[Tuple[str, int]]:
    """``prefix=policy,...`` → [(prefix, policy)]."""
    rules = []
    for item in text.split(','):
        prefix, _, name = item.partition('=')
        if not prefix or name not in POLICIES:
            raise SystemExit(f'error: expected prefix=batch|other|idle, got {item!r}')
        rules.append((prefix, POLICIES[name]))
    return rules


def parse_slices(text: str) -> List[Tuple[str, int]]:
    """``prefix=µs,...`` → [(prefix, µs)]."""
    rules = []
    for item in filter(None, text.split(',')):
        prefix, _, value = item.partition('=')
        if not prefix or not value.isdigit():
            raise SystemExit(f'error: expected prefix=microseconds, got {item!r}')
        rules.append((prefix, int(value)))
    return rules


def first_matches(rules: List[Tuple[str, int]]) -> Iterator[Tuple[int, str, int]]:
    """(thread id, key, value) of every thread of this process with a matching rule, the
    first match's value (``main`` = the gyro loop's thread, ``*`` = any thread)."""
    for entry in sorted(TASKS.iterdir()):
        thread_id = int(entry.name)
        try:
            name = (entry / 'comm').read_text().strip()
        except OSError:
            continue
        key = 'main' if thread_id == os.getpid() else name
        value = next((value for prefix, value in rules
                      if prefix == '*' or key.startswith(prefix)), None)
        if value is not None:
            yield thread_id, key, value


def apply_slices(rules: List[Tuple[str, int]]) -> List[str]:
    """Give every thread the slice of its first matching rule."""
    from rigid_body_attitude.ros.time_slices import set_slice
    applied = []
    for thread_id, key, slice_us in first_matches(rules):
        set_slice(thread_id, slice_us * 1000)
        applied.append(f'{key}:{slice_us}us')
    return applied


def apply(rules: List[Tuple[str, int]]) -> List[str]:
    """Give every thread of this process the policy of its first matching rule."""
    applied = []
    for thread_id, key, policy in first_matches(rules):
        os.sched_setscheduler(thread_id, policy, os.sched_param(0))
        applied.append(f'{key}:{policy}')
    return applied


def watch_senders(path: Path) -> None:
    """Thread body: every 0.1 s, each sender's (CPU ms, wait ms, runs) over the last 0.1 s."""
    from rigid_body_attitude.ros.sender_threads import read_schedstat, sender_thread_ids
    previous = {}
    with path.open('w') as out:
        out.write('monotonic_s thread cpu_ms wait_ms runs\n')
        while True:
            time.sleep(0.1)
            for thread_id in sender_thread_ids():
                now = read_schedstat(TASKS / str(thread_id) / 'schedstat')
                before = previous.get(thread_id)
                if now is not None and before is not None:
                    out.write(f'{time.monotonic():.3f} {thread_id} '
                              f'{(now.run_ns - before.run_ns) * 1e-6:.3f} '
                              f'{(now.wait_ns - before.wait_ns) * 1e-6:.3f} '
                              f'{now.runs - before.runs}\n')
                    out.flush()
                previous[thread_id] = now


def main(argv: Optional[List[str]] = None) -> int:
    """Run the node with the given per-thread policies until SIGINT."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--policies', required=True, help='prefix=batch|other|idle,...')
    parser.add_argument('--slices', default='', help='prefix=microseconds,...')
    parser.add_argument('--sender-waits', type=Path, default=None, metavar='FILE')
    args, ros_args = parser.parse_known_args(argv)
    rules = parse_policies(args.policies)
    slices = parse_slices(args.slices)
    from rigid_body_attitude.ros import serve

    def scheduling(node, sender_remark) -> None:  # replaces the cpu_scheduling rule
        node.get_logger().info('policies: ' + ' '.join(apply(rules) + apply_slices(slices))
                               + '; serving')
        if args.sender_waits is not None:
            threading.Thread(target=watch_senders, args=(args.sender_waits,),
                             daemon=True).start()

    serve._apply_cpu_scheduling = scheduling
    serve._sender_rule = lambda *args: (None, '')  # no sender rule: the policies are the rules
    return serve.main([sys.argv[0]] + ros_args)


if __name__ == '__main__':
    sys.exit(main())
