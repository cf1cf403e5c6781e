"""The node's own middleware set-up (:mod:`rigid_body_attitude.ros.middleware`).

What the settings buy is measured, not tested (``bench/node_throughput.py``). Here: which
profile is used when, that the shipped profile is what its comment says and reaches the node's
participant, that the node publishes asynchronously unless told otherwise, and that the node
leaves its threads' scheduling policy and CPUs as it was started.
"""

from __future__ import annotations

import os
from pathlib import Path
import subprocess
import time
import xml.etree.ElementTree as ElementTree

import pytest
from ros_helpers import remove_stale_fastdds_shm
from test_node_subprocess import executable, read_until, SERVING, start, stop_with_sigint

from rigid_body_attitude.ros.middleware import (
    FASTDDS_PROFILE_VARIABLES, PROFILE_SETTINGS, packaged_fastdds_profile,
    use_packaged_fastdds_profile)

#: rmw_fastrtps's variable for its writers' publication mode (its default: SYNCHRONOUS).
PUBLICATION_MODE_VARIABLE = 'RMW_FASTRTPS_PUBLICATION_MODE'
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
    remove_stale_fastdds_shm()  # a port left by a killed participant keeps the stale state
    process = start('--ros-args', '-p', 'scene:=strapdown')
    processes.append(process)
    lines = read_until(process, SERVING)
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


def _sender_thread_ids(pid: int) -> list[int]:
    """Ids of the Fast DDS asynchronous sender threads (named ``dds.asyn.*``) of ``pid``."""
    return sorted(int(task.name) for task in Path(f'/proc/{pid}/task').iterdir()
                  if (task / 'comm').read_text().startswith('dds.asyn.'))


@pytest.mark.parametrize('mode, asynchronous_threads', [
    ('', 1),  # rmw_fastrtps's default, synchronous: discovery's own only
    ('ASYNCHRONOUS', 2),  # the user's choice: plus the writers' asynchronous thread
])
def test_the_installed_node_leaves_the_publication_mode_to_the_environment(
        processes, monkeypatch, mode, asynchronous_threads):
    """Fast DDS names its asynchronous sender threads ``dds.asyn.*``: the participant's
    discovery always has one; writers publishing asynchronously add one."""
    if mode:
        monkeypatch.setenv(PUBLICATION_MODE_VARIABLE, mode)
    else:
        monkeypatch.delenv(PUBLICATION_MODE_VARIABLE, raising=False)
    process = start('--ros-args', '-p', 'scene:=strapdown')
    processes.append(process)
    lines = read_until(process, SERVING)
    senders = _sender_thread_ids(process.pid)
    code, stderr = stop_with_sigint(process)
    stderr = ''.join(lines) + stderr
    assert code == 0, stderr
    assert len(senders) == asynchronous_threads, senders
    assert 'publication' not in stderr


def test_the_installed_node_keeps_the_policy_and_cpus_it_was_started_with(
        processes, monkeypatch):
    """Started under ``chrt --batch`` and ``taskset`` on one CPU (a user's recipe), every
    thread of the serving node, Fast DDS's too, is still on SCHED_BATCH and that CPU; the
    packaged profile was used and Fast DDS parsed it without complaint."""
    for variable in FASTDDS_PROFILE_VARIABLES:  # set by an in-process main() of another test
        monkeypatch.delenv(variable, raising=False)
    cpu = max(os.sched_getaffinity(0))
    process = subprocess.Popen(
        ['chrt', '--batch', '0', 'taskset', '-c', str(cpu), str(executable()), '--ros-args',
         '-p', 'scene:=strapdown'], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    processes.append(process)
    lines = read_until(process, SERVING)
    time.sleep(0.5)
    tasks = [int(entry.name) for entry in Path(f'/proc/{process.pid}/task').iterdir()]
    policies = {task: os.sched_getscheduler(task) for task in tasks}
    affinities = {task: os.sched_getaffinity(task) for task in tasks}
    code, stderr = stop_with_sigint(process)
    stderr = ''.join(lines) + stderr
    assert code == 0, stderr
    assert len(tasks) >= 5, tasks  # Python, the executor thread and Fast DDS's threads
    assert set(policies.values()) == {os.SCHED_BATCH}, policies
    assert all(cpus == {cpu} for cpus in affinities.values()), affinities
    assert f'Fast DDS profile {packaged_fastdds_profile()} ({PROFILE_SETTINGS})' in stderr
    assert 'XMLPARSER' not in stderr and 'Error' not in stderr and 'Traceback' not in stderr
