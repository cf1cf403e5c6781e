"""A strapdown attitude with the filter, sample by sample, as a gyro session runs it.

:class:`FilteredStrapdown` is the sequence a session follows, without ROS, for studies, tests
and benchmarks:

1. **levelling** (:class:`~rigid_body_attitude.core.estimation.alignment.GravityAligner`):
   wait for rest, average ``align_seconds`` of it; the magnetometer's samples over the same
   rest are averaged alongside (:mod:`.estimator_start`);
2. **per sample** after it: the rate less the bias estimate, the strapdown step
   ``q ← q ⊗ exp(ω Δt)`` with the rate of the sample that ends the step (the ``delta_single``
   method of the shipped ``strapdown`` scene), :meth:`AttitudeEstimator.sample` with the step;
   each magnetometer sample goes to :meth:`AttitudeEstimator.magnetic_field`;
3. **per update interval**: :meth:`AttitudeEstimator.update`, whose corrected attitude and
   bias the next steps use.

Samples are body-frame (calibration and mount applied); rates [rad/s], specific force
[m/s²], field [T], ``dt`` [s].
"""

from __future__ import annotations

from rigid_body_attitude.core.attitude.quaternion import scalar_exp_step
from rigid_body_attitude.core.estimation.alignment import ALIGNING, GravityAligner
from rigid_body_attitude.core.estimation.estimator import AttitudeEstimator
from rigid_body_attitude.core.estimation.estimator_start import start_estimator

__all__ = ['FilteredStrapdown']

Quat = tuple[float, float, float, float]
Vec = tuple[float, float, float]


class FilteredStrapdown:
    """Levelling, strapdown and filter (module docstring).

    Args:
        estimator: the filter (not started).
        aligner: the levelling.
        use_magnetometer: whether fields given to :meth:`add` are used.
    """

    def __init__(self, estimator: AttitudeEstimator, aligner: GravityAligner,
                 use_magnetometer: bool = True) -> None:
        self.estimator = estimator
        self.aligner = aligner
        self.use_magnetometer = use_magnetometer
        self.attitude: Quat = (1.0, 0.0, 0.0, 0.0)
        #: The last bias-corrected body rate [rad/s].
        self.rate: Vec = (0.0, 0.0, 0.0)
        self.started = False
        self._field_sum = [0.0, 0.0, 0.0]
        self._field_count = 0

    def add(self, rate: Vec, specific_force: Vec, field: Vec | None, dt: float) -> bool:
        """One IMU sample (and the magnetometer's, if any); returns whether the attitude is
        estimated (levelling done)."""
        if not self.started:
            return self._level(rate, specific_force, field, dt)
        estimator = self.estimator
        b = estimator.gyro_bias
        corrected = (rate[0] - b[0], rate[1] - b[1], rate[2] - b[2])
        self.rate = corrected
        q_before = self.attitude
        q = scalar_exp_step(q_before, corrected, dt)
        due = estimator.sample(q_before, corrected, dt, q, specific_force)
        if field is not None and self.use_magnetometer:
            estimator.magnetic_field(q, field)
        self.attitude = estimator.update(q) if due else q
        return True

    def _level(self, rate: Vec, specific_force: Vec, field: Vec | None, dt: float) -> bool:
        aligner = self.aligner
        done = aligner.update(*rate, *specific_force, dt)
        if field is not None and self.use_magnetometer:
            if aligner.state == ALIGNING or done:
                self._field_sum = [s + v for s, v in zip(self._field_sum, field)]
                self._field_count += 1
            else:
                self._field_sum, self._field_count = [0.0, 0.0, 0.0], 0
        if not done:
            return False
        at_rest = aligner.state != 'aligned_without_rest'
        f = aligner.specific_force
        gravity = (f[0] * f[0] + f[1] * f[1] + f[2] * f[2]) ** 0.5
        mean_field = None
        if self._field_count:
            mean_field = tuple(s / self._field_count for s in self._field_sum)
        self.attitude = start_estimator(
            self.estimator, aligner.attitude, aligner.gyro_bias,
            aligner.align_seconds if at_rest else None, gravity, mean_field, self._field_count)
        self.started = True
        return True
