"""A hand-written CDR encoder of ``diagnostic_msgs/msg/DiagnosticArray``.

The one variable-layout message the package writes (the replay tool's ``/diagnostics``):
a header, then a sequence of ``DiagnosticStatus`` (``byte level``, strings ``name``,
``message``, ``hardware_id``, a sequence of ``KeyValue`` string pairs). Written little-endian
(``00 01 00 00``) with CDR's alignment: sequence lengths and string lengths on multiples of 4
of the payload, ``level`` a single byte where it falls. ``test/msgs/test_diagnostic_array.py``
checks the bytes against ``rosbags``' serialiser.
"""

from __future__ import annotations

import struct
from collections.abc import Mapping, Sequence
from types import MappingProxyType
from typing import NamedTuple

from rigid_body_attitude.core.errors import InputError

__all__ = ['DiagnosticStatus', 'encode_diagnostic_array']

_NS_PER_S = 1_000_000_000
_ENCAPSULATION_LE = b'\x00\x01\x00\x00'
_UINT32 = struct.Struct('<I')
_LEVELS = (0, 1, 2, 3)


class DiagnosticStatus(NamedTuple):
    """One ``diagnostic_msgs/msg/DiagnosticStatus``: level 0 OK, 1 WARN, 2 ERROR, 3 STALE."""

    level: int
    name: str
    message: str
    hardware_id: str = ''
    values: Mapping[str, str] = MappingProxyType({})


class _Payload:
    """CDR payload under construction (offsets count from the end of the encapsulation)."""

    def __init__(self) -> None:
        self.data = bytearray(_ENCAPSULATION_LE)

    def uint32(self, value: int) -> None:
        self.data += bytes(-(len(self.data) - 4) % 4)
        self.data += _UINT32.pack(value)

    def string(self, text: str, name: str) -> None:
        if not isinstance(text, str):
            raise InputError(f'Expected `{name}` to be a string, got {text!r}')
        encoded = text.encode('utf-8') + b'\x00'
        self.uint32(len(encoded))
        self.data += encoded


def encode_diagnostic_array(stamp_ns: int, frame_id: str,
                            statuses: Sequence[DiagnosticStatus]) -> bytes:
    """CDR bytes of a ``diagnostic_msgs/msg/DiagnosticArray`` stamped ``stamp_ns``.

    ``values`` mappings become ``KeyValue`` pairs in their iteration order (keys and values
    through ``str``).
    """
    if not isinstance(stamp_ns, int) or not -2 ** 31 <= stamp_ns // _NS_PER_S < 2 ** 31:
        raise InputError(f'Expected `stamp_ns` to be an integer with seconds in int32 range, '
                         f'got {stamp_ns!r}')
    sec, nanosec = divmod(stamp_ns, _NS_PER_S)
    payload = _Payload()
    payload.data += struct.pack('<iI', sec, nanosec)
    payload.string(frame_id, 'frame_id')
    payload.uint32(len(statuses))
    for status in statuses:
        if status.level not in _LEVELS:
            raise InputError(f'Expected `level` to be 0 (OK), 1 (WARN), 2 (ERROR) or 3 (STALE), '
                             f'got {status.level!r}')
        payload.data.append(status.level)
        payload.string(status.name, 'name')
        payload.string(status.message, 'message')
        payload.string(status.hardware_id, 'hardware_id')
        payload.uint32(len(status.values))
        for key, value in status.values.items():
            payload.string(str(key), 'key')
            payload.string(str(value), 'value')
    return bytes(payload.data)
