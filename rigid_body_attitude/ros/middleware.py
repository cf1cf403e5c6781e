"""How the node sets up the middleware and the Linux scheduler for itself before it serves.

The package's Fast DDS profile (``config/fastdds.xml``, :func:`use_packaged_fastdds_profile`)
must be in place before the participant exists, so :func:`main
<rigid_body_attitude.ros.node.main>` applies it before ``rclpy.init``, through the environment
variable Fast DDS reads, and never over a profile the user chose. It holds two settings:

* **A 30 ms shared-memory health check.** Fast DDS 2.14's shared-memory listener sleeps on an
  interprocess condition that can miss its wake-ups for a while after the process handles a
  peer's participant re-announcement; the listener then wakes only on its own timeout, a third
  of ``healthy_check_timeout_ms`` (default 1000 ms: the "~300 ms stall" of issue 13, in about
  one run of three of ``bench/node_throughput.py``). With 30 ms such a stall lasts at most
  10 ms. It protects the process that receives, so the node's own gyro and command inputs,
  and any subscriber that loads the same file (``bench/NOTES.md``, section 9).
* **Fast DDS NACK suppression.** At kHz gyro rates most of the node's CPU goes to per-message
  thread wake-ups, not to its own work (``bench/NOTES.md``, section 3). With Fast DDS's
  default ``nackSupressionDuration`` of 0, every sample a reliable writer sends to a reader
  in another process restarts a timer on the participant's event thread, which wakes up for
  it. The profile sets 10 ms; the timer then fires at most 100 times a second.

And, through rmw_fastrtps's own variable (:func:`use_asynchronous_publication`):

* **Asynchronous publication.** rmw_fastrtps publishes synchronously by default: the gyro loop's
  thread itself hands every output sample to the readers (of the 26–37 µs that thread spent per
  message at 15–20 kHz, the node's own Python was 5 µs, ``bench/gyro_handler_costs.py``; the
  rest is taking and publishing). With ``RMW_FASTRTPS_PUBLICATION_MODE=ASYNCHRONOUS`` a Fast DDS
  thread sends while the loop decodes and integrates the next message, so a backlog drains on
  both cores: in interleaved runs at 15–20 kHz the node's p99 latency was 0.4–1.4× the fast
  relay's with it and 1.5–3.9× without (``bench/NOTES.md``, section 10). The user's own choice
  of the variable is kept.

And for the scheduler:

* **SCHED_BATCH** (:func:`apply_cpu_scheduling`, parameter ``cpu_scheduling``). When a Fast
  DDS receive thread hands a message to the gyro loop, Linux lets each newly woken thread
  preempt the one that woke it; the loop then blocks on the reader's mutex, which the receive
  thread still holds, and both switch again. Threads under ``SCHED_BATCH`` do not preempt on
  wake-up: they run when the CPU is free or the current thread's slice ends. Only threads on
  the default policy are changed; real-time (FIFO/RR) and idle threads are left alone.
  On a busy CPU a batch thread can wait up to one scheduler slice (a few ms) before it runs;
  ``cpu_scheduling: default`` keeps the usual policy. Under SCHED_BATCH Fast DDS's
  asynchronous sender threads can busy-wait on a writer's mutex for up to a scheduler tick, so
  with ``batch`` they get the kernel's shortest time slice (:mod:`~.time_slices`, Linux 6.12
  and later), or, with ``idle_senders_above_hz`` set, move to SCHED_IDLE while the gyro rate
  is above it, where the process may undo that (:mod:`~.sender_threads`). Above
  ``separate_cpus_above_hz`` of gyro input they also run on other CPUs than the gyro loop
  (:mod:`~.cpu_split`).

Measured on this project's machine at 1 kHz (``bench/fast_relay.py``): Fast DDS defaults 12.5 %
of a core; with the NACK suppression 9.8–10.3 %; with it and SCHED_BATCH 8.8–9.2 %, p99
latency unchanged (0.31 ms).
"""

from __future__ import annotations

from collections.abc import MutableMapping
import os
from pathlib import Path
from typing import NamedTuple

from rigid_body_attitude.core.errors import InputError
from rigid_body_attitude.core.paths import config_folders

__all__ = ['CPU_SCHEDULING', 'FASTDDS_PROFILE_VARIABLES', 'PROFILE_SETTINGS',
           'PUBLICATION_MODE_VARIABLE', 'SchedulingChoice', 'SchedulingOutcome',
           'apply_cpu_scheduling',
           'check_cpu_scheduling', 'packaged_fastdds_profile', 'use_asynchronous_publication',
           'use_packaged_fastdds_profile']

#: What the packaged profile sets, for the start-up log.
PROFILE_SETTINGS = 'shared-memory health check 30 ms, NACK suppression 10 ms'

#: RMW implementations that read Fast DDS XML profiles ('' = the default RMW, rmw_fastrtps_cpp).
FASTDDS_RMWS = ('', 'rmw_fastrtps_cpp', 'rmw_fastrtps_dynamic_cpp')

#: Environment variables naming a Fast DDS XML profile file (Fast DDS 2.x and 3.x names).
FASTDDS_PROFILE_VARIABLES = ('FASTRTPS_DEFAULT_PROFILES_FILE', 'FASTDDS_DEFAULT_PROFILES_FILE')

#: rmw_fastrtps's variable for its writers' publication mode (its default: SYNCHRONOUS).
PUBLICATION_MODE_VARIABLE = 'RMW_FASTRTPS_PUBLICATION_MODE'

#: Files Fast DDS loads from the working directory when present.
FASTDDS_WORKING_DIRECTORY_PROFILES = ('DEFAULT_FASTRTPS_PROFILES.xml',
                                      'DEFAULT_FASTDDS_PROFILES.xml')


class SchedulingChoice(NamedTuple):
    """What a ``cpu_scheduling`` value asks for."""

    #: The policy threads on SCHED_OTHER move to (None = every thread as it started).
    policy: int | None
    #: Fast DDS's sender threads get short time slices (:mod:`~.time_slices`), or go to
    #: SCHED_IDLE while the gyro rate is above ``idle_senders_above_hz`` under a guard
    #: (:mod:`~.sender_threads`).
    sender_rule: bool = False


#: Values of the ``cpu_scheduling`` parameter.
CPU_SCHEDULING: dict[str, SchedulingChoice] = {
    'batch': SchedulingChoice(getattr(os, 'SCHED_BATCH', None), sender_rule=True),
    'all_batch': SchedulingChoice(getattr(os, 'SCHED_BATCH', None)),
    'default': SchedulingChoice(None),
}


def packaged_fastdds_profile() -> Path | None:
    """The shipped ``config/fastdds.xml`` (installed or in the source tree), or None."""
    for folder in config_folders():
        candidate = folder / 'fastdds.xml'
        if candidate.is_file():
            return candidate
    return None


def use_packaged_fastdds_profile(environ: MutableMapping[str, str] | None = None,
                                 working_directory: Path | None = None) -> str:
    """Point Fast DDS at the packaged profile unless the user configured Fast DDS already.

    Sets :data:`FASTDDS_PROFILE_VARIABLES` in ``environ`` (default ``os.environ``, which the
    C library sees) when the RMW is Fast DDS, none of them is set,
    ``RMW_FASTRTPS_USE_QOS_FROM_XML`` is not 1 and no default profile file is in the working
    directory. Must run before the first node of the process is created. Returns one line
    for the log saying what was done and why.
    """
    environ = os.environ if environ is None else environ
    working_directory = Path.cwd() if working_directory is None else working_directory
    rmw = environ.get('RMW_IMPLEMENTATION', '')
    if rmw not in FASTDDS_RMWS:
        return f'Fast DDS profile not used: RMW_IMPLEMENTATION is {rmw!r}'
    for variable in FASTDDS_PROFILE_VARIABLES:
        if environ.get(variable):
            return f'Fast DDS profile not used: {variable} is set ({environ[variable]!r})'
    if environ.get('RMW_FASTRTPS_USE_QOS_FROM_XML') == '1':
        return 'Fast DDS profile not used: RMW_FASTRTPS_USE_QOS_FROM_XML is 1'
    for name in FASTDDS_WORKING_DIRECTORY_PROFILES:
        if (working_directory / name).is_file():
            return f'Fast DDS profile not used: {name} is in the working directory'
    profile = packaged_fastdds_profile()
    if profile is None:
        return 'Fast DDS profile not used: config/fastdds.xml is not installed'
    for variable in FASTDDS_PROFILE_VARIABLES:
        environ[variable] = str(profile)
    return f'Fast DDS profile {profile} ({PROFILE_SETTINGS})'


def use_asynchronous_publication(environ: MutableMapping[str, str] | None = None) -> str:
    """Ask rmw_fastrtps for asynchronous publication unless the user chose how to publish.

    Sets :data:`PUBLICATION_MODE_VARIABLE` to ``ASYNCHRONOUS`` in ``environ`` (default
    ``os.environ``) when the RMW is Fast DDS, the variable is not set and
    ``RMW_FASTRTPS_USE_QOS_FROM_XML`` is not 1 (the user's XML then decides). Must run before
    the first node of the process is created. Returns one line for the log.
    """
    environ = os.environ if environ is None else environ
    rmw = environ.get('RMW_IMPLEMENTATION', '')
    if rmw not in FASTDDS_RMWS:
        return f'publication mode left alone: RMW_IMPLEMENTATION is {rmw!r}'
    if environ.get(PUBLICATION_MODE_VARIABLE):
        return (f'publication mode left alone: {PUBLICATION_MODE_VARIABLE} is '
                f'{environ[PUBLICATION_MODE_VARIABLE]!r}')
    if environ.get('RMW_FASTRTPS_USE_QOS_FROM_XML') == '1':
        return 'publication mode left alone: RMW_FASTRTPS_USE_QOS_FROM_XML is 1'
    environ[PUBLICATION_MODE_VARIABLE] = 'ASYNCHRONOUS'
    return f'asynchronous publication ({PUBLICATION_MODE_VARIABLE}=ASYNCHRONOUS)'


def check_cpu_scheduling(value: str) -> str:
    """Why ``value`` is not a usable ``cpu_scheduling`` parameter, or ``''``."""
    if value not in CPU_SCHEDULING:
        return (f'Expected parameter `cpu_scheduling` to be one of '
                f'{", ".join(repr(name) for name in CPU_SCHEDULING)}, got {value!r}')
    if value != 'default' and CPU_SCHEDULING[value].policy is None:
        return (f'Expected parameter `cpu_scheduling` to be \'default\' on this system '
                f'(no SCHED_BATCH), got {value!r}')
    return ''


class SchedulingOutcome(NamedTuple):
    """What :func:`apply_cpu_scheduling` did: threads changed, and why it stopped early."""

    changed: int
    #: '' or the system's refusal (e.g. a container's seccomp policy); the threads not yet
    #: changed keep their policy.
    refused: str = ''


def apply_cpu_scheduling(value: str, task_folder: Path = Path('/proc/self/task')
                         ) -> SchedulingOutcome:
    """Move this process's threads on SCHED_OTHER to the policy named by ``value``.

    Threads created later by one of them inherit the policy. A refusal by the system is
    returned, not raised (the node then runs as started); a value
    :func:`check_cpu_scheduling` refuses raises :class:`InputError`.
    """
    problem = check_cpu_scheduling(value)
    if problem:
        raise InputError(problem)
    policy = CPU_SCHEDULING[value].policy
    if policy is None or not task_folder.is_dir():
        return SchedulingOutcome(0)
    changed = 0
    for entry in sorted(task_folder.iterdir()):
        thread_id = int(entry.name)
        try:
            if os.sched_getscheduler(thread_id) != os.SCHED_OTHER:
                continue
            os.sched_setscheduler(thread_id, policy, os.sched_param(0))
        except ProcessLookupError:  # the thread ended meanwhile
            continue
        except OSError as err:
            return SchedulingOutcome(changed, f'thread {thread_id}: {err}')
        changed += 1
    return SchedulingOutcome(changed)
