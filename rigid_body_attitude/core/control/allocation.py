"""Torque allocation over reaction wheels: the minimum-norm pseudo-inverse.

A body torque ``τ_c`` [N m, body] is asked of ``N`` wheels with spin axes ``âᵢ`` (the columns
of ``A = [â₁ … â_N]``). A motor torque ``τₘᵢ`` on wheel ``i`` turns the body by ``−τₘᵢ âᵢ``,
so the motor torques ``τₘ = −A⁺ τ_c`` give the body ``−A τₘ = τ_c`` when the wheels span the
three axes, with the least ``|τₘ|`` of all that do (the Moore-Penrose pseudo-inverse
``A⁺ = Aᵀ (A Aᵀ)⁻¹``; F. L. Markley and J. L. Crassidis, *Fundamentals of Spacecraft Attitude
Determination and Control*, 2014, sec. 7.3 (reaction-wheel torque distribution)). With fewer
than three independent axes the body gets the projection of ``τ_c`` on their span.
Limitations: each wheel's torque and speed limits are the wheel's (the effect clips them);
no null-space management of the wheel speeds.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

__all__ = ['minimum_norm_allocation', 'wheel_torques']

FloatArray = NDArray[np.float64]


def minimum_norm_allocation(axes: Sequence[Sequence[float]] | FloatArray
                            ) -> list[list[float]]:
    """``A⁺`` as ``N`` rows of 3 plain floats, from the wheels' unit spin axes (``N`` rows
    of 3, body axes)."""
    matrix = np.asarray(axes, dtype=np.float64)
    if matrix.ndim != 2 or matrix.shape[1] != 3 or matrix.shape[0] < 1:
        raise ValueError(f'Expected wheel axes of shape (N, 3), got {matrix.shape}')
    rows: list[list[float]] = np.linalg.pinv(matrix.T).tolist()
    return rows


def wheel_torques(allocation: Sequence[Sequence[float]],
                  torque_body: Sequence[float]) -> tuple[float, ...]:
    """``τₘ = −A⁺ τ_c`` [N m]: the motor torques giving the body ``torque_body``."""
    tx, ty, tz = torque_body
    return tuple(-(a * tx + b * ty + c * tz) for a, b, c in allocation)
