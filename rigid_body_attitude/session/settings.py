"""The propagation node's defaults, topics and timing rules, importable without rclpy.

The node (:mod:`rigid_body_attitude.ros.node`) and the replay tool
(:mod:`rigid_body_attitude.tools.replay`) must agree on these, so a replayed bag gives the numbers
the node would have published; the replay tool cannot import the node (it needs no ROS install).
``test/tools/test_replay.py`` checks that the node's parameter defaults equal
:data:`NODE_DEFAULTS`.

Timing rules shared by both:

* the output timer period is :func:`timer_period_ns` of ``publish_rate`` (what
  ``rclpy.node.Node.create_timer(1 / publish_rate)`` uses); an rcl timer on a clock that
  starts at 0 (``use_sim_time`` before the first ``/clock``) fires at the multiples of the
  period, reading the clock when it runs;
* gyro and tick outcomes are published unless rejected, except that a ``gap`` or
  ``time_jump`` still publishes (the state moved to the new time): :func:`publishes`.
"""

from __future__ import annotations

from typing import Any

from rigid_body_attitude.core.scene import Scene, load_scene
from rigid_body_attitude.session.stream import Outcome

__all__ = [
    'COMMAND_EFFECTS',
    'DIAGNOSTICS_PERIOD',
    'DIAGNOSTICS_TOPIC',
    'GYRO_TOPICS',
    'MOVED_REASONS',
    'NODE_DEFAULTS',
    'NODE_NAME',
    'OUTPUT_TOPICS',
    'ROTOR_TORQUE_TOPIC',
    'SET_POSE_TOPIC',
    'TORQUE_TOPIC',
    'load_node_scene',
    'publishes',
    'timer_period_ns',
]

NODE_NAME = 'attitude_propagator'

#: Parameter name → default value of the node (types as declared: float, bool, str).
NODE_DEFAULTS: dict[str, Any] = {
    'scene': 'torque_free_box',
    'world_frame': 'world',
    'body_frame': 'base_link',
    'publish_rate': 50.0,
    'use_header_stamps': True,
    'constant_dt': 0.0,
    'max_dt': 0.1,
    'time_jump_threshold': 1.0,
    'torque_timeout': 0.0,
    'integrator': '',
    'step': 0.0,
    'cpu_scheduling': 'batch',
}

#: Gyro input topics (relative names) → message type.
GYRO_TOPICS = {'imu': 'sensor_msgs/msg/Imu',
               'angular_velocity': 'geometry_msgs/msg/Vector3Stamped'}
#: Commanded torque and force (``geometry_msgs/msg/WrenchStamped``).
TORQUE_TOPIC = 'torque'
#: Commanded motor torque on a rotor (``geometry_msgs/msg/Vector3Stamped``).
ROTOR_TORQUE_TOPIC = 'rotor_torque'
#: Re-initialisation of the attitude (and position) (``geometry_msgs/msg/PoseStamped``).
SET_POSE_TOPIC = 'set_pose'
#: Diagnostics (absolute name, as every ROS node publishes it).
DIAGNOSTICS_TOPIC = '/diagnostics'
#: Output topics (relative names) → message type. ``twist`` for dynamics scenes only,
#: ``imu/data`` for gyro scenes fed by ``sensor_msgs/msg/Imu`` only.
OUTPUT_TOPICS = {
    'orientation': 'geometry_msgs/msg/QuaternionStamped',
    'pose': 'geometry_msgs/msg/PoseStamped',
    'energy': 'std_msgs/msg/Float64',
    'angular_momentum': 'geometry_msgs/msg/Vector3Stamped',
    'twist': 'geometry_msgs/msg/TwistStamped',
    'imu/data': 'sensor_msgs/msg/Imu',
    DIAGNOSTICS_TOPIC: 'diagnostic_msgs/msg/DiagnosticArray',
}
#: Seconds between diagnostics messages.
DIAGNOSTICS_PERIOD = 1.0
#: Rejections after which the state still moved to the message's time (so it is published).
MOVED_REASONS = ('gap', 'time_jump')
#: Effects whose ``timeout`` the ``torque_timeout`` parameter overrides.
COMMAND_EFFECTS = ('commanded_torque', 'commanded_force', 'rotor')


def timer_period_ns(publish_rate: float) -> int:
    """Timer period [ns] of ``create_timer(1.0 / publish_rate)`` (rclpy truncates to ns)."""
    return int(float(1.0 / publish_rate) * 1e9)


def publishes(outcome: Outcome) -> bool:
    """Whether the node publishes after a gyro sample or clock tick with this outcome."""
    return not outcome.reason or outcome.reason in MOVED_REASONS


def load_node_scene(scene: str, integrator: str = '', step: float = 0.0,
                    torque_timeout: float = 0.0) -> Scene:
    """The scene as the node loads it: integrator, step and command timeout overridden.

    Empty or zero values keep the scene's own; raises the project's errors for a bad scene.
    """
    held = {'timeout': torque_timeout} if torque_timeout > 0.0 else {}
    return load_scene(scene).with_overrides(
        integrator=integrator, step=step,
        effect_parameters={name: held for name in COMMAND_EFFECTS} if held else None)
