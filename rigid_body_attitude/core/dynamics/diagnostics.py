"""Energy and angular-momentum diagnostics (Landau & Lifshitz, *Mechanics*, 3rd ed., 1976, §36).

* rotational kinetic energy ``T = ½ ωᵀ J ω`` (+ ``½ m v²`` with translation) [J]; with
  reaction wheels ``½ ωᵀ J' ω + Σ Hᵢ²/(2 Jₛᵢ)`` (``J'`` without the wheels' spin inertia,
  ``Hᵢ`` their absolute axial momenta: :mod:`.effects.reaction_wheels`);
* body angular momentum ``m = J ω + h_rotor`` [N m s] (with wheels ``J' ω + Σ Hᵢ âᵢ``) and
  its world-frame image ``H = R(q) m``, constant for a torque-free body;
* the energy-balance residual ``T − T₀ − W``, where ``W = ∫ (ω·(M − ḣ) + v·F) dt`` is the work
  of the external torques and forces (power theorem ``dT/dt = ω·M``), plus with wheels the
  change of their own energy, so that ``W`` holds the motors' work minus the friction loss;
  zero up to the integrator's error;
* the quaternion norm error ``| |q| − 1 |``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from rigid_body_attitude.core.attitude import quaternion
from rigid_body_attitude.core.dynamics.inertia import Inertia

__all__ = [
    'Diagnostics',
    'DiagnosticsTracker',
    'body_angular_momentum',
    'kinetic_energy',
    'world_angular_momentum',
]

FloatArray = NDArray[np.float64]


def kinetic_energy(inertia: Inertia, omega_body: ArrayLike, mass: float = 0.0,
                   velocity_world: ArrayLike = (0.0, 0.0, 0.0)) -> float:
    """``½ ωᵀ J ω + ½ m v²`` [J]."""
    omega = np.asarray(omega_body, dtype=np.float64)
    velocity = np.asarray(velocity_world, dtype=np.float64)
    return float(0.5 * omega @ inertia.tensor @ omega + 0.5 * mass * velocity @ velocity)


def body_angular_momentum(inertia: Inertia, omega_body: ArrayLike,
                          rotor_momentum_body: ArrayLike = (0.0, 0.0, 0.0)) -> FloatArray:
    """``J ω + h_rotor`` [N m s] in body axes."""
    omega = np.asarray(omega_body, dtype=np.float64)
    return inertia.tensor @ omega + np.asarray(rotor_momentum_body, dtype=np.float64)


def world_angular_momentum(attitude: ArrayLike, inertia: Inertia, omega_body: ArrayLike,
                           rotor_momentum_body: ArrayLike = (0.0, 0.0, 0.0)) -> FloatArray:
    """``R(q) (J ω + h_rotor)`` [N m s] in the world frame (constant when torque-free)."""
    return quaternion.rotate(attitude,
                             body_angular_momentum(inertia, omega_body, rotor_momentum_body))


@dataclass(frozen=True)
class Diagnostics:
    """One snapshot of the invariants and their drift from the initial state.

    Attributes:
        kinetic_energy: ``T`` [J].
        energy_drift: ``(T − T₀)/|T₀|`` (absolute ``T − T₀`` when ``T₀ = 0``).
        energy_balance_residual: ``T − T₀ − W`` [J], ``W`` the work of torques and forces.
        world_angular_momentum: ``H`` [N m s].
        momentum_drift: ``|H − H₀|/|H₀|`` (absolute when ``H₀ = 0``).
        quaternion_norm_error: ``| |q| − 1 |``.
    """

    kinetic_energy: float
    energy_drift: float
    energy_balance_residual: float
    world_angular_momentum: FloatArray
    momentum_drift: float
    quaternion_norm_error: float


class DiagnosticsTracker:
    """Remembers the initial invariants and the accumulated work; reports drift snapshots."""

    def __init__(self, energy: float, world_momentum: FloatArray) -> None:
        """Start tracking from energy ``energy`` [J] and world momentum ``world_momentum``."""
        self.initial_energy = float(energy)
        self.initial_world_momentum = np.array(world_momentum, dtype=np.float64)
        self.work = 0.0

    def add_work(self, work: float) -> None:
        """Accumulate the work [J] done by external torques and forces over one step."""
        self.work += work

    def snapshot(self, attitude: ArrayLike, energy: float,
                 world_momentum: FloatArray) -> Diagnostics:
        """Drift of ``energy`` and ``world_momentum`` against the initial values."""
        energy_change = energy - self.initial_energy
        energy_scale = abs(self.initial_energy)
        momentum_change = float(np.linalg.norm(world_momentum - self.initial_world_momentum))
        momentum_scale = float(np.linalg.norm(self.initial_world_momentum))
        return Diagnostics(
            kinetic_energy=energy,
            energy_drift=energy_change / energy_scale if energy_scale > 0 else energy_change,
            energy_balance_residual=energy_change - self.work,
            world_angular_momentum=world_momentum,
            momentum_drift=(momentum_change / momentum_scale if momentum_scale > 0
                            else momentum_change),
            quaternion_norm_error=float(quaternion.norm_error(attitude)),
        )
