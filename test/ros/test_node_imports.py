"""The running node loads no bag library: neither ``rosbags`` nor ``apsw`` nor the package's
``bag`` and ``tools`` layers, for a gyro scene fed by Imu messages and for a dynamics scene fed
by torque commands.

The node runs in its own process, started by a launcher that runs the executable's entry point
(``rigid_body_attitude.ros.serve:main``) and, when it returns after SIGINT, writes the names of
every module the process loaded; the test looks at them after real messages went through the
node's decoders and encoders.
"""

from __future__ import annotations

import json
from pathlib import Path
import subprocess
import sys

from geometry_msgs.msg import QuaternionStamped, WrenchStamped
import pytest
from ros_helpers import Harness, unique_namespace
from sensor_msgs.msg import Imu
from test_node_subprocess import START_TIMEOUT, stop_with_sigint

#: Runs the node's entry point; at exit writes the loaded module names to argv[1].
LAUNCHER = r'''
import atexit, json, sys
report = sys.argv.pop(1)
atexit.register(lambda: open(report, 'w').write(json.dumps(sorted(sys.modules))))
from rigid_body_attitude.ros.serve import main
sys.exit(main())
'''
#: Top-level modules of bag storage, and the package's layers built on them.
FORBIDDEN = ('rosbags', 'apsw', 'rigid_body_attitude.bag', 'rigid_body_attitude.tools')


def loaded_modules(tmp_path: Path, processes: list, arguments: list[str], drive) -> list[str]:
    """Start the node with ``arguments``, call ``drive()`` (which returns once outputs came
    back), stop it with SIGINT; the modules it had loaded."""
    report = tmp_path / 'modules.json'
    process = subprocess.Popen(
        [sys.executable, '-P', '-c', LAUNCHER, str(report), '--ros-args', *arguments],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    processes.append(process)
    drive()
    code, stderr = stop_with_sigint(process)
    assert code == 0 and 'Traceback' not in stderr, stderr
    return json.loads(report.read_text())


def forbidden(modules: list[str]) -> list[str]:
    return [name for name in modules
            if any(name == root or name.startswith(root + '.') for root in FORBIDDEN)]


def test_gyro_node_fed_imu_messages_loads_no_bag_library(ros, request, processes, tmp_path):
    namespace = unique_namespace(request)
    harness = Harness(ros, namespace)
    imu_publisher = harness.publisher(Imu, 'imu')
    imu_outputs = harness.record(Imu, 'imu/data')

    def drive() -> None:
        harness.wait_for_connections(START_TIMEOUT)
        for k in range(500):
            imu = Imu()
            imu.header.stamp.sec, imu.header.stamp.nanosec = 1_700_000_000 + k // 100, (
                k % 100) * 10**7
            imu.angular_velocity.z = 0.5
            imu_publisher.publish(imu)
            if harness.spin_until(lambda: len(imu_outputs) >= 10, 0.02):
                break
        assert len(imu_outputs) >= 10

    modules = loaded_modules(tmp_path, processes,
                             ['-p', 'scene:=strapdown', '-r', f'__ns:={namespace}'], drive)
    assert 'rigid_body_attitude.msgs.decoders' in modules  # the report sees the package
    assert 'rigid_body_attitude.session.gyro' in modules
    assert forbidden(modules) == []


def test_dynamics_node_fed_torques_loads_no_bag_library(ros, request, processes, tmp_path):
    namespace = unique_namespace(request)
    harness = Harness(ros, namespace)
    torque_publisher = harness.publisher(WrenchStamped, 'torque')
    orientations = harness.record(QuaternionStamped, 'orientation')

    def drive() -> None:
        harness.wait_for_connections(START_TIMEOUT)
        for _ in range(200):
            wrench = WrenchStamped()
            wrench.header.frame_id = 'base_link'
            wrench.wrench.torque.x = 0.01
            torque_publisher.publish(wrench)
            if harness.spin_until(lambda: len(orientations) >= 10, 0.05):
                break
        assert len(orientations) >= 10

    modules = loaded_modules(tmp_path, processes,
                             ['-p', 'scene:=commanded_torque', '-r', f'__ns:={namespace}'],
                             drive)
    assert 'rigid_body_attitude.session.dynamics' in modules
    assert forbidden(modules) == []


@pytest.mark.parametrize('modules, found', [
    (['rosbags', 'numpy'], ['rosbags']),
    (['apsw', 'rosbags.rosbag2.reader'], ['apsw', 'rosbags.rosbag2.reader']),
    (['rigid_body_attitude.bag.reader', 'rigid_body_attitude.msgs'],
     ['rigid_body_attitude.bag.reader']),
    (['rosbagsx', 'rigid_body_attitude.bagger'], []),
])
def test_the_check_names_what_it_forbids(modules, found):
    assert forbidden(modules) == found
