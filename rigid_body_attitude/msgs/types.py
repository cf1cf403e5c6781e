"""The message types the package reads and writes: names and fixed layouts.

A fixed-layout message is an optional ``std_msgs/msg/Header`` followed by float64 fields only
(no sequence, no other string). :data:`FIXED_LAYOUTS` lists those fields in wire order, the
nested ones flattened (``orientation.x``, ``orientation_covariance[0]``, ...); the decoders and
encoders of :mod:`~rigid_body_attitude.msgs.decoders` and :mod:`~rigid_body_attitude.msgs.cdr`
take their field positions from it. The table is written here, not derived from a type store,
so the node reads messages without loading any bag library; ``test/msgs/test_types.py`` checks
it field for field against the ROS 2 Jazzy definitions of ``rosbags``' type store.
"""

from __future__ import annotations

from dataclasses import dataclass

__all__ = [
    'ACCEL_WITH_COVARIANCE_STAMPED',
    'CLOCK',
    'DIAGNOSTIC_ARRAY',
    'FIXED_LAYOUTS',
    'FLOAT64',
    'IMU',
    'MAGNETIC_FIELD',
    'MESSAGE_TYPES',
    'ODOMETRY',
    'ODOMETRY_BODY',
    'POSE_STAMPED',
    'POSE_WITH_COVARIANCE_STAMPED',
    'QUATERNION_STAMPED',
    'TRIGGER',
    'TWIST_STAMPED',
    'VECTOR3_STAMPED',
    'WRENCH_STAMPED',
    'Layout',
]

IMU = 'sensor_msgs/msg/Imu'
VECTOR3_STAMPED = 'geometry_msgs/msg/Vector3Stamped'
WRENCH_STAMPED = 'geometry_msgs/msg/WrenchStamped'
QUATERNION_STAMPED = 'geometry_msgs/msg/QuaternionStamped'
POSE_STAMPED = 'geometry_msgs/msg/PoseStamped'
POSE_WITH_COVARIANCE_STAMPED = 'geometry_msgs/msg/PoseWithCovarianceStamped'
TWIST_STAMPED = 'geometry_msgs/msg/TwistStamped'
FLOAT64 = 'std_msgs/msg/Float64'
MAGNETIC_FIELD = 'sensor_msgs/msg/MagneticField'
ACCEL_WITH_COVARIANCE_STAMPED = 'geometry_msgs/msg/AccelWithCovarianceStamped'
DIAGNOSTIC_ARRAY = 'diagnostic_msgs/msg/DiagnosticArray'
#: A header, ``child_frame_id`` (a second string), then float64 only (:data:`ODOMETRY_BODY`).
ODOMETRY = 'nav_msgs/msg/Odometry'
#: Types the node uses through rclpy only (no codec here).
CLOCK = 'rosgraph_msgs/msg/Clock'
TRIGGER = 'std_srvs/srv/Trigger'


@dataclass(frozen=True)
class Layout:
    """A fixed-layout message: a header (if ``stamped``), then float64 ``fields``."""

    stamped: bool
    fields: tuple[str, ...]

    @property
    def count(self) -> int:
        """Number of float64 values after the header."""
        return len(self.fields)

    def at(self, field: str) -> int:
        """Position of ``field`` among the float64 values."""
        return self.fields.index(field)


def _vector(name: str) -> tuple[str, ...]:
    return tuple(f'{name}.{axis}' for axis in 'xyz')


def _quaternion(name: str) -> tuple[str, ...]:
    return tuple(f'{name}.{axis}' for axis in 'xyzw')


def _covariance(name: str) -> tuple[str, ...]:
    return tuple(f'{name}_covariance[{index}]' for index in range(9))


#: The fixed-layout messages by type name.
FIXED_LAYOUTS: dict[str, Layout] = {
    IMU: Layout(True, _quaternion('orientation') + _covariance('orientation')
                + _vector('angular_velocity') + _covariance('angular_velocity')
                + _vector('linear_acceleration') + _covariance('linear_acceleration')),
    VECTOR3_STAMPED: Layout(True, _vector('vector')),
    WRENCH_STAMPED: Layout(True, _vector('wrench.force') + _vector('wrench.torque')),
    TWIST_STAMPED: Layout(True, _vector('twist.linear') + _vector('twist.angular')),
    QUATERNION_STAMPED: Layout(True, _quaternion('quaternion')),
    POSE_STAMPED: Layout(True, _vector('pose.position') + _quaternion('pose.orientation')),
    POSE_WITH_COVARIANCE_STAMPED: Layout(
        True, _vector('pose.pose.position') + _quaternion('pose.pose.orientation')
        + tuple(f'pose.covariance[{index}]' for index in range(36))),
    FLOAT64: Layout(False, ('data',)),
    MAGNETIC_FIELD: Layout(True, _vector('magnetic_field') + _covariance('magnetic_field')),
    ACCEL_WITH_COVARIANCE_STAMPED: Layout(
        True, _vector('accel.accel.linear') + _vector('accel.accel.angular')
        + tuple(f'accel.covariance[{index}]' for index in range(36))),
}

#: The float64 fields of ``nav_msgs/msg/Odometry`` after its header and ``child_frame_id``
#: (``stamped`` false: the header comes before the string; :mod:`~.odometry` reads both).
ODOMETRY_BODY = Layout(
    False, _vector('pose.pose.position') + _quaternion('pose.pose.orientation')
    + tuple(f'pose.covariance[{index}]' for index in range(36))
    + _vector('twist.twist.linear') + _vector('twist.twist.angular')
    + tuple(f'twist.covariance[{index}]' for index in range(36)))

#: Every message type the package reads or writes (DiagnosticArray: variable layout;
#: Odometry: two strings, then :data:`ODOMETRY_BODY`).
MESSAGE_TYPES: tuple[str, ...] = (*FIXED_LAYOUTS, ODOMETRY, DIAGNOSTIC_ARRAY)
