"""The samples of one update interval, summed in plain floats: the filter's per-sample work.

Per IMU sample (:meth:`ImuInterval.add`): the specific force rotated into the world frame
with the attitude at the sample (``q ⊗ f ⊗ q*``, 18 products), its sum, the sums of the
body-frame specific force and rate and of their squared norms (for the rest test), the count
and the duration. Per magnetometer sample (:meth:`MagneticInterval.add`, corrected for hard
and soft iron by
:class:`~rigid_body_attitude.core.estimation.magnetometer.MagnetometerCalibration`): the
rotation into the world frame, the sum.
Per IMU sample too (:meth:`RecentTurn.add`): the rate and step, kept for a short while, so
that a magnetometer sample taken some milliseconds before the gyro's can be paired with the
attitude at its own instant (:meth:`RecentTurn.turn`, :mod:`.magnetometer`).
Averaging in the world frame is what lets the updates run at a low rate: the body may turn
fast within an interval, the world-frame gravity and field do not (VQF low-passes the
specific force in an almost-inertial frame for the same reason: D. Laidig, T. Seel,
Information Fusion 91, 2023, section 3.2).
"""

from __future__ import annotations

import math
from collections import deque
from collections.abc import Sequence

__all__ = ['ImuInterval', 'MagneticInterval', 'RecentTurn']

Quat = tuple[float, float, float, float]


class ImuInterval:
    """Sums of one interval's IMU samples (module docstring); :meth:`clear` starts anew."""

    def __init__(self) -> None:
        self.clear()

    def clear(self) -> None:
        """Forget the sums."""
        #: Σ f_world (3), Σ f_body (3), Σ|f|², Σ ω (3), Σ|ω|² (indices 0-10).
        self.sums = [0.0] * 11
        self.count = 0
        self.duration = 0.0
        #: Seconds of samples at the accelerometer's full scale (clipped).
        self.clipped = 0.0

    def add(self, q: Quat, rate: Sequence[float], specific_force: Sequence[float],
            dt: float) -> None:
        """One sample: attitude ``q`` (w, x, y, z) at it, body rate [rad/s] (bias removed),
        body specific force [m/s²], its interval [s]."""
        w, x, y, z = q
        fx, fy, fz = specific_force
        tx, ty, tz = 2.0 * (y * fz - z * fy), 2.0 * (z * fx - x * fz), 2.0 * (x * fy - y * fx)
        s = self.sums
        s[0] += fx + w * tx + (y * tz - z * ty)
        s[1] += fy + w * ty + (z * tx - x * tz)
        s[2] += fz + w * tz + (x * ty - y * tx)
        s[3] += fx
        s[4] += fy
        s[5] += fz
        s[6] += fx * fx + fy * fy + fz * fz
        wx, wy, wz = rate
        s[7] += wx
        s[8] += wy
        s[9] += wz
        s[10] += wx * wx + wy * wy + wz * wz
        self.count += 1
        self.duration += dt

    def mean_world_force(self) -> tuple[float, float, float]:
        """Mean specific force in the world frame [m/s²]."""
        s, n = self.sums, self.count
        return s[0] / n, s[1] / n, s[2] / n

    def mean_rate(self) -> tuple[float, float, float]:
        """Mean body rate [rad/s]."""
        s, n = self.sums, self.count
        return s[7] / n, s[8] / n, s[9] / n

    def rms_rate(self) -> float:
        """Root mean square of the body rate's magnitude [rad/s]."""
        return math.sqrt(self.sums[10] / self.count)

    def spreads(self) -> tuple[float, float]:
        """Total standard deviations (over the axes) of the rate [rad/s] and of the specific
        force [m/s²] within the interval."""
        s, n = self.sums, self.count
        gyro = s[10] / n - (s[7] ** 2 + s[8] ** 2 + s[9] ** 2) / (n * n)
        accel = s[6] / n - (s[3] ** 2 + s[4] ** 2 + s[5] ** 2) / (n * n)
        return math.sqrt(max(gyro, 0.0)), math.sqrt(max(accel, 0.0))

    def mean_force_norm(self) -> float:
        """``|mean body specific force|`` [m/s²]."""
        s, n = self.sums, self.count
        return math.sqrt(s[3] ** 2 + s[4] ** 2 + s[5] ** 2) / n


class MagneticInterval:
    """Sums of one interval's magnetometer samples in the world frame and in the sensor frame
    (module docstring)."""

    def __init__(self) -> None:
        self.clear()

    def clear(self) -> None:
        """Forget the sums."""
        self.sums = [0.0, 0.0, 0.0]
        self.body_sums = [0.0, 0.0, 0.0]
        self.count = 0

    def add_body(self, field: Sequence[float]) -> None:
        """One sample [T] in the sensor frame, corrected for hard and soft iron (the hard-iron
        fit's data, :mod:`.hard_iron`); :meth:`add` counts it."""
        b = self.body_sums
        b[0] += field[0]
        b[1] += field[1]
        b[2] += field[2]

    def mean_body(self) -> tuple[float, float, float]:
        """Mean field in the sensor frame [T]."""
        b, n = self.body_sums, self.count
        return b[0] / n, b[1] / n, b[2] / n

    def add(self, q: Quat, field: Sequence[float]) -> None:
        """One sample [T], body frame, corrected for hard and soft iron, seen at ``q``."""
        mx, my, mz = field
        w, x, y, z = q
        tx, ty, tz = 2.0 * (y * mz - z * my), 2.0 * (z * mx - x * mz), 2.0 * (x * my - y * mx)
        s = self.sums
        s[0] += mx + w * tx + (y * tz - z * ty)
        s[1] += my + w * ty + (z * tx - x * tz)
        s[2] += mz + w * tz + (x * ty - y * tx)
        self.count += 1

    def mean(self) -> tuple[float, float, float]:
        """Mean field in the world frame [T]."""
        s, n = self.sums, self.count
        return s[0] / n, s[1] / n, s[2] / n


class RecentTurn:
    """The body's rates over the last ``span`` seconds [s] (module docstring)."""

    def __init__(self, span: float) -> None:
        self.span = span
        self._steps: deque[tuple[float, float, float, float]] = deque()
        self._seconds = 0.0

    def add(self, rate: Sequence[float], dt: float) -> None:
        """One step: the body rate [rad/s] held over ``dt`` [s]."""
        self._steps.append((rate[0], rate[1], rate[2], dt))
        self._seconds += dt
        while self._steps and self._seconds - self._steps[0][3] >= self.span:
            self._seconds -= self._steps.popleft()[3]

    def turn(self, seconds: float) -> tuple[float, float, float]:
        """The body-frame rotation vector [rad] turned over the last ``seconds`` [s] (the
        sum of ``ω Δt``, the oldest step in part; at most the steps kept)."""
        x = y = z = 0.0
        left = seconds
        for wx, wy, wz, dt in reversed(self._steps):
            if left <= 0.0:
                break
            part = dt if dt <= left else left
            x += wx * part
            y += wy * part
            z += wz * part
            left -= part
        return x, y, z
