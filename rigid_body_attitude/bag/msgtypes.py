"""Message type names, the ROS 2 Jazzy type store, and generic (slow-path) serialisation.

The fixed-layout messages the package reads and writes per sample have hand-written codecs in
:mod:`rigid_body_attitude.bag.cdr`; everything else (``diagnostic_msgs/msg/DiagnosticArray``,
or any message a user wants to inspect in full) goes through the ``rosbags`` type store here.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from functools import lru_cache
from types import MappingProxyType
from typing import Any, NamedTuple

from rosbags.serde import SerdeError
from rosbags.typesys import Stores, get_typestore

from rigid_body_attitude.bag.errors import BagError
from rigid_body_attitude.bag.rosbags_internals import Typestore
from rigid_body_attitude.core.errors import InputError

__all__ = [
    'DIAGNOSTIC_ARRAY',
    'FLOAT64',
    'IMU',
    'POSE_STAMPED',
    'QUATERNION_STAMPED',
    'TWIST_STAMPED',
    'VECTOR3_STAMPED',
    'WRENCH_STAMPED',
    'DiagnosticStatus',
    'deserialize',
    'encode_diagnostic_array',
    'serialize',
    'typestore',
]

IMU = 'sensor_msgs/msg/Imu'
VECTOR3_STAMPED = 'geometry_msgs/msg/Vector3Stamped'
WRENCH_STAMPED = 'geometry_msgs/msg/WrenchStamped'
QUATERNION_STAMPED = 'geometry_msgs/msg/QuaternionStamped'
POSE_STAMPED = 'geometry_msgs/msg/PoseStamped'
TWIST_STAMPED = 'geometry_msgs/msg/TwistStamped'
FLOAT64 = 'std_msgs/msg/Float64'
DIAGNOSTIC_ARRAY = 'diagnostic_msgs/msg/DiagnosticArray'

_NS_PER_S = 1_000_000_000


@lru_cache(maxsize=1)
def typestore() -> Typestore:
    """The ``rosbags`` type store of ROS 2 Jazzy (built once, shared)."""
    return get_typestore(Stores.ROS2_JAZZY)


def _check_msgtype(msgtype: str) -> None:
    if msgtype not in typestore().fielddefs:
        raise BagError(f'Expected a ROS 2 Jazzy message type such as {IMU!r}, '
                       f'got {msgtype!r}')


def serialize(message: object, msgtype: str) -> bytes:
    """CDR bytes (little-endian) of a ``rosbags`` message object of type ``msgtype``."""
    _check_msgtype(msgtype)
    try:
        return bytes(typestore().serialize_cdr(message, msgtype))
    except (SerdeError, AttributeError, TypeError, ValueError, AssertionError) as err:
        raise BagError(f'Expected a {msgtype} message object, got {message!r}: {err}') from err


def deserialize(data: bytes | memoryview, msgtype: str) -> Any:
    """The ``rosbags`` message object of CDR bytes ``data`` of type ``msgtype``."""
    _check_msgtype(msgtype)
    try:
        return typestore().deserialize_cdr(data, msgtype)
    except SerdeError as err:
        raise BagError(f'Expected a CDR-encoded {msgtype} message, got {len(data)} bytes: '
                       f'{err}') from err


class DiagnosticStatus(NamedTuple):
    """One ``diagnostic_msgs/msg/DiagnosticStatus``: level 0 OK, 1 WARN, 2 ERROR, 3 STALE."""

    level: int
    name: str
    message: str
    hardware_id: str = ''
    values: Mapping[str, str] = MappingProxyType({})


def encode_diagnostic_array(stamp_ns: int, frame_id: str,
                            statuses: Sequence[DiagnosticStatus]) -> bytes:
    """CDR bytes of a ``diagnostic_msgs/msg/DiagnosticArray`` (variable layout: rosbags path).

    ``values`` mappings become ``KeyValue`` pairs in their iteration order.
    """
    types = typestore().types
    if not isinstance(stamp_ns, int) or not -2 ** 31 <= stamp_ns // _NS_PER_S < 2 ** 31:
        raise InputError(f'Expected `stamp_ns` to be an integer with seconds in int32 range, '
                         f'got {stamp_ns!r}')
    sec, nanosec = divmod(stamp_ns, _NS_PER_S)
    status_messages = []
    for status in statuses:
        if status.level not in (0, 1, 2, 3):
            raise InputError(f'Expected `level` to be 0 (OK), 1 (WARN), 2 (ERROR) or 3 (STALE), '
                             f'got {status.level!r}')
        values = [types['diagnostic_msgs/msg/KeyValue'](key=str(key), value=str(value))
                  for key, value in status.values.items()]
        status_messages.append(types['diagnostic_msgs/msg/DiagnosticStatus'](
            level=status.level, name=status.name, message=status.message,
            hardware_id=status.hardware_id, values=values))
    header = types['std_msgs/msg/Header'](
        stamp=types['builtin_interfaces/msg/Time'](sec=sec, nanosec=nanosec), frame_id=frame_id)
    return serialize(types[DIAGNOSTIC_ARRAY](header=header, status=status_messages),
                     DIAGNOSTIC_ARRAY)
