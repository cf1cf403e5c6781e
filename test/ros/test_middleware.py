"""The node's own middleware and scheduler set-up (:mod:`rigid_body_attitude.ros.middleware`).

What the settings buy is measured, not tested: ``bench/NOTES.md`` sections 3 and 9 and
``docs/performance.md``. Here: which profile is used when, that the shipped profile is what
its comment says and reaches the node's participant, that the node publishes asynchronously
unless told otherwise, and that the scheduling policy reaches every thread of the installed
node.
"""

from __future__ import annotations

import os
import re
from pathlib import Path
import subprocess
import sys
import textwrap
import time
import xml.etree.ElementTree as ElementTree

import pytest
from test_node_subprocess import read_until, start, stop_with_sigint

from rigid_body_attitude.core.errors import InputError
from rigid_body_attitude.ros.middleware import (
    apply_cpu_scheduling, check_cpu_scheduling, FASTDDS_PROFILE_VARIABLES, PROFILE_SETTINGS,
    packaged_fastdds_profile, PUBLICATION_MODE_VARIABLE, use_asynchronous_publication,
    use_packaged_fastdds_profile)
from rigid_body_attitude.ros.sender_threads import can_leave_idle_policy, sender_thread_ids
from rigid_body_attitude.ros.time_slices import (
    kernel_takes_slices, SENDER_SLICE_NS, time_slice_ns)

FASTDDS_NAMESPACE = '{http://www.eprosima.com/XMLSchemas/fastRTPS_Profiles}'


def _element(parent: ElementTree.Element, path: str) -> ElementTree.Element:
    """The one element at ``path`` (tags without the Fast DDS namespace) below ``parent``."""
    found = parent.findall('/'.join(FASTDDS_NAMESPACE + tag for tag in path.split('/')))
    assert len(found) == 1, path
    return found[0]


def _children(element: ElementTree.Element) -> list[str]:
    return [child.tag.removeprefix(FASTDDS_NAMESPACE) for child in element]


def test_the_packaged_profile_sets_its_two_settings_and_nothing_else():
    profile = packaged_fastdds_profile()
    assert profile is not None and profile.is_file()
    profiles = _element(ElementTree.parse(profile).getroot(), 'profiles')
    assert _children(profiles) == ['transport_descriptors', 'participant', 'data_writer']
    # Every writer: NACK suppression 10 ms.
    writer = _element(profiles, 'data_writer')
    assert writer.get('is_default_profile') == 'true'
    assert _children(writer) == ['times']
    assert _children(_element(writer, 'times')) == ['nackSupressionDuration']
    duration = _element(writer, 'times/nackSupressionDuration')
    seconds = (int(_element(duration, 'sec').text)
               + int(_element(duration, 'nanosec').text) * 1e-9)
    assert seconds == pytest.approx(0.010, abs=1e-12)
    # The participant: Fast DDS's two built-in transports, the shared-memory one with a 30 ms
    # health check (its listener wakes every 10 ms).
    participant = _element(profiles, 'participant')
    assert participant.get('is_default_profile') == 'true'
    assert _children(_element(participant, 'rtps')) == ['userTransports', 'useBuiltinTransports']
    assert _element(participant, 'rtps/useBuiltinTransports').text == 'false'
    used = [entry.text for entry in _element(participant, 'rtps/userTransports')]
    descriptors = {_element(entry, 'transport_id').text: entry
                   for entry in _element(profiles, 'transport_descriptors')}
    assert sorted(used) == sorted(descriptors)
    settings = {_element(entry, 'type').text: {
        tag: _element(entry, tag).text for tag in _children(entry)
        if tag not in ('transport_id', 'type')} for entry in descriptors.values()}
    assert settings == {'SHM': {'healthy_check_timeout_ms': '30'}, 'UDPv4': {}}


def _user_data_listener_wakeups(pid: int, seconds: float) -> dict[int, int]:
    """Voluntary context switches over ``seconds`` of each Fast DDS shared-memory listener
    thread of ``pid`` that serves a user-data port of this run's domain (threads are named
    ``dds.shm.<port>``; user-data ports are 7400 + 250 domain + 11 + 2 participant, while the
    metatraffic ports 7000 + participant are shared by every domain, so one left behind by a
    crashed process keeps that process's settings)."""
    first_user_port = 7400 + 250 * int(os.environ['ROS_DOMAIN_ID'])

    def switches() -> dict[int, int]:
        counts = {}
        for task in Path(f'/proc/{pid}/task').iterdir():
            name = (task / 'comm').read_text().strip()
            port = name.removeprefix('dds.shm.')
            if port.isdigit() and int(port) >= first_user_port:
                status = (task / 'status').read_text()
                counts[int(port)] = int(status.split('voluntary_ctxt_switches:')[1].split()[0])
        return counts
    before = switches()
    time.sleep(seconds)
    after = switches()
    return {port: after[port] - before[port] for port in before}


@pytest.mark.parametrize('profile, least, most', [
    ('packaged', 60, 400),  # 2 s / 10 ms = 200 wake-ups; 60 leaves room for a loaded machine
    ('fast_dds_defaults', 0, 20),  # 2 s / 333 ms = 6
])
def test_the_nodes_idle_shared_memory_listener_wakes_every_10_ms_with_the_profile(
        processes, monkeypatch, tmp_path, profile, least, most):
    """The listener's own wake-up period is what bounds Fast DDS's lost-wake-up stall, so the
    profile must reach the node's participant (a participant profile that did not apply, or
    an rmw that replaced its transports, would leave the 333 ms default)."""
    for variable in FASTDDS_PROFILE_VARIABLES:
        monkeypatch.delenv(variable, raising=False)
    if profile == 'fast_dds_defaults':
        empty = tmp_path / 'empty.xml'
        empty.write_text('<?xml version="1.0" encoding="UTF-8"?>\n<dds xmlns='
                         '"http://www.eprosima.com/XMLSchemas/fastRTPS_Profiles"><profiles>'
                         '</profiles></dds>\n')
        monkeypatch.setenv('FASTRTPS_DEFAULT_PROFILES_FILE', str(empty))
    process = start('--ros-args', '-p', 'scene:=strapdown')
    processes.append(process)
    lines = read_until(process, 'serving')
    wakeups = _user_data_listener_wakeups(process.pid, 2.0)
    code, stderr = stop_with_sigint(process)
    assert code == 0, ''.join(lines) + stderr
    assert len(wakeups) == 1, wakeups  # one participant, one user-data port
    assert least <= next(iter(wakeups.values())) <= most, wakeups


@pytest.mark.parametrize('rmw', ['', 'rmw_fastrtps_cpp', 'rmw_fastrtps_dynamic_cpp'])
def test_the_profile_is_used_when_fast_dds_is_not_configured(tmp_path, rmw):
    environ = {'RMW_IMPLEMENTATION': rmw} if rmw else {}
    note = use_packaged_fastdds_profile(environ, tmp_path)
    profile = str(packaged_fastdds_profile())
    assert all(environ[variable] == profile for variable in FASTDDS_PROFILE_VARIABLES)
    assert note == f'Fast DDS profile {profile} ({PROFILE_SETTINGS})'


@pytest.mark.parametrize('environ, reason', [
    ({'RMW_IMPLEMENTATION': 'rmw_cyclonedds_cpp'}, "RMW_IMPLEMENTATION is 'rmw_cyclonedds_cpp'"),
    ({'FASTRTPS_DEFAULT_PROFILES_FILE': '/mine.xml'}, 'FASTRTPS_DEFAULT_PROFILES_FILE is set'),
    ({'FASTDDS_DEFAULT_PROFILES_FILE': '/mine.xml'}, 'FASTDDS_DEFAULT_PROFILES_FILE is set'),
    ({'RMW_FASTRTPS_USE_QOS_FROM_XML': '1'}, 'RMW_FASTRTPS_USE_QOS_FROM_XML is 1'),
])
def test_a_users_middleware_configuration_is_never_overridden(tmp_path, environ, reason):
    before = dict(environ)
    note = use_packaged_fastdds_profile(environ, tmp_path)
    assert environ == before
    assert note.startswith('Fast DDS profile not used: ') and reason in note


def test_a_default_profile_file_in_the_working_directory_wins(tmp_path):
    (tmp_path / 'DEFAULT_FASTRTPS_PROFILES.xml').write_text('<dds/>')
    environ: dict[str, str] = {}
    note = use_packaged_fastdds_profile(environ, tmp_path)
    assert environ == {}
    assert note == ('Fast DDS profile not used: DEFAULT_FASTRTPS_PROFILES.xml is in the '
                    'working directory')


@pytest.mark.parametrize('value', ['fifo', 'BATCH', ''])
def test_an_unknown_cpu_scheduling_value_is_named_in_the_error(value):
    expected = (f"Expected parameter `cpu_scheduling` to be one of 'batch', 'all_batch', "
                f"'default', got {value!r}")
    assert check_cpu_scheduling(value) == expected
    with pytest.raises(InputError) as raised:
        apply_cpu_scheduling(value)
    assert str(raised.value) == expected


def _policies_after(script: str) -> list[str]:
    """Run ``script`` (which applies a policy) in a fresh interpreter; its printed lines."""
    result = subprocess.run([sys.executable, '-c', textwrap.dedent(script)],
                            capture_output=True, text=True, timeout=60, check=True)
    return result.stdout.split()


def test_batch_moves_every_normal_thread_leaves_others_and_is_inherited():
    # A separate process: the policy must not leak into the test run.
    lines = _policies_after("""
        import os, threading
        from rigid_body_attitude.ros.middleware import apply_cpu_scheduling
        idle_ready, release = threading.Event(), threading.Event()
        def idle():
            os.sched_setscheduler(threading.get_native_id(), os.SCHED_IDLE, os.sched_param(0))
            idle_ready.set()
            release.wait()
        def normal():
            release.wait()
        threads = [threading.Thread(target=idle), threading.Thread(target=normal)]
        for thread in threads:
            thread.start()
        idle_ready.wait()
        print('changed', apply_cpu_scheduling('batch').changed)
        later = threading.Thread(target=release.wait)
        later.start()
        for thread in threads + [later]:
            print(os.sched_getscheduler(thread.native_id))
        print(os.sched_getscheduler(0))
        release.set()
    """)
    assert lines[:2] == ['changed', '2']  # the main thread and the normal one
    assert [int(line) for line in lines[2:]] == [
        os.SCHED_IDLE, os.SCHED_BATCH, os.SCHED_BATCH, os.SCHED_BATCH]


def test_default_leaves_every_thread_as_it_started():
    lines = _policies_after("""
        import os
        from rigid_body_attitude.ros.middleware import apply_cpu_scheduling
        print(apply_cpu_scheduling('default').changed, os.sched_getscheduler(0))
    """)
    assert lines == ['0', str(os.SCHED_OTHER)]


def test_a_refusal_by_the_system_is_returned_not_raised(tmp_path):
    # A thread id the kernel refuses with EINVAL (sched_getscheduler(-1)) stands for any
    # OSError other than "no such thread", e.g. EPERM from a container's seccomp policy.
    (tmp_path / '-1').mkdir()
    outcome = apply_cpu_scheduling('batch', tmp_path)
    assert outcome.changed == 0
    assert outcome.refused.startswith('thread -1: [Errno 22] Invalid argument')


def test_a_thread_that_ended_is_skipped(tmp_path):
    (tmp_path / str(2**22 + 12345)).mkdir()  # above pid_max: no such thread
    assert apply_cpu_scheduling('batch', tmp_path) == (0, '')


def _thread_policies(pid: int) -> dict[str, int]:
    """Thread id → scheduling policy of every thread of process ``pid``."""
    return {entry.name: os.sched_getscheduler(int(entry.name))
            for entry in Path(f'/proc/{pid}/task').iterdir()}


@pytest.mark.parametrize('rmw', ['', 'rmw_fastrtps_cpp', 'rmw_fastrtps_dynamic_cpp'])
def test_asynchronous_publication_is_asked_for_when_no_mode_is_chosen(rmw):
    environ = {'RMW_IMPLEMENTATION': rmw} if rmw else {}
    note = use_asynchronous_publication(environ)
    assert environ[PUBLICATION_MODE_VARIABLE] == 'ASYNCHRONOUS'
    assert note == 'asynchronous publication (RMW_FASTRTPS_PUBLICATION_MODE=ASYNCHRONOUS)'


@pytest.mark.parametrize('environ, reason', [
    ({'RMW_IMPLEMENTATION': 'rmw_cyclonedds_cpp'}, "RMW_IMPLEMENTATION is 'rmw_cyclonedds_cpp'"),
    ({'RMW_FASTRTPS_PUBLICATION_MODE': 'SYNCHRONOUS'},
     "RMW_FASTRTPS_PUBLICATION_MODE is 'SYNCHRONOUS'"),
    ({'RMW_FASTRTPS_USE_QOS_FROM_XML': '1'}, 'RMW_FASTRTPS_USE_QOS_FROM_XML is 1'),
])
def test_a_users_publication_mode_is_never_overridden(environ, reason):
    before = dict(environ)
    note = use_asynchronous_publication(environ)
    assert environ == before
    assert note == f'publication mode left alone: {reason}'


@pytest.mark.parametrize('mode, asynchronous_threads', [
    ('', 2),  # the node's default: discovery's own and the writers' asynchronous thread
    ('SYNCHRONOUS', 1),  # discovery's only
])
def test_the_installed_node_publishes_from_an_asynchronous_thread_by_default(
        processes, monkeypatch, mode, asynchronous_threads):
    """Fast DDS names its asynchronous sender threads ``dds.asyn.*``: the participant's
    discovery always has one; writers publishing asynchronously add one."""
    if mode:
        monkeypatch.setenv(PUBLICATION_MODE_VARIABLE, mode)
    else:  # set by an in-process main() of another test
        monkeypatch.delenv(PUBLICATION_MODE_VARIABLE, raising=False)
    process = start('--ros-args', '-p', 'scene:=strapdown')
    processes.append(process)
    lines = read_until(process, 'serving')
    senders = sender_thread_ids(Path(f'/proc/{process.pid}/task'))
    code, stderr = stop_with_sigint(process)
    stderr = ''.join(lines) + stderr
    assert code == 0, stderr
    assert len(senders) == asynchronous_threads, senders
    expected = (f"publication mode left alone: {PUBLICATION_MODE_VARIABLE} is '{mode}'" if mode
                else 'asynchronous publication (RMW_FASTRTPS_PUBLICATION_MODE=ASYNCHRONOUS)')
    assert expected in stderr


@pytest.mark.parametrize('arguments, policy, guarded, logged', [
    ((), os.SCHED_BATCH, 'slices', "cpu_scheduling 'batch': "),
    (('-p', 'idle_senders_above_hz:=12000.0'), os.SCHED_BATCH, 'idle',
     "cpu_scheduling 'batch': "),
    (('-p', 'cpu_scheduling:=all_batch'), os.SCHED_BATCH, False,
     "cpu_scheduling 'all_batch': "),
    (('-p', 'cpu_scheduling:=default'), os.SCHED_OTHER, False,
     "cpu_scheduling 'default': 0 threads"),
])
def test_the_installed_node_runs_every_thread_on_its_cpu_scheduling(
        processes, monkeypatch, arguments, policy, guarded, logged):
    """Every thread, the senders too, starts on the policy; with ``batch`` the senders get
    0.1 ms time slices where the kernel has them (Linux 6.12+), or with
    ``idle_senders_above_hz`` the start-up line says when they go to SCHED_IDLE
    (``test_sender_threads`` moves them); nothing else gets a custom slice."""
    for variable in FASTDDS_PROFILE_VARIABLES:  # set by an in-process main() of another test
        monkeypatch.delenv(variable, raising=False)
    process = start('--ros-args', '-p', 'scene:=strapdown', *arguments)
    processes.append(process)
    lines = read_until(process, logged)
    policies = _thread_policies(process.pid)
    senders = sender_thread_ids(Path(f'/proc/{process.pid}/task'))
    assert len(policies) >= 5  # Python, the executor thread and Fast DDS's threads
    assert len(senders) == 2  # asynchronous publication: discovery's and the writers'
    assert set(policies.values()) == {policy}, policies
    slices = {int(thread_id): time_slice_ns(int(thread_id)) for thread_id in policies}
    shortened = guarded == 'slices' and kernel_takes_slices()
    assert {thread_id for thread_id, value in slices.items() if value == SENDER_SLICE_NS} == (
        set(senders) if shortened else set())
    if not guarded:
        assert 'Fast DDS sender threads' not in lines[-1]
    else:  # and the split of the gyro loop from the senders (test_cpu_split)
        split = (r'gyro loop on CPU \d+ and Fast DDS sender threads on CPUs? [\d,-]+ while '
                 r'gyro input is above 12000 Hz' if len(os.sched_getaffinity(0)) > 1 else
                 r'the gyro loop and Fast DDS sender threads share CPU \d+, the only one this '
                 r'process may use')
        assert re.search(f'; {split}; serving$', lines[-1].rstrip()), lines[-1]
    if guarded == 'slices' and shortened:
        assert (f'Fast DDS sender threads {senders} on SCHED_BATCH with 0.1 ms time slices; '
                in lines[-1])
    elif guarded == 'slices':
        assert 'has no custom time slices; see idle_senders_above_hz); ' in lines[-1]
    elif guarded and can_leave_idle_policy():
        assert (f'Fast DDS sender threads {senders} on SCHED_IDLE while gyro input is above '
                f'12000 Hz, else on SCHED_BATCH; ') in lines[-1]
    elif guarded:
        assert 'Fast DDS sender threads kept on SCHED_BATCH (leaving SCHED_IDLE' in lines[-1]
    code, stderr = stop_with_sigint(process)
    stderr = ''.join(lines) + stderr
    assert code == 0, stderr
    # The profile is the packaged one and Fast DDS parsed it without complaint.
    assert f'Fast DDS profile {packaged_fastdds_profile()} ({PROFILE_SETTINGS})' in stderr
    assert 'XMLPARSER' not in stderr and 'Error' not in stderr and 'Traceback' not in stderr


def test_a_bad_cpu_scheduling_gives_one_error_line_and_exit_2(processes):
    process = start('--ros-args', '-p', 'scene:=strapdown', '-p', 'cpu_scheduling:=fifo')
    processes.append(process)
    _, stderr = process.communicate(timeout=60)
    assert process.returncode == 2
    assert stderr.strip().splitlines()[-1] == (
        "error: Expected parameter `cpu_scheduling` to be one of 'batch', 'all_batch', "
        "'default', got 'fifo'")
