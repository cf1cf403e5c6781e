"""The ROS 2 Jazzy type store and generic (slow-path) serialisation through ``rosbags``.

The messages the package reads and writes per sample have hand-written codecs in
:mod:`rigid_body_attitude.msgs`; any other message (one a user wants to inspect in full, or
the bag writer's connection metadata) goes through the ``rosbags`` type store here.
"""

from __future__ import annotations

from functools import lru_cache
from typing import Any

from rosbags.serde import SerdeError
from rosbags.typesys import Stores, get_typestore

from rigid_body_attitude.bag.errors import BagError
from rigid_body_attitude.bag.rosbags_internals import Typestore
from rigid_body_attitude.msgs.types import IMU

__all__ = ['check_msgtype', 'deserialize', 'serialize', 'typestore']


@lru_cache(maxsize=1)
def typestore() -> Typestore:
    """The ``rosbags`` type store of ROS 2 Jazzy (built once, shared)."""
    return get_typestore(Stores.ROS2_JAZZY)


def check_msgtype(msgtype: str) -> None:
    """Raise :class:`BagError` unless ``msgtype`` is a ROS 2 Jazzy message type."""
    if msgtype not in typestore().fielddefs:
        raise BagError(f'Expected a ROS 2 Jazzy message type such as {IMU!r}, '
                       f'got {msgtype!r}')


def serialize(message: object, msgtype: str) -> bytes:
    """CDR bytes (little-endian) of a ``rosbags`` message object of type ``msgtype``."""
    check_msgtype(msgtype)
    try:
        return bytes(typestore().serialize_cdr(message, msgtype))
    except (SerdeError, AttributeError, TypeError, ValueError, AssertionError) as err:
        raise BagError(f'Expected a {msgtype} message object, got {message!r}: {err}') from err


def deserialize(data: bytes | memoryview, msgtype: str) -> Any:
    """The ``rosbags`` message object of CDR bytes ``data`` of type ``msgtype``."""
    check_msgtype(msgtype)
    try:
        return typestore().deserialize_cdr(data, msgtype)
    except SerdeError as err:
        raise BagError(f'Expected a CDR-encoded {msgtype} message, got {len(data)} bytes: '
                       f'{err}') from err
