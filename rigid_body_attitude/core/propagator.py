"""Propagators: the one place that advances a body's state; node, replay and study call it.

* :class:`DynamicsPropagator` integrates Euler's equations and the attitude jointly with the
  scene's integrator and step, summing the torques, rotor momenta and forces of the scene's
  effects through :class:`~rigid_body_attitude.core.dynamics.RigidBodyModel`.
* :class:`GyroPropagator` integrates measured body rates (strapdown), after the scene's rate
  corrections (bias, Earth rate), with the scene's strapdown method.

Neither knows any particular effect: they ask each effect for the capabilities it has
(:mod:`rigid_body_attitude.core.effects.base`). Time handling of input streams (stale stamps, gaps,
jumps) is :mod:`rigid_body_attitude.session.stream`'s job.
"""

from __future__ import annotations

import math
import numbers
from dataclasses import dataclass, field
import numpy as np
from numpy.typing import ArrayLike, NDArray

from rigid_body_attitude.core import quaternion
from rigid_body_attitude.core.diagnostics import Diagnostics, DiagnosticsTracker
from rigid_body_attitude.core.dynamics import RigidBodyModel
from rigid_body_attitude.core.effects import Effect, StatefulEffect
from rigid_body_attitude.core.errors import InputError, IntegratorError
from rigid_body_attitude.core.integrators import (
    dynamics_integrator, strapdown_method, torque_integrators)
from rigid_body_attitude.core.scene import Scene

__all__ = ['DynamicsPropagator', 'GyroPropagator', 'PropagatorState', 'build_propagator']

FloatArray = NDArray[np.float64]

#: A single call may not integrate more steps than this (a clock jump far ahead).
MAX_STEPS_PER_CALL = 10_000_000

#: Largest rotation per step ``h·|ω|`` [rad] for the explicit Runge–Kutta methods. For a
#: torque-free body every eigenvalue of the linearised equations has ``|λ| ≤ |ω|`` (the
#: attitude ``|ω|/2``; the body-frame precession of ``m`` at most ``|ω|`` because
#: ``J₁ + J₂ ≥ J₃``), and RK4 is stable on the imaginary axis up to ``h|λ| = 2√2 ≈ 2.83``;
#: at ``h|ω| = 3`` it diverges within ten steps. Steps above the limit are split into equal
#: substeps (:meth:`DynamicsPropagator.step`). An integrator may declare its own
#: ``max_rotation_per_step``; methods not listed (splitting, exact, adaptive) have none.
MAX_ROTATION_PER_STEP = {'rk4': 2.0, 'rkmk4': 2.0}

#: A single step may not be split into more substeps than this.
MAX_SUBSTEPS = 1_000_000

#: Relative slack on the limit, so that a step at the limit up to round-off (h·|ω| computed
#: as 2·(1 + 2ε)) is not split into one substep more.
_LIMIT_SLACK = 1.0 + 1e-9


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


class GyroState(PropagatorState):
    """A :class:`PropagatorState` that keeps attitude and rate as float tuples.

    The gyro hot path (:meth:`GyroPropagator.advance`, once per sample) writes tuples with
    :meth:`set_sample` and reads them with :meth:`attitude_tuple` / :meth:`omega_tuple`, so no
    array is built per sample (each costs about 1 µs, more with a cold cache). ``attitude``
    and ``omega_body`` are built when read and are read-only: assign a new value to change
    them.
    """

    _attitude_floats: tuple[float, float, float, float]
    _omega_floats: tuple[float, float, float]
    _attitude_array: FloatArray | None
    _omega_array: FloatArray | None

    @property  # type: ignore[override]
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

    @property  # type: ignore[override]
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
        self.rotors = [e for e in self.effects if hasattr(e, 'rotor_momentum')]
        self._inertia_entries = tuple(scene.inertia.tensor.ravel().tolist())
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
        return any('position' in e.outputs() for e in self.stateful)

    def reset(self, time: float = 0.0) -> None:
        """Back to the scene's initial state at ``time``; every effect resets too."""
        for effect in self.effects:
            effect.reset()
        self.state = self._state_type(time, self.scene.initial_attitude.copy(),
                                      self.scene.initial_omega_body.copy())
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
                if hasattr(effect, 'set_position'):
                    effect.set_position(new_position)
            self._sync_position()
        self.tracker = DiagnosticsTracker(self.energy(), self.world_momentum())

    def command(self, input_name: str, t: float, value: ArrayLike) -> None:
        """Pass a commanded input (e.g. ``torque`` [N m, body]) stamped ``t`` to its effects.

        Raises :class:`InputError` for an input no effect takes or a non-finite value.
        """
        if input_name not in self.input_routes:
            raise InputError(f'Scene {self.scene.name!r} takes no input {input_name!r}; '
                             f'inputs: {", ".join(sorted(self.input_routes)) or "(none)"}')
        vector = quaternion.as_vector(value, input_name)
        if vector.shape != (3,) or not math.isfinite(t):
            raise InputError(f'Expected `{input_name}` as 3 finite numbers at a finite time, '
                             f'got {vector.tolist()!r} at t={t!r}')
        for effect in self.input_routes[input_name]:
            effect.accept_input(input_name, t, vector)

    def counters(self) -> dict[str, int]:
        """Counters of every effect, e.g. ``commanded_torque.stale``."""
        return {f'{effect.name}.{key}': value for effect in self.effects
                for key, value in effect.counters.items()}

    def rotor_momentum(self, t: float) -> FloatArray:
        """Summed rotor momentum [N m s, body] at ``t`` (zero without rotors)."""
        total = np.zeros(3)
        for effect in self.rotors:
            total = total + effect.rotor_momentum(t)[0]
        return total

    def energy(self) -> float:
        """Kinetic energy [J]: rotation plus the effects' own (translation)."""
        p, q, r = self.state.omega_tuple()
        j00, j01, j02, _, j11, j12, _, _, j22 = self._inertia_entries
        rotation = 0.5 * (j00 * p * p + j11 * q * q + j22 * r * r) + (
            j01 * p * q + j02 * p * r + j12 * q * r)
        if self.stateful:
            return rotation + sum(effect.kinetic_energy() for effect in self.stateful)
        return rotation

    def world_momentum(self) -> FloatArray:
        """World-frame angular momentum ``R(q)(J ω + h)`` [N m s] (plain float math)."""
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
        return np.array([mx + w * tx + (y * tz - z * ty),
                         my + w * ty + (z * tx - x * tz),
                         mz + w * tz + (x * ty - y * tx)])

    def diagnostics(self) -> Diagnostics:
        """Energy, momentum and their drift, energy-balance residual, norm error."""
        return self.tracker.snapshot(self.state.attitude, self.energy(), self.world_momentum())

    def _sync_position(self) -> None:
        for effect in self.stateful:
            outputs = effect.outputs()
            if 'position' in outputs:
                self.state.position = np.array(outputs['position'])


class DynamicsPropagator(_Propagator):
    """Integrates Euler's equations and the attitude with the scene's integrator and step."""

    def __init__(self, scene: Scene) -> None:
        """Build the scene's effects, the body model and the integrator."""
        if scene.rate_source != 'dynamics':
            raise IntegratorError(f'DynamicsPropagator needs a dynamics scene, got '
                                  f'rate_source {scene.rate_source!r}')
        super().__init__(scene)
        torque_effects = [e for e in self.effects if hasattr(e, 'torque_body')]
        self.model = RigidBodyModel(
            scene.inertia, tuple(e.torque_body for e in torque_effects),
            tuple(e.rotor_momentum for e in self.effects if hasattr(e, 'rotor_momentum')),
            torque_depends_on_rate=any(e.torque_depends_on_rate for e in torque_effects))
        self.force_effects = [e for e in self.effects if hasattr(e, 'force_world')]
        self.switching = [e for e in self.effects if hasattr(e, 'switch_times')]
        self.integrator = dynamics_integrator(scene.integrator)
        if not self.model.torque_free and not self.integrator.supports_torque:
            raise IntegratorError(f'Integrator {scene.integrator!r} handles torque-free bodies '
                                  f'only; scene {scene.name!r} has torques or rotors '
                                  f'({", ".join(e.name for e in self.effects)}). Use one of '
                                  f'{", ".join(torque_integrators())}')
        self._power_start: float | None = None
        self.rotation_limit = float(getattr(
            self.integrator, 'max_rotation_per_step',
            MAX_ROTATION_PER_STEP.get(self.integrator.name, math.inf)))
        self.substeps_taken = 0

    def step(self, h: float) -> None:
        """Advance the state by one step of ``h`` seconds.

        An explicit method whose stability limit :attr:`rotation_limit` the step would exceed
        (``h·|ω| > limit``, :data:`MAX_ROTATION_PER_STEP`) takes equal substeps instead, each
        within the limit for the rate at its start; :attr:`substeps_taken` counts the extra
        ones. Raises :class:`InputError` unless ``h`` is a positive finite number, and
        :class:`IntegratorError` if more than :data:`MAX_SUBSTEPS` substeps would be needed;
        the state is then unchanged.
        """
        if not (isinstance(h, numbers.Real) and math.isfinite(h) and h > 0.0):
            raise InputError(f'Expected `h` to be a positive finite number of seconds, got {h!r}')
        if h * _norm(self.state.omega_body) <= self.rotation_limit * _LIMIT_SLACK:
            self._single_step(h)
            return
        start = (self.state.time, self.state.attitude, self.state.omega_body,
                 self.state.position, self.tracker.work)
        try:
            self._substeps(h)
        except IntegratorError:
            (self.state.time, self.state.attitude, self.state.omega_body, self.state.position,
             self.tracker.work) = start
            raise
        self.state.time = start[0] + h

    def _substeps(self, h: float) -> None:
        """Cover ``h`` with substeps of at most :attr:`rotation_limit` rad each."""
        end = self.state.time + h
        remaining = h
        taken = 0
        while remaining > 0.0:
            needed = math.ceil(remaining * _norm(self.state.omega_body)
                               / (self.rotation_limit * _LIMIT_SLACK))
            if taken + needed > MAX_SUBSTEPS:
                raise IntegratorError(
                    f'Integrator {self.integrator.name!r} is stable only for h·|ω| <= '
                    f'{self.rotation_limit} rad; a step of {h!r} s at |ω| = '
                    f'{_norm(self.state.omega_body)!r} rad/s would need more than '
                    f'{MAX_SUBSTEPS} substeps. Use a smaller step or the strang, yoshida4, '
                    f'dopri45 or exact integrator')
            substep = remaining / max(needed, 1)
            self._single_step(substep)
            taken += 1
            remaining = end - self.state.time if needed > 1 else 0.0
        self.substeps_taken += taken - 1

    def _single_step(self, h: float) -> None:
        state = self.state
        t, attitude, omega = state.time, state.attitude, state.omega_body
        for effect in self.switching:
            effect.begin_step(t, t + h)
        try:
            new_attitude, new_omega = self.integrator.step(attitude, omega, t, h, self.model)
            if not self.model.torque_free:
                self.tracker.add_work(self._rotational_work(t, h, attitude, omega,
                                                            new_attitude, new_omega))
            for effect in self.stateful:
                self.tracker.add_work(effect.advance(t, h, attitude, new_attitude, self._force))
        finally:
            for effect in self.switching:
                effect.end_step()
        state.time, state.attitude, state.omega_body = t + h, new_attitude, new_omega
        if self.stateful:
            self._sync_position()

    def advance_to(self, t_end: float) -> int:
        """Integrate with the scene's step up to ``t_end`` (the last step may be shorter).

        Steps end exactly where a commanded input switches (a new command's stamp, a timeout),
        so no step straddles a jump of the torque and the integrator keeps its order. Returns
        the number of steps taken. Raises :class:`InputError` for a non-finite time or one
        needing more than :data:`MAX_STEPS_PER_CALL` steps; the state is unchanged.
        """
        if not math.isfinite(t_end):
            raise InputError(f'Expected `t_end` to be finite, got {t_end!r}')
        if (t_end - self.state.time) / self.scene.step > MAX_STEPS_PER_CALL:
            raise InputError(f'Advancing to t_end={t_end!r} from {self.state.time!r} needs '
                             f'more than {MAX_STEPS_PER_CALL} steps of {self.scene.step} s')
        start = self.state.time
        switches = sorted({time for effect in self.switching for time in effect.switch_times()
                           if start < time < t_end})
        return sum(self._advance_steps(boundary) for boundary in switches + [t_end])

    def _advance_steps(self, t_end: float) -> int:
        """Steps of the scene's step up to ``t_end``, the last one shorter."""
        step = self.scene.step
        remaining = t_end - self.state.time
        steps = 0
        while remaining > 1e-12 * max(1.0, abs(t_end)):
            self.step(min(step, remaining))
            steps += 1
            remaining = t_end - self.state.time
        if steps:
            # t + h + h + ... misses t_end by round-off; the steps covered [t, t_end]
            self.state.time = float(t_end)
        return steps

    def _force(self, t: float, attitude: FloatArray) -> FloatArray:
        total = np.zeros(3)
        for effect in self.force_effects:
            total = total + effect.force_world(t, attitude)
        return total

    def _power(self, t: float, attitude: FloatArray, omega: FloatArray) -> float:
        return float(omega @ self.model.external_torque(t, attitude, omega))

    def _rotational_work(self, t: float, h: float, attitude: FloatArray, omega: FloatArray,
                         new_attitude: FloatArray, new_omega: FloatArray) -> float:
        """``∫ ω·(M − ḣ) dt`` over the step by Simpson's rule (error O(h⁵) per step).

        The midpoint rate comes from cubic Hermite interpolation with the end slopes from
        Euler's equations (error O(h⁴)); the midpoint attitude from the exponential map of
        the mean rate.
        """
        slope_start = self.model.omega_dot(t, attitude, omega)
        slope_end = self.model.omega_dot(t + h, new_attitude, new_omega)
        omega_mid = 0.5 * (omega + new_omega) + 0.125 * h * (slope_start - slope_end)
        attitude_mid = quaternion.multiply(
            attitude, quaternion.exp(0.25 * h * (omega + omega_mid)))
        power_start = self._power(t, attitude, omega)
        power_mid = self._power(t + 0.5 * h, attitude_mid, omega_mid)
        power_end = self._power(t + h, new_attitude, new_omega)
        return h / 6.0 * (power_start + 4.0 * power_mid + power_end)


class GyroPropagator(_Propagator):
    """Strapdown integration of measured body rates with the scene's strapdown method."""

    _state_type = GyroState
    state: GyroState

    def __init__(self, scene: Scene) -> None:
        """Build the rate corrections and the strapdown method named by the scene."""
        if scene.rate_source != 'gyro':
            raise IntegratorError(f'GyroPropagator needs a gyro scene, got rate_source '
                                  f'{scene.rate_source!r}')
        self.method = strapdown_method(scene.integrator)
        super().__init__(scene)
        self.corrections = [e for e in self.effects if hasattr(e, 'corrected_rate')]

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


def _norm(vector: FloatArray) -> float:
    """Euclidean norm of a (3,) array in plain float math."""
    x, y, z = vector.tolist()
    return math.sqrt(x * x + y * y + z * z)


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
