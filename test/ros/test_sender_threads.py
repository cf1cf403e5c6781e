"""Fast DDS's sender threads at idle priority and their guard
(:mod:`rigid_body_attitude.ros.sender_threads`).

What idle priority buys is measured, not tested (``bench/NOTES.md``, section 11). Here: the
privilege probe, the ``schedstat`` reader, the starvation rule, a starved thread moved to
SCHED_BATCH, and the installed node under CPU-bound load moving its sender.
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
    can_leave_idle_policy, GUARD_PERIOD, idle_sender_guard, read_schedstat, SchedStat,
    SenderGuard, sender_thread_ids, STARVED_MEAN_DELAY_NS, STARVED_TOTAL_DELAY_NS)

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
def idle_thread() -> Iterator[int]:
    """The native id of a thread on SCHED_IDLE (its own policy only: nothing reaches the
    test run), alive until the test ends."""
    ready, release = threading.Event(), threading.Event()
    ids: list[int] = []

    def body() -> None:
        os.sched_setscheduler(0, os.SCHED_IDLE, os.sched_param(0))
        ids.append(threading.get_native_id())
        ready.set()
        release.wait()

    thread = threading.Thread(target=body)
    thread.start()
    ready.wait()
    yield ids[0]
    release.set()
    thread.join()


def _moved_line(thread_id: int, waited_ns: int, runs: int) -> str:
    return (f'Fast DDS sender thread {thread_id} starved by other load '
            f'({waited_ns * 1e-6:.0f} ms waiting for a CPU in {runs} runs over '
            f'{GUARD_PERIOD:g} s): moved from SCHED_IDLE to SCHED_BATCH')


@pytest.mark.parametrize('waited_ns, runs, starved', [
    (STARVED_TOTAL_DELAY_NS, 10, False),  # 2 ms a run, but not more than the total in all
    (STARVED_TOTAL_DELAY_NS + 1, 21, False),  # more in all, but under 1 ms a run: just busy
    (STARVED_TOTAL_DELAY_NS + 1, 20, True),
    (90_000_000, 0, True),  # never ran at all
])
def test_the_starvation_rule(tmp_path, idle_thread, waited_ns, runs, starved):
    assert STARVED_MEAN_DELAY_NS == 1_000_000
    _thread(tmp_path, idle_thread, stat=(1_000, 5_000, 7))
    guard = SenderGuard([idle_thread], tmp_path)
    assert guard.check() == []  # the first reading is the baseline
    _thread(tmp_path, idle_thread, stat=(2_000, 5_000 + waited_ns, 7 + runs))
    lines = guard.check()
    if not starved:
        assert lines == []
        assert guard.watched == {idle_thread: SchedStat(2_000, 5_000 + waited_ns, 7 + runs)}
        assert os.sched_getscheduler(idle_thread) == os.SCHED_IDLE
    elif _may_leave_idle():
        assert lines == [_moved_line(idle_thread, waited_ns, runs)]
        assert os.sched_getscheduler(idle_thread) == os.SCHED_BATCH
        assert guard.watched == {} and guard.promoted == [idle_thread]
    else:
        assert len(lines) == 1
        assert lines[0].startswith(f'Fast DDS sender thread {idle_thread} starved ('
                                   f'{waited_ns * 1e-6:.0f} ms waiting for a CPU in {runs} '
                                   f'runs) and could not leave SCHED_IDLE: ')
        assert os.sched_getscheduler(idle_thread) == os.SCHED_IDLE
        assert guard.watched == {} and guard.promoted == []


def test_a_starved_thread_is_moved_once_others_are_left_alone_or_forgotten(tmp_path,
                                                                           idle_thread):
    normal = threading.get_native_id()  # this thread: not on SCHED_IDLE, not ours to move
    for thread_id in (idle_thread, normal):
        _thread(tmp_path, thread_id, stat=(0, 0, 0))
    _thread(tmp_path, NO_SUCH_THREAD)  # no schedstat: ended
    guard = SenderGuard([idle_thread, normal, NO_SUCH_THREAD], tmp_path)
    assert guard.check() == []
    assert list(guard.watched) == [idle_thread, normal]
    for thread_id in (idle_thread, normal):
        _thread(tmp_path, thread_id, stat=(1_000_000, 80_000_000, 4))
    lines = guard.check()
    assert os.sched_getscheduler(normal) == os.SCHED_OTHER
    assert guard.watched == {}
    if _may_leave_idle():
        assert lines == [_moved_line(idle_thread, 80_000_000, 4)]
        assert guard.promoted == [idle_thread]
    else:
        assert len(lines) == 1 and 'could not leave SCHED_IDLE' in lines[0]
    _thread(tmp_path, idle_thread, stat=(2_000_000, 900_000_000, 5))
    assert guard.check() == []  # moved once, never again


def test_the_guard_of_a_process_and_its_remark(tmp_path):
    assert idle_sender_guard(tmp_path) == (None, '')  # synchronous publication: no senders
    _thread(tmp_path, 21, 'dds.asyn.0.0')
    _thread(tmp_path, 22, 'dds.asyn.0.1', stat=(1, 2, 3))
    guard, remark = idle_sender_guard(tmp_path)
    assert guard is None
    assert remark == (f'Fast DDS sender threads kept on SCHED_BATCH (no {tmp_path}/<tid>/'
                      f'schedstat to watch them by)')
    _thread(tmp_path, 21, stat=(4, 5, 6))
    guard, remark = idle_sender_guard(tmp_path)
    if _may_leave_idle():
        assert guard is not None and list(guard.watched) == [21, 22]
        assert remark == ('Fast DDS sender threads [21, 22] on SCHED_IDLE, moved to '
                          'SCHED_BATCH if starved')
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


def test_the_installed_node_moves_its_starved_sender_to_batch(ros, request, processes):
    """One CPU-bound process per CPU the test may use, and one more, while the node publishes
    a pose per gyro sample: a sender at idle priority gets next to no CPU, and the guard moves
    it."""
    namespace = unique_namespace(request)
    process = start('--ros-args', '-p', 'scene:=strapdown', '-r', f'__ns:={namespace}')
    processes.append(process)
    lines = read_until(process, 'serving')
    senders = _sender_policies(process.pid)
    assert len(senders) == 2, senders  # discovery's and the writers'
    if not _may_leave_idle():  # nothing to guard: the senders stay on SCHED_BATCH
        assert set(senders.values()) == {os.SCHED_BATCH}
        assert 'leaving SCHED_IDLE needs CAP_SYS_NICE or RLIMIT_NICE >= 20' in lines[-1]
        assert stop_with_sigint(process)[0] == 0
        return
    assert set(senders.values()) == {os.SCHED_IDLE}
    harness = Harness(ros, namespace)
    imu_publisher = harness.publisher(Imu, 'imu')
    poses = harness.record(PoseStamped, 'pose')
    harness.wait_for_connections(30.0)
    hogs = _cpu_hogs(len(os.sched_getaffinity(0)) + 1)
    processes.extend(hogs)
    base_ns, sent = 1_700_000_000 * 10**9, 0
    deadline = time.monotonic() + 20.0
    while time.monotonic() < deadline and os.SCHED_BATCH not in _sender_policies(
            process.pid).values():
        for _ in range(50):  # 1 kHz stamps, in bursts
            imu = Imu()
            imu.header.stamp = stamp(base_ns + sent * 10**6)
            imu.angular_velocity.z = 0.5
            imu_publisher.publish(imu)
            sent += 1
        harness.spin_for(0.02)
    for hog in hogs:
        hog.kill()
    policies = _sender_policies(process.pid)
    code, stderr = stop_with_sigint(process)
    assert code == 0, stderr
    assert os.SCHED_BATCH in policies.values(), (policies, stderr)
    assert re.search(r'Fast DDS sender thread \d+ starved by other load \(\d+ ms waiting for '
                     r'a CPU in \d+ runs over 0\.1 s\): moved from SCHED_IDLE to SCHED_BATCH',
                     stderr), stderr
    assert len(poses) > 0
