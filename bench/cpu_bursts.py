"""Bursty CPU load beside a benchmark: N processes, each busy B ms out of every P ms.

Other ROS nodes on a robot rarely keep a CPU busy all the time; they wake, work a few tens
of milliseconds and sleep. This is that load, reproducible: ``--processes`` (default 2)
processes, each spinning ``--busy-ms`` (default 30) in every ``--period-ms`` (default 330),
until SIGINT or SIGTERM (or ``--seconds``). The processes burst at the same moments (as many
CPUs busy at once as there are processes), or with ``--spread`` each at a random phase.
``bench/NOTES.md``, section 12, measures the node's latency under it.

Example (in another terminal, or backgrounded around a ``node_throughput.py`` run)::

    python bench/cpu_bursts.py --processes 2 --busy-ms 30 --period-ms 330
"""

import argparse
import multiprocessing
import random
import signal
import sys
import time
from typing import List, Optional


def burst_loop(busy_s: float, period_s: float, seconds: float, start: float) -> None:
    """Spin ``busy_s`` at the start of every ``period_s`` from ``start`` (monotonic) for
    ``seconds`` (0 = forever)."""
    signal.signal(signal.SIGINT, signal.SIG_DFL)
    end = start + seconds if seconds > 0 else float('inf')
    period_start = start
    while period_start < end:
        time.sleep(max(0.0, period_start - time.monotonic()))
        busy_until = period_start + busy_s
        while time.monotonic() < busy_until:
            pass
        period_start += period_s


def parse_args(argv: Optional[List[str]] = None) -> argparse.Namespace:
    """Parse the command line."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--processes', type=int, default=2)
    parser.add_argument('--busy-ms', type=float, default=30.0)
    parser.add_argument('--period-ms', type=float, default=330.0)
    parser.add_argument('--seconds', type=float, default=0.0, help='0 = until SIGINT/SIGTERM')
    parser.add_argument('--spread', action='store_true',
                        help='each process at a random phase (default: all at once)')
    args = parser.parse_args(argv)
    if not 0 < args.busy_ms <= args.period_ms or args.processes < 1:
        parser.error('expected --processes >= 1 and 0 < --busy-ms <= --period-ms')
    return args


def main(argv: Optional[List[str]] = None) -> int:
    """Run the processes until a signal (or ``--seconds``); exit 0."""
    args = parse_args(argv)
    period_s = args.period_ms * 1e-3
    start = time.monotonic() + 0.1
    starts = [start + (random.uniform(0.0, period_s) if args.spread else 0.0)
              for _ in range(args.processes)]
    workers = [multiprocessing.Process(target=burst_loop, args=(
        args.busy_ms * 1e-3, period_s, args.seconds, first), daemon=True)
        for first in starts]
    for worker in workers:
        worker.start()

    def stop(signum: int, frame: object) -> None:
        for worker in workers:
            worker.terminate()
    signal.signal(signal.SIGTERM, stop)
    # Set explicitly: a shell that backgrounds a job without job control starts it with
    # SIGINT ignored, and Python then installs no KeyboardInterrupt handler of its own.
    signal.signal(signal.SIGINT, stop)
    try:
        for worker in workers:
            worker.join()
    except KeyboardInterrupt:
        stop(signal.SIGINT, None)
    return 0


if __name__ == '__main__':
    sys.exit(main())
