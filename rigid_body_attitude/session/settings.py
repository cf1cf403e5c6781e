"""What the node and the replay tool share besides the sessions: topics, timing, the scene.

* Topics, one table per scene kind: :func:`input_topics` and :func:`output_topics` (relative
  names, message types), so the node subscribes and publishes, and the replay tool reads and
  writes, the same set.
* The output timer period :func:`timer_period_ns` of ``publish_rate`` (what
  ``rclpy.node.Node.create_timer(1 / publish_rate)`` uses); an rcl timer on a clock that
  starts at 0 (``use_sim_time`` before the first ``/clock``) fires at the multiples of the
  period, reading the clock when it runs.
* :func:`load_node_scene`: the scene with the ``integrator``, ``step`` and ``torque_timeout``
  overrides; :func:`open_session`: the session of a scene's rate source.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import Any

from rigid_body_attitude.core.dynamics.scene import Scene, load_scene
from rigid_body_attitude.msgs.types import (
    DIAGNOSTIC_ARRAY, FLOAT64, IMU, POSE_STAMPED, POSE_WITH_COVARIANCE_STAMPED,
    QUATERNION_STAMPED, TWIST_STAMPED, VECTOR3_STAMPED, WRENCH_STAMPED)
from rigid_body_attitude.session.base import OutputSink
from rigid_body_attitude.session.dynamics import DynamicsSession
from rigid_body_attitude.session.gyro import GyroSession

__all__ = [
    'AnySession', 'COMMAND_EFFECTS', 'DIAGNOSTICS_PERIOD', 'DIAGNOSTICS_TOPIC', 'GYRO_TOPICS',
    'NODE_NAME', 'OUTPUT_TOPICS', 'ROTOR_TORQUE_TOPIC', 'SET_POSE_TOPIC',
    'SET_POSE_WITH_COVARIANCE_TOPIC', 'TORQUE_TOPIC',
    'input_topics',
    'load_node_scene', 'open_session', 'output_topics', 'timer_period_ns',
]

NODE_NAME = 'attitude_propagator'

#: Gyro input topics (relative names) → message type.
GYRO_TOPICS = {'imu': IMU, 'angular_velocity': VECTOR3_STAMPED}
#: Commanded torque and force (``geometry_msgs/msg/WrenchStamped``).
TORQUE_TOPIC = 'torque'
#: Commanded motor torque on a rotor (``geometry_msgs/msg/Vector3Stamped``).
ROTOR_TORQUE_TOPIC = 'rotor_torque'
#: Re-initialisation of the attitude (and position) (``geometry_msgs/msg/PoseStamped``).
SET_POSE_TOPIC = 'set_pose'
#: The same with the attitude's covariance (``geometry_msgs/msg/PoseWithCovarianceStamped``).
SET_POSE_WITH_COVARIANCE_TOPIC = 'set_pose_with_covariance'
#: Diagnostics (absolute name, as every ROS node publishes it).
DIAGNOSTICS_TOPIC = '/diagnostics'
#: Output topics (relative names) → message type.
OUTPUT_TOPICS = {
    'orientation': QUATERNION_STAMPED,
    'pose': POSE_STAMPED,
    'pose_with_covariance': POSE_WITH_COVARIANCE_STAMPED,
    'energy': FLOAT64,
    'angular_momentum': VECTOR3_STAMPED,
    'twist': TWIST_STAMPED,
    'imu/data': IMU,
    DIAGNOSTICS_TOPIC: DIAGNOSTIC_ARRAY,
}
#: Seconds between diagnostics messages.
DIAGNOSTICS_PERIOD = 1.0
#: Effects whose ``timeout`` the ``torque_timeout`` parameter overrides.
COMMAND_EFFECTS = ('commanded_torque', 'commanded_force', 'rotor')

#: A session of either rate source (what :func:`open_session` returns).
AnySession = GyroSession | DynamicsSession


def input_topics(scene: Scene, input_names: frozenset[str]) -> dict[str, str]:
    """Input topic → message type for a scene whose propagator takes ``input_names``."""
    topics: dict[str, str] = {}
    if scene.rate_source == 'gyro':
        topics.update(GYRO_TOPICS)
    if input_names & {'torque', 'force'}:
        topics[TORQUE_TOPIC] = WRENCH_STAMPED
    if 'rotor_torque' in input_names:
        topics[ROTOR_TORQUE_TOPIC] = VECTOR3_STAMPED
    topics[SET_POSE_TOPIC] = POSE_STAMPED
    topics[SET_POSE_WITH_COVARIANCE_TOPIC] = POSE_WITH_COVARIANCE_STAMPED
    return topics


def output_topics(scene: Scene, imu_input: bool = True,
                  covariance: bool = True) -> tuple[str, ...]:
    """Output topics of a scene, in the order they are listed; ``imu/data`` for gyro scenes
    fed by ``sensor_msgs/Imu`` (``imu_input``), ``pose_with_covariance`` for gyro scenes with
    the ``covariance`` on; ``twist``, ``energy`` and ``angular_momentum`` for dynamics scenes
    (the only ones that simulate a body)."""
    if scene.rate_source == 'gyro':
        pose = ('pose', 'pose_with_covariance') if covariance else ('pose',)
        return ('orientation', *pose, *(('imu/data',) if imu_input else ()),
                DIAGNOSTICS_TOPIC)
    return ('orientation', 'pose', 'twist', 'energy', 'angular_momentum', DIAGNOSTICS_TOPIC)


def timer_period_ns(publish_rate: float) -> int:
    """Timer period [ns] of ``create_timer(1.0 / publish_rate)`` (rclpy truncates to ns)."""
    return int(float(1.0 / publish_rate) * 1e9)


def load_node_scene(scene: str, integrator: str = '', step: float = 0.0,
                    torque_timeout: float = 0.0) -> Scene:
    """The scene as the node loads it: integrator, step and command timeout overridden.

    Empty or zero values keep the scene's own; raises the project's errors for a bad scene.
    """
    held = {'timeout': torque_timeout} if torque_timeout > 0.0 else {}
    return load_scene(scene).with_overrides(
        integrator=integrator, step=step,
        effect_parameters={name: held for name in COMMAND_EFFECTS} if held else None)


def open_session(scene: Scene, values: Mapping[str, Any], sink: OutputSink,
                 clock_ns: Callable[[], int], monotonic: Callable[[], float]) -> AnySession:
    """The session of the scene's rate source (see :class:`~.base.Session`)."""
    kind = GyroSession if scene.rate_source == 'gyro' else DynamicsSession
    return kind(scene, values, sink, clock_ns, monotonic)
