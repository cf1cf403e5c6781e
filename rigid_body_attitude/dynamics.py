"""Euler's rigid-body equations and the body model the dynamics integrators advance.

Body axes, full symmetric inertia ``J`` about the centre of mass (or the fixed point), rotor
(gyrostat) momentum ``h`` in body axes (physics.md §1, seed 002 §8):

    J ω̇ + ω × (J ω + h) = M − ḣ,        q̇ = ½ q ⊗ (0, ω).

:class:`RigidBodyModel` bundles the inertia and the summed effect torques and rotor momenta so
that integrators see one small object and know no effect.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from rigid_body_attitude.inertia import Inertia
from rigid_body_attitude.kinematics import quaternion_rate

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
    """

    inertia: Inertia
    torque_functions: Sequence[TorqueFunction] = field(default_factory=tuple)
    rotor_functions: Sequence[RotorFunction] = field(default_factory=tuple)

    @property
    def torque_free(self) -> bool:
        """True when no torque and no rotor act: the exact and splitting methods apply."""
        return not self.torque_functions and not self.rotor_functions

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


def rk4_step(model: RigidBodyModel, t: float, attitude: FloatArray, omega_body: FloatArray,
             h: float) -> tuple[FloatArray, FloatArray]:
    """Classical RK4 on ``(q, ω)`` jointly, then ``q`` renormalised.

    Order 4; cost 4 evaluations of Euler's equations and of the torques per step. Keeps
    ``|q| = 1`` by projection only (RK4 alone shrinks ``|q|`` by about ``(h|ω|)⁶/9216`` per
    step, physics.md §6); energy and momentum drift at O(h⁴) per unit time. The baseline every
    other method is measured against (Kutta 1901; Hairer, Nørsett & Wanner, *Solving ODEs I*,
    §II.1).
    """
    k1q = quaternion_rate(attitude, omega_body)
    k1w = model.omega_dot(t, attitude, omega_body)
    q2, w2 = attitude + 0.5 * h * k1q, omega_body + 0.5 * h * k1w
    k2q = quaternion_rate(q2, w2)
    k2w = model.omega_dot(t + 0.5 * h, q2, w2)
    q3, w3 = attitude + 0.5 * h * k2q, omega_body + 0.5 * h * k2w
    k3q = quaternion_rate(q3, w3)
    k3w = model.omega_dot(t + 0.5 * h, q3, w3)
    q4, w4 = attitude + h * k3q, omega_body + h * k3w
    k4q = quaternion_rate(q4, w4)
    k4w = model.omega_dot(t + h, q4, w4)
    new_attitude = attitude + (h / 6.0) * (k1q + 2.0 * k2q + 2.0 * k3q + k4q)
    new_omega = omega_body + (h / 6.0) * (k1w + 2.0 * k2w + 2.0 * k3w + k4w)
    return new_attitude / np.linalg.norm(new_attitude), new_omega
