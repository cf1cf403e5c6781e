"""One measurement update of the error-state (multiplicative) Kalman filter, and its injection.

A measurement ``z`` of the error state (residual ``y = z − h(x̂)``, model ``y = H δx + v``,
``v ~ N(0, R)``) gives, with ``S = H P Hᵀ + R``:

    K = P Hᵀ S⁻¹,  rows of the considered states (and of any state the measurement must not
    correct) set to zero;
    δx = K y;
    P ← (I − K H) P (I − K H)ᵀ + K R Kᵀ                (Joseph form)

The Joseph form holds for any gain, so the zeroed rows (a Schmidt consider filter; a
magnetometer kept off the tilt) keep the covariance that of the actual error (R. G. Brown,
P. Y. C. Hwang, "Introduction to Random Signals and Applied Kalman Filtering", 4th ed., 2012,
eq. 4.2.18). ``y`` is first tested against ``S``: its normalised squared size ``yᵀ S⁻¹ y``
(chi-square with ``m`` degrees of freedom when the model holds) above ``gate`` rejects it.

**Injection** (F. L. Markley, "Attitude error representations for Kalman filtering", JGCD
26(2), 2003, section III; J. Solà, "Quaternion kinematics for the error-state Kalman filter",
2017, section 7.2): the attitude takes the world-frame correction ``q ← exp(δθ) ⊗ q``, the
gyro bias ``b ← b + δb`` (the error was ``δb = b − b_est``), and the error state restarts at
zero. Solà's reset Jacobian ``G = I − ½ [δθ×]`` (eq. 287, :func:`reset_jacobian_applied`)
is a second-order term that the filter does not apply: with an unknown heading (variance
π²) it turns a tilt correction of a milliradian into a tilt-heading correlation the data never
gave, and the next gravity update then pretends to know the heading (Markley's MEKF keeps
the covariance as it is, section III).
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from rigid_body_attitude.core.attitude.float_quaternion import q_exp, q_multiply, q_normalize

__all__ = ['UpdateResult', 'injected_attitude', 'joseph_update', 'reset_jacobian_applied']

FloatArray = NDArray[np.float64]
BoolArray = NDArray[np.bool_]
Quat = tuple[float, float, float, float]


class UpdateResult(NamedTuple):
    """An update's outcome: ``accepted`` (False: gated out, nothing changed), the correction
    ``dx`` of the error state, the updated covariance and the test statistic ``yᵀ S⁻¹ y``."""

    accepted: bool
    dx: FloatArray
    covariance: FloatArray
    statistic: float


def joseph_update(p: FloatArray, h: FloatArray, residual: FloatArray, r: FloatArray,
                  gain_rows: BoolArray, gate: float = math.inf,
                  bias_projection: FloatArray | None = None) -> UpdateResult:
    """The update of the module docstring: ``p`` (n, n), ``h`` (m, n), ``residual`` (m,),
    ``r`` (m, m); only the states of ``gain_rows`` are corrected, the gyro-bias rows (3-5)
    of the gain multiplied by ``bias_projection`` (3, 3) when given; rejected when
    ``yᵀ S⁻¹ y > gate``."""
    ph = p @ h.T
    s = h @ ph + r
    try:
        s_inverse = np.linalg.inv(s)
    except np.linalg.LinAlgError:
        return UpdateResult(False, np.zeros(p.shape[0]), p, math.inf)
    statistic = float(residual @ s_inverse @ residual)
    if not statistic <= gate:  # NaN too
        return UpdateResult(False, np.zeros(p.shape[0]), p, statistic)
    gain = ph @ s_inverse
    gain[~gain_rows] = 0.0
    if bias_projection is not None:
        gain[3:6] = bias_projection @ gain[3:6]
    dx = gain @ residual
    a = np.eye(p.shape[0]) - gain @ h
    updated = a @ p @ a.T + gain @ r @ gain.T
    return UpdateResult(True, dx, updated, statistic)


def injected_attitude(q: Quat, dtheta: FloatArray) -> Quat:
    """``exp(δθ) ⊗ q``: the attitude ``q`` (w, x, y, z) corrected by the world-frame rotation
    vector ``δθ`` [rad]."""
    return q_normalize(q_multiply(q_exp(float(dtheta[0]), float(dtheta[1]),
                                        float(dtheta[2])), q))


def reset_jacobian_applied(p: FloatArray, dtheta: FloatArray) -> FloatArray:
    """``G P Gᵀ`` with ``G`` the identity but ``I − ½ [δθ×]`` on the attitude block."""
    x, y, z = (0.5 * float(value) for value in dtheta)
    block = np.array([[1.0, z, -y], [-z, 1.0, x], [y, -x, 1.0]])
    out = p.copy()
    out[:3, :] = block @ p[:3, :]
    out[:, :3] = out[:, :3] @ block.T
    return out
