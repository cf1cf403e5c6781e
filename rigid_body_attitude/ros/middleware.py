"""How the node sets up the middleware before it serves: declarative settings only.

The package's Fast DDS profile (``config/fastdds.xml``, :func:`use_packaged_fastdds_profile`)
must be in place before the participant exists, so :func:`main
<rigid_body_attitude.ros.serve.main>` applies it before ``rclpy.init``, through the environment
variable Fast DDS reads, and never over a profile the user chose. It holds two settings (the
file's comment says why):

* **A 30 ms shared-memory health check.** Fast DDS 2.14's shared-memory listener sleeps on an
  interprocess condition that can miss its wake-ups for a while after the process handles a
  peer's participant re-announcement; the listener then wakes only on its own timeout, a third
  of ``healthy_check_timeout_ms`` (default 1000 ms). With 30 ms such a stall lasts at most
  10 ms. It protects the process that receives, so the node's own gyro and command inputs,
  and any subscriber that loads the same file.
* **Fast DDS NACK suppression.** With Fast DDS's default ``nackSupressionDuration`` of 0, every
  sample a reliable writer sends to a reader in another process restarts a timer on the
  participant's event thread, which wakes up for it. The profile sets 10 ms; the timer then
  fires at most 100 times a second.

Nothing else: rmw_fastrtps publishes synchronously by default (the raw-take loop's thread hands
every output sample to the readers itself), and the node leaves
``RMW_FASTRTPS_PUBLICATION_MODE`` to the user's environment (docs/tuning.md).

The node leaves the threads' scheduling policy and CPU affinity as the process was started
(``chrt``, ``taskset``); what these settings cost and buy is measured by
``bench/node_throughput.py``.
"""

from __future__ import annotations

from collections.abc import MutableMapping
import os
from pathlib import Path

from rigid_body_attitude.core.paths import config_folders

__all__ = ['FASTDDS_PROFILE_VARIABLES', 'PROFILE_SETTINGS', 'packaged_fastdds_profile',
           'use_packaged_fastdds_profile']

#: What the packaged profile sets, for the start-up log.
PROFILE_SETTINGS = 'shared-memory health check 30 ms, NACK suppression 10 ms'

#: RMW implementations that read Fast DDS XML profiles ('' = the default RMW, rmw_fastrtps_cpp).
FASTDDS_RMWS = ('', 'rmw_fastrtps_cpp', 'rmw_fastrtps_dynamic_cpp')

#: Environment variables naming a Fast DDS XML profile file (Fast DDS 2.x and 3.x names).
FASTDDS_PROFILE_VARIABLES = ('FASTRTPS_DEFAULT_PROFILES_FILE', 'FASTDDS_DEFAULT_PROFILES_FILE')

#: Files Fast DDS loads from the working directory when present.
FASTDDS_WORKING_DIRECTORY_PROFILES = ('DEFAULT_FASTRTPS_PROFILES.xml',
                                      'DEFAULT_FASTDDS_PROFILES.xml')


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
