"""What the dynamics integrators share: the body-model protocol and the state derivatives.

Conventions are those of :mod:`rigid_body_attitude.core.attitude.quaternion` (Hamilton, scalar
first, ``q`` maps body to world, ``q̇ = ½ q ⊗ (0, ω_body)``). Hot per-step code works on tuples
of floats, with the helpers of :mod:`rigid_body_attitude.core.attitude.float_quaternion`.

The dynamics integrators see the body only through :class:`BodyModel`, a protocol with the
few members they use (``rigid_body_attitude.core.dynamics.euler.RigidBodyModel`` provides
them). The equations they advance are, in body axes,

    J ω̇ + ω × (J ω + h) = M − ḣ,        q̇ = ½ q ⊗ (0, ω),

with ``M = torque_body(t, q, ω)`` and the rotor momentum ``(h, ḣ) = rotor_momentum(t)``.
:class:`SimpleBodyModel` is a minimal concrete model for scripts, tests and the study.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from typing import Any, Protocol, runtime_checkable

import numpy as np
from numpy.typing import ArrayLike, NDArray

from rigid_body_attitude.core.attitude import quaternion as quat
from rigid_body_attitude.core.attitude.float_quaternion import (
    q_exp, q_multiply, q_normalize, q_rotate_step, Quat, SERIES_THRESHOLD, Vec)
from rigid_body_attitude.core.errors import InertiaError, IntegratorError
from rigid_body_attitude.core.dynamics.integrators.exact_torque_free import principal_frame

__all__ = [
    'BodyModel',
    'DynamicsIntegrator',
    'SimpleBodyModel',
    'Quat',
    'SERIES_THRESHOLD',
    'Vec',
    'as_state',
    'body_derivative',
    'body_derivative_power',
    'check_step',
    'omega_derivative',
    'output',
    'q_exp',
    'q_multiply',
    'q_normalize',
    'q_rotate_step',
]

FloatArray = NDArray[np.float64]
TorqueFunction = Callable[[float, FloatArray, FloatArray], ArrayLike]
RotorFunction = Callable[[float], tuple[ArrayLike, ArrayLike]]


@runtime_checkable
class BodyModel(Protocol):
    """The body as the dynamics integrators see it (all vectors in body axes).

    Members: ``tensor_entries`` and ``inverse_entries`` (``J`` and ``J⁻¹`` [kg m²], row-major
    9-tuples of floats), ``principal_moments`` (ascending, (3,)), ``principal_axes``
    (rotation whose columns are the principal axes), ``torque_free`` (no torque, no rotor),
    ``torque_body(t, attitude, omega_body) -> (3,)`` [N m] and
    ``rotor_momentum(t) -> (h [N m s], ḣ [N m])``, and four declarations: ``has_torque``
    (False: ``torque_body`` is zero, never called by the written-out RK4 step),
    ``torque_depends_on_rate`` (False lets the splitting methods apply a torque kick exactly
    in one evaluation), ``has_rotor`` (False skips the rotor query) and
    ``torque_takes_floats`` (True: the integrators call
    ``torque_body(t, (w, x, y, z), (ω₁, ω₂, ω₃))`` with plain-float tuples and take any three
    numbers back, no NumPy conversion in their hot loops).
    """

    tensor_entries: tuple[float, ...]
    inverse_entries: tuple[float, ...]
    torque_depends_on_rate: bool
    has_torque: bool
    has_rotor: bool
    torque_takes_floats: bool

    @property
    def torque_free(self) -> bool:
        """True when no torque and no rotor act."""

    @property
    def principal_moments(self) -> FloatArray:
        """Principal moments in ascending order [kg m²]."""

    @property
    def principal_axes(self) -> FloatArray:
        """Right-handed rotation whose columns are the principal axes (body coordinates)."""

    def torque_body(self, t: float, attitude: Any, omega_body: Any) -> Any:
        """External torque [N m] in body axes (arrays, or plain floats when
        ``torque_takes_floats``)."""

    def rotor_momentum(self, t: float) -> tuple[Any, Any]:
        """Rotor momentum ``h`` [N m s] and its rate ``ḣ`` [N m] in body axes."""


def _no_torque(t: float, attitude: Any, omega_body: Any) -> FloatArray:
    """Zero torque [N m]."""
    return np.zeros(3)


class SimpleBodyModel:
    """A minimal :class:`BodyModel`: inertia, an optional torque and an optional rotor.

    ``inertia`` is three principal moments or a symmetric (3, 3) tensor [kg m²];
    ``torque_body(t, attitude, omega_body) -> (3,)`` [N m] and
    ``rotor_momentum(t) -> (h, ḣ)`` are optional callables (absent means zero).
    ``torque_depends_on_rate=False`` declares that the torque ignores ``omega_body``;
    ``torque_takes_floats=True`` that it also accepts plain-float tuples for the attitude and
    the rate (see :class:`BodyModel`).
    """

    def __init__(self, inertia: ArrayLike, torque_body: TorqueFunction | None = None,
                 rotor_momentum: RotorFunction | None = None,
                 torque_depends_on_rate: bool = True, torque_takes_floats: bool = False):
        tensor = np.asarray(inertia, dtype=np.float64)
        if tensor.shape == (3,):
            tensor = np.diag(tensor)
        moments, axes = principal_frame(tensor)
        if moments[0] + moments[1] < moments[2] * (1.0 - 1e-12):
            raise InertiaError(f'Expected principal moments with J1 + J2 >= J3, got '
                               f'{moments.tolist()!r}')
        self.inertia_tensor = tensor
        self.inverse_inertia = np.linalg.inv(tensor)
        self.tensor_entries = tuple(tensor.ravel().tolist())
        self.inverse_entries = tuple(self.inverse_inertia.ravel().tolist())
        self._moments = moments
        self._axes = axes
        self._torque = torque_body
        self._rotor = rotor_momentum
        # the user's function itself (no wrapper call on the hot path), or zero
        self.torque_body: Callable[[float, Any, Any], Any] = (
            _no_torque if torque_body is None else torque_body)
        self.torque_depends_on_rate = bool(torque_depends_on_rate)
        self.torque_takes_floats = bool(torque_takes_floats) and torque_body is not None
        self.has_rotor = rotor_momentum is not None
        self.has_torque = torque_body is not None

    @property
    def torque_free(self) -> bool:
        """True when neither a torque nor a rotor was given."""
        return self._torque is None and self._rotor is None

    @property
    def principal_moments(self) -> FloatArray:
        """Principal moments in ascending order [kg m²]."""
        return self._moments

    @property
    def principal_axes(self) -> FloatArray:
        """Right-handed rotation whose columns are the principal axes (body coordinates)."""
        return self._axes

    def rotor_momentum(self, t: float) -> tuple[Any, Any]:
        """The rotor callable's ``(h, ḣ)``, or zeros."""
        if self._rotor is None:
            return np.zeros(3), np.zeros(3)
        return self._rotor(t)


class DynamicsIntegrator(Protocol):
    """One step of the coupled attitude/Euler equations.

    Attributes ``name``, ``order``, ``supports_torque`` and a docstring giving the equation,
    order, cost, invariants and source; ``step(attitude, omega_body, t, h, model)`` returns the
    new ``(attitude, omega_body)`` as arrays of shape (4,) and (3,).
    """

    name: str
    order: int
    supports_torque: bool

    def step(self, attitude: ArrayLike, omega_body: ArrayLike, t: float, h: float,
             model: BodyModel) -> tuple[FloatArray, FloatArray]:
        """Advance by ``h`` seconds from time ``t``."""


def check_step(h: float) -> float:
    """Return ``h`` as a float, or raise :class:`IntegratorError` if it is not finite."""
    step = float(h)
    if not math.isfinite(step):
        raise IntegratorError(f'Expected a finite step `h`, got {h!r}')
    return step


def body_derivative(model: BodyModel, t: float, state: Sequence[float]) -> tuple[float, ...]:
    """``(q̇, ω̇)`` for the 7-float state ``(w, x, y, z, ω₁, ω₂, ω₃)`` (plain floats).

    ``ω̇ = J⁻¹ (M − ḣ − ω × (J ω + h))``; the torque and rotor callables are only called when
    the model is not torque-free (:func:`body_derivative_power` also returns the power).
    """
    return body_derivative_power(model, t, state)[:7]


def body_derivative_power(model: BodyModel, t: float,
                          state: Sequence[float]) -> tuple[float, ...]:
    """:func:`body_derivative` and, eighth, the power ``ω·(M − ḣ)`` [W] of the torques.

    The torque is called with plain-float tuples when the model declares
    ``torque_takes_floats``, with arrays otherwise.
    """
    qw, qx, qy, qz, p, q, r = state
    j00, j01, j02, j10, j11, j12, j20, j21, j22 = model.tensor_entries
    mx = j00 * p + j01 * q + j02 * r
    my = j10 * p + j11 * q + j12 * r
    mz = j20 * p + j21 * q + j22 * r
    tx = ty = tz = power = 0.0
    if not model.torque_free:
        if model.torque_takes_floats:
            tx, ty, tz = model.torque_body(t, (qw, qx, qy, qz), (p, q, r))
        else:
            torque = model.torque_body(t, np.array((qw, qx, qy, qz)), np.array((p, q, r)))
            tx, ty, tz = float(torque[0]), float(torque[1]), float(torque[2])
        if model.has_rotor:
            rotor, rotor_rate = model.rotor_momentum(t)
            tx -= float(rotor_rate[0])
            ty -= float(rotor_rate[1])
            tz -= float(rotor_rate[2])
            mx, my, mz = mx + float(rotor[0]), my + float(rotor[1]), mz + float(rotor[2])
        power = p * tx + q * ty + r * tz
    bx = tx - (q * mz - r * my)
    by = ty - (r * mx - p * mz)
    bz = tz - (p * my - q * mx)
    i00, i01, i02, i10, i11, i12, i20, i21, i22 = model.inverse_entries
    return (0.5 * (-qx * p - qy * q - qz * r),
            0.5 * (qw * p + qy * r - qz * q),
            0.5 * (qw * q - qx * r + qz * p),
            0.5 * (qw * r + qx * q - qy * p),
            i00 * bx + i01 * by + i02 * bz,
            i10 * bx + i11 * by + i12 * bz,
            i20 * bx + i21 * by + i22 * bz,
            power)


def omega_derivative(model: BodyModel, t: float, attitude: Sequence[float],
                     omega: Sequence[float]) -> Vec:
    """``ω̇`` alone (plain floats), for methods that update the attitude on the group."""
    derivative = body_derivative(model, t, tuple(attitude) + tuple(omega))
    return derivative[4], derivative[5], derivative[6]


def as_state(attitude: ArrayLike, omega_body: ArrayLike) -> tuple[Quat, Vec]:
    """Validated plain-float ``(q, ω)`` from array-likes; bad input raises InputError."""
    q = quat.as_quaternion(attitude, 'attitude')
    omega = quat.as_vector(omega_body, 'omega_body')
    if q.shape != (4,) or omega.shape != (3,):
        raise IntegratorError(f'Expected one body: attitude (4,) and omega_body (3,), got '
                              f'{q.shape} and {omega.shape}')
    w, x, y, z = q.tolist()
    p, r, s = omega.tolist()
    return (w, x, y, z), (p, r, s)


def output(q: Sequence[float], omega: Sequence[float]) -> tuple[FloatArray, FloatArray]:
    """Arrays ``(q (4,), ω (3,))``; a non-finite result raises :class:`IntegratorError`."""
    q_array = np.array(q, dtype=np.float64)
    omega_array = np.array(omega, dtype=np.float64)
    if not (np.all(np.isfinite(q_array)) and np.all(np.isfinite(omega_array))):
        raise IntegratorError(f'Integration produced a non-finite state: attitude '
                              f'{q_array.tolist()!r}, omega_body {omega_array.tolist()!r}; '
                              f'reduce the step')
    return q_array, omega_array
