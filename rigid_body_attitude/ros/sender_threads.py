"""Fast DDS's asynchronous sender threads: ``SCHED_IDLE`` while the gyro rate is high, else
``SCHED_BATCH``; the guard that chooses, and lifts them while other load contends.

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
So the :class:`SenderGuard` looks at the gyro loop's message count every :data:`GUARD_PERIOD`
seconds: the senders go to ``SCHED_IDLE`` when the rate over the last :data:`RATE_WINDOW`
seconds reaches the node's ``idle_senders_above_hz`` and back to ``SCHED_BATCH`` when it falls
below :data:`BATCH_BELOW_FRACTION` of it. While they are idle it looks every
:data:`IDLE_LOOK_PERIOD` seconds at each sender's ``/proc/self/task/<tid>/schedstat`` (time on
the CPU, time waiting on a run queue, runs): other load that keeps the CPUs busy shows as
longer waits per run, and the guard then puts the senders on ``SCHED_BATCH`` for a hold of
:data:`FIRST_HOLD` seconds, doubled at each new contention up to :data:`MAX_HOLD`
(:func:`contended`; the thresholds and what they separate: ``bench/NOTES.md``, section 13).
Leaving ``SCHED_IDLE`` needs ``CAP_SYS_NICE`` or an ``RLIMIT_NICE`` of at least 20
(``ulimit -e``); a process without it keeps its senders on ``SCHED_BATCH``
(:func:`can_leave_idle_policy`).
"""

from __future__ import annotations

from collections import deque
from collections.abc import Callable
import os
import threading
import time
from pathlib import Path
from typing import NamedTuple

__all__ = ['BATCH_BELOW_FRACTION', 'CONTENDED_MEAN_WAIT_NS', 'CONTENDED_WAIT_FRACTION',
           'FIRST_HOLD', 'GUARD_PERIOD', 'GuardNote', 'IDLE_LOOK_PERIOD', 'MAX_HOLD',
           'RATE_WINDOW', 'SENDER_THREAD_PREFIX', 'SchedStat', 'SenderGuard',
           'can_leave_idle_policy', 'contended', 'read_schedstat', 'sender_guard',
           'sender_thread_ids']

#: Name prefix of Fast DDS 2.14's asynchronous sender threads.
SENDER_THREAD_PREFIX = 'dds.asyn.'

#: Seconds between two looks at the gyro rate while the senders are on ``SCHED_BATCH``.
GUARD_PERIOD = 0.1

#: Seconds between two looks while they are idle (the rate and the senders' waits).
IDLE_LOOK_PERIOD = 0.02

#: Seconds of gyro messages the rate is taken over.
RATE_WINDOW = 0.5

#: Idle senders go back to ``SCHED_BATCH`` below this fraction of ``idle_senders_above_hz``
#: (so that a rate near the threshold does not move them back and forth).
BATCH_BELOW_FRACTION = 2.0 / 3.0

#: An idle sender is contended when, between two looks, it waited on a run queue longer than
#: this on average per run ... (20 kHz without other load: at most 0.06 ms per run in 20 ms;
#: beside a process busy 100 ms in every second: a median of 0.17 ms in the windows with
#: poses over 5 ms late; ``bench/NOTES.md``, section 13)
CONTENDED_MEAN_WAIT_NS = 150_000

#: ... and for more than this fraction of the time between the looks (at most 0.69 without
#: other load; a median of 0.84 in those late windows).
CONTENDED_WAIT_FRACTION = 0.75

#: Seconds the senders stay on ``SCHED_BATCH`` after a first contention; a contention less
#: than :data:`MAX_HOLD` seconds after the last hold ended doubles the hold, up to
#: :data:`MAX_HOLD` (other load that comes back and back then costs one contention a minute).
FIRST_HOLD = 1.0
MAX_HOLD = 64.0

_TASKS = Path('/proc/self/task')


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


def sender_thread_ids(task_folder: Path = _TASKS) -> list[int]:
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


class GuardNote(NamedTuple):
    """A line for the node's log: a policy change (info), or a move the system refused
    (warning)."""

    warning: bool
    text: str


class SenderGuard:
    """Chooses the senders' policy from the gyro rate; lifts them while other load contends.

    The senders start on ``SCHED_BATCH``. A sender whose policy is not the one the guard
    last gave it (changed by someone else, or gone) is left alone and no longer watched.
    :meth:`check` wants to be called every :attr:`period` seconds.
    """

    def __init__(self, thread_ids: list[int], message_count: Callable[[], int],
                 idle_above_hz: float, task_folder: Path = _TASKS,
                 monotonic: Callable[[], float] = time.monotonic) -> None:
        """Watch ``thread_ids`` (on ``SCHED_BATCH``); ``message_count()`` is the number of
        gyro messages handled so far; idle from ``idle_above_hz`` on."""
        self.thread_ids = list(thread_ids)
        self.message_count = message_count
        self.idle_above_hz = idle_above_hz
        self.task_folder = task_folder
        self.monotonic = monotonic
        self.counts: deque[tuple[float, int]] = deque()
        #: The senders are on ``SCHED_IDLE``.
        self.idle = False
        #: Until when (monotonic s) the senders stay on ``SCHED_BATCH`` after a contention.
        self.batch_until = -float('inf')
        #: Seconds of the last hold.
        self.hold = 0.0
        #: Each watched sender's last ``schedstat`` while idle, and when it was read.
        self.readings: dict[int, tuple[float, SchedStat]] = {}

    @property
    def period(self) -> float:
        """Seconds until the next look: :data:`IDLE_LOOK_PERIOD` while idle, else
        :data:`GUARD_PERIOD`."""
        return IDLE_LOOK_PERIOD if self.idle else GUARD_PERIOD

    def rate(self) -> float | None:
        """Gyro messages per second over the last :data:`RATE_WINDOW` seconds of looks (None
        before the looks span that long)."""
        if not self.counts:
            return None
        (first_at, first), (last_at, last) = self.counts[0], self.counts[-1]
        if last_at - first_at < RATE_WINDOW * (1.0 - 1e-6):
            return None
        return (last - first) / (last_at - first_at)

    def check(self) -> list[GuardNote]:
        """One look; a note per change made."""
        now = self.monotonic()
        self._count(now)
        rate = self.rate()
        if rate is None or not self.thread_ids:
            return []
        if not self.idle:
            if rate < self.idle_above_hz or now < self.batch_until:
                return []
            return self._move(os.SCHED_BATCH, os.SCHED_IDLE, (
                f'gyro input at {rate:.0f} Hz (idle_senders_above_hz '
                f'{self.idle_above_hz:g}): Fast DDS sender threads'))
        if rate < BATCH_BELOW_FRACTION * self.idle_above_hz:
            return self._move(os.SCHED_IDLE, os.SCHED_BATCH, (
                f'gyro input at {rate:.0f} Hz (below {BATCH_BELOW_FRACTION:.3g} of '
                f'idle_senders_above_hz {self.idle_above_hz:g}): Fast DDS sender threads'))
        waits = self._contended_sender(now)
        if not waits:
            return []
        self.hold = (min(2.0 * self.hold, MAX_HOLD) if now - self.batch_until < MAX_HOLD
                     else FIRST_HOLD)
        self.batch_until = now + self.hold
        return self._move(os.SCHED_IDLE, os.SCHED_BATCH, (
            f'other load contends for the CPUs ({waits}): for {self.hold:g} s, '
            f'Fast DDS sender threads'))

    def _count(self, now: float) -> None:
        """Add this look's message count; keep one look at least :data:`RATE_WINDOW` old."""
        counts = self.counts
        counts.append((now, self.message_count()))
        while len(counts) > 2 and now - counts[1][0] >= RATE_WINDOW * (1.0 - 1e-6):
            counts.popleft()

    def _contended_sender(self, now: float) -> str:
        """The waits of the first contended sender since the last look ('' when none is)."""
        for thread_id in self.thread_ids:
            reading = read_schedstat(self.task_folder / str(thread_id) / 'schedstat')
            last = self.readings.pop(thread_id, None)
            if reading is None:
                continue
            self.readings[thread_id] = (now, reading)
            if last is not None and contended(last[1], reading, now - last[0]):
                waited, runs = reading.wait_ns - last[1].wait_ns, reading.runs - last[1].runs
                return (f'sender {thread_id} waited {waited * 1e-6:.1f} ms for a CPU in '
                        f'{runs} runs over {(now - last[0]) * 1e3:.0f} ms')
        return ''

    def _move(self, old: int, new: int, reason: str) -> list[GuardNote]:
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
        self.readings = {}
        if not moved and not refused:
            return []
        return [GuardNote(bool(refused),
                          f'{reason} {moved} moved to {_POLICY_NAMES[new]}{refused}')]


_POLICY_NAMES = {os.SCHED_IDLE: 'SCHED_IDLE', os.SCHED_BATCH: 'SCHED_BATCH'}


def _policy(thread_id: int) -> int | None:
    """A thread's scheduling policy, or None when it is gone."""
    try:
        return os.sched_getscheduler(thread_id)
    except OSError:
        return None


def contended(before: SchedStat, after: SchedStat, elapsed_s: float) -> bool:
    """Whether a sender's waits between two readings ``elapsed_s`` apart say that other load
    contends for the CPUs: more than :data:`CONTENDED_MEAN_WAIT_NS` per run on average and
    more than :data:`CONTENDED_WAIT_FRACTION` of the time."""
    waited = after.wait_ns - before.wait_ns
    runs = max(after.runs - before.runs, 1)
    return (waited > CONTENDED_MEAN_WAIT_NS * runs
            and waited > CONTENDED_WAIT_FRACTION * elapsed_s * 1e9)


def sender_guard(message_count: Callable[[], int], idle_above_hz: float,
                 task_folder: Path = _TASKS) -> tuple[SenderGuard | None, str]:
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
