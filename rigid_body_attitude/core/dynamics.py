"""Euler's rigid-body equations and the body model the dynamics integrators advance.

Body axes, full symmetric inertia ``J`` about the centre of mass (or the fixed point), rotor
(gyrostat) momentum ``h`` in body axes (physics.md §1, seed 002 §8):

    J ω̇ + ω × (J ω + h) = M − ḣ,        q̇ = ½ q ⊗ (0, ω).

:class:`RigidBodyModel` bundles the inertia and the summed effect torques and rotor momenta so
that integrators see one small object and know no effect.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from rigid_body_attitude.core.errors import InputError, IntegratorError
from rigid_body_attitude.core.inertia import Inertia
from rigid_body_attitude.core.integrators.rigid_body_rk4 import rk4_state_step

__all__ = ['RigidBodyModel', 'euler_rate', 'rk4_step']

FloatArray = NDArray[np.float64]
TorqueFunction = Callable[[float, FloatArray, FloatArray], FloatArray]
RotorFunction = Callable[[float], tuple[FloatArray, FloatArray]]

_ZERO3 = np.zeros(3)


def euler_rate(inertia: Inertia, omega_body: FloatArray, torque_body: FloatArray,
               rotor_momentum: FloatArray = _ZERO3,
               rotor_momentum_rate: FloatArray = _ZERO3) -> FloatArray:
    """``ω̇ = J⁻¹ (M − ḣ − ω × (J ω + h))`` [rad/s²], all vectors in body axes."""
    momentum = inertia.tensor @ omega_body + rotor_momentum
    return inertia.inverse @ (torque_body - rotor_momentum_rate - np.cross(omega_body, momentum))


@dataclass
class RigidBodyModel:
    """What a dynamics integrator needs to know about the body: inertia, torques and rotors.

    Attributes:
        inertia: the validated inertia tensor [kg m²] in body axes.
        torque_functions: callables ``(t, attitude, omega_body) -> torque_body [N m]`` summed
            into ``M``; empty for a torque-free body.
        rotor_functions: callables ``t -> (h_body [N m s], ḣ_body [N m])`` summed into the
            gyrostat terms; empty when there is no rotor.
        torque_depends_on_rate: False when no torque function uses ``omega_body`` (the
            propagator sets it from its effects); the splitting methods then apply a torque
            kick exactly, in one evaluation. True (the safe default) otherwise.
    """

    inertia: Inertia
    torque_functions: Sequence[TorqueFunction] = field(default_factory=tuple)
    rotor_functions: Sequence[RotorFunction] = field(default_factory=tuple)
    torque_depends_on_rate: bool = True
    tensor_entries: tuple[float, ...] = field(init=False, repr=False)
    inverse_entries: tuple[float, ...] = field(init=False, repr=False)

    def __post_init__(self) -> None:
        """Keep ``J`` and ``J⁻¹`` as row-major float tuples for plain-float hot paths."""
        self.tensor_entries = tuple(self.inertia.tensor.ravel().tolist())
        self.inverse_entries = tuple(self.inertia.inverse.ravel().tolist())

    @property
    def torque_free(self) -> bool:
        """True when no torque and no rotor act: the exact and splitting methods apply."""
        return not self.torque_functions and not self.rotor_functions

    @property
    def has_rotor(self) -> bool:
        """True when a rotor (gyrostat momentum) acts."""
        return bool(self.rotor_functions)

    @property
    def inverse_inertia(self) -> FloatArray:
        """``J⁻¹`` [1/(kg m²)]."""
        return self.inertia.inverse

    @property
    def principal_moments(self) -> FloatArray:
        """Principal moments in ascending order [kg m²]."""
        return self.inertia.principal_moments

    @property
    def principal_axes(self) -> FloatArray:
        """Columns are the principal axes in body coordinates."""
        return self.inertia.principal_axes

    def torque_body(self, t: float, attitude: FloatArray, omega_body: FloatArray) -> FloatArray:
        """Sum of the effect torques at ``(t, attitude, omega_body)`` [N m, body axes]."""
        total = np.zeros(3)
        for torque in self.torque_functions:
            total = total + torque(t, attitude, omega_body)
        return total

    def rotor_momentum(self, t: float) -> tuple[FloatArray, FloatArray]:
        """Summed rotor momentum ``h`` and its rate ``ḣ`` at ``t`` (body axes)."""
        momentum = np.zeros(3)
        rate = np.zeros(3)
        for rotor in self.rotor_functions:
            h, h_dot = rotor(t)
            momentum = momentum + h
            rate = rate + h_dot
        return momentum, rate

    def omega_dot(self, t: float, attitude: FloatArray, omega_body: FloatArray) -> FloatArray:
        """Angular acceleration from Euler's equations with every effect included."""
        torque = self.torque_body(t, attitude, omega_body) if self.torque_functions else _ZERO3
        if not self.rotor_functions:
            return euler_rate(self.inertia, omega_body, torque)
        h, h_dot = self.rotor_momentum(t)
        return euler_rate(self.inertia, omega_body, torque, h, h_dot)

    def external_torque(self, t: float, attitude: FloatArray,
                        omega_body: FloatArray) -> FloatArray:
        """``M − ḣ``: the torque whose power ``ω·(M − ḣ)`` changes the kinetic energy."""
        torque = self.torque_body(t, attitude, omega_body) if self.torque_functions else _ZERO3
        if self.rotor_functions:
            torque = torque - self.rotor_momentum(t)[1]
        return torque


def _all_finite(h: float, values: tuple[float, ...]) -> bool:
    """Whether ``h`` and every value are finite numbers (False for nested sequences)."""
    try:
        return math.isfinite(h) and all(map(math.isfinite, values))
    except TypeError:
        return False


def rk4_step(model: RigidBodyModel, t: float, attitude: FloatArray, omega_body: FloatArray,
             h: float) -> tuple[FloatArray, FloatArray]:
    """Classical RK4 on ``(q, ω)`` jointly, then ``q`` renormalised: the ``rk4`` integrator's
    step (:func:`.integrators.rigid_body_rk4.rk4_state_step`) on arrays, with its checks.

    Raises :class:`InputError` for a non-finite ``h`` or state or wrong shapes and
    :class:`IntegratorError` for a non-finite result. Order 4; cost 4 evaluations of Euler's
    equations and of the torques per step, in plain float math (no NumPy per-call overhead
    for a torque-free body). Keeps ``|q| = 1`` by
    projection only (RK4 alone shrinks ``|q|`` by about ``(h|ω|)⁶/9216`` per step,
    physics.md §6); energy and momentum drift at O(h⁴) per unit time. The baseline every other
    method is measured against (Kutta 1901; Hairer, Nørsett & Wanner, *Solving ODEs I*, §II.1).
    """
    y0 = tuple(attitude.tolist()) + tuple(omega_body.tolist())
    if len(y0) != 7 or not _all_finite(h, y0):
        raise InputError(f'Expected a finite step `h`, `attitude` (4,) and `omega_body` (3,), '
                         f'got h={h!r}, attitude={attitude.tolist()!r}, '
                         f'omega_body={omega_body.tolist()!r}')
    y1 = list(rk4_state_step(model, t, y0, h))
    norm = math.sqrt(y1[0] * y1[0] + y1[1] * y1[1] + y1[2] * y1[2] + y1[3] * y1[3])
    if not (norm > 0.0 and all(map(math.isfinite, y1))):
        raise IntegratorError(f'RK4 step of h={h!r} from attitude {list(y0[:4])!r}, omega_body '
                              f'{list(y0[4:])!r} gave the non-finite state {y1!r}; reduce the '
                              f'step')
    return np.array(y1[:4]) / norm, np.array(y1[4:])
