"""Euler's rigid-body equations and the body model the dynamics integrators advance.

Body axes, full symmetric inertia ``J`` about the centre of mass (or the fixed point), rotor
(gyrostat) momentum ``h`` in body axes (Landau & Lifshitz, *Mechanics*, 3rd ed., 1976, §36; the
rotor term: Hughes, *Spacecraft Attitude Dynamics*, 1986, §3.4):

    J ω̇ + ω × (J ω + h) = M − ḣ,        q̇ = ½ q ⊗ (0, ω).

:class:`RigidBodyModel` bundles the inertia and the summed effect torques and rotor momenta so
that integrators see one small object and know no effect.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray

from rigid_body_attitude.core.dynamics.effects import (
    Effect, RotorEffect, RotorState, TorqueEffect)
from rigid_body_attitude.core.errors import InputError, IntegratorError
from rigid_body_attitude.core.dynamics.inertia import Inertia
from rigid_body_attitude.core.dynamics.integrators.base import body_derivative
from rigid_body_attitude.core.dynamics.integrators.rk4_kernel import rk4_state_step

__all__ = ['RigidBodyModel', 'euler_rate', 'inertia_without_rotors', 'rk4_step']

FloatArray = NDArray[np.float64]
Quat = tuple[float, float, float, float]
Vec = tuple[float, float, float]
#: ``(t, q, ω) -> M`` [N m, body] on plain floats (an effect's ``torque``).
FloatTorque = Callable[[float, Quat, Vec], Vec]
#: ``t -> (h, ḣ)`` [N m s, N m; body] on plain floats (an effect's ``rotor``).
FloatRotor = Callable[[float], tuple[Vec, Vec]]
#: Array callables ``(t, attitude, omega_body) -> torque_body`` for scripts.
TorqueFunction = Callable[[float, FloatArray, FloatArray], ArrayLike]
RotorFunction = Callable[[float], tuple[ArrayLike, ArrayLike]]

_ZERO3 = np.zeros(3)
_ZERO: Vec = (0.0, 0.0, 0.0)


def euler_rate(inertia: Inertia, omega_body: FloatArray, torque_body: ArrayLike,
               rotor_momentum: ArrayLike = _ZERO3,
               rotor_momentum_rate: ArrayLike = _ZERO3) -> FloatArray:
    """``ω̇ = J⁻¹ (M − ḣ − ω × (J ω + h))`` [rad/s²], all vectors in body axes."""
    momentum = inertia.tensor @ omega_body + np.asarray(rotor_momentum)
    return np.asarray(inertia.inverse @ (np.asarray(torque_body) - np.asarray(rotor_momentum_rate)
                                         - np.cross(omega_body, momentum)))


def _float_torque(function: TorqueFunction) -> FloatTorque:
    """An array torque callable as a plain-float one."""
    def torque(t: float, q: Quat, omega: Vec) -> Vec:
        x, y, z = np.asarray(function(t, np.array(q), np.array(omega)), dtype=np.float64).tolist()
        return x, y, z
    return torque


def _float_rotor(function: RotorFunction) -> FloatRotor:
    """An array rotor callable as a plain-float one."""
    def rotor(t: float) -> tuple[Vec, Vec]:
        momentum, rate = function(t)
        hx, hy, hz = np.asarray(momentum, dtype=np.float64).tolist()
        rx, ry, rz = np.asarray(rate, dtype=np.float64).tolist()
        return (hx, hy, hz), (rx, ry, rz)
    return rotor


def _floats(values: Sequence[float] | FloatArray) -> tuple[float, ...]:
    """Plain floats from a tuple (as is) or an array."""
    return values if isinstance(values, tuple) else tuple(np.asarray(values).tolist())


class RigidBodyModel:
    """What a dynamics integrator needs to know about the body: inertia, torques and rotors.

    Every torque and rotor is held as a plain-float callable (:data:`FloatTorque`,
    :data:`FloatRotor`; the effects' ``torque`` and ``rotor``), so the integrators' hot loops
    build no array. ``torque_functions`` and ``rotor_functions`` take array callables for
    scripts (converted once, at a NumPy round trip per call); :meth:`from_effects` takes the
    scene's effects.

    Attributes:
        inertia: the validated inertia tensor [kg m²] in body axes.
        torques: plain-float torque callables summed into ``M``; empty for a torque-free body.
        rotors: plain-float rotor callables summed into the gyrostat terms.
        torque_depends_on_rate: False when no torque uses ``ω`` (the splitting methods then
            apply a torque kick exactly, in one evaluation). True (the safe default) otherwise.
        torque_takes_floats: always True: :attr:`torque_body` takes and returns plain floats.
        has_rotor: whether a rotor acts.
        has_torque: whether a torque acts.
        torque_body: ``(t, q, ω) -> M`` [N m], the sum of :attr:`torques` (plain floats).
        rotor_momentum: ``t -> (h, ḣ)``, the sum of :attr:`rotors` (plain floats).
        tensor_entries, inverse_entries: ``J`` and ``J⁻¹`` as row-major 9-tuples of floats.
    """

    torque_body: FloatTorque
    rotor_momentum: FloatRotor

    def __init__(self, inertia: Inertia, torque_functions: Sequence[TorqueFunction] = (),
                 rotor_functions: Sequence[RotorFunction] = (),
                 torque_depends_on_rate: bool = True, *,
                 float_torques: Sequence[FloatTorque] = (),
                 float_rotors: Sequence[FloatRotor] = ()) -> None:
        """A body of ``inertia`` under the given torques and rotors (array or plain-float)."""
        self.inertia = inertia
        self.torques = tuple(float_torques) + tuple(map(_float_torque, torque_functions))
        self.rotors = tuple(float_rotors) + tuple(map(_float_rotor, rotor_functions))
        self.torque_depends_on_rate = bool(torque_depends_on_rate)
        self.torque_takes_floats = True
        self.has_rotor = bool(self.rotors)
        self.has_torque = bool(self.torques)
        self.tensor_entries = tuple(inertia.tensor.ravel().tolist())
        self.inverse_entries = tuple(inertia.inverse.ravel().tolist())
        self.torque_body = self.torques[0] if len(self.torques) == 1 else self._torque_sum
        self.rotor_momentum = self.rotors[0] if len(self.rotors) == 1 else self._rotor_sum

    @classmethod
    def from_effects(cls, inertia: Inertia, effects: Sequence[Effect]) -> RigidBodyModel:
        """The model of a scene's effects: their torques and rotors (other kinds ignored;
        a controller driving an actuator applies no torque itself), with the rotors' spin
        inertia taken out of ``inertia`` (:func:`inertia_without_rotors`)."""
        torques = [e for e in effects if isinstance(e, TorqueEffect) and e.applies_torque]
        return cls(inertia_without_rotors(inertia, effects),
                   float_torques=[e.torque for e in torques],
                   float_rotors=[e.rotor for e in effects if isinstance(e, RotorEffect)],
                   torque_depends_on_rate=any(e.torque_depends_on_rate for e in torques))

    @property
    def torque_functions(self) -> tuple[FloatTorque, ...]:
        """:attr:`torques` (the name scripts used)."""
        return self.torques

    @property
    def torque_free(self) -> bool:
        """True when no torque and no rotor act: the exact and splitting methods apply."""
        return not self.torques and not self.rotors

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

    def _torque_sum(self, t: float, q: Quat, omega: Vec) -> Vec:
        """Sum of the torques at ``(t, q, ω)`` [N m, body axes]."""
        x = y = z = 0.0
        for torque in self.torques:
            a, b, c = torque(t, q, omega)
            x, y, z = x + a, y + b, z + c
        return x, y, z

    def _rotor_sum(self, t: float) -> tuple[Vec, Vec]:
        """Summed rotor momentum ``h`` and its rate ``ḣ`` at ``t`` (body axes)."""
        hx = hy = hz = rx = ry = rz = 0.0
        for rotor in self.rotors:
            (a, b, c), (d, e, f) = rotor(t)
            hx, hy, hz, rx, ry, rz = hx + a, hy + b, hz + c, rx + d, ry + e, rz + f
        return (hx, hy, hz), (rx, ry, rz)

    def external_torque(self, t: float, attitude: Sequence[float] | FloatArray,
                        omega_body: Sequence[float] | FloatArray) -> Vec:
        """``M − ḣ``: the torque whose power ``ω·(M − ḣ)`` changes the kinetic energy."""
        qw, qx, qy, qz = _floats(attitude)
        p, r, s = _floats(omega_body)
        x, y, z = self.torque_body(t, (qw, qx, qy, qz), (p, r, s)) if self.torques else _ZERO
        if self.rotors:
            _, (rx, ry, rz) = self.rotor_momentum(t)
            x, y, z = x - rx, y - ry, z - rz
        return x, y, z

    def omega_dot(self, t: float, attitude: Sequence[float] | FloatArray,
                  omega_body: Sequence[float] | FloatArray) -> FloatArray:
        """Angular acceleration from Euler's equations with every effect included."""
        state = _floats(attitude) + _floats(omega_body)
        return np.array(body_derivative(self, t, state)[4:])


def inertia_without_rotors(inertia: Inertia, effects: Sequence[Effect]) -> Inertia:
    """``J' = J − Σ Jₛ â âᵀ``: the inertia Euler's equations take when rotors with a state of
    their own (:class:`.RotorState`) carry their axial momentum (``inertia`` itself when the
    scene has none). ``J'`` is no rigid body's inertia (the triangle inequalities need not
    hold) but must stay symmetric positive definite and non-singular: :class:`InertiaError`
    otherwise."""
    spinning = [e.spin_inertia_body() for e in effects if isinstance(e, RotorState)]
    if not spinning:
        return inertia
    return Inertia(inertia.tensor - sum(spinning), triangle=False)


def _all_finite(h: float, values: tuple[float, ...]) -> bool:
    """Whether ``h`` and every value are finite numbers (False for nested sequences)."""
    try:
        return math.isfinite(h) and all(map(math.isfinite, values))
    except TypeError:
        return False


def rk4_step(model: RigidBodyModel, t: float, attitude: FloatArray, omega_body: FloatArray,
             h: float) -> tuple[FloatArray, FloatArray]:
    """Classical RK4 on ``(q, ω)`` jointly, then ``q`` renormalised: the ``rk4`` integrator's
    step (:func:`.integrators.rk4_kernel.rk4_state_step`) on arrays, with its checks.

    Raises :class:`InputError` for a non-finite ``h`` or state or wrong shapes and
    :class:`IntegratorError` for a non-finite result. Order 4; cost 4 evaluations of Euler's
    equations and of the torques per step, in plain float math (no NumPy per-call overhead
    for a torque-free body). Keeps ``|q| = 1`` by
    projection only (RK4 alone shrinks ``|q|`` by about ``(h|ω|)⁶/9216`` per step,
    its stability function on the imaginary axis); energy and momentum drift at O(h⁴) per unit
    time. The baseline every other method is measured against (Kutta 1901; Hairer, Nørsett &
    Wanner, *Solving ODEs I*, §II.1).
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
