"""The wheel loop over ROS: ``attitude_controller`` drives the scene's reaction wheels.

The installed ``propagation_node`` (``lockstep``, ``real_time_factor`` 0, 20 Hz ticks: one
per step) runs the shipped ``wheel_slew_commanded`` scene (four pyramid wheels on
``wheels/command``, commanded torque rods on ``dipole``), and the installed
``attitude_controller`` (``actuator`` ``reaction_wheels``, the same scene) answers each tick
with the wheels' motor torques and a zero dipole: two processes. The run is compared bit for
bit with a second run, and with the core: the same spacecraft with the ``attitude_pd`` effect
(``actuator: reaction_wheels``, the same law, gains, limit and period) and idle rods, in the
single-body propagator and the batch engine (one measured run over 60 s: 2.2e-16 rad against
the propagator, 4.5e-16 rad against the batch engine, wheel speeds within 2.8e-14 rad/s; the
test prints them; the bounds: 1e-9 rad and 1e-9 rad/s).
"""

from __future__ import annotations

import dataclasses
import math

from controller_process import assert_every_tick_answered, start_controller, stop_controller
from geometry_msgs.msg import QuaternionStamped
import numpy as np
from ros_helpers import Harness, unique_namespace
from sensor_msgs.msg import JointState
from test_node_subprocess import read_until, SERVING, start, stop_with_sigint

from rigid_body_attitude.core.attitude.quaternion import attitude_error as angle
from rigid_body_attitude.core.dynamics.batch import SceneBatch
from rigid_body_attitude.core.dynamics.scene import load_scene
from rigid_body_attitude.core.dynamics.effects.reaction_wheels import ReactionWheels
from rigid_body_attitude.core.propagator import DynamicsPropagator

TICK_NS = 50_000_000  # 20 Hz, the scene's step
TICKS = 1201  # 0 .. 60 s
GAINS = {'kp': 0.4, 'kd': 4.0, 'torque_limit': 0.03, 'control_period': 0.1}
TARGET_RPY = [0.0, 0.0, 0.6981317]  # 40 deg of yaw


def stamp_ns(message) -> int:
    return message.header.stamp.sec * 10**9 + message.header.stamp.nanosec


def ros_loop(ros, namespace: str) -> tuple[dict[int, np.ndarray], dict[int, tuple]]:
    """Tick stamp [ns] → the attitude (w, x, y, z) and the wheels' speeds published."""
    harness = Harness(ros, namespace)
    orientation = harness.record(QuaternionStamped, 'orientation')
    wheels = harness.record(JointState, 'wheels/state')
    node = start('--ros-args', '-r', f'__ns:={namespace}', '-p', 'scene:=wheel_slew_commanded',
                 '-p', 'lockstep:=true', '-p', 'publish_rate:=20.0',
                 '-p', 'real_time_factor:=0.0', '-p', 'lockstep_timeout:=60.0')
    controller = None
    try:
        read_until(node, SERVING)
        harness.wait_for_connections()
        controller = start_controller(namespace, {
            'actuator': 'reaction_wheels', 'scene': 'wheel_slew_commanded',
            'target_rpy': TARGET_RPY, **GAINS})
        last = (TICKS - 1) * TICK_NS
        assert harness.spin_until(lambda: bool(wheels) and bool(orientation) and max(
            stamp_ns(m) for m in orientation[-5:]) >= last and max(
            stamp_ns(m) for m in wheels[-5:]) >= last, timeout=300.0), (
            f'{len(orientation)} ticks recorded')
    finally:
        code, stderr = stop_with_sigint(node)
        stop_controller(controller)
    assert_every_tick_answered(code, stderr)
    attitudes: dict[int, np.ndarray] = {}
    for message in orientation:
        q = message.quaternion
        attitudes.setdefault(stamp_ns(message), np.array([q.w, q.x, q.y, q.z]))
    speeds: dict[int, tuple] = {}
    for message in wheels:
        assert tuple(message.name) == ('wheel_a', 'wheel_b', 'wheel_c', 'wheel_d')
        speeds.setdefault(stamp_ns(message), tuple(message.velocity))
    assert all(k * TICK_NS in attitudes and k * TICK_NS in speeds for k in range(TICKS))
    return attitudes, speeds


def in_scene():
    """The same spacecraft with the PD law inside the scene, rods idle."""
    scene = load_scene('wheel_slew_commanded')
    effects = tuple((name, {**params, 'commanded': False}) if name in (
        'reaction_wheels', 'magnetorquers') else (name, params)
        for name, params in scene.effects) + (
        ('attitude_pd', {**GAINS, 'target_rpy': TARGET_RPY, 'actuator': 'reaction_wheels'}),)
    return dataclasses.replace(scene, effects=effects)


def test_the_wheel_loop_is_reproducible_and_is_the_in_scene_loop(ros, request, capsys):
    first, first_speeds = ros_loop(ros, unique_namespace(request))
    second, second_speeds = ros_loop(ros, unique_namespace(request) + '_again')
    assert all(np.array_equal(first[k], second[k]) for k in first)
    assert first_speeds == second_speeds
    scene = in_scene()
    single = DynamicsPropagator(scene)
    batch = SceneBatch(scene, np.array([scene.initial_attitude]),
                       np.array([scene.initial_omega_body]))
    wheels = next(e for e in single.effects if isinstance(e, ReactionWheels))
    single_worst = batch_worst = speed_worst = 0.0
    for k in range(TICKS):
        t = k * TICK_NS * 1e-9
        if k:
            single.advance_to(t)
            batch.advance_to(t)
        reference = first[k * TICK_NS]
        single_worst = max(single_worst, angle(reference, np.asarray(single.state.attitude)))
        batch_worst = max(batch_worst, angle(reference, batch.attitude[0]))
        speed_worst = max(speed_worst, max(abs(a - b) for a, b in zip(
            first_speeds[k * TICK_NS], wheels.speeds())))
    with capsys.disabled():
        print(f'\nwheel loop over ROS vs in-scene PD over 60 s: propagator {single_worst:.3g} '
              f'rad, batch {batch_worst:.3g} rad, wheel speeds {speed_worst:.3g} rad/s')
    assert single_worst <= 1e-9 and batch_worst <= 1e-9 and speed_worst <= 1e-9
    # the loop did slew: from 40 deg to within 2 deg of the target in 60 s
    final = first[(TICKS - 1) * TICK_NS]
    target = np.array([math.cos(0.6981317 / 2), 0.0, 0.0, math.sin(0.6981317 / 2)])
    assert angle(first[0], target) > math.radians(39.0)
    assert angle(final, target) < math.radians(2.0)
