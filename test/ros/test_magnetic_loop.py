"""Torque rods in the loop over ROS: ``attitude_controller`` on the measured field.

The installed ``propagation_node`` (``lockstep``, ``real_time_factor`` 0) and the installed
``attitude_controller``, two processes:

* **B-dot**: the shipped ``bdot_detumbling_commanded`` CubeSat (10 deg/s, commanded rods, a
  10 Hz magnetometer mounted yawed 90 degrees, its mount on ``/tf_static``), the controller
  with ``actuator`` ``magnetorquers`` (k = 4e5 A m² s/T, 1 s control period), 1 Hz ticks: the
  whole detumbling, every tick bit for bit the loop of the same two sessions in one process
  (``magnetic_loop.spacecraft_loop``), which reaches 0.5 deg/s at 3 137 s (the in-scene
  ``bdot`` effect: 3 138 s; ``test/session/test_spacecraft_loop.py``).
* **Dumping**: ``wheel_slew_commanded`` with ``actuator`` ``reaction_wheels`` and a
  ``dumping_gain`` (the controller reads ``wheels/state`` and ``imu/mag``), 20 Hz ticks over
  60 s: bit for bit the loop in one process.
"""

from __future__ import annotations


from controller_process import assert_every_tick_answered, start_controller, stop_controller
from geometry_msgs.msg import QuaternionStamped, TwistStamped
from ros_helpers import Harness, unique_namespace
from test_node_subprocess import read_until, SERVING, start, stop_with_sigint

from magnetic_loop import rate_deg_s, spacecraft_loop, Tick

BDOT = {'actuator': 'magnetorquers', 'bdot_gain': 4e5, 'control_period': 1.0}
DUMPING = {'actuator': 'reaction_wheels', 'dumping_gain': 0.001, 'kp': 0.4, 'kd': 4.0,
           'torque_limit': 0.03, 'control_period': 0.1, 'target_rpy': [0.0, 0.0, 0.6981317]}


def stamp_ns(message) -> int:
    return message.header.stamp.sec * 10**9 + message.header.stamp.nanosec


def ros_loop(ros, namespace: str, scene: str, controller_values: dict, publish_rate: float,
             seconds: float) -> dict[int, Tick]:
    """The node's ticks (stamp → attitude and rate) over ``seconds`` of sim time."""
    harness = Harness(ros, namespace)
    orientation = harness.record(QuaternionStamped, 'orientation')
    twist = harness.record(TwistStamped, 'twist')
    node = start('--ros-args', '-r', f'__ns:={namespace}', '-p', f'scene:={scene}',
                 '-p', 'lockstep:=true', '-p', f'publish_rate:={publish_rate}',
                 '-p', 'real_time_factor:=0.0', '-p', 'lockstep_timeout:=60.0')
    controller = None
    last = round(seconds * 1e9)
    try:
        read_until(node, SERVING)
        harness.wait_for_connections()
        controller = start_controller(namespace, {'scene': scene, **controller_values})
        assert harness.spin_until(lambda: len(twist) > 5 and len(orientation) > 5 and min(
            max(stamp_ns(m) for m in twist[-5:]),
            max(stamp_ns(m) for m in orientation[-5:])) >= last, timeout=600.0), (
            f'{len(twist)} ticks recorded')
    finally:
        code, stderr = stop_with_sigint(node)
        stop_controller(controller)
    assert_every_tick_answered(code, stderr)
    attitudes = {}
    for message in orientation:
        q = message.quaternion
        attitudes.setdefault(stamp_ns(message), (q.w, q.x, q.y, q.z))
    ticks = {}
    for message in twist:
        w = message.twist.angular
        ticks.setdefault(stamp_ns(message), Tick(stamp_ns(message), attitudes[stamp_ns(message)],
                                                 (w.x, w.y, w.z)))
    return ticks


def assert_same_ticks(over_ros: dict[int, Tick], in_process: list[Tick]) -> None:
    """Every tick of the in-process loop published over ROS with the same bits."""
    assert in_process and all(tick.stamp_ns in over_ros for tick in in_process)
    for tick in in_process:
        assert over_ros[tick.stamp_ns] == tick, tick.stamp_ns


def test_bdot_over_ros_is_the_in_process_loop_down_to_half_a_degree_per_second(ros, request,
                                                                               capsys):
    in_process = spacecraft_loop('bdot_detumbling_commanded', BDOT, 1.0, 3140.0)
    reached = next(tick.stamp_ns for tick in in_process if rate_deg_s(tick) < 0.5)
    assert reached == 3137 * 10**9
    over_ros = ros_loop(ros, unique_namespace(request), 'bdot_detumbling_commanded', BDOT,
                        1.0, 3140.0)
    assert_same_ticks(over_ros, in_process)
    assert abs(rate_deg_s(over_ros[0]) - 10.0) < 0.01
    with capsys.disabled():
        print(f'\nB-dot over ROS: 10 -> 0.5 deg/s in {reached * 1e-9:.0f} s, '
              f'{len(in_process)} ticks bit for bit the in-process loop')


def test_dumping_over_ros_is_the_in_process_loop(ros, request):
    in_process = spacecraft_loop('wheel_slew_commanded', DUMPING, 20.0, 60.0)
    over_ros = ros_loop(ros, unique_namespace(request), 'wheel_slew_commanded', DUMPING, 20.0,
                        60.0)
    assert_same_ticks(over_ros, in_process)
