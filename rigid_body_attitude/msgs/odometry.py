"""``nav_msgs/msg/Odometry`` as CDR bytes: the node's ``odom`` encoder, the controller's decoder.

Layout (OMG CDR, offsets from the payload after the 4-byte encapsulation): the
``std_msgs/Header`` (``int32 sec``, ``uint32 nanosec``, ``frame_id``), ``child_frame_id`` (a
``uint32`` length at the next multiple of 4, the bytes with their NUL), then the float64 body
of :data:`~rigid_body_attitude.msgs.types.ODOMETRY_BODY` at the next multiple of the float64
alignment: pose (position, orientation ``x, y, z, w``), its 6×6 covariance, twist (linear,
angular), its 6×6 covariance. nav_msgs says the pose is in ``header.frame_id`` and the twist in
``child_frame_id``.

:func:`odometry_encoder` packs the two frame ids and both covariances once; each message is
then one ``struct`` call of the stamp and 13 values. :func:`decode_odometry` checks what the
fixed-layout decoders of :mod:`~rigid_body_attitude.msgs.decoders` check, under the same rules
(the encapsulations rclpy reads, strings of one terminating NUL and UTF-8, bytes after the
body ignored; ``test/msgs/test_odometry.py`` holds it to ``rclpy.serialization``): a CDR_LE
message of the frame pair it saw last costs one ``struct`` call and two byte-string
comparisons; anything else goes through :class:`~.tf_message.CdrReader`, which names the
fault, and a pair that comes twice in a row becomes the primed one.
"""

from __future__ import annotations

import struct
from collections.abc import Callable, Sequence
from struct import Struct
from typing import NamedTuple, cast

from rigid_body_attitude.core.errors import InputError
from rigid_body_attitude.msgs.decoders import ENCAPSULATIONS, Floats
from rigid_body_attitude.msgs.errors import MalformedMessage
from rigid_body_attitude.msgs.tf_message import CdrReader
from rigid_body_attitude.msgs.types import ODOMETRY, ODOMETRY_BODY

__all__ = ['EXACT_COVARIANCE', 'Odometry', 'OdometryEncoder', 'decode_odometry',
           'encode_odometry', 'odometry_encoder']

#: The 6×6 covariance of a simulated body's pose and twist: all zeros, the state is exact
#: (Gazebo's OdometryPublisher sends zeros too; robot_localization raises a variance below
#: 1e-9 to 1e-9 before it fuses it).
EXACT_COVARIANCE: tuple[float, ...] = (0.0,) * 36

#: ``encode(sec, nanosec, position, (w, x, y, z), linear, angular)``: the CDR bytes.
OdometryEncoder = Callable[[int, int, Sequence[float], Sequence[float], Sequence[float],
                            Sequence[float]], bytes]

_ENCAPSULATION_LE = b'\x00\x01\x00\x00'
_COUNT = ODOMETRY_BODY.count                             # 85 float64
_TWIST_AT = ODOMETRY_BODY.at('twist.twist.linear.x')     # after pose (7) and covariance (36)
_COVARIANCE_BYTES = 8 * 36


class Odometry(NamedTuple):
    """A decoded ``nav_msgs/msg/Odometry``: the pose in ``frame_id``, the twist in
    ``child_frame_id``; the orientation scalar-first (the message holds ``x, y, z, w``).
    The covariances are checked for presence, not returned."""

    sec: int
    nanosec: int
    frame_id: str
    child_frame_id: str
    position: Floats
    orientation: Floats
    linear: Floats
    angular: Floats


def _frame_bytes(frame_id: str, name: str) -> bytes:
    if not isinstance(frame_id, str) or '\x00' in frame_id:
        raise InputError(f'Expected `{name}` to be a string without NUL, got {frame_id!r}')
    return frame_id.encode('utf-8') + b'\x00'


def _strings(frame: bytes, child: bytes) -> tuple[bytes, bytes, int]:
    """The payload from the frame id's length to the body, the frames' bytes with their
    lengths (each as CDR writes it, padding zero) and its padding before the body; and the
    byte offset of the body in the message."""
    child_at = 4 + -(-(12 + len(frame)) // 4) * 4          # message offset of its length
    end = child_at + 4 + len(child)
    body_at = 4 + -(-(end - 4) // 8) * 8
    head = (struct.pack('<I', len(frame)) + frame + bytes(child_at - 16 - len(frame))
            + struct.pack('<I', len(child)) + child)
    return head, bytes(body_at - end), body_at


def odometry_encoder(frame_id: str, child_frame_id: str,
                     pose_covariance: Sequence[float] = EXACT_COVARIANCE,
                     twist_covariance: Sequence[float] = EXACT_COVARIANCE) -> OdometryEncoder:
    """``encode(sec, nanosec, position, (w, x, y, z), linear, angular)``: an Odometry with
    the pose in ``frame_id`` [m], the twist in ``child_frame_id`` [m/s, rad/s] and the given
    covariances (36 row-major values each), little-endian CDR.

    Frames and covariances are packed once; each call is one ``struct`` call.
    """
    for name, covariance in (('pose_covariance', pose_covariance),
                             ('twist_covariance', twist_covariance)):
        if len(covariance) != 36:
            raise InputError(f'Expected `{name}` to have 36 values, got {len(covariance)}')
    head, padding, _ = _strings(_frame_bytes(frame_id, 'frame_id'),
                                _frame_bytes(child_frame_id, 'child_frame_id'))
    constant = head + padding
    pose_block = Struct('<36d').pack(*pose_covariance)
    twist_block = Struct('<36d').pack(*twist_covariance)
    pack = Struct(f'<4siI{len(constant)}s7d{_COVARIANCE_BYTES}s6d{_COVARIANCE_BYTES}s').pack

    def encode(sec: int, nanosec: int, position: Sequence[float], attitude: Sequence[float],
               linear: Sequence[float], angular: Sequence[float]) -> bytes:
        px, py, pz = position
        w, x, y, z = attitude
        try:
            return pack(_ENCAPSULATION_LE, sec, nanosec, constant, px, py, pz, x, y, z, w,
                        pose_block, *linear, *angular, twist_block)
        except struct.error as err:
            raise InputError(f'Expected `sec` in int32 and `nanosec` in uint32 range and '
                             f'3 linear and 3 angular values, got sec={sec!r}, '
                             f'nanosec={nanosec!r}') from err
    return encode


def encode_odometry(stamp_ns: int, frame_id: str, child_frame_id: str,
                    position: Sequence[float], attitude: Sequence[float],
                    linear: Sequence[float], angular: Sequence[float],
                    pose_covariance: Sequence[float] = EXACT_COVARIANCE,
                    twist_covariance: Sequence[float] = EXACT_COVARIANCE) -> bytes:
    """CDR bytes of one ``nav_msgs/msg/Odometry`` stamped ``stamp_ns`` (:func:`odometry_encoder`
    for a single message)."""
    sec, nanosec = divmod(stamp_ns, 1_000_000_000)
    return odometry_encoder(frame_id, child_frame_id, pose_covariance, twist_covariance)(
        sec, nanosec, position, attitude, linear, angular)


class _Primed(NamedTuple):
    """The one-call path for the CDR_LE messages of one pair of frames."""

    unpack: Callable[[bytes, int], tuple[object, ...]]
    frame: bytes           # length and bytes of frame_id
    child: bytes           # length and bytes of child_frame_id
    names: tuple[str, str]
    size: int


def _primed(frame: bytes, child: bytes, names: tuple[str, str]) -> _Primed:
    child_at = 4 + -(-(12 + len(frame)) // 4) * 4
    end = child_at + 4 + len(child)
    body_at = 4 + -(-(end - 4) // 8) * 8
    unpack = Struct(f'<2s2xiI{4 + len(frame)}s{child_at - 16 - len(frame)}x{4 + len(child)}s'
                    f'{body_at - end}x7d{_COVARIANCE_BYTES}x6d').unpack_from
    return _Primed(unpack, struct.pack('<I', len(frame)) + frame,
                   struct.pack('<I', len(child)) + child, names, body_at + 8 * _COUNT)


def _checked(data: bytes) -> Odometry:
    """The complete check (:class:`~.tf_message.CdrReader`), naming the fault."""
    if not isinstance(data, (bytes, bytearray, memoryview)):
        raise MalformedMessage(ODOMETRY, f'expected bytes, got {type(data).__name__[:40]}')
    raw = bytes(data)
    if len(raw) < 4:
        raise MalformedMessage(ODOMETRY, f'truncated: {len(raw)} bytes')
    encapsulation = ENCAPSULATIONS.get(raw[0] << 8 | raw[1])
    if encapsulation is None:
        raise MalformedMessage(ODOMETRY, f'bad encapsulation 0x{raw[0] << 8 | raw[1]:04x}')
    reader = CdrReader(raw, encapsulation.little_endian, encapsulation.float64_alignment,
                       ODOMETRY)
    sec, nanosec = reader.uint32s('iI')
    frame_id = reader.string('frame_id')
    child_frame_id = reader.string('child_frame_id')
    body = reader.float64s(_COUNT)
    px, py, pz, x, y, z, w = body[:7]
    return Odometry(sec, nanosec, frame_id, child_frame_id, (px, py, pz), (w, x, y, z),
                    body[_TWIST_AT:_TWIST_AT + 3], body[_TWIST_AT + 3:_TWIST_AT + 6])


def _decoder() -> Callable[[bytes], Odometry]:
    """:func:`decode_odometry`, primed on the frame pair it met twice in a row."""
    primed = _primed(b'\x00', b'\x00', ('', ''))
    missed: tuple[str, str] | None = None
    fast_errors = (TypeError, ValueError, struct.error)

    def decode_odometry(data: bytes) -> Odometry:
        """The stamp, frames, pose and twist of a ``nav_msgs/msg/Odometry``'s CDR ``data``
        (:class:`Odometry`); :class:`MalformedMessage` for bytes that are not one."""
        nonlocal primed, missed
        unpack, frame, child, names, size = primed
        try:
            fields = unpack(data, 0)
            if (fields[0] == b'\x00\x01' and fields[3] == frame and fields[4] == child
                    and len(data) >= size):
                sec, nanosec = cast('tuple[int, int]', fields[1:3])
                px, py, pz, x, y, z, w, vx, vy, vz, wx, wy, wz = cast(Floats, fields[5:])
                return Odometry(sec, nanosec, names[0], names[1], (px, py, pz),
                                (w, x, y, z), (vx, vy, vz), (wx, wy, wz))
        except fast_errors:
            pass
        decoded = _checked(data)
        pair = (decoded.frame_id, decoded.child_frame_id)
        if pair == missed and data[:2] == b'\x00\x01':
            primed = _primed(pair[0].encode() + b'\x00', pair[1].encode() + b'\x00', pair)
        missed = pair
        return decoded
    return decode_odometry


decode_odometry = _decoder()
