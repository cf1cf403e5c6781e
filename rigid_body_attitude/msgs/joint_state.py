"""``sensor_msgs/msg/JointState``: the checked decoder and the encoder (wheel commands and state).

A reaction-wheel array is commanded with one JointState per array (``name``: the wheels;
``effort``: motor torques [N m] or ``velocity``: speeds [rad/s]) and reports its wheels in one
(``position`` [rad], ``velocity`` [rad/s], ``effort`` [N m]), the message ``ros2_control``'s
joint state broadcaster and ``robot_state_publisher`` use for joints.

:func:`decode_joint_state` takes the CDR bytes of one message and returns
:class:`JointStateValues`, or raises :class:`~rigid_body_attitude.msgs.errors.MalformedMessage`
with a short, bounded reason, under the rules of the fixed-layout decoders of
:mod:`~rigid_body_attitude.msgs.decoders` (the same encapsulations, the same string rules as the
header's ``frame_id``; bytes after the message ignored, as rclpy does). Layout (OMG CDR, offsets
from the payload after the 4-byte encapsulation): the header (``int32 sec``, ``uint32
nanosec``, ``frame_id``), ``string[] name`` (a ``uint32`` count, then each string as a
``uint32`` length at the next multiple of 4 and its bytes with their NUL), then ``position``,
``velocity`` and ``effort``, each a ``uint32`` count at the next multiple of 4 and its float64
values at the next multiple of the float64 alignment. A hostile count is refused before any
work: at most :data:`MAX_JOINTS` names or values per field. No value is judged here (lengths
that disagree, NaN: the session's job).

:func:`joint_state_encoder` packs the messages of one frame and one list of names (the node's
``wheels/state``, the controller's ``wheels/command``) as CDR_LE bytes, the fixed prefix packed
once.
"""

from __future__ import annotations

import struct
from collections.abc import Callable, Sequence
from typing import NamedTuple

from rigid_body_attitude.core.errors import InputError
from rigid_body_attitude.msgs.decoders import ENCAPSULATIONS, Floats
from rigid_body_attitude.msgs.errors import MalformedMessage
from rigid_body_attitude.msgs.tf_message import CdrReader

__all__ = ['JOINT_STATE', 'JointStateEncoder', 'JointStateValues', 'MAX_JOINTS',
           'MAX_JOINT_NAME', 'decode_joint_state', 'joint_state_encoder']

JOINT_STATE = 'sensor_msgs/msg/JointState'
#: Most names (and values of each field) one message may hold.
MAX_JOINTS = 1024
#: Longest joint name in bytes, its NUL included.
MAX_JOINT_NAME = 256


class JointStateValues(NamedTuple):
    """One JointState: header stamp and frame, the names, the three value fields."""

    sec: int
    nanosec: int
    frame_id: str
    names: tuple[str, ...]
    position: Floats
    velocity: Floats
    effort: Floats


class _Reader(CdrReader):
    """:class:`~rigid_body_attitude.msgs.tf_message.CdrReader` for a JointState: sequences of
    at most :data:`MAX_JOINTS`, names of at most :data:`MAX_JOINT_NAME` bytes."""

    def __init__(self, raw: bytes, little_endian: bool, float64_alignment: int) -> None:
        super().__init__(raw, little_endian, float64_alignment, JOINT_STATE)

    def count(self, field: str, smallest: int) -> int:
        """A sequence's length, refused when it cannot fit or exceeds :data:`MAX_JOINTS`."""
        (count,) = self.uint32s('I')
        if count > MAX_JOINTS or count * smallest > len(self.raw) - self.offset:
            raise MalformedMessage(JOINT_STATE, f'{field}: {count} elements in a message of '
                                                f'{len(self.raw)} bytes')
        return count

    def float_field(self, field: str) -> Floats:
        """The float64 sequence ``field``."""
        count = self.count(field, 8)
        return self.float64s(count) if count else ()

    def string(self, name: str) -> str:
        """The CDR string ``name``, its length refused beyond :data:`MAX_JOINT_NAME`."""
        at = self.offset
        (length,) = self.uint32s('I')
        if length == 0 or length > MAX_JOINT_NAME:
            raise MalformedMessage(JOINT_STATE, f'{name} length {length} (1 to '
                                                f'{MAX_JOINT_NAME} bytes with the NUL)')
        self.offset = at
        return super().string(name)


def decode_joint_state(data: bytes) -> JointStateValues:
    """The values of a ``sensor_msgs/msg/JointState``'s CDR ``data`` (checked)."""
    if not isinstance(data, (bytes, bytearray, memoryview)):
        raise MalformedMessage(JOINT_STATE, f'expected bytes, got {type(data).__name__[:40]}')
    raw = bytes(data)
    if len(raw) < 4:
        raise MalformedMessage(JOINT_STATE, f'truncated: {len(raw)} of at least 4 bytes')
    encapsulation = ENCAPSULATIONS.get(raw[0] << 8 | raw[1])
    if encapsulation is None:
        raise MalformedMessage(JOINT_STATE, f'bad encapsulation 0x{raw[0] << 8 | raw[1]:04x}')
    reader = _Reader(raw, encapsulation.little_endian, encapsulation.float64_alignment)
    sec, nanosec = reader.uint32s('iI')
    frame_id = reader.string('frame_id')
    names = tuple(reader.string('name') for _ in range(reader.count('name', 5)))
    return JointStateValues(sec, nanosec, frame_id, names, reader.float_field('position'),
                            reader.float_field('velocity'), reader.float_field('effort'))


#: Packs one message: ``(sec, nanosec, position, velocity, effort)`` → CDR_LE bytes.
JointStateEncoder = Callable[[int, int, Sequence[float], Sequence[float], Sequence[float]],
                             bytes]


def _cdr_string(text: str, name: str) -> bytes:
    """A CDR string: its ``uint32`` length, the UTF-8 bytes and the NUL."""
    if not isinstance(text, str) or '\x00' in text:
        raise InputError(f'Expected `{name}` to be a string without NUL, got {text!r}')
    encoded = text.encode('utf-8') + b'\x00'
    if name == 'name' and len(encoded) > MAX_JOINT_NAME:
        raise InputError(f'Expected a joint name of at most {MAX_JOINT_NAME - 1} bytes, got '
                         f'{len(encoded) - 1}')
    return struct.pack('<I', len(encoded)) + encoded


def _pad(payload: bytearray, alignment: int) -> None:
    payload.extend(b'\x00' * (-len(payload) % alignment))


def joint_state_encoder(frame_id: str, names: Sequence[str]) -> JointStateEncoder:
    """An encoder of JointStates in ``frame_id`` naming ``names`` (each field empty or one
    value per name; InputError otherwise)."""
    if len(names) > MAX_JOINTS:
        raise InputError(f'Expected at most {MAX_JOINTS} joint names, got {len(names)}')
    payload = bytearray(8)  # the stamp, packed per message
    payload += _cdr_string(frame_id, 'frame_id')
    _pad(payload, 4)
    payload += struct.pack('<I', len(names))
    for name in names:
        _pad(payload, 4)
        payload += _cdr_string(name, 'name')
    head = bytes(payload[8:])
    count = len(names)

    def encode(sec: int, nanosec: int, position: Sequence[float], velocity: Sequence[float],
               effort: Sequence[float]) -> bytes:
        message = bytearray(b'\x00\x01\x00\x00')
        message += struct.pack('<iI', sec, nanosec)
        message += head
        for field, values in (('position', position), ('velocity', velocity),
                              ('effort', effort)):
            if len(values) not in (0, count):
                raise InputError(f'Expected `{field}` empty or {count} values, got '
                                 f'{len(values)}')
            _pad_payload(message, 4)
            message += struct.pack('<I', len(values))
            if values:
                _pad_payload(message, 8)
                message += struct.pack(f'<{len(values)}d', *values)
        return bytes(message)
    return encode


def _pad_payload(message: bytearray, alignment: int) -> None:
    """Pad a message (its 4-byte encapsulation first) to ``alignment`` of the payload."""
    message.extend(b'\x00' * (-(len(message) - 4) % alignment))
