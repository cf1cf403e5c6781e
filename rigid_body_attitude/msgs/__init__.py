"""ROS 2 messages as bytes: the CDR codecs of the messages the node and the tools exchange.

Pure Python (``struct``), no ROS and no bag library: the running node decodes and encodes its
messages with these, as the replay tool does with a bag's records.

* :mod:`~rigid_body_attitude.msgs.types`: the message type names and the table of fixed
  layouts (a header, then float64 fields) the codecs are built from.
* :mod:`~rigid_body_attitude.msgs.decoders`: checked decoders of the fixed-layout messages
  (Imu, Vector3Stamped, WrenchStamped, TwistStamped, QuaternionStamped, PoseStamped,
  PoseWithCovarianceStamped, MagneticField, Float64)
  to plain values, raising :class:`MalformedMessage` for any bytes that are not one.
* :mod:`~rigid_body_attitude.msgs.odometry`: ``nav_msgs/msg/Odometry``, the encoder of the
  node's ``odom`` and the checked decoder of the controller's.
* :mod:`~rigid_body_attitude.msgs.tf_message`: the checked decoder of ``tf2_msgs/TFMessage``
  (the static transforms of a bag's ``/tf_static``).
* :mod:`~rigid_body_attitude.msgs.cdr`: fast ``struct`` encoders of those messages and the
  float-stamp decoders of bag readers.
* :mod:`~rigid_body_attitude.msgs.sensor_encoders`: the encoders of the simulated sensors'
  messages (Imu, MagneticField, PoseWithCovarianceStamped) and of their mounts (TFMessage).
* :mod:`~rigid_body_attitude.msgs.diagnostics`: the ``DiagnosticArray`` encoder.

Quaternions cross this API scalar-first ``(w, x, y, z)`` as everywhere in the package
(:mod:`rigid_body_attitude.core.attitude.quaternion`); only the CDR bytes hold ``(x, y, z, w)``.
Decoders
return header stamps as float seconds (resolution 2.4·10⁻⁷ s at epoch times) or as the integer
``(sec, nanosec)`` of the header; :func:`header_stamp_ns` gives the exact integer nanoseconds.
"""

from rigid_body_attitude.msgs.cdr import (
    ATTITUDE_DECODERS,
    TORQUE_DECODERS,
    Decoder,
    encode_float64,
    encode_imu,
    encode_pose_stamped,
    encode_pose_with_covariance_stamped,
    encode_quaternion_stamped,
    encode_twist_stamped,
    encode_vector3_stamped,
    encode_wrench_stamped,
    float64_value,
    header_frame_id,
    header_stamp_ns,
    imu_acceleration,
    imu_rates,
    imu_with_orientation,
    pose_orientation,
    pose_position,
    pose_stamped_encoder,
    pose_with_covariance_stamped_encoder,
    quaternion_stamped,
    quaternion_stamped_encoder,
    stamp_to_ns,
    stamped_floats_encoder,
    twist_angular,
    twist_linear,
    vector3_stamped,
    wrench_force,
    wrench_torque,
)
from rigid_body_attitude.msgs.decoders import (
    ENCAPSULATIONS,
    RATE_DECODERS,
    RateDecoder,
    RateSample,
    decode_float64,
    decode_header,
    decode_imu,
    decode_imu_motion,
    decode_imu_rate,
    decode_pose_stamped,
    decode_pose_with_covariance_stamped,
    decode_quaternion_stamped,
    decode_twist_angular,
    decode_twist_stamped,
    decode_vector3_stamped,
    decode_wrench_stamped,
)
from rigid_body_attitude.msgs.odometry import (
    Odometry, decode_odometry, encode_odometry, odometry_encoder)
from rigid_body_attitude.msgs.tf_message import TF_MESSAGE, Transform, decode_tf_message
from rigid_body_attitude.msgs.diagnostics import DiagnosticStatus, encode_diagnostic_array
from rigid_body_attitude.msgs.errors import MalformedMessage
from rigid_body_attitude.msgs.types import (
    DIAGNOSTIC_ARRAY,
    FIXED_LAYOUTS,
    FLOAT64,
    IMU,
    MAGNETIC_FIELD,
    MESSAGE_TYPES,
    ODOMETRY,
    ODOMETRY_BODY,
    POSE_STAMPED,
    POSE_WITH_COVARIANCE_STAMPED,
    QUATERNION_STAMPED,
    TWIST_STAMPED,
    VECTOR3_STAMPED,
    WRENCH_STAMPED,
    Layout,
)

__all__ = [
    'ATTITUDE_DECODERS',
    'DIAGNOSTIC_ARRAY',
    'ENCAPSULATIONS',
    'FIXED_LAYOUTS',
    'FLOAT64',
    'IMU',
    'MAGNETIC_FIELD',
    'MESSAGE_TYPES',
    'ODOMETRY',
    'ODOMETRY_BODY',
    'Odometry',
    'POSE_STAMPED',
    'POSE_WITH_COVARIANCE_STAMPED',
    'QUATERNION_STAMPED',
    'RATE_DECODERS',
    'TF_MESSAGE',
    'TORQUE_DECODERS',
    'TWIST_STAMPED',
    'VECTOR3_STAMPED',
    'WRENCH_STAMPED',
    'Decoder',
    'DiagnosticStatus',
    'RateDecoder',
    'RateSample',
    'Layout',
    'MalformedMessage',
    'Transform',
    'decode_float64',
    'decode_header',
    'decode_imu',
    'decode_imu_motion',
    'decode_imu_rate',
    'decode_odometry',
    'decode_pose_stamped',
    'decode_pose_with_covariance_stamped',
    'decode_quaternion_stamped',
    'decode_twist_angular',
    'decode_tf_message',
    'decode_twist_stamped',
    'decode_vector3_stamped',
    'decode_wrench_stamped',
    'encode_diagnostic_array',
    'encode_float64',
    'encode_imu',
    'encode_odometry',
    'encode_pose_stamped',
    'encode_pose_with_covariance_stamped',
    'encode_quaternion_stamped',
    'encode_twist_stamped',
    'encode_vector3_stamped',
    'encode_wrench_stamped',
    'float64_value',
    'header_frame_id',
    'header_stamp_ns',
    'imu_acceleration',
    'imu_rates',
    'imu_with_orientation',
    'odometry_encoder',
    'pose_orientation',
    'pose_position',
    'pose_stamped_encoder',
    'pose_with_covariance_stamped_encoder',
    'quaternion_stamped',
    'quaternion_stamped_encoder',
    'stamp_to_ns',
    'stamped_floats_encoder',
    'twist_angular',
    'twist_linear',
    'vector3_stamped',
    'wrench_force',
    'wrench_torque',
]
