"""Fast DDS's sender threads at idle priority while the gyro rate is high, and their guard
(:mod:`rigid_body_attitude.ros.sender_threads`).

What idle priority buys is measured, not tested (``bench/NOTES.md``, sections 11 and 12).
Here: the privilege probe, the ``schedstat`` reader, the rate rule with its hysteresis, the
contention rule and its holds, threads that are not the guard's, and the installed node moving
its senders with the gyro rate and under CPU-bound load.
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
    can_leave_idle_policy, contended, CONTENDED_MEAN_WAIT_NS, CONTENDED_WAIT_FRACTION,
    FIRST_HOLD, GUARD_PERIOD, GuardNote, IDLE_LOOK_PERIOD, MAX_HOLD, RATE_WINDOW,
    read_schedstat, sender_guard, SenderGuard, sender_thread_ids, SchedStat)

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


class Feed:
    """Fake time and gyro message count for a guard: each look advances both by the guard's
    period, the count at ``rate`` messages a second."""

    def __init__(self) -> None:
        self.now = 0.0
        self.count = 0.0

    def monotonic(self) -> float:
        return self.now

    def message_count(self) -> int:
        return round(self.count)


def _guard(thread_ids: list[int], feed: Feed, folder: Path) -> SenderGuard:
    """A guard over ``thread_ids``, idle from 1 kHz on, on ``feed``'s time and count."""
    return SenderGuard(thread_ids, feed.message_count, 1000.0, folder, feed.monotonic)


def _looks(guard: SenderGuard, feed: Feed, rate: float, looks: int) -> list[GuardNote]:
    """``looks`` checks of ``guard`` at ``rate``, each one period after the last; their
    notes."""
    notes = []
    for _ in range(looks):
        feed.now += guard.period
        feed.count += rate * guard.period
        notes += guard.check()
    return notes


LOOKS_PER_WINDOW = round(RATE_WINDOW / GUARD_PERIOD)
HIGH_RATE = 1200.0  # over the guards' threshold of 1 kHz


def _idle_guard(folder: Path, thread_id: int) -> tuple[SenderGuard, Feed]:
    """A guard over ``thread_id`` that has just put it on SCHED_IDLE (threshold 1 kHz)."""
    feed = Feed()
    guard = _guard([thread_id], feed, folder)
    assert _looks(guard, feed, HIGH_RATE, LOOKS_PER_WINDOW + 1) == [GuardNote(False, (
        f'gyro input at 1200 Hz (idle_senders_above_hz 1000): Fast DDS sender threads '
        f'[{thread_id}] moved to SCHED_IDLE'))]
    assert guard.idle and os.sched_getscheduler(thread_id) == os.SCHED_IDLE
    assert guard.period == IDLE_LOOK_PERIOD
    return guard, feed


def test_the_senders_follow_the_gyro_rate_with_hysteresis(tmp_path, batch_thread):
    _thread(tmp_path, batch_thread, stat=(1_000, 5_000, 7))  # never waits
    feed = Feed()
    guard = _guard([batch_thread], feed, tmp_path)
    assert guard.rate() is None and guard.period == GUARD_PERIOD
    # No rate before the looks span a whole window, then below the threshold: nothing moves.
    assert _looks(guard, feed, 990.0, LOOKS_PER_WINDOW) == []
    assert guard.rate() is None
    assert _looks(guard, feed, 990.0, 1) == []
    assert guard.rate() == pytest.approx(990.0)
    assert os.sched_getscheduler(batch_thread) == os.SCHED_BATCH
    guard, feed = _idle_guard(tmp_path, batch_thread)
    assert _looks(guard, feed, 700.0, 50) == []  # above 2/3 of the threshold: stays idle
    assert os.sched_getscheduler(batch_thread) == os.SCHED_IDLE
    # The window at the second look: 0.46 s at 700 Hz and 0.04 s at 250 Hz, 664 Hz.
    notes = _looks(guard, feed, 250.0, 2)
    reason = ('gyro input at 664 Hz (below 0.667 of idle_senders_above_hz 1000): Fast DDS '
              'sender threads')
    if _may_leave_idle():
        assert notes == [GuardNote(False, f'{reason} [{batch_thread}] moved to SCHED_BATCH')]
        assert os.sched_getscheduler(batch_thread) == os.SCHED_BATCH and not guard.idle
        assert guard.period == GUARD_PERIOD
        assert len(_looks(guard, feed, HIGH_RATE, LOOKS_PER_WINDOW)) == 1  # idle again
    else:  # refused: said once, as a warning; the thread is no longer the guard's
        assert len(notes) == 1 and notes[0].warning
        assert notes[0].text.startswith(f'{reason} [] moved to SCHED_BATCH ({batch_thread} '
                                        f'refused: ')
        assert guard.thread_ids == [] and not guard.idle


LOOK_NS = round(IDLE_LOOK_PERIOD * 1e9)


@pytest.mark.parametrize('waited_ns, runs, is_contended', [
    (CONTENDED_WAIT_FRACTION * LOOK_NS, 10, False),  # 1.5 ms a run, but not over 3/4 the time
    (CONTENDED_WAIT_FRACTION * LOOK_NS + 1, 101, False),  # most of the time, in short waits
    (CONTENDED_WAIT_FRACTION * LOOK_NS + 1, 100, True),
    (LOOK_NS, 0, True),  # never ran at all
])
def test_the_contention_rule(waited_ns, runs, is_contended):
    assert CONTENDED_MEAN_WAIT_NS == 150_000 and CONTENDED_WAIT_FRACTION == 0.75
    before = SchedStat(1_000, 5_000, 7)
    after = SchedStat(2_000, 5_000 + round(waited_ns), 7 + runs)
    assert contended(before, after, IDLE_LOOK_PERIOD) is is_contended


def _contend(folder: Path, thread_id: int, guard: SenderGuard, feed: Feed) -> list[GuardNote]:
    """Two looks at 1.2 kHz: a baseline reading of the sender, then one with 20 ms waited in
    10 runs since."""
    _thread(folder, thread_id, stat=(1_000, 5_000, 7))
    assert _looks(guard, feed, HIGH_RATE, 1) == []
    _thread(folder, thread_id, stat=(2_000, 5_000 + 20_000_000, 17))
    return _looks(guard, feed, HIGH_RATE, 1)


def test_contention_holds_the_senders_on_batch_for_doubling_holds(tmp_path, batch_thread):
    if not _may_leave_idle():
        return  # the guard would never exist (sender_guard): nothing to hold
    guard, feed = _idle_guard(tmp_path, batch_thread)
    expected = FIRST_HOLD
    for _ in range(8):  # 1, 2, 4 ... then MAX_HOLD: each contention comes right after a hold
        notes = _contend(tmp_path, batch_thread, guard, feed)
        assert notes == [GuardNote(False, (
            f'other load contends for the CPUs (sender {batch_thread} waited 20.0 ms for a '
            f'CPU in 10 runs over 20 ms): for {expected:g} s, Fast DDS sender threads '
            f'[{batch_thread}] moved to SCHED_BATCH'))]
        assert os.sched_getscheduler(batch_thread) == os.SCHED_BATCH and not guard.idle
        looks = round(expected / GUARD_PERIOD)
        assert _looks(guard, feed, HIGH_RATE, looks - 1) == []  # held, though the rate is high
        notes = _looks(guard, feed, HIGH_RATE, 2)  # the hold ends at one of these (float sums)
        assert len(notes) == 1 and notes[0].text.endswith('moved to SCHED_IDLE') and guard.idle
        expected = min(2 * expected, MAX_HOLD)
    assert expected == MAX_HOLD
    # A whole MAX_HOLD without contention: the next hold is the first one again.
    _thread(tmp_path, batch_thread, stat=(1_000, 5_000, 7))
    assert _looks(guard, feed, HIGH_RATE, round(MAX_HOLD / IDLE_LOOK_PERIOD)) == []
    notes = _contend(tmp_path, batch_thread, guard, feed)
    assert len(notes) == 1 and f'for {FIRST_HOLD:g} s' in notes[0].text


def test_threads_whose_policy_changed_elsewhere_or_that_ended_are_forgotten(
        tmp_path, batch_thread):
    normal = threading.get_native_id()  # this thread: on SCHED_OTHER, not ours to move
    feed = Feed()
    guard = _guard([batch_thread, normal, NO_SUCH_THREAD], feed, tmp_path)
    notes = _looks(guard, feed, 2000.0, LOOKS_PER_WINDOW + 1)
    assert [note.text for note in notes] == [
        f'gyro input at 2000 Hz (idle_senders_above_hz 1000): Fast DDS sender threads '
        f'[{batch_thread}] moved to SCHED_IDLE']
    assert guard.thread_ids == [batch_thread]
    assert os.sched_getscheduler(normal) == os.SCHED_OTHER
    if not _may_leave_idle():
        return
    os.sched_setscheduler(batch_thread, os.SCHED_OTHER, os.sched_param(0))
    # Someone else changed it: left alone, forgotten, no more notes.
    assert _looks(guard, feed, 0.0, round(RATE_WINDOW / IDLE_LOOK_PERIOD) + 1) == []
    assert guard.thread_ids == [] and not guard.idle
    assert os.sched_getscheduler(batch_thread) == os.SCHED_OTHER


def test_the_guard_of_a_process_and_its_remark(tmp_path):
    count = Feed().message_count
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


def test_the_installed_node_idles_its_senders_at_high_rates_and_lifts_them_under_load(
        ros, request, processes):
    """With ``idle_senders_above_hz`` 100: the senders go to SCHED_IDLE while gyro messages
    come at over 100 Hz, back to SCHED_BATCH when they stop, to SCHED_IDLE again, and to
    SCHED_BATCH for a first hold beside one CPU-bound process per CPU the test may use, and
    one more (a sender at idle priority then waits for a CPU nearly all the time)."""
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
    assert re.search(r'INFO.*other load contends for the CPUs \(sender \d+ waited [\d.]+ ms for '
                     r'a CPU in \d+ runs over \d+ ms\): for 1 s, Fast DDS sender threads '
                     r'\[[\d, ]+\] moved to SCHED_BATCH', stderr), stderr
    assert len(poses) > 0


def test_a_dynamics_scene_keeps_its_senders_on_batch_without_a_guard(processes):
    """No gyro input: no guard runs, even with ``idle_senders_above_hz`` 0 (a guard would
    move the senders to SCHED_IDLE once it has a rate, 0.5 s after start), and the start-up
    line has no remark about the senders."""
    process = start('--ros-args', '-p', 'scene:=torque_free_box',
                    '-p', 'idle_senders_above_hz:=0.0')
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
