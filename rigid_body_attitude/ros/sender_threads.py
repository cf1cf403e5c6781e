"""Fast DDS's asynchronous sender threads: ``SCHED_IDLE`` while the gyro rate is high, else
``SCHED_BATCH``; the guard that chooses, and lifts a starved sender. Opt-in since the node gives
the senders short time slices instead (:mod:`~.time_slices`, ``bench/NOTES.md`` section 14):
this rule runs when ``idle_senders_above_hz`` is set, and is the remedy for kernels before
Linux 6.12, which have no custom slices.

With asynchronous publication (:func:`~rigid_body_attitude.ros.middleware.\
use_asynchronous_publication`) a Fast DDS 2.14 thread named ``dds.asyn.*`` sends what the
node's writers publish. When it finds a writer's mutex held by another thread (the gyro loop
publishing, the event thread's heartbeat or NACK-suppression timer, a listener handling an
acknowledgement), its loop tries again at once instead of sleeping (``FlowControllerImpl::run``:
``try_lock``, ``break``, round again). Under ``SCHED_BATCH`` no thread woken on its CPU
preempts it, so it can spin until the scheduler tick (4 ms on this project's machine) while
the holder of the mutex, and any other thread queued behind it, waits: in a 15 kHz run
``perf sched`` showed the sender running 1.0–3.9 ms without a break six times in 4 s, once
with the node's event thread runnable on the same CPU for 3.5 ms and the other CPU idle.
Those were the node's intermittent multi-millisecond latency tails at 15–20 kHz
(``bench/NOTES.md``, section 11).

Under ``SCHED_IDLE`` any other thread woken on its CPU preempts the sender at once, so a spin
ends as soon as the mutex's holder can run. The price: an idle thread gets only a sliver of a
CPU that other threads keep busy. With two CPU-bound processes on this 2-core machine a
sender at idle priority fell behind by 20–270 ms at 1–5 kHz, and with two processes each busy
30 ms in every 330 ms, at the same moments (``bench/cpu_bursts.py``), p99 at 2 kHz was
12.3–21.4 ms against 7.4–8.9 ms on ``SCHED_BATCH``.
Below 10 kHz the spin did not matter (with the senders on ``SCHED_BATCH``, p99 ≤ 1 ms up to
5 kHz and ahead of the fast relay at 10 kHz in ten sweeps of ``bench/NOTES.md``, section 10).
So the :class:`SenderGuard` (when ``idle_senders_above_hz`` is above 0) looks at the gyro
loop's message count every :data:`GUARD_PERIOD` seconds: the senders go to ``SCHED_IDLE`` when
the rate over the last half second reaches the node's ``idle_senders_above_hz`` and back to
``SCHED_BATCH`` when it falls below :data:`BATCH_BELOW_FRACTION` of it. While they are idle it
also reads each sender's ``/proc/self/task/<tid>/schedstat`` (time on the CPU, time waiting on
a run queue, runs) and puts them on ``SCHED_BATCH`` for good once one is starved. It does not
see short bursts of other load (waits of tens of ms in a few runs among hundreds leave the mean
per run low). Leaving ``SCHED_IDLE`` needs ``CAP_SYS_NICE`` or an ``RLIMIT_NICE`` of at least
20 (``ulimit -e``); a process without it keeps its senders on ``SCHED_BATCH``
(:func:`can_leave_idle_policy`).
"""

from __future__ import annotations

from collections import deque
from collections.abc import Callable
import os
import threading
from pathlib import Path
from typing import NamedTuple

__all__ = ['BATCH_BELOW_FRACTION', 'GUARD_PERIOD', 'GuardNote', 'GyroRate',
           'RATE_WINDOW_PERIODS', 'SENDER_THREAD_PREFIX', 'STARVED_MEAN_DELAY_NS',
           'STARVED_TOTAL_DELAY_NS', 'SchedStat', 'SenderGuard', 'TASKS', 'can_leave_idle_policy',
           'sender_guard', 'read_schedstat', 'sender_thread_ids']

#: Name prefix of Fast DDS 2.14's asynchronous sender threads.
SENDER_THREAD_PREFIX = 'dds.asyn.'

#: Seconds between two looks at the gyro rate (and, while idle, the senders' delays).
GUARD_PERIOD = 0.1

#: Looks over which the gyro rate is taken (half a second).
RATE_WINDOW_PERIODS = 5

#: Idle senders go back to ``SCHED_BATCH`` below this fraction of ``idle_senders_above_hz``
#: (so that a rate near the threshold does not move them back and forth).
BATCH_BELOW_FRACTION = 2.0 / 3.0

#: A sender is starved when, over one period, it waited on a run queue longer than this on
#: average per run ... (at 1–20 kHz without other load: at most 0.084 ms; with two CPU-bound
#: processes beside the node: a median of 4–12 ms; ``bench/NOTES.md``, section 11)
STARVED_MEAN_DELAY_NS = 1_000_000

#: ... and longer than this in all (one late run alone is not starvation).
STARVED_TOTAL_DELAY_NS = 20_000_000

#: This process's threads.
TASKS = Path('/proc/self/task')


class SchedStat(NamedTuple):
    """One thread's ``schedstat``: nanoseconds on a CPU and waiting on a run queue, runs."""

    run_ns: int
    wait_ns: int
    runs: int


def read_schedstat(path: Path) -> SchedStat | None:
    """A thread's ``schedstat`` file, or None when it is gone or the kernel has none."""
    try:
        run_ns, wait_ns, runs = (int(field) for field in path.read_text().split())
    except (OSError, ValueError):
        return None
    return SchedStat(run_ns, wait_ns, runs)


def sender_thread_ids(task_folder: Path = TASKS) -> list[int]:
    """Ids of this process's threads named :data:`SENDER_THREAD_PREFIX` ``*``."""
    ids = []
    for entry in sorted(task_folder.iterdir()):
        try:
            name = (entry / 'comm').read_text().strip()
        except OSError:  # the thread ended meanwhile
            continue
        if name.startswith(SENDER_THREAD_PREFIX):
            ids.append(int(entry.name))
    return ids


def can_leave_idle_policy() -> bool:
    """Whether a thread of this process may go from ``SCHED_IDLE`` back to ``SCHED_BATCH``.

    Tried on a short-lived thread of its own, so whatever the system allows or refuses
    (capabilities, ``RLIMIT_NICE``, a container's seccomp policy) is what counts.
    """
    allowed: list[bool] = []

    def probe() -> None:
        try:
            os.sched_setscheduler(0, os.SCHED_IDLE, os.sched_param(0))
            os.sched_setscheduler(0, os.SCHED_BATCH, os.sched_param(0))
        except OSError:
            allowed.append(False)
        else:
            allowed.append(True)

    thread = threading.Thread(target=probe, name='idle-probe')
    thread.start()
    thread.join()
    return allowed == [True]


class GyroRate:
    """The gyro input rate, from the gyro loop's message count looked at every
    :data:`GUARD_PERIOD` seconds."""

    def __init__(self, message_count: Callable[[], int]) -> None:
        """``message_count()`` is the number of gyro messages handled so far."""
        self.message_count = message_count
        self.counts: deque[int] = deque(maxlen=RATE_WINDOW_PERIODS + 1)

    def look(self) -> float | None:
        """Take the count; the :meth:`rate` with it."""
        self.counts.append(self.message_count())
        return self.rate()

    def rate(self) -> float | None:
        """Gyro messages per second over the last :data:`RATE_WINDOW_PERIODS` looks (None
        before that many)."""
        if len(self.counts) <= RATE_WINDOW_PERIODS:
            return None
        return (self.counts[-1] - self.counts[0]) / (RATE_WINDOW_PERIODS * GUARD_PERIOD)


class GuardNote(NamedTuple):
    """A line for the node's log: a policy change (info) or a starved sender (warning)."""

    warning: bool
    text: str


class SenderGuard:
    """Chooses the senders' policy from the gyro rate; lifts them for good when starved.

    The senders start on ``SCHED_BATCH``. A sender whose policy is not the one the guard
    last gave it (changed by someone else, or gone) is left alone and no longer watched.
    """

    def __init__(self, thread_ids: list[int], message_count: Callable[[], int],
                 idle_above_hz: float, task_folder: Path = TASKS) -> None:
        """Watch ``thread_ids`` (on ``SCHED_BATCH``); ``message_count()`` is the number of
        gyro messages handled so far; idle from ``idle_above_hz`` on."""
        self.thread_ids = list(thread_ids)
        self.gyro_rate = GyroRate(message_count)
        self.idle_above_hz = idle_above_hz
        self.task_folder = task_folder
        #: The senders are on ``SCHED_IDLE``.
        self.idle = False
        #: A sender starved: the senders stay on ``SCHED_BATCH`` for good.
        self.starved = False
        self.delays: dict[int, SchedStat | None] = {}

    def check(self) -> list[GuardNote]:
        """One look (every :data:`GUARD_PERIOD` s); a note per change made."""
        rate = self.gyro_rate.look()
        if self.starved or rate is None or not self.thread_ids:
            return []
        if not self.idle:
            if rate < self.idle_above_hz:
                return []
            return self._move(os.SCHED_BATCH, os.SCHED_IDLE, False, (
                f'gyro input at {rate:.0f} Hz (idle_senders_above_hz '
                f'{self.idle_above_hz:g}): Fast DDS sender threads'))
        starved = self._starved_sender()
        if starved:
            self.starved = True
            return self._move(os.SCHED_IDLE, os.SCHED_BATCH, True, starved)
        if rate < BATCH_BELOW_FRACTION * self.idle_above_hz:
            return self._move(os.SCHED_IDLE, os.SCHED_BATCH, False, (
                f'gyro input at {rate:.0f} Hz (below {BATCH_BELOW_FRACTION:.3g} of '
                f'idle_senders_above_hz {self.idle_above_hz:g}): Fast DDS sender threads'))
        return []

    def _starved_sender(self) -> str:
        """The reason the first starved sender is starved ('' when none is)."""
        for thread_id in self.thread_ids:
            now = read_schedstat(self.task_folder / str(thread_id) / 'schedstat')
            before = self.delays.get(thread_id)
            self.delays[thread_id] = now
            if before is not None and now is not None and _starved(before, now):
                return (f'Fast DDS sender thread {thread_id} starved by other load '
                        f'({(now.wait_ns - before.wait_ns) * 1e-6:.0f} ms waiting for a CPU in '
                        f'{now.runs - before.runs} runs over {GUARD_PERIOD:g} s): '
                        f'Fast DDS sender threads')
        return ''

    def _move(self, old: int, new: int, warning: bool, reason: str) -> list[GuardNote]:
        """Move the senders on ``old`` to ``new``; forget those on neither (not ours) and
        those the system refuses to move."""
        moved, kept, refused = [], [], ''
        for thread_id in self.thread_ids:
            policy = _policy(thread_id)
            if policy == old:
                try:
                    os.sched_setscheduler(thread_id, new, os.sched_param(0))
                except OSError as err:
                    refused = f' ({thread_id} refused: {err})'
                    continue
                moved.append(thread_id)
            elif policy == new:
                kept.append(thread_id)
        self.thread_ids = moved + kept
        self.idle = new == os.SCHED_IDLE and bool(self.thread_ids)
        self.delays = {}
        if not moved and not refused:
            return []
        return [GuardNote(warning or bool(refused),
                          f'{reason} {moved} moved to {_POLICY_NAMES[new]}{refused}')]


_POLICY_NAMES = {os.SCHED_IDLE: 'SCHED_IDLE', os.SCHED_BATCH: 'SCHED_BATCH'}


def _policy(thread_id: int) -> int | None:
    """A thread's scheduling policy, or None when it is gone."""
    try:
        return os.sched_getscheduler(thread_id)
    except OSError:
        return None


def _starved(before: SchedStat, now: SchedStat) -> bool:
    """Whether the waits between two readings say the thread is starved."""
    waited = now.wait_ns - before.wait_ns
    runs = max(now.runs - before.runs, 1)
    return waited > STARVED_TOTAL_DELAY_NS and waited > STARVED_MEAN_DELAY_NS * runs


def sender_guard(message_count: Callable[[], int], idle_above_hz: float,
                 task_folder: Path = TASKS) -> tuple[SenderGuard | None, str]:
    """A guard over this process's sender threads when they may go to ``SCHED_IDLE`` and
    back, and a remark for the log (``''`` when there are none: synchronous publication)."""
    thread_ids = sender_thread_ids(task_folder)
    if not thread_ids:
        return None, ''
    if any(read_schedstat(task_folder / str(thread_id) / 'schedstat') is None
           for thread_id in thread_ids):
        return None, (f'Fast DDS sender threads kept on SCHED_BATCH (no '
                      f'{task_folder}/<tid>/schedstat to watch them by)')
    if not can_leave_idle_policy():
        return None, ('Fast DDS sender threads kept on SCHED_BATCH (leaving SCHED_IDLE needs '
                      'CAP_SYS_NICE or RLIMIT_NICE >= 20)')
    return SenderGuard(thread_ids, message_count, idle_above_hz, task_folder), (
        f'Fast DDS sender threads {thread_ids} on SCHED_IDLE while gyro input is above '
        f'{idle_above_hz:g} Hz, else on SCHED_BATCH')
