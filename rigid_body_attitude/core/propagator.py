"""Propagators: the one place that advances a body's state; node, replay and study call it.

* :class:`DynamicsPropagator` integrates Euler's equations and the attitude jointly with the
  scene's integrator and step, summing the torques, rotor momenta and forces of the scene's
  effects through :class:`~rigid_body_attitude.core.dynamics.euler.RigidBodyModel`.
* :class:`GyroPropagator` integrates measured body rates (strapdown), after the scene's rate
  corrections (bias, Earth rate), with the scene's strapdown method.

Neither knows any particular effect: each effect declares its kinds by the base classes it
derives from (:mod:`rigid_body_attitude.core.dynamics.effects.base`), and the propagators sort them
by
kind. The dynamics hot loop runs on plain floats from one call of :meth:`advance_to` to its
end (arrays are built once per call, for the state's readers). Time handling of input
streams (stale stamps, gaps, jumps) is :mod:`rigid_body_attitude.session.stream`'s job.
"""

from __future__ import annotations

import math
import numbers
from dataclasses import dataclass, field
import numpy as np
from numpy.typing import ArrayLike, NDArray

from rigid_body_attitude.core.attitude import quaternion
from rigid_body_attitude.core.attitude.float_quaternion import finite_vec3
from rigid_body_attitude.core.dynamics.diagnostics import Diagnostics, DiagnosticsTracker
from rigid_body_attitude.core.dynamics.euler import inertia_without_rotors, RigidBodyModel
from rigid_body_attitude.core.dynamics.effects import (
    CommandedEffect, ConservativeTorque, Effect, ForceEffect, HeldOverStep, RateCorrection,
    RotorEffect, RotorState, SampledTorque, StatefulEffect, TorqueEffect)
from rigid_body_attitude.core.dynamics.effects.base import ForceSum
from rigid_body_attitude.core.dynamics.effects.sampled import segment_end
from rigid_body_attitude.core.errors import InputError, IntegratorError
from rigid_body_attitude.core.attitude.integrators import strapdown_method
from rigid_body_attitude.core.dynamics.integrators import dynamics_integrator, torque_integrators
from rigid_body_attitude.core.dynamics.integrators.base import Quat, Vec
from rigid_body_attitude.core.dynamics.integrators.dynamics_base import ROTATION_LIMIT_SLACK
from rigid_body_attitude.core.dynamics.scene import Scene

__all__ = ['DynamicsPropagator', 'GyroPropagator', 'PropagatorState', 'build_propagator']

FloatArray = NDArray[np.float64]

#: A single call may not integrate more steps than this (a clock jump far ahead).
MAX_STEPS_PER_CALL = 10_000_000

#: A single step may not be split into more substeps than this.
MAX_SUBSTEPS = 1_000_000


@dataclass
class PropagatorState:
    """The propagated state.

    Attributes:
        time: propagated time [s] (scene time for dynamics, the last sample's stamp for gyro).
        attitude: unit quaternion (w, x, y, z), body → world.
        omega_body: body rate [rad/s] (for gyro scenes: the last corrected measurement).
        position: centre of mass in the world frame [m] (zero without translation).
    """

    time: float
    attitude: FloatArray
    omega_body: FloatArray
    position: FloatArray = field(default_factory=lambda: np.zeros(3))

    def attitude_tuple(self) -> tuple[float, float, float, float]:
        """The attitude (w, x, y, z) as floats."""
        w, x, y, z = self.attitude.tolist()
        return w, x, y, z

    def omega_tuple(self) -> tuple[float, float, float]:
        """The body rate as floats [rad/s]."""
        p, q, r = self.omega_body.tolist()
        return p, q, r


class FloatTupleState(PropagatorState):
    """A :class:`PropagatorState` that keeps attitude and rate as float tuples.

    The gyro hot path (:meth:`GyroPropagator.advance`, once per sample) and the dynamics steps
    (:meth:`DynamicsPropagator.advance_to`, once per call: once per sample of a simulated IMU)
    write tuples with :meth:`set_sample` and read them with :meth:`attitude_tuple` /
    :meth:`omega_tuple`, so no array is built per sample (each costs about 1 µs, more with a
    cold cache). ``attitude`` and ``omega_body`` are built when read and are read-only: assign
    a new value to change them.
    """

    _attitude_floats: tuple[float, float, float, float]
    _omega_floats: tuple[float, float, float]
    _attitude_array: FloatArray | None
    _omega_array: FloatArray | None

    @property
    def attitude(self) -> FloatArray:
        """Unit quaternion (w, x, y, z), body → world (read-only array)."""
        if self._attitude_array is None:
            self._attitude_array = _read_only(self._attitude_floats)
        return self._attitude_array

    @attitude.setter
    def attitude(self, value: ArrayLike) -> None:
        self._attitude_array = _read_only(value)
        w, x, y, z = self._attitude_array.tolist()
        self._attitude_floats = (w, x, y, z)

    @property
    def omega_body(self) -> FloatArray:
        """Body rate [rad/s] (read-only array)."""
        if self._omega_array is None:
            self._omega_array = _read_only(self._omega_floats)
        return self._omega_array

    @omega_body.setter
    def omega_body(self, value: ArrayLike) -> None:
        self._omega_array = _read_only(value)
        p, q, r = self._omega_array.tolist()
        self._omega_floats = (p, q, r)

    def attitude_tuple(self) -> tuple[float, float, float, float]:
        """The attitude (w, x, y, z) as floats."""
        return self._attitude_floats

    def omega_tuple(self) -> tuple[float, float, float]:
        """The body rate as floats [rad/s]."""
        return self._omega_floats

    def set_sample(self, time: float, attitude: tuple[float, float, float, float],
                   omega_body: tuple[float, float, float]) -> None:
        """Time, attitude and rate after one sample, as floats (arrays built when read)."""
        self.time = time
        self._attitude_floats, self._attitude_array = attitude, None
        self._omega_floats, self._omega_array = omega_body, None


def _read_only(values: ArrayLike) -> FloatArray:
    """A float array copy of ``values`` that cannot be changed in place."""
    array = np.array(values, dtype=float)
    array.flags.writeable = False
    return array


class _Propagator:
    """Shared parts: effects, commanded inputs, reset, diagnostics."""

    _state_type: type[PropagatorState] = PropagatorState

    def __init__(self, scene: Scene) -> None:
        self.scene = scene
        self.effects: list[Effect] = scene.build_effects()
        self.stateful = [e for e in self.effects if isinstance(e, StatefulEffect)]
        self.rotors = [e for e in self.effects if isinstance(e, RotorEffect)]
        #: Effects held over each step, and the rotors with a state of their own among them.
        self.held = [e for e in self.effects if isinstance(e, HeldOverStep)]
        self.wheels = [e for e in self.effects if isinstance(e, RotorState)]
        #: ``J'``: the body's inertia with the wheels' spin inertia taken out.
        self._inertia_entries = tuple(
            inertia_without_rotors(scene.inertia, self.effects).tensor.ravel().tolist())
        self.input_routes: dict[str, list[Effect]] = {}
        for effect in self.effects:
            for input_name in effect.input_names:
                self.input_routes.setdefault(input_name, []).append(effect)
        self.reset()

    @property
    def input_names(self) -> frozenset[str]:
        """Commanded inputs the scene's effects listen to (``torque``, ``force``, ...)."""
        return frozenset(self.input_routes)

    @property
    def has_translation(self) -> bool:
        """Whether an effect carries a position (the pose position moves)."""
        return any(e.carries_position for e in self.stateful)

    def reset(self, time: float = 0.0) -> None:
        """Back to the scene's initial state at ``time``; every effect resets too."""
        for effect in self.effects:
            effect.reset()
        self.state = self._state_type(time, self.scene.initial_attitude.copy(),
                                      self.scene.initial_omega_body.copy())
        for wheel in self.wheels:
            wheel.start(self.state.omega_tuple())
        self._sync_position()
        self.tracker = DiagnosticsTracker(self.energy(), self.world_momentum())

    def set_attitude(self, attitude: ArrayLike, position: ArrayLike | None = None) -> None:
        """Re-initialise the attitude (and the position, with translation).

        Raises :class:`InputError` for a non-finite or zero quaternion; the state is then
        unchanged.
        """
        new_attitude = quaternion.normalize(quaternion.as_quaternion(attitude, 'attitude'))
        if new_attitude.shape != (4,):
            raise InputError(f'Expected `attitude` to have shape (4,), got {new_attitude.shape}')
        new_position = None
        if position is not None:
            new_position = quaternion.as_vector(position, 'position')
        self.state.attitude = new_attitude
        if new_position is not None:
            for effect in self.stateful:
                if effect.carries_position:
                    effect.set_position(new_position)
            self._sync_position()
        self.tracker = DiagnosticsTracker(self.energy(), self.world_momentum())

    def command(self, input_name: str, t: float, value: ArrayLike) -> None:
        """Pass a commanded input (e.g. ``torque`` [N m, body]) stamped ``t`` to its effects:
        3 numbers, or as many as its effect says (one per wheel of ``wheel_torque``);
        :class:`InputError` for an input no effect takes or a non-finite value."""
        routes = self.input_routes.get(input_name)
        if routes is None:
            raise InputError(f'Scene {self.scene.name!r} takes no input {input_name!r}; '
                             f'inputs: {", ".join(sorted(self.input_routes)) or "(none)"}')
        size = routes[0].input_size(input_name)
        vector: Vec | FloatArray | None = finite_vec3(value) if size == 3 else None  # no NumPy
        if vector is None:
            vector = _command_vector(input_name, value, size)
        if (isinstance(vector, np.ndarray) and vector.shape != (size,)) or not math.isfinite(t):
            raise InputError(f'Expected `{input_name}` as {size} finite numbers at a finite '
                             f'time, got {np.asarray(vector).tolist()!r} at t={t!r}')
        for effect in routes:
            effect.accept_input(input_name, t, vector)

    def counters(self) -> dict[str, int]:
        """Counters of every effect, e.g. ``commanded_torque.stale``."""
        return {f'{effect.name}.{key}': value for effect in self.effects
                for key, value in effect.counters.items()}

    def rotor_momentum(self, t: float) -> FloatArray:
        """Summed rotor momentum [N m s, body] at ``t`` (zero without rotors)."""
        x = y = z = 0.0
        for effect in self.rotors:
            (a, b, c), _ = effect.rotor(t)
            x, y, z = x + a, y + b, z + c
        return np.array((x, y, z))

    def energy(self) -> float:
        """Kinetic energy [J]: rotation ``½ ωᵀ J' ω`` plus the effects' own (translation, the
        wheels' ``Σ Hᵢ²/(2 Jₛᵢ)``)."""
        p, q, r = self.state.omega_tuple()
        j00, j01, j02, _, j11, j12, _, _, j22 = self._inertia_entries
        rotation = 0.5 * (j00 * p * p + j11 * q * q + j22 * r * r) + (
            j01 * p * q + j02 * p * r + j12 * q * r)
        if self.wheels:
            rotation += sum(wheel.kinetic_energy() for wheel in self.wheels)
        if self.stateful:
            return rotation + sum(effect.kinetic_energy() for effect in self.stateful)
        return rotation

    def world_momentum(self) -> FloatArray:
        """:meth:`world_momentum_tuple` as an array [N m s]."""
        return np.array(self.world_momentum_tuple())

    def world_momentum_tuple(self) -> Vec:
        """World-frame angular momentum ``R(q)(J' ω + h)`` [N m s] (plain float math; ``J'``
        is ``J`` without wheels)."""
        p, q, r = self.state.omega_tuple()
        j00, j01, j02, j10, j11, j12, j20, j21, j22 = self._inertia_entries
        mx = j00 * p + j01 * q + j02 * r
        my = j10 * p + j11 * q + j12 * r
        mz = j20 * p + j21 * q + j22 * r
        if self.rotors:
            hx, hy, hz = self.rotor_momentum(self.state.time).tolist()
            mx, my, mz = mx + hx, my + hy, mz + hz
        w, x, y, z = self.state.attitude_tuple()
        tx, ty, tz = 2.0 * (y * mz - z * my), 2.0 * (z * mx - x * mz), 2.0 * (x * my - y * mx)
        return (mx + w * tx + (y * tz - z * ty),
                my + w * ty + (z * tx - x * tz),
                mz + w * tz + (x * ty - y * tx))

    def diagnostics(self) -> Diagnostics:
        """Energy, momentum and their drift, energy-balance residual, norm error."""
        return self.tracker.snapshot(self.state.attitude, self.energy(), self.world_momentum())

    def _sync_position(self) -> None:
        for effect in self.stateful:
            if effect.carries_position:
                self.state.position = np.array(effect.outputs()['position'])


class DynamicsPropagator(_Propagator):
    """Integrates Euler's equations and the attitude with the scene's integrator and step."""

    _state_type = FloatTupleState
    state: FloatTupleState

    def __init__(self, scene: Scene) -> None:
        """Build the scene's effects, the body model and the integrator."""
        if scene.rate_source != 'dynamics':
            raise IntegratorError(f'DynamicsPropagator needs a dynamics scene, got '
                                  f'rate_source {scene.rate_source!r}')
        super().__init__(scene)
        self.model = RigidBodyModel.from_effects(scene.inertia, self.effects)
        torques = [e for e in self.effects if isinstance(e, TorqueEffect)]
        #: Every torque has a potential and no rotor acts: the work is ``V(q₀) − V(q₁)``.
        self.potentials = ([e for e in torques if isinstance(e, ConservativeTorque)]
                           if all(isinstance(e, ConservativeTorque) for e in torques)
                           and torques and not self.model.has_rotor else [])
        self.force_effects = [e for e in self.effects if isinstance(e, ForceEffect)]
        self.switching = [e for e in self.effects if isinstance(e, CommandedEffect)]
        self.sampled = [e for e in self.effects if isinstance(e, SampledTorque)]
        #: Sum of the scene's forces at ``(t, q)`` (the one force effect's own, when alone).
        self.force_sum: ForceSum = (self.force_effects[0].force if len(self.force_effects) == 1
                                    else self._force)
        self.integrator = dynamics_integrator(scene.integrator)
        if not self.model.torque_free and not self.integrator.supports_torque:
            raise IntegratorError(f'Integrator {scene.integrator!r} handles torque-free bodies '
                                  f'only; scene {scene.name!r} has torques or rotors '
                                  f'({", ".join(e.name for e in self.effects)}). Use one of '
                                  f'{", ".join(torque_integrators())}')
        self.substeps_taken = 0

    @property
    def rotation_limit(self) -> float:
        """The integrator's stability limit ``h·|ω|`` [rad] (``inf`` when unconditional)."""
        return float(self.integrator.max_rotation_per_step)

    def step(self, h: float) -> None:
        """Advance the state by one step of ``h`` seconds.

        An explicit method whose stability limit (:attr:`rotation_limit`, the integrator's
        ``max_rotation_per_step``) the step would exceed takes equal substeps instead, each
        within the limit for the rate at its start; :attr:`substeps_taken` counts the extra
        ones. Raises :class:`InputError` unless ``h`` is a positive finite number, and
        :class:`IntegratorError` if more than :data:`MAX_SUBSTEPS` substeps would be needed or
        the result is not finite; the state is then unchanged.
        """
        if not _positive_finite(h):
            raise InputError(f'Expected `h` to be a positive finite number of seconds, got {h!r}')
        state = self.state
        t = state.time
        self._sample_due(t)
        for effect in self.switching:
            effect.begin_step(t, t + h)
        try:
            q, omega, work = self._one_step(state.attitude_tuple(), state.omega_tuple(), t,
                                            float(h))
        finally:
            for effect in self.switching:
                effect.end_step()
        self._store(t + h, q, omega, work)

    def _one_step(self, q: Quat, omega: Vec, t: float, h: float) -> tuple[Quat, Vec, float]:
        """One step of ``h`` on plain floats, split into substeps when the integrator's
        stability limit asks for it; returns the new state and the work done [J]."""
        integrator = self.integrator
        speed = math.sqrt(omega[0] * omega[0] + omega[1] * omega[1] + omega[2] * omega[2])
        if integrator.substeps_needed(h, speed) == 1:
            return self._checked_step(q, omega, t, h)
        end, remaining, taken, work = t + h, h, 0, 0.0
        while remaining > 0.0:
            speed = math.sqrt(omega[0] * omega[0] + omega[1] * omega[1] + omega[2] * omega[2])
            needed = integrator.substeps_needed(remaining, speed)
            if taken + needed > MAX_SUBSTEPS:
                raise IntegratorError(
                    f'Integrator {integrator.name!r} is stable only for h·|ω| <= '
                    f'{self.rotation_limit} rad; a step of {h!r} s at |ω| = {speed!r} rad/s '
                    f'would need more than {MAX_SUBSTEPS} substeps. Use a smaller step or the '
                    f'strang, yoshida4, dopri45 or exact integrator')
            substep = remaining / needed
            q, omega, substep_work = self._checked_step(q, omega, t, substep)
            work += substep_work
            taken += 1
            t += substep
            remaining = end - t if needed > 1 else 0.0
        self.substeps_taken += taken - 1
        return q, omega, work

    def _checked_step(self, q: Quat, omega: Vec, t: float,
                      h: float) -> tuple[Quat, Vec, float]:
        """One integrator step and the stateful effects' step; a non-finite result raises.
        Effects held over the step hold their output from the state at ``t`` first; wheels
        advance their state at the end (their energy change joins the work)."""
        if self.held:
            return self._held_step(q, omega, t, h)
        if self.potentials:
            new_q, new_omega = self.integrator.advance_floats(q, omega, t, h, self.model)
            work = sum(effect.potential(q) - effect.potential(new_q)
                       for effect in self.potentials)
        else:
            new_q, new_omega, work = self.integrator.advance_with_work(q, omega, t, h,
                                                                       self.model)
        if not math.isfinite(new_omega[0] + new_omega[1] + new_omega[2] + work):
            raise IntegratorError(f'Integration produced a non-finite state: attitude '
                                  f'{list(new_q)!r}, omega_body {list(new_omega)!r}; reduce '
                                  f'the step')
        for effect in self.stateful:
            work += effect.advance(t, h, q, new_q, self.force_sum)
        return new_q, new_omega, work

    def _held_step(self, q: Quat, omega: Vec, t: float, h: float) -> tuple[Quat, Vec, float]:
        """:meth:`_checked_step` with the effects held over the step."""
        for held in self.held:
            held.hold(t, h, q, omega)
        new_q, new_omega, work = self.integrator.advance_with_work(q, omega, t, h, self.model)
        if not math.isfinite(new_omega[0] + new_omega[1] + new_omega[2] + work):
            raise IntegratorError(f'Integration produced a non-finite state: attitude '
                                  f'{list(new_q)!r}, omega_body {list(new_omega)!r}; reduce '
                                  f'the step')
        for wheel in self.wheels:
            work += wheel.commit(t, h, omega, new_omega)
        for effect in self.stateful:
            work += effect.advance(t, h, q, new_q, self.force_sum)
        return new_q, new_omega, work

    def _store(self, time: float, q: Quat, omega: Vec, work: float) -> None:
        """Write the propagated state (arrays built when read) and the work done."""
        state = self.state
        state.set_sample(time, q, omega)
        self.tracker.add_work(work)
        if self.stateful:
            self._sync_position()

    def advance_to(self, t_end: float) -> int:
        """Integrate with the scene's step up to ``t_end`` (the last step may be shorter).

        Steps end exactly where a commanded input switches (a new command's stamp, a timeout)
        and at every sample instant of a controller (:class:`.SampledTorque`, which samples
        the state there), so no step straddles a jump of the torque and the integrator keeps
        its order. Returns
        the number of steps taken. Raises :class:`InputError` for a non-finite time or one
        needing more than :data:`MAX_STEPS_PER_CALL` steps; the state is unchanged. A step
        that fails (:class:`IntegratorError`) leaves the state after the last good step.
        """
        if not math.isfinite(t_end):
            raise InputError(f'Expected `t_end` to be finite, got {t_end!r}')
        if (t_end - self.state.time) / self.scene.step > MAX_STEPS_PER_CALL:
            raise InputError(f'Advancing to t_end={t_end!r} from {self.state.time!r} needs '
                             f'more than {MAX_STEPS_PER_CALL} steps of {self.scene.step} s')
        if not self.switching and not self.sampled:
            return self._advance_steps(t_end)
        steps = 0
        tolerance = 1e-12 * max(1.0, abs(t_end))
        while t_end - self.state.time > tolerance:
            t = self.state.time
            self._sample_due(t)
            boundary = segment_end(t, t_end, self.switching, self.sampled)
            taken = self._advance_steps(boundary)
            if not taken:
                self.state.time = float(boundary)
            steps += taken
        return steps

    def _sample_due(self, t: float) -> None:
        """Controllers whose sample instant ``t`` is take their sample of the state."""
        for controller in self.sampled:
            if controller.due(t):
                controller.sample(t, self.state.attitude_tuple(), self.state.omega_tuple())

    def _advance_steps(self, t_end: float) -> int:
        """Steps of the scene's step up to ``t_end``, the last one shorter (no input switches
        inside: the commanded effects are pinned to the command in force once)."""
        step = self.scene.step
        t = self.state.time
        remaining = t_end - t
        tolerance = 1e-12 * max(1.0, abs(t_end))
        if remaining <= tolerance:
            return 0
        q, omega = self.state.attitude_tuple(), self.state.omega_tuple()
        steps, work = 0, 0.0
        for effect in self.switching:
            effect.begin_step(t, t_end)
        # |ω|² below this needs no substeps at h ≤ step (the integrator's limit, its slack)
        fast = (self.integrator.max_rotation_per_step * ROTATION_LIMIT_SLACK / step) ** 2
        try:
            while remaining > tolerance:
                h = step if step < remaining else remaining
                if omega[0] * omega[0] + omega[1] * omega[1] + omega[2] * omega[2] <= fast:
                    q, omega, step_work = self._checked_step(q, omega, t, h)
                else:
                    q, omega, step_work = self._one_step(q, omega, t, h)
                work += step_work
                steps += 1
                t += h
                remaining = t_end - t
            # t + h + h + ... misses t_end by round-off; the steps covered [t, t_end]
            t = float(t_end)
        finally:
            for effect in self.switching:
                effect.end_step()
            if steps:
                self._store(t, q, omega, work)
        return steps

    def _force(self, t: float, q: Quat) -> Vec:
        """Sum of the scene's forces [N, world] at ``(t, q)``."""
        x = y = z = 0.0
        for effect in self.force_effects:
            a, b, c = effect.force(t, q)
            x, y, z = x + a, y + b, z + c
        return x, y, z


class GyroPropagator(_Propagator):
    """Strapdown integration of measured body rates with the scene's strapdown method."""

    _state_type = FloatTupleState
    state: FloatTupleState

    def __init__(self, scene: Scene) -> None:
        """Build the rate corrections and the strapdown method named by the scene."""
        if scene.rate_source != 'gyro':
            raise IntegratorError(f'GyroPropagator needs a gyro scene, got rate_source '
                                  f'{scene.rate_source!r}')
        self.method = strapdown_method(scene.integrator)
        super().__init__(scene)
        self.corrections = [e for e in self.effects if isinstance(e, RateCorrection)]

    def reset(self, time: float = 0.0) -> None:
        """Back to the initial attitude; forget the previous sample."""
        super().reset(time)
        self.method.reset()
        self.has_sample = False

    def set_attitude(self, attitude: ArrayLike, position: ArrayLike | None = None) -> None:
        """Re-initialise the attitude; methods that group samples start a new group."""
        super().set_attitude(attitude, position)
        self.method.reset()

    def corrected(self, t: float, omega_measured: FloatArray) -> FloatArray:
        """Apply the scene's rate corrections in order (bias, Earth rate, ...)."""
        omega = omega_measured
        for effect in self.corrections:
            omega = effect.corrected_rate(t, self.state.attitude, omega)
        return omega

    def start(self, t: float, omega_measured: ArrayLike) -> None:
        """Take a baseline sample at ``t`` without integrating (first sample, after a gap).

        Raises :class:`InputError` for a non-finite ``t`` or a rate that is not 3 finite
        numbers; the state is then unchanged (as for :meth:`update`).
        """
        omega = self.corrected(t, _checked_sample(t, omega_measured))
        self.method.reset()
        self.state.time, self.state.omega_body = float(t), omega
        if not self.has_sample:
            self.tracker = DiagnosticsTracker(self.energy(), self.world_momentum())
        self.has_sample = True

    def update(self, t: float, omega_measured: ArrayLike) -> None:
        """Integrate from the previous sample's time to ``t`` with the new sample.

        Raises :class:`InputError` for a non-finite ``t`` or a rate that is not 3 finite
        numbers; the state is then unchanged.
        """
        self.advance(float(t), tuple(_checked_sample(t, omega_measured).tolist()))

    def advance(self, t: float, omega_measured: tuple[float, float, float]) -> None:
        """:meth:`update` for an already checked sample (finite float ``t``, 3 finite floats).

        The hot path of the node and the replay tool (:class:`~.stream.GyroStream` checks each
        sample before calling it): plain float math, no per-call validation.
        """
        state = self.state
        if self.corrections:
            omega = tuple(self.corrected(t, np.array(omega_measured)).tolist())
        else:
            omega = omega_measured
        attitude = self.method.propagate(state.attitude_tuple(), state.omega_tuple(), omega,
                                         t - state.time)
        state.set_sample(t, attitude, omega)


def _command_vector(input_name: str, value: ArrayLike, size: int) -> FloatArray:
    """A command's numbers as a finite float array (3: a body vector), or InputError."""
    if size == 3:
        return quaternion.as_vector(value, input_name)
    try:
        vector = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError) as err:
        raise InputError(f'Expected `{input_name}` as {size} finite numbers, got '
                         f'{value!r}') from err
    if not np.all(np.isfinite(vector)):
        raise InputError(f'Expected `{input_name}` to be finite, got {vector.tolist()!r}')
    return vector


def _positive_finite(value: object) -> bool:
    """Whether ``value`` is a real number, finite and > 0."""
    return (isinstance(value, numbers.Real) and math.isfinite(value)
            and float(value) > 0.0)


def _checked_sample(t: float, omega_measured: ArrayLike) -> FloatArray:
    """A gyro sample's rate as a finite (3,) array, or :class:`InputError`."""
    omega = quaternion.as_vector(omega_measured, 'omega_measured')
    if omega.shape != (3,) or not math.isfinite(t):
        raise InputError(f'Expected a gyro sample at a finite time `t` with `omega_measured` '
                         f'3 finite numbers, got t={t!r}, omega_measured={omega.tolist()!r}')
    return omega


def build_propagator(scene: Scene) -> DynamicsPropagator | GyroPropagator:
    """The propagator for the scene's rate source."""
    if scene.rate_source == 'gyro':
        return GyroPropagator(scene)
    return DynamicsPropagator(scene)
