"""The sim clock and lockstep over real topics: the installed node, the installed
``attitude_controller`` (a process of its own), a recorder in this process; bit-identical
trajectories at any real-time factor and under CPU load; a follower with ``use_sim_time``; a
silent controller."""

from __future__ import annotations

from collections.abc import Iterator
import os
from pathlib import Path
import re
import subprocess
import sys
import time

from ament_index_python.packages import get_package_prefix
from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import QuaternionStamped, TwistStamped, WrenchStamped
import pytest
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from rclpy.serialization import deserialize_message, serialize_message
from ros_helpers import Harness, ros_session, RosContext, unique_namespace
from rosgraph_msgs.msg import Clock
from test_node_subprocess import read_until, SERVING, start, stop_with_sigint

from rigid_body_attitude.bag import BagReader, BagWriter
from rigid_body_attitude.msgs.cdr import twist_angular
from rigid_body_attitude.tools.replay import ReplayOptions, replay_bag

CONTROLLER = Path(get_package_prefix('rigid_body_attitude')) / 'lib' / 'rigid_body_attitude' \
    / 'attitude_controller'
#: Gains [N m, N m s] and limit [N m] of the slew: saturated at first, settled within 4 s.
GAINS = ('-p', 'kp:=0.05', '-p', 'kd:=0.04', '-p', 'torque_limit:=0.02')
#: 60 degrees about (1, 1, 1) / sqrt(3), at rest: the controller's slew to the identity.
SCENE = """name: slew_under_pd
description: a box 60 deg from the identity, driven by commanded torques
rate_source: dynamics
integrator: rk4
step: 0.001
body:
  mass: 2.0
  inertia: {box: {edges: [0.1, 0.2, 0.3], about: centre}}
initial_state:
  attitude: [0.8660254037844387, 0.28867513459481287, 0.28867513459481287,
             0.28867513459481287]
  omega_body: [0.0, 0.01, 0.0]
effects:
  - commanded_torque: {timeout: 0.5}
"""
PERIOD_NS = 10_000_000  # 100 Hz


@pytest.fixture
def ros(ros_domain_id: int) -> Iterator[RosContext]:
    with ros_session(ros_domain_id) as session:
        yield session


@pytest.fixture
def scene_file(tmp_path: Path) -> str:
    path = tmp_path / 'slew.yaml'
    path.write_text(SCENE)
    return str(path)


def start_controller(namespace: str) -> subprocess.Popen:
    """The installed ``attitude_controller`` in ``namespace``, the slew's gains."""
    assert CONTROLLER.is_file() and os.access(CONTROLLER, os.X_OK), CONTROLLER
    return subprocess.Popen([str(CONTROLLER), '--ros-args', '-r', f'__ns:={namespace}',
                             *GAINS], stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                            text=True)


def stop(process: subprocess.Popen) -> None:
    process.terminate()
    try:
        process.communicate(timeout=10.0)
    except subprocess.TimeoutExpired:
        process.kill()
        process.communicate()


def by_stamp(messages: list, field: str) -> dict[int, tuple[float, ...]]:
    """First message per stamp [ns] → its values (the first tick may come more than once)."""
    found: dict[int, tuple[float, ...]] = {}
    for message in messages:
        key = message.header.stamp.sec * 10**9 + message.header.stamp.nanosec
        if field == 'quaternion':
            q = message.quaternion
            values = (q.x, q.y, q.z, q.w)
        else:
            w = message.twist.angular
            values = (w.x, w.y, w.z)
        found.setdefault(key, values)
    return found


def run_loop(ros: RosContext, namespace: str, scene: str, rtf: float, ticks: int,
             extra: tuple[str, ...] = (), bag: Path | None = None
             ) -> dict[int, tuple[float, ...]]:
    """One lockstep run: ``ticks`` ticks recorded; stamp → attitude + rate. With ``bag``,
    what the recorder received (orientation, twist, torque) is written there, at its receive
    times, as a recorder would."""
    harness = Harness(ros, namespace)
    orientation = harness.record(QuaternionStamped, 'orientation')
    twist = harness.record(TwistStamped, 'twist')
    received: list[tuple[str, int, object]] = []
    for topic, kind in (('orientation', QuaternionStamped), ('twist', TwistStamped),
                        ('torque', WrenchStamped)):
        # torque transient local, as ros2 bag record subscribes to the controller's
        # transient-local writer: every command from tick 0 on, however late it matched
        harness.node.create_subscription(
            kind, topic, lambda m, t=topic: received.append((t, time.time_ns(), m)),
            QoSProfile(depth=5000, reliability=ReliabilityPolicy.RELIABLE,
                       durability=DurabilityPolicy.TRANSIENT_LOCAL if topic == 'torque'
                       else DurabilityPolicy.VOLATILE))
    # A controller stalled by the machine must be waited for, never timed out: the run
    # compares trajectories, and a tick advanced without its command is another trajectory
    # (the timeout itself: test_a_silent_controller_...).
    node = start('--ros-args', '-r', f'__ns:={namespace}', '-p', f'scene:={scene}',
                 '-p', 'lockstep:=true', '-p', 'publish_rate:=100.0',
                 '-p', f'real_time_factor:={rtf}', '-p', 'lockstep_timeout:=60.0', *extra)
    controller = None
    try:
        read_until(node, SERVING)
        harness.wait_for_connections()
        controller = start_controller(namespace)

        def done() -> bool:
            return len(by_stamp(twist, 'twist')) >= ticks and len(
                by_stamp(orientation, 'quaternion')) >= ticks
        assert harness.spin_until(done, timeout=60.0), f'{len(twist)} ticks recorded'
        if bag is not None:  # the commands answering every recorded tick recorded too
            def answered() -> bool:
                stamps = {m.header.stamp.sec * 10**9 + m.header.stamp.nanosec
                          for topic, _, m in received if topic == 'torque'}
                return all(k * PERIOD_NS in stamps for k in range(ticks))
            assert harness.spin_until(answered, timeout=60.0), 'torques missing'
    finally:
        code, stderr = stop_with_sigint(node)  # first: the loop stops with its controller on
        if controller is not None:
            stop(controller)
    assert code == 0 and 'Traceback' not in stderr, stderr
    # The controller answered every recorded tick (the loop goes on while the test stops it).
    silent_at = re.findall(r'lockstep: no command stamped t=([0-9.]+) s', stderr)
    assert all(float(t) > (ticks - 1) * PERIOD_NS * 1e-9 for t in silent_at), silent_at
    q, w = by_stamp(orientation, 'quaternion'), by_stamp(twist, 'twist')
    stamps = [k * PERIOD_NS for k in range(ticks)]
    assert all(stamp in q and stamp in w for stamp in stamps)  # t_k = k P from 0
    if bag is not None:
        write_received(bag, received)
    return {stamp: q[stamp] + w[stamp] for stamp in stamps}


def write_received(path: Path, received: list[tuple[str, int, object]]) -> None:
    types = {'orientation': 'geometry_msgs/msg/QuaternionStamped',
             'twist': 'geometry_msgs/msg/TwistStamped',
             'torque': 'geometry_msgs/msg/WrenchStamped'}
    with BagWriter(path) as writer:
        connections = writer.add_topics(types)
        for topic, bag_time_ns, message in received:
            writer.write(connections[topic], bag_time_ns, serialize_message(message))


def test_lockstep_trajectories_are_bit_identical_at_any_rate_and_under_load(
        ros, request, scene_file, tmp_path):
    namespace = unique_namespace(request)
    paced = run_loop(ros, namespace + '_paced', scene_file, 1.0, 150)
    bag = tmp_path / 'loop'
    unpaced = run_loop(ros, namespace + '_unpaced', scene_file, 0.0, 400, bag=bag)
    load = [subprocess.Popen([sys.executable, '-c', 'while True: pass']) for _ in range(2)]
    try:
        loaded = run_loop(ros, namespace + '_loaded', scene_file, 0.0, 400)
    finally:
        for process in load:
            process.kill()
            process.wait()
    assert unpaced == loaded
    assert paced == {stamp: unpaced[stamp] for stamp in paced}
    # The controller acted: the 60 deg error shrank over the 4 s (q_w grew from cos 30 deg).
    assert unpaced[399 * PERIOD_NS][3] > 0.9
    # The recorded loop, replayed on the scene with --lockstep, gives the plant's outputs.
    result = replay_bag(bag, tmp_path / 'replayed', ReplayOptions(
        scene=scene_file, publish_rate=100.0, lockstep=True, outputs=('orientation', 'twist')))
    series = result.series
    replayed = {}
    for index, stamp in enumerate(series.attitude_stamps_ns):
        w, x, y, z = series.attitudes[4 * index:4 * index + 4]
        replayed.setdefault(stamp, (x, y, z, w))
    with BagReader(tmp_path / 'replayed') as reader:
        for _, _, _, data in reader.messages(['twist']):
            stamp_s, rate = twist_angular(data)
            stamp = round(stamp_s * 1e9)
            if stamp in unpaced and len(replayed[stamp]) == 4:
                replayed[stamp] = replayed[stamp] + tuple(rate)
    assert {stamp: replayed[stamp] for stamp in unpaced} == unpaced
    # A torque stamped like an earlier one: the controller answered tick 0 again when the
    # node repeated it (waiting for its first command); the replay counts it, as the node did.
    with BagReader(bag) as reader:
        torques = [deserialize_message(data, WrenchStamped)
                   for _, _, _, data in reader.messages(['torque'])]
    torque_stamps = [m.header.stamp.sec * 10**9 + m.header.stamp.nanosec for m in torques]
    repeated = len(torque_stamps) - len(set(torque_stamps))
    assert result.rejected['future_stamp'] == 0
    assert result.rejected['stale_stamp'] == repeated


def test_a_node_with_use_sim_time_follows_the_published_clock(ros, request):
    namespace = unique_namespace(request)
    follower = Node('follower', namespace=namespace, context=ros.context,
                    parameter_overrides=[Parameter('use_sim_time', value=True)])
    ros.executor.add_node(follower)
    received: list[tuple[int, float]] = []
    follower.create_subscription(
        Clock, '/clock',
        lambda m: received.append((m.clock.sec * 10**9 + m.clock.nanosec, time.monotonic())),
        QoSProfile(depth=100, reliability=ReliabilityPolicy.BEST_EFFORT))
    harness = Harness(ros, namespace)
    node = start('--ros-args', '-r', f'__ns:={namespace}', '-p', 'publish_clock:=true',
                 '-p', 'real_time_factor:=5.0')
    try:
        read_until(node, SERVING)
        assert harness.spin_until(lambda: len(received) > 10, timeout=30.0)
        harness.spin_for(1.0)
    finally:
        code, stderr = stop_with_sigint(node)
    assert code == 0 and 'Traceback' not in stderr, stderr
    harness.spin_for(0.5)  # the last /clock messages delivered
    stamps = [stamp for stamp, _ in received]
    assert stamps == sorted(stamps) and all(stamp % 20_000_000 == 0 for stamp in stamps)
    assert follower.get_clock().now().nanoseconds == stamps[-1]
    (first_ns, first_wall), (last_ns, last_wall) = received[10], received[-1]
    factor = (last_ns - first_ns) * 1e-9 / (last_wall - first_wall)
    assert 2.0 < factor < 5.5  # paced near 5x: neither wall pace (1x) nor unpaced


def test_a_silent_controller_is_warned_about_once_counted_and_the_loop_goes_on(
        ros, request, scene_file):
    namespace = unique_namespace(request)
    harness = Harness(ros, namespace)
    twist = harness.record(TwistStamped, 'twist')
    diagnostics = harness.record(DiagnosticArray, '/diagnostics')
    node = start('--ros-args', '-r', f'__ns:={namespace}', '-p', f'scene:={scene_file}',
                 '-p', 'lockstep:=true', '-p', 'publish_rate:=100.0',
                 '-p', 'real_time_factor:=0.0', '-p', 'lockstep_timeout:=0.1')
    try:
        read_until(node, SERVING)
        harness.wait_for_connections()
        controller = start_controller(namespace)
        assert harness.spin_until(lambda: len(twist) > 50, timeout=60.0)
        controller.kill()
        controller.wait()
        silent_from = len(by_stamp(twist, 'twist'))

        def timeouts() -> int:
            for array in diagnostics[::-1]:
                for status in array.status:
                    values = {v.key: v.value for v in status.values}
                    if 'lockstep_timeouts' in values:
                        return int(values['lockstep_timeouts'])
            return 0
        assert harness.spin_until(lambda: timeouts() >= 5, timeout=30.0)
    finally:
        code, stderr = stop_with_sigint(node)
    assert code == 0 and 'Traceback' not in stderr, stderr
    assert stderr.count('lockstep: no command stamped') == 1
    assert len(by_stamp(twist, 'twist')) >= silent_from + 5  # it advanced without commands
    warned = [status for array in diagnostics for status in array.status
              if 'lockstep_timeout' in status.message]
    assert warned and warned[-1].level == b'\x01'


@pytest.mark.parametrize('parameter', ['lockstep', 'publish_clock'])
def test_the_stock_executor_path_refuses_the_sim_clock_with_one_error_line(
        processes, scene_file, parameter):
    process = start('--ros-args', '-p', f'scene:={scene_file}', '-p', f'{parameter}:=true',
                    path='stock')
    processes.append(process)
    _, stderr = process.communicate(timeout=30.0)
    assert process.returncode == 2 and 'Traceback' not in stderr, stderr
    errors = [line for line in stderr.splitlines() if line.startswith('error:')]
    assert errors == [
        "error: publish_clock and lockstep need the node's own step loop, which rclpy's stock "
        'executor cannot serve (RIGID_BODY_ATTITUDE_STOCK_EXECUTOR=1); run without them on '
        'this path'], stderr
