"""The effect kinds held over each integration step: :class:`HeldOverStep` and
:class:`RotorState` (reaction wheels), beside the kinds of :mod:`.base`."""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Mapping
from typing import Any

from rigid_body_attitude.core.dynamics.effects.base import (
    BatchChunk, Effect, FloatArray, Quat, RotorEffect, Vec)

__all__ = ['HeldOverStep', 'RotorState']


class HeldOverStep(Effect, ABC):
    """An effect whose output is held constant over each integration step.

    The propagators call :meth:`hold` at the start of every step (and substep) with the state
    there, before the integrator evaluates anything; the effect then answers every evaluation
    inside the step with what it held (a wheel drive's torque, a coil's dipole: a zero-order
    hold at the scene's step). :meth:`batch_hold` is the same for a chunk of bodies, whose
    per-body rows are ``chunk.state`` (:attr:`batch_state_rows` of them).
    """

    @abstractmethod
    def hold(self, t: float, h: float, q: Quat, omega: Vec) -> None:
        """Hold the output for the step ``[t, t + h]`` from the state ``(q, ω)`` at ``t``."""

    def batch_state_rows(self) -> int:
        """Rows of per-body state this effect keeps in a batch."""
        return 0

    def batch_start(self, omega: FloatArray, chunk: BatchChunk) -> None:
        """Initialise the per-body rows of ``chunk.state`` from the rates ``omega`` (3, n)."""

    @abstractmethod
    def batch_hold(self, t: float, h: float, q: FloatArray, omega: FloatArray,
                   chunk: BatchChunk) -> None:
        """:meth:`hold` for every body of ``chunk`` (``q`` (4, n), ``omega`` (3, n))."""


class RotorState(HeldOverStep, RotorEffect, ABC):
    """Rotors whose speeds are an integrated state of their own (reaction wheels).

    Each rotor ``i`` spins about a body axis ``âᵢ`` with spin inertia ``Jₛᵢ``; its state is
    the absolute axial momentum ``Hᵢ = Jₛᵢ (Ωᵢ + âᵢ·ω)`` (``Ωᵢ`` its speed relative to the
    body), driven by the net axial torque ``uᵢ`` (motor minus friction) that :meth:`hold`
    holds over the step: ``Hᵢ(t) = Hᵢ(tₖ) + uᵢ (t − tₖ)`` is exact inside the step, so
    :meth:`rotor` gives ``h = Σ Hᵢ âᵢ`` and ``ḣ = Σ uᵢ âᵢ`` at any stage. The body then obeys
    ``J' ω̇ + ω × (J' ω + h) = M − ḣ`` with ``J' = J − Σ Jₛᵢ âᵢ âᵢᵀ``
    (:meth:`spin_inertia_body`; ``J`` the whole body with the rotors locked). The total
    kinetic energy is ``½ ωᵀ J' ω + Σ Hᵢ²/(2 Jₛᵢ)`` (:meth:`kinetic_energy`); :meth:`commit`
    advances the state at the step's end and returns the change of that own energy, which
    with the integrator's work ``∫ ω·(M − ḣ) dt`` is the work of the external torques, the
    motors and the friction.
    """

    @abstractmethod
    def spin_inertia_body(self) -> FloatArray:
        """``Σ Jₛᵢ âᵢ âᵢᵀ`` [kg m²] (3, 3), body axes."""

    @abstractmethod
    def start(self, omega_body: Vec) -> None:
        """Set the state from the initial rotor speeds and the body rate ``omega_body``."""

    @abstractmethod
    def commit(self, t: float, h: float, omega_start: Vec, omega_end: Vec) -> float:
        """Advance the state to ``t + h`` with the held torques; return the change [J] of
        :meth:`kinetic_energy` over the step."""

    @abstractmethod
    def kinetic_energy(self) -> float:
        """``Σ Hᵢ²/(2 Jₛᵢ)`` [J]: the rotors' axial kinetic energy."""

    @abstractmethod
    def stored_momentum(self) -> Vec:
        """``Σ Jₛᵢ Ωᵢ âᵢ`` [N m s, body]: the momentum the rotors hold relative to the body
        (what momentum dumping takes out)."""

    @abstractmethod
    def batch_spin_inertia(self, parameters: Mapping[str, Any], count: int) -> FloatArray:
        """:meth:`spin_inertia_body` of ``count`` bodies from their batch parameters, shape
        (3, 3, count) or (3, 3, 1) when shared."""

    @abstractmethod
    def batch_commit(self, t: float, h: float, omega_start: FloatArray,
                     omega_end: FloatArray, chunk: BatchChunk) -> None:
        """:meth:`commit` for every body of ``chunk`` (its state rows)."""
