"""The gyro loop thread and Fast DDS's sender threads on different CPUs at high gyro rates
(:mod:`rigid_body_attitude.ros.cpu_split`).

What the split buys is measured, not tested (``bench/NOTES.md``, section 17). Here: the rate
rule with its hysteresis on real threads of this process, threads that ended, a move the
system refuses, the rule of a process and its remark, and the installed node moving its
threads with the gyro rate.
"""

from __future__ import annotations

import os
from pathlib import Path
import re
import threading
from typing import Iterator

import pytest
from geometry_msgs.msg import PoseStamped
from ros_helpers import Harness, unique_namespace
from sensor_msgs.msg import Imu
from test_node_subprocess import read_until, start, stop_with_sigint
from test_sender_threads import _publish_until, _thread, GyroCount

from rigid_body_attitude.ros.cpu_split import cpu_split, CpuSplit
from rigid_body_attitude.ros.sender_threads import (
    GuardNote, RATE_WINDOW_PERIODS, sender_thread_ids)

NO_SUCH_THREAD = 2**22 + 12345  # above pid_max
NO_SUCH_CPU = 4095  # above any CPU this machine has (sched_setaffinity: EINVAL alone)

#: The CPUs this test process may use (the split needs two; the project's machine has two).
CPUS = os.sched_getaffinity(0)


@pytest.fixture
def idle_threads() -> Iterator[list[int]]:
    """Native ids of three threads that wait until the test ends (loop, two senders)."""
    release = threading.Event()
    ids: list[int] = []
    ready = threading.Barrier(4)

    def body() -> None:
        ids.append(threading.get_native_id())
        ready.wait()
        release.wait()

    threads = [threading.Thread(target=body) for _ in range(3)]
    for thread in threads:
        thread.start()
    ready.wait()
    yield ids
    release.set()
    for thread in threads:
        thread.join()


def _looks(split: CpuSplit, count: GyroCount, rate: float, looks: int) -> list[GuardNote]:
    """``looks`` checks of ``split`` at ``rate``; their notes."""
    count.rate = rate
    return [note for _ in range(looks) for note in split.check()]


def _cpus_text(cpus: set[int]) -> str:
    return f'CPU {min(cpus)}' if len(cpus) == 1 else 'CPUs ' + ','.join(map(str, sorted(cpus)))


def test_the_threads_follow_the_gyro_rate_with_hysteresis(idle_threads):
    assert len(CPUS) >= 2, 'the split needs a process that may use two CPUs'
    loop, *senders = idle_threads
    count = GyroCount()
    split = CpuSplit(loop, senders, count, 1000.0, CPUS)
    # No rate before a whole window, then below the threshold: nothing moves.
    assert _looks(split, count, 990.0, RATE_WINDOW_PERIODS + 3) == []
    assert os.sched_getaffinity(loop) == CPUS and not split.separated
    loop_cpu, sender_cpus = min(CPUS), CPUS - {min(CPUS)}
    assert _looks(split, count, 1000.0, RATE_WINDOW_PERIODS) == [GuardNote(False, (
        f'gyro input at 1000 Hz (separate_cpus_above_hz 1000): the gyro loop on CPU '
        f'{loop_cpu}, Fast DDS sender threads {senders} on {_cpus_text(sender_cpus)}'))]
    assert split.separated and os.sched_getaffinity(loop) == {loop_cpu}
    assert [os.sched_getaffinity(sender) for sender in senders] == [sender_cpus] * 2
    # 700 Hz is above 2/3 of the threshold: they stay apart; at 600 Hz the rate over the
    # window is 680 Hz after one look, 660 Hz, below, after two.
    assert _looks(split, count, 700.0, RATE_WINDOW_PERIODS + 1) == []
    assert _looks(split, count, 600.0, RATE_WINDOW_PERIODS) == [GuardNote(False, (
        f'gyro input at 660 Hz (below 0.667 of separate_cpus_above_hz 1000): the gyro loop '
        f'and Fast DDS sender threads {senders} back on {_cpus_text(CPUS)}'))]
    assert not split.separated
    assert [os.sched_getaffinity(thread) for thread in idle_threads] == [CPUS] * 3
    assert _looks(split, count, 2000.0, RATE_WINDOW_PERIODS)[0].text.endswith(
        f'sender threads {senders} on {_cpus_text(sender_cpus)}')


def test_a_sender_that_ended_is_forgotten(idle_threads):
    loop, sender, _ = idle_threads
    count = GyroCount()
    split = CpuSplit(loop, [NO_SUCH_THREAD, sender], count, 1000.0, CPUS)
    notes = _looks(split, count, 1000.0, RATE_WINDOW_PERIODS + 1)
    assert [note.text.split(': ', 1)[1] for note in notes] == [
        f'the gyro loop on CPU {min(CPUS)}, Fast DDS sender threads [{sender}] on '
        f'{_cpus_text(CPUS - {min(CPUS)})}']
    assert split.sender_ids == [sender] and split.separated


def test_a_refused_move_leaves_every_thread_on_every_cpu_for_good(idle_threads):
    """The senders' CPUs would be none the machine has: the kernel refuses (EINVAL); the
    loop, already moved, goes back, and no later look moves anything."""
    loop, *senders = idle_threads
    cpus = {min(CPUS), NO_SUCH_CPU}
    count = GyroCount()
    split = CpuSplit(loop, senders, count, 1000.0, cpus)
    notes = _looks(split, count, 1000.0, RATE_WINDOW_PERIODS + 1)
    assert notes == [GuardNote(True, (
        f'gyro input at 1000 Hz (separate_cpus_above_hz 1000): CPU affinity refused ([Errno '
        f'22] Invalid argument); the gyro loop and Fast DDS sender threads stay on CPUs '
        f'{min(CPUS)},{NO_SUCH_CPU}'))]
    assert split.refused and not split.separated
    # Every thread on every CPU of the split's set that exists.
    assert [os.sched_getaffinity(thread) for thread in idle_threads] == [{min(CPUS)}] * 3
    assert _looks(split, count, 500.0, RATE_WINDOW_PERIODS + 1) == []
    assert _looks(split, count, 5000.0, RATE_WINDOW_PERIODS + 1) == []


def test_the_rule_of_a_process_and_its_remark(tmp_path, idle_threads):
    loop, *_ = idle_threads
    count = GyroCount()
    assert cpu_split(loop, count, 8000.0, tmp_path) == (None, '')  # synchronous: no senders
    _thread(tmp_path, 21, 'dds.asyn.0.0')
    _thread(tmp_path, 22, 'dds.asyn.0.1')
    split, remark = cpu_split(loop, count, 8000.0, tmp_path)
    assert split is not None and split.sender_ids == [21, 22] and split.above_hz == 8000.0
    assert split.cpus == CPUS and not split.separated
    assert remark == (f'gyro loop on CPU {min(CPUS)} and Fast DDS sender threads on '
                      f'{_cpus_text(CPUS - {min(CPUS)})} while gyro input is above 8000 Hz')
    os.sched_setaffinity(loop, {max(CPUS)})
    assert cpu_split(loop, count, 8000.0, tmp_path) == (None, (
        f'the gyro loop and Fast DDS sender threads share CPU {max(CPUS)}, the only one this '
        f'process may use'))


def _affinities(pid: int) -> tuple[set[int], list[set[int]]]:
    """The CPUs of process ``pid``'s main thread (its gyro loop) and of its senders."""
    senders = sender_thread_ids(Path(f'/proc/{pid}/task'))
    return os.sched_getaffinity(pid), [os.sched_getaffinity(sender) for sender in senders]


def test_the_installed_node_separates_its_threads_at_high_rates(ros, request, processes):
    """With ``separate_cpus_above_hz`` 100: the gyro loop (the main thread) and the senders
    go to different CPUs while gyro messages come at over 100 Hz, and back on every CPU when
    they stop."""
    namespace = unique_namespace(request)
    process = start('--ros-args', '-p', 'scene:=strapdown', '-p',
                    'separate_cpus_above_hz:=100.0', '-r', f'__ns:={namespace}')
    processes.append(process)
    lines = read_until(process, 'serving')
    assert (f'gyro loop on CPU {min(CPUS)} and Fast DDS sender threads on '
            f'{_cpus_text(CPUS - {min(CPUS)})} while gyro input is above 100 Hz; '
            f'serving') in lines[-1]
    assert _affinities(process.pid) == (CPUS, [CPUS, CPUS])
    harness = Harness(ros, namespace)
    imu_publisher = harness.publisher(Imu, 'imu')
    poses = harness.record(PoseStamped, 'pose')
    harness.wait_for_connections(30.0)

    def separated() -> bool:
        return _affinities(process.pid)[0] == {min(CPUS)}
    _publish_until(harness, imu_publisher, 0, separated)
    assert _affinities(process.pid) == ({min(CPUS)}, [CPUS - {min(CPUS)}] * 2)
    harness.spin_for(2.0)  # no gyro messages
    assert _affinities(process.pid) == (CPUS, [CPUS, CPUS])
    code, stderr = stop_with_sigint(process)
    assert code == 0, stderr
    moves = re.findall(r'(on CPU \d+, Fast DDS sender threads \[[\d, ]+\] on CPUs? [\d,-]+'
                       r'|sender threads \[[\d, ]+\] back on CPUs [\d,-]+)$', stderr, re.M)
    assert len(moves) == 2 and 'back on' in moves[1], stderr
    assert len(poses) > 0


def test_the_rule_needs_cpu_scheduling_batch_and_a_gyro_scene(processes):
    """``all_batch`` and a dynamics scene: no split, no remark, every thread on every CPU."""
    for arguments in (('scene:=strapdown', 'cpu_scheduling:=all_batch'),
                      ('scene:=torque_free_box', 'separate_cpus_above_hz:=1.0')):
        process = start('--ros-args', *[f for a in arguments for f in ('-p', a)])
        processes.append(process)
        lines = read_until(process, 'serving')
        assert 'gyro loop on CPU' not in lines[-1], lines[-1]
        assert _affinities(process.pid)[0] == CPUS
        code, stderr = stop_with_sigint(process)
        assert code == 0, stderr
