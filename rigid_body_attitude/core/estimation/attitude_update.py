"""An external attitude measurement (a star tracker, motion capture) as an update.

A measured attitude ``q_m`` with its 3×3 covariance ``R`` about fixed world axes (the
orientation block of a ``geometry_msgs/PoseWithCovarianceStamped``, REP-145) gives the
residual ``y = log(q_m ⊗ q_est*)``, the world-frame rotation from the estimate to the
measurement, and ``H = [I 0]``: ``q_m = exp(v) ⊗ q_true`` and ``q_true = exp(δθ) ⊗ q_est``
give ``y = δθ + v`` to first order (F. L. Markley, J. L. Crassidis, "Fundamentals of
Spacecraft Attitude Determination and Control", Springer 2014, section 6.2.4). Every
estimated state is corrected through the covariance; the measurement's own noise is assumed
white (one measurement does not know the next).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

from rigid_body_attitude.core.attitude import quaternion
from rigid_body_attitude.core.errors import InputError
from rigid_body_attitude.core.estimation.attitude_covariance import checked_attitude_covariance
from rigid_body_attitude.core.estimation.filter_covariance import ATTITUDE, FILTER_STATE_SIZE

__all__ = ['attitude_measurement']

FloatArray = NDArray[np.float64]


def attitude_measurement(q_estimate: Sequence[float], q_measured: Sequence[float],
                         covariance: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray]:
    """``(h, y, r)`` of the measurement (module docstring); InputError naming a non-finite or
    zero ``q_measured`` or a covariance that is not one (checked as ``set_pose``'s)."""
    measured = quaternion.as_quaternion(q_measured, 'q_measured')
    if measured.shape != (4,) or not float(np.abs(measured).sum()) > 0.0:
        raise InputError(f'Expected `q_measured` as 4 finite numbers, not all zero, got '
                         f'{tuple(q_measured)!r}')
    r = checked_attitude_covariance(covariance, 'attitude covariance')
    residual = quaternion.log(quaternion.multiply(
        quaternion.normalize(measured), quaternion.conjugate(np.array(q_estimate))))
    h = np.zeros((3, FILTER_STATE_SIZE))
    h[:, ATTITUDE] = np.eye(3)
    return h, residual, r
