"""The node's own middleware and scheduler set-up (:mod:`rigid_body_attitude.ros.middleware`).

What the settings buy is measured, not tested: ``bench/NOTES.md`` section 3 and
``docs/performance.md``. Here: which profile is used when, that the shipped profile is what
its comment says, and that the scheduling policy reaches every thread of the installed node.
"""

from __future__ import annotations

import os
from pathlib import Path
import subprocess
import sys
import textwrap
import xml.etree.ElementTree as ElementTree

import pytest
from test_node_subprocess import read_until, start, stop_with_sigint

from rigid_body_attitude.core.errors import InputError
from rigid_body_attitude.ros.middleware import (
    apply_cpu_scheduling, check_cpu_scheduling, FASTDDS_PROFILE_VARIABLES,
    packaged_fastdds_profile, use_packaged_fastdds_profile)

FASTDDS_NAMESPACE = '{http://www.eprosima.com/XMLSchemas/fastRTPS_Profiles}'


def test_the_packaged_profile_is_installed_and_sets_10_ms_nack_suppression_only():
    profile = packaged_fastdds_profile()
    assert profile is not None and profile.is_file()
    root = ElementTree.parse(profile).getroot()
    writers = root.findall(f'{FASTDDS_NAMESPACE}profiles/{FASTDDS_NAMESPACE}data_writer')
    assert len(writers) == 1 and writers[0].get('is_default_profile') == 'true'
    assert [child.tag for child in writers[0]] == [f'{FASTDDS_NAMESPACE}times']
    times = writers[0].find(f'{FASTDDS_NAMESPACE}times')
    assert [child.tag for child in times] == [f'{FASTDDS_NAMESPACE}nackSupressionDuration']
    duration = times.find(f'{FASTDDS_NAMESPACE}nackSupressionDuration')
    seconds = (int(duration.find(f'{FASTDDS_NAMESPACE}sec').text)
               + int(duration.find(f'{FASTDDS_NAMESPACE}nanosec').text) * 1e-9)
    assert seconds == pytest.approx(0.010, abs=1e-12)


@pytest.mark.parametrize('rmw', ['', 'rmw_fastrtps_cpp', 'rmw_fastrtps_dynamic_cpp'])
def test_the_profile_is_used_when_fast_dds_is_not_configured(tmp_path, rmw):
    environ = {'RMW_IMPLEMENTATION': rmw} if rmw else {}
    note = use_packaged_fastdds_profile(environ, tmp_path)
    profile = str(packaged_fastdds_profile())
    assert all(environ[variable] == profile for variable in FASTDDS_PROFILE_VARIABLES)
    assert note == f'Fast DDS profile {profile} (NACK suppression 10 ms)'


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
    expected = (f"Expected parameter `cpu_scheduling` to be one of 'batch', 'default', "
                f'got {value!r}')
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


@pytest.mark.parametrize('arguments, policy, logged', [
    ((), os.SCHED_BATCH, "cpu_scheduling 'batch': "),
    (('-p', 'cpu_scheduling:=default'), os.SCHED_OTHER, "cpu_scheduling 'default': 0 threads"),
])
def test_the_installed_node_runs_every_thread_on_its_cpu_scheduling(processes, monkeypatch,
                                                                    arguments, policy, logged):
    for variable in FASTDDS_PROFILE_VARIABLES:  # set by an in-process main() of another test
        monkeypatch.delenv(variable, raising=False)
    process = start('--ros-args', '-p', 'scene:=strapdown', *arguments)
    processes.append(process)
    lines = read_until(process, logged)
    policies = _thread_policies(process.pid)
    assert len(policies) >= 5  # Python, the executor thread and Fast DDS's threads
    assert set(policies.values()) == {policy}, policies
    code, stderr = stop_with_sigint(process)
    stderr = ''.join(lines) + stderr
    assert code == 0, stderr
    # The profile is the packaged one and Fast DDS parsed it without complaint.
    assert f'Fast DDS profile {packaged_fastdds_profile()} (NACK suppression 10 ms)' in stderr
    assert 'XMLPARSER' not in stderr and 'Error' not in stderr and 'Traceback' not in stderr


def test_a_bad_cpu_scheduling_gives_one_error_line_and_exit_2(processes):
    process = start('--ros-args', '-p', 'scene:=strapdown', '-p', 'cpu_scheduling:=fifo')
    processes.append(process)
    _, stderr = process.communicate(timeout=60)
    assert process.returncode == 2
    assert stderr.strip().splitlines()[-1] == (
        "error: Expected parameter `cpu_scheduling` to be one of 'batch', 'default', "
        "got 'fifo'")
