"""The filter's magnetometer channel: samples in, one heading measurement per interval out.

Per magnetometer sample (:meth:`MagnetometerChannel.add`): the hard- and soft-iron correction
(:class:`~rigid_body_attitude.core.estimation.magnetometer.MagnetometerCalibration`), the
sensor-frame sum for the hard-iron fit (:mod:`.hard_iron`), the body's turn over the sample's
delay undone (:func:`~rigid_body_attitude.core.estimation.magnetometer.turned_back`) and the
world-frame sum (:class:`~rigid_body_attitude.core.estimation.interval_sums.MagneticInterval`).
Per update interval (:meth:`MagnetometerChannel.measurement`): the field's norm and dip checked
(:mod:`.field_reference`), the hard-iron fit fed and, when it learns an offset, the correction
extended, the timing's heading variance (:mod:`.magnetometer`), and the heading measurement
of an accepted field; every other outcome counted by reason.
"""

from __future__ import annotations

import math
from collections import Counter

import numpy as np
from numpy.typing import NDArray

from rigid_body_attitude.core.errors import InputError
from rigid_body_attitude.core.estimation.estimator_settings import EstimatorSettings
from rigid_body_attitude.core.estimation.field_reference import (
    ACCEPTED, SETTLING, FieldReference)
from rigid_body_attitude.core.estimation.hard_iron import (
    MAX_INTERVAL_TURN, MIN_INTERVAL_TURN, HardIronFit)
from rigid_body_attitude.core.estimation.interval_sums import MagneticInterval, RecentTurn
from rigid_body_attitude.core.estimation.magnetometer import (
    HeadingMeasurement, MagnetometerCalibration, heading_measurement, turned_back)

__all__ = ['FIELD_LIMIT', 'MAX_FIELD_AGE', 'MagnetometerChannel']

FloatArray = NDArray[np.float64]
Quat = tuple[float, float, float, float]
Vec = tuple[float, float, float]

#: Largest field magnitude [T] a sample may have.
FIELD_LIMIT = 1.0e-2
#: Largest age [s] of a magnetometer sample behind the last gyro sample (beyond the
#: magnetometer's own delay) that is paired with the attitude at its instant.
MAX_FIELD_AGE = 0.1


class MagnetometerChannel:
    """The magnetometer's side of the filter (module docstring).

    Args:
        settings: the filter's settings.
        calibration: the hard- and soft-iron correction.
        sample_rate: the IMU's rate [Hz].
        axes: the world's east, north and up.
        counts: the filter's counts (outcomes are added here).
    """

    def __init__(self, settings: EstimatorSettings, calibration: MagnetometerCalibration,
                 sample_rate: float, axes: tuple[FloatArray, FloatArray, FloatArray],
                 counts: Counter[str]) -> None:
        self.settings = settings
        self.calibration = calibration
        self.sample_rate = sample_rate
        self.east, self.north, self.up = axes
        self.counts = counts
        self.interval = MagneticInterval()
        self.recent = RecentTurn(settings.magnetometer_delay + MAX_FIELD_AGE)
        self.hard_iron = (HardIronFit(settings.hard_iron_time, settings.field_norm_tolerance)
                          if settings.learn_hard_iron else None)
        #: The field's reference (None: no magnetometer at start).
        self.reference: FieldReference | None = None
        self._accepted = True

    def add(self, q: Quat, field: Vec, age: float) -> None:
        """One sample [T] (sensor frame, uncorrected), ``age`` [s] behind the attitude ``q``
        (module docstring); InputError for a non-finite, zero or out-of-range field or age."""
        mx, my, mz = field
        if not 0.0 < mx * mx + my * my + mz * mz <= FIELD_LIMIT ** 2:
            raise InputError(f'Expected a finite, non-zero magnetic field of at most '
                             f'{FIELD_LIMIT:g} T, got {tuple(field)!r}')
        if not -MAX_FIELD_AGE <= age <= MAX_FIELD_AGE:
            raise InputError(f'Expected the magnetometer sample\'s age within '
                             f'{MAX_FIELD_AGE:g} s of the gyro\'s, got {age!r}')
        corrected = self.calibration.corrected(field)
        self.interval.add_body(corrected)
        lag = self.settings.magnetometer_delay + age
        if lag > 0.0:
            corrected = turned_back(corrected, self.recent.turn(lag))
        self.interval.add(q, corrected)

    def measurement(self, rotation: FloatArray, speed: float, rms_rate: float
                    ) -> HeadingMeasurement | None:
        """The interval's heading measurement, its field turned by ``rotation`` (the updates
        made since its samples), the body's mean and RMS rates [rad/s]; None when there is
        no field, no reference or the field is not accepted (the outcome counted)."""
        reference, count = self.reference, self.interval.count
        if reference is None or count == 0:
            return None
        settings = self.settings
        mean_field = rotation @ np.array(self.interval.mean())
        duration = count / self.sample_rate
        outcome = reference.check(mean_field, self.up, speed, duration)
        self._learn(rms_rate * duration, outcome, duration)
        timing = math.hypot(speed * settings.magnetometer_timing,
                            0.5 * (rms_rate * settings.magnetometer_delay) ** 2)
        if outcome == ACCEPTED and timing > settings.magnetic_disturbance_stddev:
            outcome = 'turning'  # the timing error would exceed the disturbance tolerated
        if outcome != ACCEPTED:
            self.counts[f'magnetometer_{outcome}'] += 1
            return None
        noise = settings.magnetometer_noise_density ** 2 * self.sample_rate / count
        return heading_measurement(mean_field, self.east, self.north, settings.declination,
                                   noise, timing * timing)

    def _learn(self, turn: float, outcome: str, duration: float) -> None:
        """The interval's sensor-frame field into the hard-iron fit (:mod:`.hard_iron`: a
        field found disturbed after an accepted one starts the fit anew); an offset learned
        extends the correction."""
        fit, reference = self.hard_iron, self.reference
        if fit is None or reference is None:
            return
        if self._accepted and outcome not in (ACCEPTED, SETTLING):
            fit.clear()
        self._accepted = outcome == ACCEPTED
        if not MIN_INTERVAL_TURN <= turn <= MAX_INTERVAL_TURN:
            return
        fit.add(np.array(self.interval.mean_body()), duration)
        offset = fit.learned(reference.norm)
        if offset is not None:
            self.calibration = self.calibration.learned(offset)
            self.counts['hard_iron_learned'] += 1
