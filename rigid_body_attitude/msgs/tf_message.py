"""Checked decoder of ``tf2_msgs/msg/TFMessage`` (what ``/tf`` and ``/tf_static`` carry).

:func:`decode_tf_message` takes the CDR bytes of one message (a bag record of ``/tf_static``)
and returns its transforms as plain values, or raises
:class:`~rigid_body_attitude.msgs.errors.MalformedMessage` with a short, bounded reason, as the
fixed-layout decoders of :mod:`~rigid_body_attitude.msgs.decoders` do, whose encapsulations and
string rules it shares. Layout (OMG CDR, offsets from the payload after the 4-byte
encapsulation): ``uint32`` count of ``geometry_msgs/TransformStamped``, each a header (``int32
sec``, ``uint32 nanosec``, ``frame_id``), ``child_frame_id`` (a ``uint32`` length at the next
multiple of 4, the bytes with their NUL), then translation (3 float64) and rotation (4 float64,
``x, y, z, w`` on the wire) at the next multiple of the float64 alignment.
"""

from __future__ import annotations

import struct
from typing import NamedTuple

from rigid_body_attitude.msgs.decoders import ENCAPSULATIONS, Floats
from rigid_body_attitude.msgs.errors import MalformedMessage

__all__ = ['CdrReader', 'MAX_TF_TRANSFORMS', 'TF_MESSAGE', 'Transform', 'decode_tf_message']

TF_MESSAGE = 'tf2_msgs/msg/TFMessage'
#: Most transforms one message may hold (a hostile count is refused before any work).
MAX_TF_TRANSFORMS = 10_000
#: Fewest payload bytes of one transform: stamp, two one-byte strings, 7 float64.
_SMALLEST_TRANSFORM = 8 + 5 + 3 + 5 + 3 + 56


class Transform(NamedTuple):
    """One ``TransformStamped``: rotation scalar-first, mapping child-frame vectors into the
    parent frame."""

    sec: int
    nanosec: int
    parent_frame: str
    child_frame: str
    translation: Floats
    rotation: Floats


class CdrReader:
    """Bounds-checked reads at payload offsets of one message of type ``msgtype`` (its
    :class:`MalformedMessage` s name it), from the first byte after the encapsulation."""

    def __init__(self, raw: bytes, little_endian: bool, float64_alignment: int,
                 msgtype: str = TF_MESSAGE) -> None:
        """Read ``raw`` in the byte order and float64 alignment of its encapsulation."""
        self.raw, self.offset, self.msgtype = raw, 4, msgtype
        self.order = '<' if little_endian else '>'
        self.alignment = float64_alignment

    def _take(self, size: int, alignment: int) -> int:
        start = 4 + -(-(self.offset - 4) // alignment) * alignment
        if start + size > len(self.raw):
            raise MalformedMessage(self.msgtype, f'truncated: {len(self.raw)} bytes, '
                                                 f'{start + size} needed')
        self.offset = start + size
        return start

    def uint32s(self, fmt: str) -> tuple[int, ...]:
        """The 4-byte integers of ``fmt`` (``'iI'``) at the next multiple of 4."""
        size = struct.calcsize(fmt)
        values: tuple[int, ...] = struct.unpack_from(self.order + fmt, self.raw,
                                                     self._take(size, 4))
        return values

    def float64s(self, count: int) -> Floats:
        """``count`` float64 at the next multiple of the float64 alignment."""
        at = self._take(8 * count, self.alignment)
        values: Floats = struct.unpack_from(f'{self.order}{count}d', self.raw, at)
        return values

    def string(self, name: str) -> str:
        """The CDR string ``name`` (a length, the bytes with one terminating NUL, UTF-8)."""
        (length,) = self.uint32s('I')
        if length == 0 or length > len(self.raw):
            raise MalformedMessage(self.msgtype, f'{name} length {length} in a message of '
                                                 f'{len(self.raw)} bytes')
        text = self.raw[self._take(length, 1):self.offset]
        if text.find(0) != length - 1:
            raise MalformedMessage(self.msgtype, f'{name} is not NUL-terminated once')
        try:
            return text[:-1].decode('utf-8')
        except UnicodeDecodeError as err:
            raise MalformedMessage(self.msgtype, f'{name} is not UTF-8 (byte {err.start})'
                                   ) from None


def decode_tf_message(data: bytes) -> list[Transform]:
    """The transforms of a ``tf2_msgs/msg/TFMessage``'s CDR ``data`` (checked; bytes after
    the last transform are ignored, as rclpy does)."""
    if not isinstance(data, (bytes, bytearray, memoryview)):
        raise MalformedMessage(TF_MESSAGE, f'expected bytes, got {type(data).__name__[:40]}')
    raw = bytes(data)
    if len(raw) < 8:
        raise MalformedMessage(TF_MESSAGE, f'truncated: {len(raw)} of at least 8 bytes')
    encapsulation = ENCAPSULATIONS.get(raw[0] << 8 | raw[1])
    if encapsulation is None:
        raise MalformedMessage(TF_MESSAGE, f'bad encapsulation 0x{raw[0] << 8 | raw[1]:04x}')
    reader = CdrReader(raw, encapsulation.little_endian, encapsulation.float64_alignment)
    (count,) = reader.uint32s('I')
    if count > MAX_TF_TRANSFORMS or 8 + count * _SMALLEST_TRANSFORM > len(raw):
        raise MalformedMessage(TF_MESSAGE, f'{count} transforms in {len(raw)} bytes')
    return [_transform(reader) for _ in range(count)]


def _transform(reader: CdrReader) -> Transform:
    sec, nanosec = reader.uint32s('iI')
    parent = reader.string('frame_id')
    child = reader.string('child_frame_id')
    translation = reader.float64s(3)
    x, y, z, w = reader.float64s(4)
    return Transform(sec, nanosec, parent, child, translation, (w, x, y, z))
