"""Attitude kinematics in Euler angles, Bryant angles and direction cosines, for comparison.

The quaternion integrators are the package's; these exist so the study can show where the
older forms break. Angle conventions are those of
:mod:`rigid_body_attitude.core.attitude.quaternion`
(ZXZ ``q = exp(ψ e_z) ⊗ exp(θ e_x) ⊗ exp(φ e_z)``, XYZ ``q = exp(α₁ e_x) ⊗ exp(α₂ e_y) ⊗
exp(α₃ e_z)``); rates are body-frame. All three use classical RK4 (order 4, three rate
evaluations per step) on a rate given as a function of time.

* Euler angles (Wittenburg, *Dynamics of Multibody Systems*, 2nd ed., 2008, §2.2)::

      ψ̇ = (ω_x sin φ + ω_y cos φ)/sin θ,   θ̇ = ω_x cos φ − ω_y sin φ,
      φ̇ = ω_z − (ω_x sin φ + ω_y cos φ) cot θ         — singular at sin θ = 0.

* Bryant angles (Wittenburg, *Dynamics of Multibody Systems*, 2nd ed., 2008, §2.2)::

      α̇₁ = (ω_x cos α₃ − ω_y sin α₃)/cos α₂,   α̇₂ = ω_x sin α₃ + ω_y cos α₃,
      α̇₃ = ω_z − (ω_x cos α₃ − ω_y sin α₃) tan α₂   — singular at cos α₂ = 0.

* Direction cosines (Poisson's equation, ibid.): ``Ȧ = A ω̃`` with ``v_world = A v_body``;
  nine numbers, no singularity, orthogonality drifts unless re-orthonormalised (optional
  symmetric ``A (AᵀA)^(−1/2)`` projection each step).

Near a singularity the angle rates blow up; when ``|sin θ|`` (``|cos α₂|``) falls below
:data:`SINGULARITY_TOLERANCE` at any stage the step raises :class:`IntegratorError` instead of
returning huge or NaN angles.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence

import numpy as np
from numpy.typing import NDArray

from rigid_body_attitude.core.errors import IntegratorError

__all__ = [
    'SINGULARITY_TOLERANCE',
    'bryant_xyz_rates',
    'bryant_xyz_rk4_step',
    'dcm_poisson_rk4_step',
    'euler_zxz_rates',
    'euler_zxz_rk4_step',
]

FloatArray = NDArray[np.float64]
RateFunction = Callable[[float], Sequence[float]]
Angles = tuple[float, float, float]

#: Below this |sin θ| (Euler) or |cos α₂| (Bryant) a step is refused as singular.
SINGULARITY_TOLERANCE = 1e-9


def euler_zxz_rates(angles: Sequence[float], omega_body: Sequence[float]) -> Angles:
    """``(ψ̇, θ̇, φ̇)`` from body rates (Wittenburg 2008, §2.2); raises at ``sin θ ≈ 0``."""
    _, theta, phi = angles
    wx, wy, wz = omega_body
    sin_theta = math.sin(theta)
    if abs(sin_theta) < SINGULARITY_TOLERANCE:
        raise IntegratorError(f'Euler (ZXZ) angles are singular at sin θ = 0: got θ = '
                              f'{theta!r} rad (|sin θ| < {SINGULARITY_TOLERANCE}); use '
                              f'quaternions')
    s, c = math.sin(phi), math.cos(phi)
    lateral = wx * s + wy * c
    return lateral / sin_theta, wx * c - wy * s, wz - lateral * math.cos(theta) / sin_theta


def bryant_xyz_rates(angles: Sequence[float], omega_body: Sequence[float]) -> Angles:
    """``(α̇₁, α̇₂, α̇₃)`` from body rates (Wittenburg 2008, §2.2); raises at ``cos α₂ ≈ 0``."""
    _, alpha2, alpha3 = angles
    wx, wy, wz = omega_body
    cos_alpha2 = math.cos(alpha2)
    if abs(cos_alpha2) < SINGULARITY_TOLERANCE:
        raise IntegratorError(f'Bryant (XYZ) angles are singular at cos α₂ = 0: got α₂ = '
                              f'{alpha2!r} rad (|cos α₂| < {SINGULARITY_TOLERANCE}); use '
                              f'quaternions')
    s, c = math.sin(alpha3), math.cos(alpha3)
    lateral = wx * c - wy * s
    return (lateral / cos_alpha2, wx * s + wy * c,
            wz - lateral * math.sin(alpha2) / cos_alpha2)


def _rk4_angles(rates: Callable[[Sequence[float], Sequence[float]], Angles],
                angles: Sequence[float], omega_of_time: RateFunction, t: float,
                h: float) -> Angles:
    y0 = tuple(float(a) for a in angles)
    w0, wm, w1 = omega_of_time(t), omega_of_time(t + 0.5 * h), omega_of_time(t + h)
    k1 = rates(y0, w0)
    k2 = rates([a + 0.5 * h * b for a, b in zip(y0, k1)], wm)
    k3 = rates([a + 0.5 * h * b for a, b in zip(y0, k2)], wm)
    k4 = rates([a + h * b for a, b in zip(y0, k3)], w1)
    first, second, third = (a + h / 6.0 * (b + 2.0 * (c + d) + e)
                            for a, b, c, d, e in zip(y0, k1, k2, k3, k4))
    return first, second, third


def euler_zxz_rk4_step(angles: Sequence[float], omega_of_time: RateFunction, t: float,
                       h: float) -> Angles:
    """One RK4 step of the Euler-angle kinematics; :class:`IntegratorError` near sin θ = 0."""
    return _rk4_angles(euler_zxz_rates, angles, omega_of_time, t, h)


def bryant_xyz_rk4_step(angles: Sequence[float], omega_of_time: RateFunction, t: float,
                        h: float) -> Angles:
    """One RK4 step of the Bryant-angle kinematics; :class:`IntegratorError` near cos α₂ = 0."""
    return _rk4_angles(bryant_xyz_rates, angles, omega_of_time, t, h)


def _poisson(matrix: FloatArray, w: Sequence[float]) -> FloatArray:
    skew = np.array([[0.0, -w[2], w[1]], [w[2], 0.0, -w[0]], [-w[1], w[0], 0.0]])
    product: FloatArray = matrix @ skew
    return product


def dcm_poisson_rk4_step(matrix: FloatArray, omega_of_time: RateFunction, t: float, h: float,
                         orthonormalize: bool = False) -> FloatArray:
    """One RK4 step of ``Ȧ = A ω̃`` (``A`` body → world); optional re-orthonormalisation.

    Without projection ``AᵀA − I`` drifts at O(h⁴) per unit time (and grows for fast rates);
    with the symmetric projection ``A (AᵀA)^(−1/2)`` (via the SVD: ``U Vᵀ``) ``A`` stays a
    rotation to round-off. Cost: four 3×3 products (+ one SVD).
    """
    a0 = np.asarray(matrix, dtype=np.float64)
    w0, wm, w1 = omega_of_time(t), omega_of_time(t + 0.5 * h), omega_of_time(t + h)
    k1 = _poisson(a0, w0)
    k2 = _poisson(a0 + 0.5 * h * k1, wm)
    k3 = _poisson(a0 + 0.5 * h * k2, wm)
    k4 = _poisson(a0 + h * k3, w1)
    result = a0 + h / 6.0 * (k1 + 2.0 * (k2 + k3) + k4)
    if not np.all(np.isfinite(result)):
        raise IntegratorError(f'DCM integration produced non-finite entries '
                              f'{result.tolist()!r}; reduce the step')
    if orthonormalize:
        u, _, vt = np.linalg.svd(result)
        result = u @ vt
    return result
