"""Fast DDS's asynchronous sender threads at idle priority, and the guard that lifts a starved one.

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
Those were the node's intermittent multi-millisecond latency tails at 10–20 kHz
(``bench/NOTES.md``, section 11).

Under ``SCHED_IDLE`` any other thread woken on its CPU preempts the sender at once, so a spin
ends as soon as the mutex's holder can run. The price: an idle thread gets only a sliver of a
CPU that other threads keep busy (with two CPU-bound processes on this 2-core machine, a
sender at idle priority fell behind by 20–270 ms at 1–5 kHz). The :class:`SenderGuard` therefore
looks at each sender's scheduling delay every :data:`GUARD_PERIOD` seconds and moves a starved
one to ``SCHED_BATCH`` for good. It does not see short bursts of other load (waits of tens
of ms in a few runs among hundreds leave the mean per run low), during which an idle sender
is the last thread to run: with two processes each busy 30 ms in every 330 ms, p99 at 2 kHz
was 10.7–20.1 ms against 8.1–9.0 ms with the senders on ``SCHED_BATCH``
(``cpu_scheduling: all_batch``). Leaving ``SCHED_IDLE`` needs ``CAP_SYS_NICE`` or an
``RLIMIT_NICE`` of at least 20 (``ulimit -e``); a process without it keeps its senders on
``SCHED_BATCH`` (:func:`can_leave_idle_policy`). The delays come from
``/proc/self/task/<tid>/schedstat`` (time on the CPU, time waiting on a run queue, runs).
"""

from __future__ import annotations

import os
import threading
from pathlib import Path
from typing import NamedTuple

__all__ = ['GUARD_PERIOD', 'SENDER_THREAD_PREFIX', 'STARVED_MEAN_DELAY_NS',
           'STARVED_TOTAL_DELAY_NS', 'SchedStat', 'SenderGuard', 'can_leave_idle_policy',
           'idle_sender_guard', 'read_schedstat', 'sender_thread_ids']

#: Name prefix of Fast DDS 2.14's asynchronous sender threads.
SENDER_THREAD_PREFIX = 'dds.asyn.'

#: Seconds between two looks at the senders' scheduling delays.
GUARD_PERIOD = 0.1

#: A sender is starved when, over one period, it waited on a run queue longer than this on
#: average per run ... (at 1–20 kHz without other load: at most 0.084 ms; with two CPU-bound
#: processes beside the node: a median of 4–12 ms; ``bench/NOTES.md``, section 11)
STARVED_MEAN_DELAY_NS = 1_000_000

#: ... and longer than this in all (one late run alone is not starvation).
STARVED_TOTAL_DELAY_NS = 20_000_000

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


class SenderGuard:
    """Watches sender threads on ``SCHED_IDLE``; moves a starved one to ``SCHED_BATCH``.

    A starved thread that is not on ``SCHED_IDLE`` (its policy was not the node's to set) is
    left as it is and no longer watched.
    """

    def __init__(self, thread_ids: list[int], task_folder: Path = _TASKS) -> None:
        """Watch ``thread_ids`` (already on ``SCHED_IDLE``, or about to be)."""
        self.task_folder = task_folder
        self.watched: dict[int, SchedStat | None] = dict.fromkeys(thread_ids)
        #: Threads moved to ``SCHED_BATCH`` so far.
        self.promoted: list[int] = []

    def check(self) -> list[str]:
        """Look at every watched thread once; a line for the log per thread moved."""
        lines = []
        for thread_id, before in list(self.watched.items()):
            now = read_schedstat(self.task_folder / str(thread_id) / 'schedstat')
            if now is None:  # the thread ended
                del self.watched[thread_id]
                continue
            self.watched[thread_id] = now
            if before is None or not _starved(before, now):
                continue
            del self.watched[thread_id]
            if _policy(thread_id) == os.SCHED_IDLE:  # else not ours to move (or gone)
                lines.append(self._promote(thread_id, before, now))
        return lines

    def _promote(self, thread_id: int, before: SchedStat, now: SchedStat) -> str:
        waited_ms = (now.wait_ns - before.wait_ns) * 1e-6
        runs = now.runs - before.runs
        try:
            os.sched_setscheduler(thread_id, os.SCHED_BATCH, os.sched_param(0))
        except OSError as err:
            return (f'Fast DDS sender thread {thread_id} starved ({waited_ms:.0f} ms waiting for '
                    f'a CPU in {runs} runs) and could not leave SCHED_IDLE: {err}')
        self.promoted.append(thread_id)
        return (f'Fast DDS sender thread {thread_id} starved by other load ({waited_ms:.0f} ms '
                f'waiting for a CPU in {runs} runs over {GUARD_PERIOD:g} s): moved from '
                f'SCHED_IDLE to SCHED_BATCH')


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


def idle_sender_guard(task_folder: Path = _TASKS) -> tuple[SenderGuard | None, str]:
    """A guard over this process's sender threads when they may go to ``SCHED_IDLE``, and a
    remark for the log (``''`` when there are none: synchronous publication)."""
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
    return SenderGuard(thread_ids, task_folder), (
        f'Fast DDS sender threads {thread_ids} on SCHED_IDLE, moved to SCHED_BATCH if starved')
