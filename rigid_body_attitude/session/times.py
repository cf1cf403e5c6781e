"""Time at the boundaries: integer nanoseconds, converted here and nowhere else.

Every time that enters or leaves the session layer is an ``int`` of nanoseconds: header stamps
(``builtin_interfaces/Time``: ``sec`` int32, ``nanosec`` uint32), the node clock, bag times.
The propagators integrate in float seconds; :class:`TimeBase` maps nanoseconds to seconds since
an epoch so that stamps near 1.7e9 s keep sub-nanosecond resolution (a float near 1.7e9 has a
spacing of 2.4e-7 s, which would put a 2.4e-4 relative error on the step of a 1 kHz gyro).
"""

from __future__ import annotations

import math

__all__ = ['NANOSECONDS_PER_SECOND', 'TimeBase', 'seconds_to_ns', 'split_ns', 'stamp_problem',
           'to_ns']

NANOSECONDS_PER_SECOND = 1_000_000_000

#: ``builtin_interfaces/Time.sec`` is an int32.
_MAX_SEC = 2**31 - 1


def stamp_problem(sec: int, nanosec: int) -> str:
    """Why ``(sec, nanosec)`` is not a valid ROS time, or ``''``.

    Valid: ``0 <= sec <= 2³¹ − 1`` and ``0 <= nanosec < 10⁹`` (a ``nanosec`` of 10⁹ or more
    is not a normalised time: rclpy's own ``Time`` refuses it).
    """
    if not 0 <= nanosec < NANOSECONDS_PER_SECOND:
        return f'nanosec {nanosec} outside [0, 1e9)'
    if not 0 <= sec <= _MAX_SEC:
        return f'sec {sec} outside [0, 2^31 - 1]'
    return ''


def to_ns(sec: int, nanosec: int) -> int:
    """Nanoseconds of a (valid) stamp."""
    return sec * NANOSECONDS_PER_SECOND + nanosec


def split_ns(nanoseconds: int) -> tuple[int, int]:
    """``(sec, nanosec)`` of a time in nanoseconds."""
    sec, nanosec = divmod(nanoseconds, NANOSECONDS_PER_SECOND)
    return sec, nanosec


def seconds_to_ns(seconds: float) -> int:
    """Nanoseconds of a time or duration given in float seconds, rounded to the nanosecond."""
    whole = math.floor(seconds)
    return whole * NANOSECONDS_PER_SECOND + round((seconds - whole) * NANOSECONDS_PER_SECOND)


class TimeBase:
    """Nanoseconds ↔ float seconds since an epoch fixed by the first time converted.

    The epoch is the first time's whole seconds, so the first time maps to ``[0, 1)`` s and
    later ones to their exact distance from it (float resolution ~1e-10 s within ±1e6 s of the
    epoch). :meth:`rebase` moves the epoch (after the state was reset to a new time).
    """

    def __init__(self) -> None:
        """No epoch until the first conversion."""
        self.epoch_ns: int | None = None

    def seconds(self, nanoseconds: int) -> float:
        """Seconds since the epoch of a time in nanoseconds."""
        if self.epoch_ns is None:
            self.epoch_ns = nanoseconds - nanoseconds % NANOSECONDS_PER_SECOND
        return (nanoseconds - self.epoch_ns) * 1e-9

    def rebase(self, nanoseconds: int) -> float:
        """Move the epoch to ``nanoseconds``' whole seconds; its seconds since the new epoch."""
        self.epoch_ns = None
        return self.seconds(nanoseconds)

    def nanoseconds(self, seconds: float) -> int:
        """Nanoseconds of ``seconds`` since the epoch, rounded to the nanosecond."""
        epoch = self.epoch_ns if self.epoch_ns is not None else 0
        return epoch + round(seconds * NANOSECONDS_PER_SECOND)
