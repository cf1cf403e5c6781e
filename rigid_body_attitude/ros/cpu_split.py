"""The gyro loop thread and Fast DDS's sender threads on different CPUs while the gyro rate is
high.

Fast DDS 2.14's asynchronous sender retries at once, without sleeping, when it finds a
writer's mutex held by another thread (:mod:`~.sender_threads`). With 0.1 ms time slices
(:mod:`~.time_slices`) such a spin still made spells of tens of ms at 15–20 kHz: the gyro
loop waited for the CPU the sender went round on while the other CPU was partly idle
(``bench/NOTES.md``, section 16). While the gyro rate (over 0.5 s) is at least
``separate_cpus_above_hz``, :class:`CpuSplit` keeps the loop thread on the lowest CPU the
process may use and the sender threads on the others, so a sender never takes the loop's CPU;
below :data:`~.sender_threads.BATCH_BELOW_FRACTION` of that rate every thread may use every
CPU again.

In three interleaved runs against the node without it (``bench/results/node/cpu_split/``,
16 windows of 4 s a rate, zero loss everywhere), the median of the windows' p99 latency was
0.82 against 1.11 ms at 20 kHz (windows over 1 ms: 6 against 10; median maximum 3.3 against
5.5 ms), 0.58 against 0.57 ms at 15 kHz and 0.50 against 0.47 ms at 10 kHz, for a median of
80.7 against 72.4, 74.4 against 72.2 and 61.5 against 58.9 % of a core. At 1 kHz, in one of
the runs, it would have cost 11.1 against 9.5 % of a core (the messages cross CPUs). Hence
the threshold of 12 kHz: the split at 15 and 20 kHz, not at 10 kHz, where it bought nothing.
"""

from __future__ import annotations

from collections.abc import Callable
import os
from pathlib import Path

from rigid_body_attitude.ros.sender_threads import (
    BATCH_BELOW_FRACTION, GuardNote, GyroRate, sender_thread_ids, TASKS)

__all__ = ['CpuSplit', 'cpu_split']


class CpuSplit:
    """Moves the gyro loop thread to one CPU and the sender threads to the others while the
    gyro rate is high, and every thread back to every CPU when it falls.

    If the system refuses a move, every thread goes back to every CPU and stays there.
    """

    def __init__(self, loop_thread_id: int, sender_ids: list[int],
                 message_count: Callable[[], int], above_hz: float, cpus: set[int]) -> None:
        """Separate ``loop_thread_id`` from ``sender_ids`` among ``cpus`` (at least two) from
        ``above_hz`` on; ``message_count()`` is the number of gyro messages handled so far."""
        self.loop_thread_id = loop_thread_id
        self.sender_ids = list(sender_ids)
        self.gyro_rate = GyroRate(message_count)
        self.above_hz = above_hz
        self.cpus = set(cpus)
        self.loop_cpu = min(self.cpus)
        #: The loop and the senders are on different CPUs.
        self.separated = False
        #: A move was refused: every thread stays on every CPU for good.
        self.refused = False

    def check(self) -> list[GuardNote]:
        """One look (every :data:`~.sender_threads.GUARD_PERIOD` s); a note per change."""
        rate = self.gyro_rate.look()
        if rate is None or self.refused:
            return []
        if not self.separated and rate >= self.above_hz:
            return self._place(True, f'gyro input at {rate:.0f} Hz (separate_cpus_above_hz '
                                     f'{self.above_hz:g})')
        if self.separated and rate < BATCH_BELOW_FRACTION * self.above_hz:
            return self._place(False, f'gyro input at {rate:.0f} Hz (below '
                                      f'{BATCH_BELOW_FRACTION:.3g} of separate_cpus_above_hz '
                                      f'{self.above_hz:g})')
        return []

    def _place(self, separate: bool, reason: str) -> list[GuardNote]:
        """Separate the threads (or join them on every CPU); the note saying so."""
        sender_cpus = self.cpus - {self.loop_cpu} if separate else self.cpus
        try:
            os.sched_setaffinity(self.loop_thread_id,
                                 {self.loop_cpu} if separate else self.cpus)
            self.sender_ids = _set_affinities(self.sender_ids, sender_cpus)
        except OSError as err:
            self.refused, self.separated = True, False
            try:
                _set_affinities([self.loop_thread_id] + self.sender_ids, self.cpus)
            except OSError:  # refused too: as the system left them
                pass
            return [GuardNote(True, f'{reason}: CPU affinity refused ({err}); the gyro loop '
                                    f'and Fast DDS sender threads stay on '
                                    f'{_cpu_list(self.cpus)}')]
        self.separated = separate
        if not separate:
            return [GuardNote(False, f'{reason}: the gyro loop and Fast DDS sender threads '
                                     f'{self.sender_ids} back on {_cpu_list(self.cpus)}')]
        return [GuardNote(False, f'{reason}: the gyro loop on CPU {self.loop_cpu}, Fast DDS '
                                 f'sender threads {self.sender_ids} on '
                                 f'{_cpu_list(sender_cpus)}')]


def _set_affinities(thread_ids: list[int], cpus: set[int]) -> list[int]:
    """Give each of ``thread_ids`` the CPUs ``cpus``; the ids of those still alive (other
    refusals raise OSError)."""
    alive = []
    for thread_id in thread_ids:
        try:
            os.sched_setaffinity(thread_id, cpus)
        except ProcessLookupError:  # ended meanwhile
            continue
        alive.append(thread_id)
    return alive


def _cpu_list(cpus: set[int]) -> str:
    """``cpus`` for a log line: ``CPU 1``, ``CPUs 0-3`` or ``CPUs 1,3``."""
    ordered = sorted(cpus)
    if len(ordered) == 1:
        return f'CPU {ordered[0]}'
    if ordered == list(range(ordered[0], ordered[-1] + 1)) and len(ordered) > 2:
        return f'CPUs {ordered[0]}-{ordered[-1]}'
    return 'CPUs ' + ','.join(map(str, ordered))


def cpu_split(loop_thread_id: int, message_count: Callable[[], int], above_hz: float,
              task_folder: Path = TASKS) -> tuple[CpuSplit | None, str]:
    """The split of this process's gyro loop thread from its sender threads, and a remark for
    the start-up line (``''`` when there are no senders: synchronous publication)."""
    sender_ids = sender_thread_ids(task_folder)
    if not sender_ids:
        return None, ''
    cpus = os.sched_getaffinity(loop_thread_id)
    if len(cpus) < 2:
        return None, (f'the gyro loop and Fast DDS sender threads share {_cpu_list(cpus)}, '
                      f'the only one this process may use')
    split = CpuSplit(loop_thread_id, sender_ids, message_count, above_hz, cpus)
    return split, (f'gyro loop on CPU {split.loop_cpu} and Fast DDS sender threads on '
                   f'{_cpu_list(cpus - {split.loop_cpu})} while gyro input is above '
                   f'{above_hz:g} Hz')
