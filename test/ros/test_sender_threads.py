"""Fast DDS's sender threads at idle priority while the gyro rate is high, and their guard
(:mod:`rigid_body_attitude.ros.sender_threads`).

What idle priority buys is measured, not tested (``bench/NOTES.md``, sections 11 and 12).
Here: the privilege probe, the ``schedstat`` reader, the rate rule with its hysteresis, the
starvation rule, threads that are not the guard's, and the installed node moving its senders
with the gyro rate and under CPU-bound load.
"""

from __future__ import annotations

import os
from pathlib import Path
import re
import resource
import subprocess
import sys
import threading
import time
from typing import Iterator

import pytest
from geometry_msgs.msg import PoseStamped
from ros_helpers import Harness, stamp, unique_namespace
from sensor_msgs.msg import Imu
from test_node_subprocess import read_until, start, stop_with_sigint

from rigid_body_attitude.ros.sender_threads import (
    can_leave_idle_policy, GUARD_PERIOD, GuardNote, RATE_WINDOW_PERIODS, read_schedstat,
    sender_guard, SenderGuard, sender_thread_ids, STARVED_MEAN_DELAY_NS,
    STARVED_TOTAL_DELAY_NS)

CAP_SYS_NICE = 23
NO_SUCH_THREAD = 2**22 + 12345  # above pid_max


def _may_leave_idle() -> bool:
    """CAP_SYS_NICE in the effective set, or an RLIMIT_NICE that allows nice 0."""
    status = Path('/proc/self/status').read_text()
    effective = int(re.search(r'^CapEff:\s*([0-9a-f]+)$', status, re.M).group(1), 16)
    return bool(effective >> CAP_SYS_NICE & 1) or resource.getrlimit(resource.RLIMIT_NICE)[0] >= 20


def test_the_probe_answers_what_the_privileges_allow_and_changes_no_thread():
    before = os.sched_getscheduler(0)
    assert can_leave_idle_policy() == _may_leave_idle()
    assert os.sched_getscheduler(0) == before


def test_schedstat_of_a_live_thread_and_of_nothing_readable(tmp_path):
    stat = read_schedstat(Path(f'/proc/self/task/{threading.get_native_id()}/schedstat'))
    assert stat is not None and stat.run_ns > 0 and stat.runs >= 1
    assert read_schedstat(tmp_path / 'missing') is None
    (tmp_path / 'short').write_text('1 2\n')
    assert read_schedstat(tmp_path / 'short') is None


def _thread(folder: Path, thread_id: int, name: str | None = None,
            stat: tuple[int, int, int] | None = None) -> None:
    """A fake ``/proc/self/task/<thread_id>`` with a ``comm`` and a ``schedstat``."""
    (folder / str(thread_id)).mkdir(exist_ok=True)
    if name is not None:
        (folder / str(thread_id) / 'comm').write_text(name + '\n')
    if stat is not None:
        (folder / str(thread_id) / 'schedstat').write_text(' '.join(map(str, stat)) + '\n')


def test_sender_threads_are_found_by_name(tmp_path):
    _thread(tmp_path, 11, 'dds.asyn.0.0')
    _thread(tmp_path, 12, 'dds.ev.0')
    _thread(tmp_path, 13, 'dds.asyn.0.1')
    _thread(tmp_path, 14)  # ended between listing and reading
    assert sender_thread_ids(tmp_path) == [11, 13]


@pytest.fixture
def batch_thread() -> Iterator[int]:
    """The native id of a thread on SCHED_BATCH (its own policy only: nothing reaches the
    test run), alive until the test ends."""
    ready, release = threading.Event(), threading.Event()
    ids: list[int] = []

    def body() -> None:
        os.sched_setscheduler(0, os.SCHED_BATCH, os.sched_param(0))
        ids.append(threading.get_native_id())
        ready.set()
        release.wait()

    thread = threading.Thread(target=body)
    thread.start()
    ready.wait()
    yield ids[0]
    release.set()
    thread.join()


class GyroCount:
    """A gyro message count the test advances: ``rate`` messages a second per look."""

    def __init__(self) -> None:
        self.count = 0
        self.rate = 0.0

    def __call__(self) -> int:
        self.count += round(self.rate * GUARD_PERIOD)
        return self.count


def _looks(guard: SenderGuard, count: GyroCount, rate: float, looks: int) -> list[GuardNote]:
    """``looks`` checks of ``guard`` at ``rate``; their notes."""
    count.rate = rate
    return [note for _ in range(looks) for note in guard.check()]


def _idle_guard(folder: Path, thread_id: int) -> tuple[SenderGuard, GyroCount]:
    """A guard over ``thread_id`` that has just put it on SCHED_IDLE (threshold 1 kHz)."""
    count = GyroCount()
    guard = SenderGuard([thread_id], count, 1000.0, folder)
    assert _looks(guard, count, 1000.0, RATE_WINDOW_PERIODS + 1) == [GuardNote(False, (
        f'gyro input at 1000 Hz (idle_senders_above_hz 1000): Fast DDS sender threads '
        f'[{thread_id}] moved to SCHED_IDLE'))]
    assert guard.idle and os.sched_getscheduler(thread_id) == os.SCHED_IDLE
    return guard, count


def test_the_senders_follow_the_gyro_rate_with_hysteresis(tmp_path, batch_thread):
    _thread(tmp_path, batch_thread, stat=(1_000, 5_000, 7))  # never starved
    count = GyroCount()
    guard = SenderGuard([batch_thread], count, 1000.0, tmp_path)
    # No rate before a whole window, then below the threshold: nothing moves.
    assert _looks(guard, count, 990.0, RATE_WINDOW_PERIODS) == []
    assert guard.gyro_rate.rate() is None
    assert _looks(guard, count, 990.0, 1) == []
    assert guard.gyro_rate.rate() == pytest.approx(990.0)
    assert os.sched_getscheduler(batch_thread) == os.SCHED_BATCH
    guard, count = _idle_guard(tmp_path, batch_thread)
    assert _looks(guard, count, 670.0, 30) == []  # above 2/3 of the threshold: stays idle
    assert os.sched_getscheduler(batch_thread) == os.SCHED_IDLE
    notes = _looks(guard, count, 600.0, RATE_WINDOW_PERIODS)  # 656 Hz at the first look
    reason = ('gyro input at 656 Hz (below 0.667 of idle_senders_above_hz 1000): Fast DDS '
              'sender threads')
    if _may_leave_idle():
        assert notes == [GuardNote(False, f'{reason} [{batch_thread}] moved to SCHED_BATCH')]
        assert os.sched_getscheduler(batch_thread) == os.SCHED_BATCH and not guard.idle
        assert len(_looks(guard, count, 1000.0, RATE_WINDOW_PERIODS)) == 1  # idle again
    else:  # refused: said once, as a warning; the thread is no longer the guard's
        assert len(notes) == 1 and notes[0].warning
        assert notes[0].text.startswith(f'{reason} [] moved to SCHED_BATCH ({batch_thread} '
                                        f'refused: ')
        assert guard.thread_ids == [] and not guard.idle


@pytest.mark.parametrize('waited_ns, runs, starved', [
    (STARVED_TOTAL_DELAY_NS, 10, False),  # 2 ms a run, but not more than the total in all
    (STARVED_TOTAL_DELAY_NS + 1, 21, False),  # more in all, but under 1 ms a run: just busy
    (STARVED_TOTAL_DELAY_NS + 1, 20, True),
    (90_000_000, 0, True),  # never ran at all
])
def test_the_starvation_rule(tmp_path, batch_thread, waited_ns, runs, starved):
    assert STARVED_MEAN_DELAY_NS == 1_000_000
    _thread(tmp_path, batch_thread, stat=(1_000, 5_000, 7))
    guard, count = _idle_guard(tmp_path, batch_thread)
    assert guard.check() == []  # the first reading while idle is the baseline
    _thread(tmp_path, batch_thread, stat=(2_000, 5_000 + waited_ns, 7 + runs))
    notes = guard.check()
    if not starved:
        assert notes == [] and guard.idle
        assert os.sched_getscheduler(batch_thread) == os.SCHED_IDLE
        return
    reason = (f'Fast DDS sender thread {batch_thread} starved by other load '
              f'({waited_ns * 1e-6:.0f} ms waiting for a CPU in {runs} runs over '
              f'{GUARD_PERIOD:g} s): Fast DDS sender threads')
    assert len(notes) == 1 and notes[0].warning and notes[0].text.startswith(reason)
    assert guard.starved and not guard.idle
    if _may_leave_idle():
        assert notes[0].text == f'{reason} [{batch_thread}] moved to SCHED_BATCH'
        assert os.sched_getscheduler(batch_thread) == os.SCHED_BATCH
    else:
        assert 'refused' in notes[0].text
    assert _looks(guard, count, 5000.0, 30) == []  # for good: never idle again


def test_threads_whose_policy_changed_elsewhere_or_that_ended_are_forgotten(
        tmp_path, batch_thread):
    normal = threading.get_native_id()  # this thread: on SCHED_OTHER, not ours to move
    count = GyroCount()
    guard = SenderGuard([batch_thread, normal, NO_SUCH_THREAD], count, 1000.0, tmp_path)
    notes = _looks(guard, count, 2000.0, RATE_WINDOW_PERIODS + 1)
    assert [note.text for note in notes] == [
        f'gyro input at 2000 Hz (idle_senders_above_hz 1000): Fast DDS sender threads '
        f'[{batch_thread}] moved to SCHED_IDLE']
    assert guard.thread_ids == [batch_thread]
    assert os.sched_getscheduler(normal) == os.SCHED_OTHER
    if not _may_leave_idle():
        return
    os.sched_setscheduler(batch_thread, os.SCHED_OTHER, os.sched_param(0))
    # Someone else changed it: left alone, forgotten, no more notes.
    assert _looks(guard, count, 0.0, 2 * RATE_WINDOW_PERIODS) == []
    assert guard.thread_ids == [] and not guard.idle
    assert os.sched_getscheduler(batch_thread) == os.SCHED_OTHER


def test_the_guard_of_a_process_and_its_remark(tmp_path):
    count = GyroCount()
    assert sender_guard(count, 12000.0, tmp_path) == (None, '')  # synchronous: no senders
    _thread(tmp_path, 21, 'dds.asyn.0.0')
    _thread(tmp_path, 22, 'dds.asyn.0.1', stat=(1, 2, 3))
    guard, remark = sender_guard(count, 12000.0, tmp_path)
    assert guard is None
    assert remark == (f'Fast DDS sender threads kept on SCHED_BATCH (no {tmp_path}/<tid>/'
                      f'schedstat to watch them by)')
    _thread(tmp_path, 21, stat=(4, 5, 6))
    guard, remark = sender_guard(count, 12000.0, tmp_path)
    if _may_leave_idle():
        assert guard is not None and guard.thread_ids == [21, 22]
        assert guard.idle_above_hz == 12000.0 and not guard.idle
        assert remark == ('Fast DDS sender threads [21, 22] on SCHED_IDLE while gyro input is '
                          'above 12000 Hz, else on SCHED_BATCH')
    else:
        assert guard is None
        assert remark == ('Fast DDS sender threads kept on SCHED_BATCH (leaving SCHED_IDLE '
                          'needs CAP_SYS_NICE or RLIMIT_NICE >= 20)')


def _sender_policies(pid: int) -> dict[int, int]:
    """Sender thread id → scheduling policy, for process ``pid``."""
    return {thread_id: os.sched_getscheduler(thread_id)
            for thread_id in sender_thread_ids(Path(f'/proc/{pid}/task'))}


def _cpu_hogs(count: int) -> list[subprocess.Popen]:
    return [subprocess.Popen([sys.executable, '-c', 'while True: pass']) for _ in range(count)]


def _publish_until(harness: Harness, publisher, sent: int, done, timeout: float = 20.0) -> int:
    """Publish Imu messages (1 kHz stamps, in bursts of 50 every 20 ms) until ``done()`` or
    ``timeout`` s; the number sent so far."""
    base_ns = 1_700_000_000 * 10**9
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline and not done():
        for _ in range(50):
            imu = Imu()
            imu.header.stamp = stamp(base_ns + sent * 10**6)
            imu.angular_velocity.z = 0.5
            publisher.publish(imu)
            sent += 1
        harness.spin_for(0.02)
    return sent


def test_the_installed_node_idles_its_senders_at_high_rates_and_lifts_them_when_starved(
        ros, request, processes):
    """With ``idle_senders_above_hz`` 100: the senders go to SCHED_IDLE while gyro messages
    come at over 100 Hz, back to SCHED_BATCH when they stop, to SCHED_IDLE again, and to
    SCHED_BATCH for good beside one CPU-bound process per CPU the test may use, and one more
    (a sender at idle priority then gets next to no CPU)."""
    namespace = unique_namespace(request)
    process = start('--ros-args', '-p', 'scene:=strapdown', '-p', 'idle_senders_above_hz:=100.0',
                    '-r', f'__ns:={namespace}')
    processes.append(process)
    lines = read_until(process, 'serving')
    senders = _sender_policies(process.pid)
    assert len(senders) == 2, senders  # discovery's and the writers'
    assert set(senders.values()) == {os.SCHED_BATCH}
    if not _may_leave_idle():  # nothing to guard: the senders stay on SCHED_BATCH
        assert 'leaving SCHED_IDLE needs CAP_SYS_NICE or RLIMIT_NICE >= 20' in lines[-1]
        assert stop_with_sigint(process)[0] == 0
        return
    assert 'on SCHED_IDLE while gyro input is above 100 Hz, else on SCHED_BATCH' in lines[-1]
    harness = Harness(ros, namespace)
    imu_publisher = harness.publisher(Imu, 'imu')
    poses = harness.record(PoseStamped, 'pose')
    harness.wait_for_connections(30.0)

    def on(policy: int):
        return lambda: policy in _sender_policies(process.pid).values()
    sent = _publish_until(harness, imu_publisher, 0, on(os.SCHED_IDLE))
    assert on(os.SCHED_IDLE)()
    harness.spin_for(2.0)  # no gyro messages
    assert set(_sender_policies(process.pid).values()) == {os.SCHED_BATCH}
    sent = _publish_until(harness, imu_publisher, sent, on(os.SCHED_IDLE))
    assert on(os.SCHED_IDLE)()
    hogs = _cpu_hogs(len(os.sched_getaffinity(0)) + 1)
    processes.extend(hogs)
    _publish_until(harness, imu_publisher, sent, on(os.SCHED_BATCH))
    for hog in hogs:
        hog.kill()
    policies = _sender_policies(process.pid)
    code, stderr = stop_with_sigint(process)
    assert code == 0, stderr
    assert os.SCHED_BATCH in policies.values(), (policies, stderr)
    moves = re.findall(r'moved to (SCHED_\w+)', stderr)
    assert moves == ['SCHED_IDLE', 'SCHED_BATCH', 'SCHED_IDLE', 'SCHED_BATCH'], stderr
    assert re.search(r'WARN.*Fast DDS sender thread \d+ starved by other load \(\d+ ms waiting '
                     r'for a CPU in \d+ runs over 0\.1 s\): Fast DDS sender threads \[[\d, ]+\] '
                     r'moved to SCHED_BATCH', stderr), stderr
    assert len(poses) > 0


def test_a_dynamics_scene_keeps_its_senders_on_batch_without_a_guard(processes):
    """No gyro input: no guard runs, even with ``idle_senders_above_hz`` 1 (a guard would
    move the senders to SCHED_IDLE once it has a rate, 0.5 s after start), and the start-up
    line has no remark about the senders (the idle rule, chosen, takes the place of the short
    time slices)."""
    process = start('--ros-args', '-p', 'scene:=torque_free_box',
                    '-p', 'idle_senders_above_hz:=1.0')
    processes.append(process)
    lines = read_until(process, 'serving')
    assert re.search(r"cpu_scheduling 'batch': \d+ threads changed; serving$",
                     lines[-1].rstrip()), lines[-1]
    time.sleep(1.5)
    senders = _sender_policies(process.pid)
    assert len(senders) == 2 and set(senders.values()) == {os.SCHED_BATCH}, senders
    code, stderr = stop_with_sigint(process)
    assert code == 0, stderr
    assert 'Fast DDS sender thread' not in stderr
