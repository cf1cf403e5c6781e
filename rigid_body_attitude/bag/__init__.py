"""rosbag2 input/output (through the pure-Python ``rosbags`` library; no ROS install needed).

* :mod:`~rigid_body_attitude.bag.reader`: :class:`BagReader`, :func:`read_messages` (raw CDR
  tuples in bag-time order) and :func:`read_series` (a topic as arrays); indexed MCAP files
  are walked by :mod:`~rigid_body_attitude.bag.mcap`.
* :mod:`~rigid_body_attitude.bag.decoders`: checked decoders of the fixed-layout messages
  (Imu, Vector3Stamped, WrenchStamped, TwistStamped, QuaternionStamped, PoseStamped, Float64)
  to plain values, raising :class:`MalformedMessage` for any bytes that are not one.
* :mod:`~rigid_body_attitude.bag.cdr`: fast ``struct`` encoders of those messages and the
  float-stamp decoders of bag readers.
* :mod:`~rigid_body_attitude.bag.writer`: :class:`BagWriter` for output bags (one record or
  a batch of :data:`Record` per call) and :func:`write_bag` for arrays of samples.
* :mod:`~rigid_body_attitude.bag.msgtypes`: message type names, the Jazzy type store and the
  generic (slow) serialisation, including ``DiagnosticArray``.

Quaternions cross this API scalar-first ``(w, x, y, z)`` as everywhere in the package
(:mod:`rigid_body_attitude.core.quaternion`); only the CDR bytes hold ``(x, y, z, w)``. Decoders
return header stamps as float seconds (resolution 2.4·10⁻⁷ s at epoch times);
:func:`header_stamp_ns` gives the exact integer nanoseconds.
"""

from rigid_body_attitude.bag.cdr import (
    ATTITUDE_DECODERS,
    RATE_DECODERS,
    TORQUE_DECODERS,
    Decoder,
    encode_float64,
    encode_imu,
    encode_pose_stamped,
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
    quaternion_stamped,
    quaternion_stamped_encoder,
    stamp_to_ns,
    twist_angular,
    twist_linear,
    vector3_stamped,
    wrench_force,
    wrench_torque,
)
from rigid_body_attitude.bag.decoders import (
    ENCAPSULATIONS,
    GYRO_DECODERS,
    GyroDecoder,
    decode_float64,
    decode_header,
    decode_imu,
    decode_imu_rate,
    decode_pose_stamped,
    decode_quaternion_stamped,
    decode_twist_angular,
    decode_twist_stamped,
    decode_vector3_stamped,
    decode_wrench_stamped,
)
from rigid_body_attitude.bag.errors import BagError, MalformedMessage
from rigid_body_attitude.bag.msgtypes import (
    DIAGNOSTIC_ARRAY,
    FLOAT64,
    IMU,
    POSE_STAMPED,
    QUATERNION_STAMPED,
    TWIST_STAMPED,
    VECTOR3_STAMPED,
    WRENCH_STAMPED,
    DiagnosticStatus,
    deserialize,
    encode_diagnostic_array,
    serialize,
    typestore,
)
from rigid_body_attitude.bag.reader import (
    SERIES_DECODERS,
    BagMessage,
    BagReader,
    Series,
    read_messages,
    read_series,
)
from rigid_body_attitude.bag.writer import (
    GROUND_TRUTH_TYPES,
    STORAGES,
    BagWriter,
    Record,
    write_bag,
)

__all__ = [
    'ATTITUDE_DECODERS',
    'DIAGNOSTIC_ARRAY',
    'ENCAPSULATIONS',
    'FLOAT64',
    'GROUND_TRUTH_TYPES',
    'GYRO_DECODERS',
    'IMU',
    'POSE_STAMPED',
    'QUATERNION_STAMPED',
    'RATE_DECODERS',
    'SERIES_DECODERS',
    'STORAGES',
    'TORQUE_DECODERS',
    'TWIST_STAMPED',
    'VECTOR3_STAMPED',
    'WRENCH_STAMPED',
    'BagError',
    'BagMessage',
    'BagReader',
    'BagWriter',
    'Decoder',
    'DiagnosticStatus',
    'GyroDecoder',
    'MalformedMessage',
    'Record',
    'Series',
    'decode_float64',
    'decode_header',
    'decode_imu',
    'decode_imu_rate',
    'decode_pose_stamped',
    'decode_quaternion_stamped',
    'decode_twist_angular',
    'decode_twist_stamped',
    'decode_vector3_stamped',
    'decode_wrench_stamped',
    'deserialize',
    'encode_diagnostic_array',
    'encode_float64',
    'encode_imu',
    'encode_pose_stamped',
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
    'pose_orientation',
    'pose_position',
    'pose_stamped_encoder',
    'quaternion_stamped',
    'quaternion_stamped_encoder',
    'read_messages',
    'read_series',
    'serialize',
    'stamp_to_ns',
    'twist_angular',
    'twist_linear',
    'typestore',
    'vector3_stamped',
    'wrench_force',
    'wrench_torque',
    'write_bag',
]
