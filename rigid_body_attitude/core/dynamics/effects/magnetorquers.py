"""magnetorquers: magnetic torque rods, a dipole that acts only across the local field.

``M = m × B_b``, ``B_b = R(q)ᵀ B_w(t)`` the scene's field (``magnetic_field:`` section) in body
axes (Source: Markley and Crassidis, *Fundamentals of Spacecraft Attitude Determination and
Control*, 2014, sec. 3.3 and ch. 7; Basilisk's MtbEffector). The rods lie along ``axes``
(default the body axes); the dipole asked, ``m_cmd``, is shared among them by the
minimum-norm pseudo-inverse, each rod's dipole clipped to ``±max_dipole``, and ``m`` is what
the rods give. ``m_cmd`` is the sum of the ``dipole`` input (body axes [A m²], stamped, held
until ``timeout`` or the next command as ``commanded_torque``'s torque; none with
``commanded: false``), the dipole of a
``bdot`` controller in the scene, and, with ``dumping_gain`` ``k > 0`` and ``reaction_wheels``
in the scene, the cross-product momentum dumping ``k (h_w × B_b) / |B_b|²`` of the wheels'
stored momentum ``h_w = Σ Jₛᵢ Ωᵢ âᵢ`` (:mod:`rigid_body_attitude.core.control.magnetic`).
The dipole is set at the start of each integration step and held over it (the coil drivers'
zero-order hold); the torque follows the field and the attitude inside the step.
``torque_impulse`` keeps ``∫|M| dt`` [N m s] (rectangle rule at the step starts): with
dumping, the momentum the rods took out. Counted: ``dipole_limit`` once per episode in which
a rod is clipped. Assumptions: rods without hysteresis, residual dipole or coupling; the field
model's accuracy. In a batch each body has its own dipole; ``max_dipole`` and
``dumping_gain`` may be dispersed.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any, ClassVar

import numpy as np

from rigid_body_attitude.core.attitude import quaternion
from rigid_body_attitude.core.control.magnetic import dumping_dipole, dumping_dipole_rows
from rigid_body_attitude.core.dynamics import wheel_batch
from rigid_body_attitude.core.dynamics.batch_rows import cross_rows
from rigid_body_attitude.core.dynamics.effects.base import (
    BatchChunk, BodyProperties, boolean, CommandedEffect, Effect, FloatArray, nonnegative,
    Parameter, positive, Quat, real, register, REQUIRED, TorqueEffect, Vec)
from rigid_body_attitude.core.dynamics.effects.held import HeldOverStep, RotorState
from rigid_body_attitude.core.dynamics.effects.sampled import SampledTorque
from rigid_body_attitude.core.errors import SceneError

_BODY_AXES = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]


def _rods(value: Any) -> FloatArray:
    """1 to 6 non-zero rod axes, each normalised."""
    if not isinstance(value, (list, tuple)) or not 1 <= len(value) <= 6 or not all(
            isinstance(axis, (list, tuple)) and len(axis) == 3 for axis in value):
        raise TypeError('a list of 1 to 6 axes [x, y, z]')
    rows = np.array([[real(item) for item in axis] for axis in value])
    scale = np.max(np.abs(rows), axis=1)
    if not np.all(scale > 1e-12):
        raise ValueError('non-zero axes')
    rows = rows / scale[:, None]
    result: FloatArray = rows / np.linalg.norm(rows, axis=1)[:, None]
    return result


def field_body(model: Any, t: float, q: Quat) -> Vec:
    """The scene's field [T] at ``t`` in the body axes of attitude ``q``."""
    return quaternion.rotate_inverse_floats(q, model.field_world(t))


@register
class Magnetorquers(CommandedEffect, HeldOverStep, TorqueEffect):
    """Torque rods: held dipole ``m`` [A m², body], torque ``m × B_b`` [N m]."""

    name = 'magnetorquers'
    description = 'magnetic torque rods: dipole input, B-dot and momentum dumping, m × B'
    parameters = {
        'max_dipole': Parameter(positive, REQUIRED, 'dipole limit of each rod [A m²]'),
        'axes': Parameter(_rods, _BODY_AXES, 'rod axes, body (normalised)'),
        'dumping_gain': Parameter(nonnegative, 0.0,
                                  'cross-product momentum dumping gain [1/s]; 0: none'),
        'timeout': Parameter(positive, 0.5, 'seconds a dipole command is held [s]'),
        'commanded': Parameter(boolean, True, 'take dipole commands (false: only B-dot and '
                                              'dumping of the scene)'),
    }
    inputs = {'dipole': 'dipole_body [A m²] (the rods\' dipole asked, body axes)'}
    shared_parameters: ClassVar[frozenset[str]] = frozenset({'axes', 'commanded'})

    def __init__(self, params: dict[str, Any], body: BodyProperties) -> None:
        """Check the scene's field; the rods' allocation."""
        super().__init__(params, body)
        self.model = body.environment.required_field(self.name)
        axes = self.params['axes']
        self.rod_axes = [tuple(axis) for axis in axes.tolist()]
        self.allocation = np.linalg.pinv(axes.T).tolist()  # (rods, 3)
        self.controllers: list[SampledTorque] = []
        self.wheels: list[RotorState] = []
        self.reset()

    @property
    def input_names(self) -> frozenset[str]:
        """``dipole`` unless ``commanded`` is false."""
        return frozenset(self.inputs) if self.params['commanded'] else frozenset()

    def reset(self) -> None:
        """No command; zero dipole; no impulse."""
        super().reset()
        self.dipole: Vec = (0.0, 0.0, 0.0)
        self.torque_impulse = 0.0
        self.clipping = False

    def bind(self, effects: Sequence[Effect]) -> None:
        """The B-dot controllers driving the rods; the wheels whose momentum is dumped."""
        self.controllers = [e for e in effects if isinstance(e, SampledTorque)
                            and e.actuator == self.name]
        if self.params['dumping_gain'] > 0.0:
            self.wheels = [e for e in effects if isinstance(e, RotorState)]
            if not self.wheels:
                raise SceneError(f"Effect {self.name!r}: parameter 'dumping_gain' needs "
                                 f"reaction_wheels in the same scene")

    def rods(self, wanted: Vec) -> tuple[Vec, bool]:
        """The dipole the rods give for ``wanted``, and whether a rod was clipped."""
        limit = self.params['max_dipole']
        x = y = z = 0.0
        clipped = False
        for (a, b, c), (u, v, w) in zip(self.allocation, self.rod_axes):
            rod = a * wanted[0] + b * wanted[1] + c * wanted[2]
            if abs(rod) > limit:
                rod, clipped = math.copysign(limit, rod), True
            x, y, z = x + rod * u, y + rod * v, z + rod * w
        return (x, y, z), clipped

    def hold(self, t: float, h: float, q: Quat, omega: Vec) -> None:
        """The dipole for the step: command, B-dot and dumping, through the rods."""
        mx, my, mz = self.command.vector_at(t)
        for controller in self.controllers:
            a, b, c = controller.held
            mx, my, mz = mx + a, my + b, mz + c
        field = field_body(self.model, t, q)
        for wheel in self.wheels:
            stored = wheel.stored_momentum()
            a, b, c = dumping_dipole(stored, field, self.params['dumping_gain'])
            mx, my, mz = mx + a, my + b, mz + c
        self.dipole, clipped = self.rods((mx, my, mz))
        if clipped and not self.clipping:
            self.count('dipole_limit')
        self.clipping = clipped
        x, y, z = self.dipole
        bx, by, bz = field
        self.torque_impulse += h * math.sqrt((y * bz - z * by) ** 2 + (z * bx - x * bz) ** 2
                                             + (x * by - y * bx) ** 2)

    def torque(self, t: float, q: Quat, omega: Vec) -> Vec:
        """``m × B_b`` [N m]."""
        bx, by, bz = field_body(self.model, t, q)
        x, y, z = self.dipole
        return y * bz - z * by, z * bx - x * bz, x * by - y * bx

    def batch_state_rows(self) -> int:
        """The held dipole (3) and the torque impulse."""
        return 4

    def batch_hold(self, t: float, h: float, q: FloatArray, omega: FloatArray,
                   chunk: BatchChunk) -> None:
        """Every body's dipole for the step (its field, controller and wheels)."""
        field = quaternion.rotate_rows(q, np.array(self.model.field_world(t))[:, None],
                                       inverse=True)
        wanted = np.array(self.command.vector_at(t))[:, None] + np.zeros_like(field)
        for controller in self.controllers:
            wanted += chunk.peers[controller.name].state[:3]
        gain = chunk.parameters['dumping_gain']
        for wheel in self.wheels:
            peer = chunk.peers[wheel.name]
            stored = wheel_batch.relative_momenta(wheel, peer.parameters, peer.state, omega)
            wanted += dumping_dipole_rows(stored, field, gain)
        allocation = np.array(self.allocation)  # (rods, 3)
        limit = np.asarray(chunk.parameters['max_dipole'])
        rods = np.clip(allocation @ wanted, -limit, limit)
        state = chunk.state
        state[:3] = np.array(self.rod_axes).T @ rods
        torque = cross_rows(state[:3], field, np.empty_like(field), chunk.scratch('mtq', 1)[0])
        state[3] += h * np.sqrt(np.einsum('in,in->n', torque, torque))

    def add_batch_torque(self, t: float, q: FloatArray, omega: FloatArray, chunk: BatchChunk,
                         out: FloatArray) -> None:
        """Each body's ``m × B_b``."""
        field = quaternion.rotate_rows(q, np.array(self.model.field_world(t))[:, None],
                                       inverse=True)
        cross_rows(chunk.state[:3], field, out, chunk.scratch('mtq', 1)[0], accumulate=True)
