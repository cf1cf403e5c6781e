"""The local magnetic field's norm and dip: learned, tracked, and a disturbed field told apart.

A homogeneous field has the same norm ``F`` and dip ``I`` (the angle below the horizontal)
whatever the body's attitude; a nearby magnet or steel changes both. :class:`FieldReference`
learns them at start (the levelling window's mean field, or given), and for each update
interval's mean world-frame field [T] decides (:meth:`FieldReference.check`):

* **accepted** when ``|F̄ − F| ≤ field_norm_tolerance · F`` and ``|Ī − I| ≤
  field_dip_tolerance``; the reference then follows it slowly (an exponential average over
  :data:`TRACKING_TIME`), so a field drifting with temperature or place is tracked;
* **disturbed** (``field_norm`` or ``field_dip``) otherwise: the interval's field is not used,
  the heading is carried by the gyro and its covariance grows;
* **settling**: a field that passes the checks within :data:`SETTLE_TIME` of a disturbed one
  (a magnet moving past may pass them for an instant), not used yet (D. Laidig, T. Seel,
  "VQF", Information Fusion 91, 2023, section 3.4, ``magMinUndisturbedTime``).

A field that stays different but steady (a new room, or a reference learned next to a
magnet) becomes the reference after ``new_field_seconds`` spent within the tolerances of a
*candidate* (an exponential average of every field seen over :data:`CANDIDATE_TIME`) while
the body turns at ``new_field_min_rate`` or faster: a homogeneous field keeps its norm and dip
as the body turns, a magnet carried with the sensor does not (D. Laidig, T. Seel, "VQF",
Information Fusion 91, 2023, section 3.4, ``magNewTime``, ``magNewMinGyr``).

The dip is measured in the world frame (``asin(−up · m̄ / |m̄|)``): a tilt error of the
estimate moves it by at most that error, far below ``field_dip_tolerance``.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

__all__ = ['ACCEPTED', 'CANDIDATE_TIME', 'FIELD_DIP', 'FIELD_NORM', 'FieldReference',
           'SETTLE_TIME', 'SETTLING', 'TRACKING_TIME', 'field_dip']

FloatArray = NDArray[np.float64]

#: Outcomes of :meth:`FieldReference.check`.
ACCEPTED, FIELD_NORM, FIELD_DIP, SETTLING = 'accepted', 'field_norm', 'field_dip', 'settling'
#: How long [s] a field must pass the checks after a disturbance before it is used again
#: (VQF's ``magMinUndisturbedTime``).
SETTLE_TIME = 0.5
#: Averaging time of the reference's tracking [s].
TRACKING_TIME = 60.0
#: Averaging time of the candidate field [s].
CANDIDATE_TIME = 2.0


def field_dip(field_world: FloatArray, up: FloatArray) -> float:
    """The dip [rad] of a world-frame field: positive when it points below the horizontal."""
    norm = float(np.linalg.norm(field_world))
    return math.asin(max(-1.0, min(1.0, -float(up @ field_world) / norm)))


class FieldReference:
    """The learned norm [T] and dip [rad] of the local field (module docstring).

    Args:
        norm, dip: the reference at start.
        norm_tolerance: relative; ``dip_tolerance`` [rad].
        new_field_seconds [s], new_field_min_rate [rad/s]: the new-field rule.
    """

    def __init__(self, norm: float, dip: float, norm_tolerance: float, dip_tolerance: float,
                 new_field_seconds: float, new_field_min_rate: float) -> None:
        self.norm, self.dip = norm, dip
        self.norm_tolerance, self.dip_tolerance = norm_tolerance, dip_tolerance
        self.new_field_seconds = new_field_seconds
        self.new_field_min_rate = new_field_min_rate
        self._candidate = (norm, dip)
        self._candidate_seconds = 0.0
        self._clean_seconds = SETTLE_TIME
        #: Intervals found disturbed, by reason; new references adopted.
        self.rejected = {FIELD_NORM: 0, FIELD_DIP: 0}
        self.new_references = 0

    def _outcome(self, norm: float, dip: float, reference: tuple[float, float]) -> str:
        if abs(norm - reference[0]) > self.norm_tolerance * reference[0]:
            return FIELD_NORM
        if abs(dip - reference[1]) > self.dip_tolerance:
            return FIELD_DIP
        return ACCEPTED

    def check(self, field_world: FloatArray, up: FloatArray, rate: float,
              duration: float) -> str:
        """One interval's mean field [T] (world frame), the body's mean rate magnitude
        [rad/s] and the interval's length [s]: :data:`ACCEPTED`, :data:`FIELD_NORM`,
        :data:`FIELD_DIP` or :data:`SETTLING`."""
        norm, dip = float(np.linalg.norm(field_world)), field_dip(field_world, up)
        weight = min(duration / CANDIDATE_TIME, 1.0)
        candidate = self._candidate
        if self._outcome(norm, dip, candidate) == ACCEPTED:
            if rate >= self.new_field_min_rate:
                self._candidate_seconds += duration
        else:
            self._candidate_seconds = 0.0
        self._candidate = (candidate[0] + weight * (norm - candidate[0]),
                           candidate[1] + weight * (dip - candidate[1]))
        outcome = self._outcome(norm, dip, (self.norm, self.dip))
        if outcome == ACCEPTED:
            self._clean_seconds += duration
            if self._clean_seconds < SETTLE_TIME:
                return SETTLING
            track = min(duration / TRACKING_TIME, 1.0)
            self.norm += track * (norm - self.norm)
            self.dip += track * (dip - self.dip)
            self._candidate_seconds = 0.0
            return ACCEPTED
        self._clean_seconds = 0.0
        if self._candidate_seconds >= self.new_field_seconds:
            self.norm, self.dip = self._candidate
            self._candidate_seconds = 0.0
            self._clean_seconds = SETTLE_TIME
            self.new_references += 1
            return self._outcome(norm, dip, (self.norm, self.dip))
        self.rejected[outcome] += 1
        return outcome
