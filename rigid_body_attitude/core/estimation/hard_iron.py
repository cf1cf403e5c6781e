"""The magnetometer's hard iron learned as the body turns: a sphere fit of the body-frame field.

A field homogeneous where the body moves, seen through a magnetometer that carries a hard-iron
offset ``h`` (a magnet on the robot, a motor, a battery's current, a calibration gone stale),
lies on a sphere in the sensor frame: ``|m − h| = F``, ``F`` the local field's norm, whatever
the attitude. Expanded, ``|m|² = 2 m·h + (F² − |h|²)``, linear in ``x = (2h, c)``: the
least-squares fit of ``x`` over the last seconds of samples (each interval's mean body-frame
field, its normal equations summed with exponential forgetting over ``hard_iron_time``) gives
``h`` and ``F`` (the flight controllers' in-flight compass learning: PX4's ``mag_bias``
states, ArduPilot's ``COMPASS_LEARN``; the linear fit: Ozyagcilar, "Calibrating an eCompass in
the presence of hard- and soft-iron interference", Freescale AN4246, 2015, the
four-parameter fit).

**Learned only when the data say so** (:meth:`HardIronFit.learned`): the fit's residual
(radial RMS) at most a third of the field-norm tolerance (a disturbance that moves with the
place, a magnet passed by, does not lie on a sphere and is never learned), its radius within
that tolerance of the reference norm (a body-fixed offset leaves the outside field's norm as
it was), its ``h`` larger than five times its 1σ (from the normal equations, samples within
:data:`CORRELATION_TIME` counted as one: the body must have turned about enough axes) and
than 1 % of ``F`` (a smaller offset turns a heading by less than the magnetometer's noise
averages out), and the same ``h`` (within three times that 1σ, and 1 % of ``F``) found again
``hard_iron_time`` later: a field that comes and goes with the body's motion (a vibrating
motor) gives fits that wander and is never learned. The offset learned is
added to the magnetometer's correction and the fit starts anew.

Intervals whose body turns more than :data:`MAX_INTERVAL_TURN` within them are left out
(their mean field falls inside the sphere), and those of a body at rest (the same point over
and over). A field found disturbed after an accepted one starts the fit anew: the samples of
the old offset do not lie on the new sphere.

Assumptions and limitations: the soft iron is calibrated (an ellipsoid would need a
nine-parameter fit); the offset changes seldom compared with ``hard_iron_time``.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

__all__ = ['CORRELATION_TIME', 'HardIronFit', 'MAX_INTERVAL_TURN', 'MIN_INTERVAL_TURN']

FloatArray = NDArray[np.float64]

#: Largest turn [rad] within an interval whose mean field enters the fit.
MAX_INTERVAL_TURN = 0.2
#: Smallest (RMS rate times length): a body at rest adds one point of the sphere over and over.
MIN_INTERVAL_TURN = 0.005
#: Correlation time [s] of the field's departures from the sphere (the body turns through a
#: radian within it, and the errors of the calibration and of the place change): samples
#: closer than that count as one in the fit's uncertainty.
CORRELATION_TIME = 0.5


class HardIronFit:
    """The sphere fit of the module docstring.

    Args:
        forgetting_time: ``hard_iron_time`` [s].
        norm_tolerance: ``field_norm_tolerance`` (relative).
    """

    def __init__(self, forgetting_time: float, norm_tolerance: float) -> None:
        self.forgetting_time = forgetting_time
        self.norm_tolerance = norm_tolerance
        self.clear()

    def clear(self) -> None:
        """Forget every sample and the candidate."""
        self._candidate: FloatArray | None = None
        self._candidate_age = 0.0
        self._normal = np.zeros((4, 4))
        self._right = np.zeros(4)
        self._squares = 0.0
        self._duration = CORRELATION_TIME

    def add(self, field_body: FloatArray, duration: float) -> None:
        """One interval's mean field [T] (sensor frame, corrected) over ``duration`` [s]."""
        self._duration = duration
        self._candidate_age += duration
        decay = math.exp(-duration / self.forgetting_time)
        row = np.array([field_body[0], field_body[1], field_body[2], 1.0])
        target = float(field_body @ field_body)
        self._normal = self._normal * decay + np.outer(row, row)
        self._right = self._right * decay + row * target
        self._squares = self._squares * decay + target * target

    def fit(self) -> tuple[FloatArray, float, float, float] | None:
        """``(h [T], F [T], radial RMS [T], 1σ of h [T])``, or None while the normal
        equations are singular."""
        count = float(self._normal[3, 3])
        if count < 10.0:
            return None
        try:
            inverse = np.linalg.inv(self._normal)
        except np.linalg.LinAlgError:
            return None
        x = inverse @ self._right
        offset = 0.5 * x[:3]
        radius2 = float(x[3] + offset @ offset)
        if not (np.all(np.isfinite(x)) and radius2 > 0.0):
            return None
        radius = math.sqrt(radius2)
        variance = max(self._squares - float(x @ self._right), 0.0) / count  # of |m|², T⁴
        radial = math.sqrt(variance) / (2.0 * radius)
        correlated = max(CORRELATION_TIME / self._duration, 1.0)
        spread = 0.5 * math.sqrt(max(float(np.max(np.diag(inverse)[:3])), 0.0) * variance
                                 * correlated)
        return offset, radius, radial, spread

    def learned(self, reference_norm: float) -> FloatArray | None:
        """The offset [T] to add to the correction when the fit passes every test of the
        module docstring against the reference norm [T] (the fit then starts anew), else
        None."""
        result = self.fit()
        if result is None:
            return None
        offset, radius, radial, spread = result
        tolerance = self.norm_tolerance * reference_norm
        small = 0.01 * reference_norm
        if not (radial <= tolerance / 3.0 and abs(radius - reference_norm) <= tolerance
                and float(np.linalg.norm(offset)) > max(5.0 * spread, small)):
            return None
        candidate = self._candidate
        if candidate is None or float(np.linalg.norm(offset - candidate)) > max(
                3.0 * spread, small):
            self._candidate, self._candidate_age = offset, 0.0
            return None
        if self._candidate_age < self.forgetting_time:
            return None
        self.clear()
        return offset
