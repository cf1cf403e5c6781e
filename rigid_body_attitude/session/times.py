"""Time at the boundaries: integer nanoseconds, converted here and nowhere else.

Every time that enters or leaves the session layer is an ``int`` of nanoseconds: header stamps
(``builtin_interfaces/Time``: ``sec`` int32, ``nanosec`` uint32), the node clock, bag times.
The propagators integrate in float seconds; :class:`TimeBase` maps nanoseconds to a dynamics
scene's time, seconds since its start, so that stamps near 1.7e9 s keep sub-nanosecond
resolution (a float near 1.7e9 has a spacing of 2.4e-7 s, which would put a 2.4e-4 relative
error on the step of a 1 kHz gyro) and the scene's time-dependent effects (orbit, field) see
the same time in the node as in the batch engine.
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
    """Nanoseconds ↔ float seconds of scene time: seconds since the scene's start.

    A dynamics scene's time starts at 0 at its first tick (:meth:`start`): the first after the
    node starts, a reset or a backward clock jump. Every time of a stamp or a clock maps to its
    exact distance from that instant (integer nanoseconds subtracted first, so a float
    resolution of ~1e-10 s holds within ±1e6 s of the start whatever the clock's origin), and
    back (:meth:`nanoseconds`). Before the first start there is no scene time
    (:attr:`started` is false).
    """

    def __init__(self) -> None:
        """No scene time until :meth:`start`."""
        self.epoch_ns: int | None = None

    @property
    def started(self) -> bool:
        """Whether the scene has started (its time is defined)."""
        return self.epoch_ns is not None

    def start(self, nanoseconds: int) -> float:
        """The scene (re)starts at ``nanoseconds``: scene time 0 there; returns 0.0."""
        self.epoch_ns = nanoseconds
        return 0.0

    def seconds(self, nanoseconds: int) -> float:
        """Scene time [s] of a time in nanoseconds (the scene must have started)."""
        epoch = self.epoch_ns
        if epoch is None:
            raise RuntimeError('no scene time before the scene starts (TimeBase.start)')
        return (nanoseconds - epoch) * 1e-9

    def nanoseconds(self, seconds: float) -> int:
        """Nanoseconds of the scene time ``seconds``, rounded to the nanosecond."""
        epoch = self.epoch_ns if self.epoch_ns is not None else 0
        return epoch + round(seconds * NANOSECONDS_PER_SECOND)
