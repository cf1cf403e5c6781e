"""Test-wide set-up: a ROS 2 environment of the test run's own, and the package under test.

pytest imports this file before any test module, so everything here happens before anything
imports rclpy (rclpy reads these variables when a context is initialised):

* ``ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST``: nodes only discover nodes on this machine.
* ``ROS_DOMAIN_ID``: a domain reserved for this pytest process. By default the first free one of
  ``TEST_DOMAIN_IDS`` (215-232: outside Linux's ephemeral port range and above the 0-101 that
  people usually use), held with a lock file for the process's lifetime, so concurrent test runs
  on one machine (several checkouts, pytest-xdist workers) never see each other's topics.
  ``RIGID_BODY_ATTITUDE_TEST_DOMAIN_ID=<id>`` chooses one instead. The user's own
  ``ROS_DOMAIN_ID``, ``ROS_LOCALHOST_ONLY`` and ``ROS_STATIC_PEERS`` are not used, nor a Fast DDS
  profile of theirs (``FASTRTPS_DEFAULT_PROFILES_FILE``, ``FASTDDS_DEFAULT_PROFILES_FILE``,
  ``RMW_FASTRTPS_USE_QOS_FROM_XML``): the node under test loads the package's own. Tests and
  fixtures get the value from the ``ros_domain_id`` fixture; subprocesses inherit it.
* ``AMENT_PREFIX_PATH`` starts with ``sys.prefix`` (the virtual env the package is installed
  in), so ``get_package_prefix('rigid_body_attitude')`` resolves there, as ``ros2 run`` would.
* The tests import the installed package (``make test`` runs ``python -P``, which keeps the
  working directory off ``sys.path``). Only if the package is not installed at all is the
  source tree put on ``sys.path``.
"""

from collections.abc import Iterator
import fcntl
import importlib.util
import os
from pathlib import Path
import subprocess
import sys
import tempfile
from typing import IO, TYPE_CHECKING

import pytest

if TYPE_CHECKING:
    from ros_helpers import RosContext

REPO_ROOT = Path(__file__).resolve().parents[1]
TEST_DOMAIN_IDS = range(215, 233)
DOMAIN_ID_OVERRIDE = 'RIGID_BODY_ATTITUDE_TEST_DOMAIN_ID'

_domain_lock: IO[str] | None = None  # kept open: the lock lasts as long as this process


def _reserve_domain_id() -> int:
    """Return a ROS domain id that no other test process on this machine holds."""
    global _domain_lock
    override = os.environ.get(DOMAIN_ID_OVERRIDE)
    if override is not None:
        if not override.isdigit() or int(override) > 232:
            raise pytest.UsageError(
                f'Expected {DOMAIN_ID_OVERRIDE} to be an integer in [0, 232], got {override!r}')
        return int(override)
    lock_dir = Path(tempfile.gettempdir()) / f'rigid_body_attitude-test-domains-{os.getuid()}'
    lock_dir.mkdir(exist_ok=True)
    for domain_id in TEST_DOMAIN_IDS:
        lock_file = open(lock_dir / f'{domain_id}.lock', 'w')  # closed below or held
        try:
            fcntl.flock(lock_file, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            lock_file.close()
            continue
        _domain_lock = lock_file
        return domain_id
    raise pytest.UsageError(
        f'Expected a free ROS domain id in {TEST_DOMAIN_IDS}, but other test processes hold '
        f'all of them (lock files in {lock_dir}); set {DOMAIN_ID_OVERRIDE} to choose one')


def _ament_prefix_path_with(prefix: str) -> str:
    """Return AMENT_PREFIX_PATH with ``prefix`` first (added only if it is not there yet)."""
    entries = [p for p in os.environ.get('AMENT_PREFIX_PATH', '').split(os.pathsep) if p]
    if prefix not in entries:
        entries.insert(0, prefix)
    return os.pathsep.join(entries)


TEST_DOMAIN_ID = _reserve_domain_id()
for _variable in ('ROS_LOCALHOST_ONLY', 'ROS_STATIC_PEERS', 'FASTRTPS_DEFAULT_PROFILES_FILE',
                  'FASTDDS_DEFAULT_PROFILES_FILE', 'RMW_FASTRTPS_USE_QOS_FROM_XML'):
    os.environ.pop(_variable, None)
os.environ['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'LOCALHOST'
os.environ['ROS_DOMAIN_ID'] = str(TEST_DOMAIN_ID)
os.environ['AMENT_PREFIX_PATH'] = _ament_prefix_path_with(sys.prefix)
os.environ['PYTHONFAULTHANDLER'] = '1'  # a crashing node subprocess leaves its stacks in stderr

if importlib.util.find_spec('rigid_body_attitude') is None:
    sys.path.insert(0, str(REPO_ROOT))


@pytest.fixture(scope='session')
def ros_domain_id() -> int:
    """Return the ROS domain id of this test run (also in ``os.environ['ROS_DOMAIN_ID']``)."""
    return TEST_DOMAIN_ID


@pytest.fixture(scope='session')
def repo_root() -> Path:
    """Return the root of the source tree the tests belong to."""
    return REPO_ROOT


@pytest.fixture(scope='session')
def data_dir(repo_root: Path) -> Path:
    """The BROAD trials shipped in data/broad (CC BY 4.0; attribution in its README)."""
    return repo_root / 'data' / 'broad'


@pytest.fixture
def processes() -> Iterator[list[subprocess.Popen]]:
    """Processes a test starts; any still running afterwards is killed."""
    started: list[subprocess.Popen] = []
    yield started
    for process in started:
        if process.poll() is None:
            process.kill()
            process.communicate()


@pytest.fixture
def ros(ros_domain_id: int) -> Iterator['RosContext']:
    """A ROS context and executor of the test's own on the test run's domain."""
    from ros_helpers import ros_session  # imports rclpy: only for the tests that use it
    with ros_session(ros_domain_id) as session:
        yield session
