"""Magnetic control laws: B-dot detumbling and cross-product momentum dumping.

* **B-dot** (A. C. Stickler and K. T. Alfriend, "Elementary magnetic attitude control system",
  Journal of Spacecraft and Rockets 13(5):282-287, 1976; Markley and Crassidis, *Fundamentals
  of Spacecraft Attitude Determination and Control*, 2014, sec. 7.5): the dipole
  ``m = −k Ḃ_b`` [A m²] opposes the change of the field measured in body axes; with
  ``Ḃ_b ≈ −ω × B_b`` (the field turning slowly in the world) the torque
  ``m × B_b = −k |B|² ω_⊥`` damps the rate across the field. Sampled: ``Ḃ_b`` is the
  difference of two field samples a control period apart (zero at the first sample).
* **Cross-product dumping** (Markley and Crassidis 2014, ch. 7, momentum dumping with
  magnetic torquers): the dipole
  ``m = k (h_w × B_b) / |B_b|²`` [A m²] gives the torque ``m × B_b = −k h_w,⊥``, which takes
  the wheels' stored momentum ``h_w`` out across the field (the attitude controller then
  slows the wheels); zero where ``|B|`` is zero.

Both are plain-float functions of body vectors; the rows versions serve the batch engine.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

__all__ = ['bdot_dipole', 'bdot_dipole_rows', 'dumping_dipole', 'dumping_dipole_rows']

Vec = tuple[float, float, float]
FloatArray = NDArray[np.float64]


def bdot_dipole(field_body: Vec, previous_field_body: Vec | None, period: float,
                gain: float) -> Vec:
    """``−k (B − B_prev) / T`` [A m²] from two body-frame field samples [T] a ``period`` [s]
    apart; zero without a previous sample."""
    if previous_field_body is None:
        return 0.0, 0.0, 0.0
    scale = -gain / period
    return (scale * (field_body[0] - previous_field_body[0]),
            scale * (field_body[1] - previous_field_body[1]),
            scale * (field_body[2] - previous_field_body[2]))


def bdot_dipole_rows(field_body: FloatArray, previous_field_body: FloatArray, period: float,
                     gain: float | FloatArray, out: FloatArray) -> FloatArray:
    """:func:`bdot_dipole` for every body (rows (3, n))."""
    np.subtract(field_body, previous_field_body, out=out)
    out *= -np.asarray(gain) / period
    return out


def dumping_dipole(wheel_momentum_body: Vec, field_body: Vec, gain: float) -> Vec:
    """``k (h_w × B) / |B|²`` [A m²] (zero for a zero field)."""
    hx, hy, hz = wheel_momentum_body
    bx, by, bz = field_body
    square = bx * bx + by * by + bz * bz
    if square == 0.0:
        return 0.0, 0.0, 0.0
    scale = gain / square
    return (scale * (hy * bz - hz * by), scale * (hz * bx - hx * bz),
            scale * (hx * by - hy * bx))


def dumping_dipole_rows(wheel_momentum_body: FloatArray, field_body: FloatArray,
                        gain: float | FloatArray) -> FloatArray:
    """:func:`dumping_dipole` for every body (rows (3, n))."""
    square = np.einsum('in,in->n', field_body, field_body)
    scale = np.divide(np.asarray(gain, dtype=np.float64) * np.ones_like(square), square,
                      out=np.zeros_like(square), where=square > 0.0)
    result: FloatArray = np.cross(wheel_momentum_body.T, field_body.T).T * scale
    return result
