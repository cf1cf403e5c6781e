"""Bursty CPU load beside a benchmark: N processes, each busy B ms out of every P ms.

Other ROS nodes on a robot rarely keep a CPU busy all the time; they wake, work a few tens
of milliseconds and sleep. This is that load, reproducible: ``--processes`` (default 2)
processes, each spinning ``--busy-ms`` (default 30) in every ``--period-ms`` (default 330),
the first of each period at a random phase so that the processes drift against each other,
until SIGINT or SIGTERM (or ``--seconds``). ``bench/NOTES.md``, sections 11 and 12, measure
the node's latency under it.

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


def burst_loop(busy_s: float, period_s: float, seconds: float, seed: int) -> None:
    """Spin ``busy_s`` at the start of every ``period_s`` for ``seconds`` (0 = forever)."""
    signal.signal(signal.SIGINT, signal.SIG_DFL)
    start = time.monotonic() + random.Random(seed).uniform(0.0, period_s)
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
    args = parser.parse_args(argv)
    if not 0 < args.busy_ms <= args.period_ms or args.processes < 1:
        parser.error('expected --processes >= 1 and 0 < --busy-ms <= --period-ms')
    return args


def main(argv: Optional[List[str]] = None) -> int:
    """Run the processes until a signal (or ``--seconds``); exit 0."""
    args = parse_args(argv)
    workers = [multiprocessing.Process(target=burst_loop, args=(
        args.busy_ms * 1e-3, args.period_ms * 1e-3, args.seconds, seed), daemon=True)
        for seed in range(args.processes)]
    for worker in workers:
        worker.start()

    def stop(signum: int, frame: object) -> None:
        for worker in workers:
            worker.terminate()
    signal.signal(signal.SIGTERM, stop)
    try:
        for worker in workers:
            worker.join()
    except KeyboardInterrupt:
        stop(signal.SIGINT, None)
    return 0


if __name__ == '__main__':
    sys.exit(main())
