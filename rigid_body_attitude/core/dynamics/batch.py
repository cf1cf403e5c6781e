"""Many bodies at once: Monte-Carlo dispersions of initial states, inertia and effects.

:class:`SceneBatch` advances N bodies of any dynamics scene, effects included (each effect
adds its own torque or force for a chunk of bodies), with the single-body propagator's RK4
steps; per-body inertia, mass, attitude, rate and effect parameters may differ.

:class:`TorqueFreeBatch` advances N bodies with the same classical RK4 (+ renormalisation)
as the ``rk4`` dynamics integrator, vectorised over bodies. Two things make it fast with plain
NumPy:

* each body is integrated in its own **principal frame**: ``q_p = q ⊗ P``, ``ω_p = Pᵀ ω``
  (``P`` the principal axes). Euler's equations become ``ω̇₁ = (J₂ − J₃)/J₁ ω₂ ω₃`` (and
  cyclic): 6 products instead of the 39 operations of a full tensor. RK4 commutes with a
  constant linear change of variables, so the result equals the body-frame RK4 step up to
  round-off;
* the bodies are processed in **chunks** that stay in the CPU cache for all the steps of a
  call, with preallocated work arrays (structure of arrays, no temporaries).

Conventions: :mod:`rigid_body_attitude.core.attitude.quaternion`. Order 4; cost per body-step about
170
vector operations / chunk size; invariants as RK4 (``|q|`` by projection).
"""

from __future__ import annotations

from collections.abc import Iterator, Mapping
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from rigid_body_attitude.core.attitude import quaternion
from rigid_body_attitude.core.dynamics.batch_chunk import SceneChunk
from rigid_body_attitude.core.dynamics import wheel_batch
from rigid_body_attitude.core.dynamics.effects import (
    CommandedEffect, Effect, HeldOverStep, RotorState, SampledTorque)
from rigid_body_attitude.core.dynamics.effects.sampled import segment_end
from rigid_body_attitude.core.dynamics.effects.translation import Translation
from rigid_body_attitude.core.errors import InputError
from rigid_body_attitude.core.dynamics.inertia import Inertia
from rigid_body_attitude.core.dynamics.scene import Scene

__all__ = ['SceneBatch', 'TorqueFreeBatch']

FloatArray = NDArray[np.float64]

#: Bodies per chunk of :class:`TorqueFreeBatch`: the state and the work arrays (about 1 MB)
#: stay in the L2 cache.
DEFAULT_CHUNK = 4096
#: Bodies per chunk of :class:`SceneBatch`: its work arrays and per-body tensors outgrow the
#: L2 cache anyway, and longer rows spread NumPy's per-call cost over more bodies (the fastest
#: of 2048 to 32768 in a sweep with ``bench/batch_throughput.py --chunk``).
SCENE_CHUNK = 8192


def _principal(inertia: ArrayLike, count: int) -> tuple[FloatArray, FloatArray]:
    """Principal moments (N, 3) and right-handed axes (N, 3, 3) of one or N tensors."""
    try:
        tensors = np.asarray(inertia, dtype=np.float64)
    except (TypeError, ValueError) as err:
        raise InputError(f'Expected `inertia` to be numeric, got {inertia!r}') from err
    if tensors.shape in ((3,), (3, 3)):
        single = Inertia(tensors)
        return (np.broadcast_to(single.principal_moments, (count, 3)),
                np.broadcast_to(single.principal_axes, (count, 3, 3)))
    if tensors.shape == (count, 3):
        tensors = tensors[:, :, None] * np.eye(3)
    if tensors.shape != (count, 3, 3):
        raise InputError(f'Expected `inertia` of shape (3,), (3, 3), ({count}, 3) or '
                         f'({count}, 3, 3), got {tensors.shape}')
    for index in np.flatnonzero(~np.all(np.isfinite(tensors), axis=(1, 2))
                                | np.any(np.abs(tensors - tensors.transpose(0, 2, 1))
                                         > 1e-12 * np.abs(tensors).max(axis=(1, 2))[:, None,
                                                                                    None],
                                         axis=(1, 2)))[:1]:
        Inertia(tensors[index])
    moments, axes = np.linalg.eigh(tensors)
    bad = (moments[:, 0] <= 0.0) | (moments[:, 0] + moments[:, 1] < moments[:, 2] * (1 - 1e-12))
    if np.any(bad):
        Inertia(tensors[np.flatnonzero(bad)[0]])
    axes[np.linalg.det(axes) < 0.0, :, 2] *= -1.0
    return moments, axes


class TorqueFreeBatch:
    """N torque-free rigid bodies advanced together with RK4.

    Attributes:
        count: number of bodies N.
    """

    def __init__(self, inertia: ArrayLike, attitude: ArrayLike, omega_body: ArrayLike,
                 chunk: int = DEFAULT_CHUNK) -> None:
        """Bodies with ``inertia`` (one tensor or moments for all, or one per body),
        ``attitude`` (N, 4) unit quaternions and ``omega_body`` (N, 3) [rad/s]."""
        attitude = quaternion.normalize(quaternion.as_quaternion(attitude, 'attitude'))
        omega = quaternion.as_vector(omega_body, 'omega_body')
        if attitude.ndim != 2 or omega.shape != (attitude.shape[0], 3):
            raise InputError(f'Expected `attitude` (N, 4) and `omega_body` (N, 3), got '
                             f'{attitude.shape} and {omega.shape}')
        self.count = attitude.shape[0]
        self.chunk = max(1, int(chunk))
        moments, axes = _principal(inertia, self.count)
        self._axes = np.ascontiguousarray(axes)
        self._axes_quaternion = quaternion.from_matrix(self._axes)
        j1, j2, j3 = moments.T
        self._gain = np.ascontiguousarray(np.stack([(j2 - j3) / j1, (j3 - j1) / j2,
                                                    (j1 - j2) / j3]))
        self._moments = np.ascontiguousarray(moments)
        self._state = np.empty((7, self.count))
        self._state[:4] = quaternion.multiply(attitude, self._axes_quaternion).T
        self._state[4:] = np.einsum('nji,nj->in', self._axes, omega)

    @property
    def attitude(self) -> FloatArray:
        """(N, 4) body → world quaternions."""
        principal = self._state[:4].T
        attitude: FloatArray = quaternion.multiply(principal,
                                                   quaternion.conjugate(self._axes_quaternion))
        return attitude

    @property
    def omega_body(self) -> FloatArray:
        """(N, 3) body rates [rad/s]."""
        omega: FloatArray = np.einsum('nij,jn->ni', self._axes, self._state[4:])
        return omega

    def kinetic_energy(self) -> FloatArray:
        """(N,) kinetic energies ``½ Σ J_i ω_i²`` [J]."""
        energy: FloatArray = 0.5 * np.sum(self._moments.T * self._state[4:] ** 2, axis=0)
        return energy

    def world_angular_momentum(self) -> FloatArray:
        """(N, 3) world-frame angular momenta [N m s]."""
        momentum_principal = (self._moments.T * self._state[4:]).T
        return quaternion.rotate(self._state[:4].T, momentum_principal)

    def rk4(self, h: float, steps: int = 1) -> None:
        """Advance every body by ``steps`` RK4 steps of ``h`` seconds."""
        if not np.isfinite(h) or h <= 0.0:
            raise InputError(f'Expected `h` to be a positive number of seconds, got {h!r}')
        for start in range(0, self.count, self.chunk):
            stop = min(start + self.chunk, self.count)
            block = np.ascontiguousarray(self._state[:, start:stop])
            gain = np.ascontiguousarray(self._gain[:, start:stop])
            _rk4_block(block, gain, h, int(steps))
            self._state[:, start:stop] = block


def _derivative(y: FloatArray, gain: FloatArray, out: FloatArray,
                half_rate: FloatArray, scratch: FloatArray) -> None:
    """``(q̇, ω̇)`` of the principal-frame torque-free body into ``out`` (7, n)."""
    qw, qx, qy, qz, p, q, r = y
    np.multiply(y[4:], 0.5, out=half_rate)
    hx, hy, hz = half_rate
    t = scratch[0]
    # q̇ = q ⊗ (0, ω/2)
    np.multiply(qx, hx, out=out[0])
    np.multiply(qy, hy, out=t)
    out[0] += t
    np.multiply(qz, hz, out=t)
    out[0] += t
    np.negative(out[0], out=out[0])
    _combine(out[1], qw, hx, qy, hz, qz, hy, t)
    _combine(out[2], qw, hy, qz, hx, qx, hz, t)
    _combine(out[3], qw, hz, qx, hy, qy, hx, t)
    # ω̇ᵢ = gainᵢ ωⱼ ωₖ
    np.multiply(q, r, out=out[4])
    out[4] *= gain[0]
    np.multiply(r, p, out=out[5])
    out[5] *= gain[1]
    np.multiply(p, q, out=out[6])
    out[6] *= gain[2]


def _combine(out: FloatArray, a: FloatArray, b: FloatArray, c: FloatArray, d: FloatArray,
             e: FloatArray, f: FloatArray, t: FloatArray) -> None:
    """``out = a b + c d − e f``."""
    np.multiply(a, b, out=out)
    np.multiply(c, d, out=t)
    out += t
    np.multiply(e, f, out=t)
    out -= t


def _rk4_block(y: FloatArray, gain: FloatArray, h: float, steps: int) -> None:
    """RK4 + renormalisation on one cache-sized block, in place."""
    n = y.shape[1]
    k = np.empty((7, n))
    total = np.empty((7, n))
    stage = np.empty((7, n))
    half_rate = np.empty((3, n))
    scratch = np.empty((1, n))
    norm = np.empty(n)
    for _ in range(steps):
        _derivative(y, gain, total, half_rate, scratch)
        np.multiply(total, 0.5 * h, out=stage)
        stage += y
        _derivative(stage, gain, k, half_rate, scratch)
        np.multiply(k, 2.0, out=k)
        total += k
        np.multiply(k, 0.25 * h, out=stage)
        stage += y
        _derivative(stage, gain, k, half_rate, scratch)
        np.multiply(k, 2.0, out=k)
        total += k
        np.multiply(k, 0.5 * h, out=stage)
        stage += y
        _derivative(stage, gain, k, half_rate, scratch)
        total += k
        total *= h / 6.0
        y += total
        np.einsum('in,in->n', y[:4], y[:4], out=norm)
        np.sqrt(norm, out=norm)
        y[:4] /= norm


class SceneBatch:
    """N bodies of one dynamics scene, effects included, advanced together with RK4.

    Each body may have its own inertia, mass, attitude, rate and effect parameters (a
    Monte-Carlo dispersion); the effects' time-dependent parts (the orbit, held commands)
    are shared. Every body takes the steps the single-body
    :class:`~rigid_body_attitude.core.propagator.DynamicsPropagator` would take for the scene
    with the ``rk4`` integrator (the scene's step, the last one shorter, ends at the commanded
    inputs' switch times) and the same arithmetic per body, vectorised over bodies in the body
    frame (structure of arrays, chunks of :data:`SCENE_CHUNK` bodies, work arrays allocated
    once per chunk, the body-frame angular momentum as the state:
    :class:`~.batch_chunk.SceneChunk`); each
    effect adds its own batch torque or force (:meth:`.TorqueEffect.add_batch_torque`). So
    each body matches the single-body result up to round-off (``test/core/dynamics/test_batch.py``:
    1e−12). Order 4; no substeps: every body must keep ``h·|ω|`` within RK4's limit (checked
    per call).
    """

    def __init__(self, scene: Scene, attitude: ArrayLike, omega_body: ArrayLike,
                 inertia: ArrayLike | None = None, mass: ArrayLike | None = None,
                 effect_parameters: Mapping[str, Mapping[str, ArrayLike]] | None = None,
                 chunk: int = SCENE_CHUNK) -> None:
        """Bodies of ``scene`` at ``attitude`` (N, 4) and ``omega_body`` (N, 3) [rad/s].

        ``inertia`` (one tensor for all or (N, 3, 3); default the scene's) and ``mass``
        (float or (N,); default the scene's) may be dispersed, and so may any numeric effect
        parameter: ``effect_parameters[effect][parameter]`` holds one value per body with the
        parameter's own shape ((N,) for a number, (N, 3) for a vector).
        """
        attitude = quaternion.normalize(quaternion.as_quaternion(attitude, 'attitude'))
        omega = quaternion.as_vector(omega_body, 'omega_body')
        if attitude.ndim != 2 or omega.shape != (attitude.shape[0], 3):
            raise InputError(f'Expected `attitude` (N, 4) and `omega_body` (N, 3), got '
                             f'{attitude.shape} and {omega.shape}')
        self.scene = scene
        self.count = attitude.shape[0]
        self.chunk = max(1, int(chunk))
        self.time = 0.0
        self._tensor, self._inverse = _tensors(scene, inertia, self.count)
        self._mass = np.broadcast_to(np.asarray(scene.mass if mass is None else mass,
                                                dtype=np.float64), (self.count,)).copy()
        self.effects = scene.build_effects()
        self._parameters = [_effect_parameters(effect, (effect_parameters or {}).get(
            effect.name, {}), self.count) for effect in self.effects]
        self._tensor, self._inverse = _without_wheels(self._tensor, self._inverse,
                                                      self.effects, self._parameters,
                                                      self.count)
        self._state = np.ascontiguousarray(np.concatenate([attitude.T, omega.T]))
        self.translation = next((e for e in self.effects if isinstance(e, Translation)), None)
        if self.translation is not None:
            self.position = np.repeat(self.translation.position[:, None], self.count, axis=1)
            self.velocity = np.repeat(self.translation.velocity[:, None], self.count, axis=1)
        self.switching = [e for e in self.effects if isinstance(e, CommandedEffect)]
        self.sampled = [e for e in self.effects if isinstance(e, SampledTorque)]
        #: Each effect's own per-body state rows (a controller's held torque, wheel momenta),
        #: or None.
        self.effect_states = [np.zeros((_state_rows(e), self.count)) if _state_rows(e) else None
                              for e in self.effects]
        self.input_routes = {name: [e for e in self.effects if name in e.input_names]
                             for e in self.effects for name in e.input_names}
        self._start_held(omega)

    def _start_held(self, omega: FloatArray) -> None:
        """The effects held over each step start from the initial rates (wheel momenta)."""
        if not any(isinstance(e, HeldOverStep) for e in self.effects):
            return
        for start in range(0, self.count, self.chunk):
            bodies = slice(start, min(start + self.chunk, self.count))
            chunk = SceneChunk(self, bodies)
            for effect, view in chunk.held:
                effect.batch_start(np.ascontiguousarray(omega[bodies].T), view)

    @property
    def attitude(self) -> FloatArray:
        """(N, 4) body → world quaternions."""
        return np.ascontiguousarray(self._state[:4].T)

    @property
    def omega_body(self) -> FloatArray:
        """(N, 3) body rates [rad/s]."""
        return np.ascontiguousarray(self._state[4:].T)

    def command(self, input_name: str, t: float, value: ArrayLike) -> None:
        """A commanded input (``torque``, ``force``, ``rotor_torque``) for every body."""
        if input_name not in self.input_routes:
            raise InputError(f'Scene {self.scene.name!r} takes no input {input_name!r}')
        vector = quaternion.as_vector(value, input_name)
        for effect in self.input_routes[input_name]:
            effect.accept_input(input_name, t, vector)

    def set_effect_parameters(self, effect_parameters: Mapping[str, Mapping[str, ArrayLike]]
                              ) -> None:
        """Replace dispersed effect parameters (one value per body, as in the constructor)
        for the steps that follow, e.g. a new torque per body at a command time."""
        for index, effect in enumerate(self.effects):
            given = effect_parameters.get(effect.name)
            if given:
                parameters, dispersed = self._parameters[index]
                update, names = _effect_parameters(effect, given, self.count)
                self._parameters[index] = ({**parameters, **{name: update[name]
                                                             for name in names}},
                                           dispersed | names)
        unknown = sorted(set(effect_parameters) - {effect.name for effect in self.effects})
        if unknown:
            raise InputError(f'Scene {self.scene.name!r} has no effect {unknown[0]!r}')

    def discard(self, bodies: NDArray[np.bool_]) -> None:
        """Take ``bodies`` (a mask of N) out of the dynamics: their state becomes NaN, which
        stays NaN and touches no other body (e.g. runs whose dynamics failed)."""
        mask = np.asarray(bodies, dtype=bool)
        if mask.shape != (self.count,):
            raise InputError(f'Expected a mask of {self.count} bodies, got {mask.shape}')
        self._state[:, mask] = np.nan

    def advance_to(self, t_end: float) -> int:
        """Advance every body to ``t_end`` with the single-body propagator's steps; returns
        the number of steps."""
        if not np.isfinite(t_end):
            raise InputError(f'Expected `t_end` to be finite, got {t_end!r}')
        # fmax skips NaN: discarded bodies take no part in the check.
        speed = float(np.sqrt(np.fmax.reduce(np.sum(self._state[4:] ** 2, axis=0))))
        if self.scene.step * speed > 2.0:
            raise InputError(f'A body turns {self.scene.step * speed:.3g} rad per step of '
                             f'{self.scene.step} s: above RK4\'s limit of 2 rad')
        steps = 0
        tolerance = 1e-12 * max(1.0, abs(t_end))
        while t_end - self.time > tolerance:
            due = [controller for controller in self.sampled if controller.due(self.time)]
            if due:
                self._sample(due)
            steps += self._segment(segment_end(self.time, t_end, self.switching, self.sampled))
        return steps

    def _sample(self, due: list[SampledTorque]) -> None:
        """The controllers ``due`` sample every body's state at the current time."""
        for start in range(0, self.count, self.chunk):
            bodies = slice(start, min(start + self.chunk, self.count))
            chunk = SceneChunk(self, bodies)
            for controller, view in chunk.sampled:
                if controller in due:
                    controller.sample_batch(self.time, self._state[:4, bodies],
                                            self._state[4:, bodies], view)
        for controller in due:
            controller.sampled(self.time)

    def torque_used(self, name: str) -> tuple[FloatArray, FloatArray]:
        """``∫|τ| dt`` [N m s] and peak ``|τ|`` [N m] of every body of the controller
        ``name`` (a :class:`.SampledTorque`) from its first sample to the batch's time, each
        (N,)."""
        for effect, state in zip(self.effects, self.effect_states):
            if effect.name == name and isinstance(effect, SampledTorque) and state is not None:
                return effect.batch_torque_used(self.time, state)
        raise InputError(f'Scene {self.scene.name!r} has no controller {name!r}')

    def _segment(self, t_end: float) -> int:
        """Steps up to ``t_end`` with no input switch inside (commands pinned once)."""
        t_start = self.time
        if not _Steps(t_start, t_end, self.scene.step):
            self.time = float(t_end)
            return 0
        for effect in self.switching:
            effect.begin_step(t_start, t_end)
        taken = 0
        try:
            for start in range(0, self.count, self.chunk):
                taken = self._advance_chunk(slice(start, min(start + self.chunk, self.count)),
                                            t_start, t_end)
        finally:
            for effect in self.switching:
                effect.end_step()
        self.time = float(t_end)
        return taken

    def _advance_chunk(self, bodies: slice, t_start: float, t_end: float) -> int:
        """Every step from ``t_start`` to ``t_end`` on one cache-sized chunk of bodies, in
        place (the steps are generated one by one, never listed); returns their number."""
        chunk = SceneChunk(self, bodies)
        y = np.empty((7, chunk.mass.shape[0]))  # (q, h = J ω)
        y[:4] = self._state[:4, bodies]
        chunk.momentum(self._state[4:, bodies], y[4:])
        translation = self.translation is not None
        if translation:
            position = self.position[:, bodies]
            velocity = self.velocity[:, bodies]
            force_start = chunk.force(t_start, y[:4])
        taken = 0
        for t, h in _Steps(t_start, t_end, self.scene.step):
            if chunk.held:
                chunk.hold(t, h, y)
            chunk.rk4(t, y, h)
            if chunk.wheels:
                chunk.commit(t, h, y)
            taken += 1
            if translation:
                force_end = chunk.force(t + h, y[:4])
                Translation.batch_advance(h, chunk.mass, position, velocity, force_start,
                                          force_end)
                force_start = force_end
        self._state[:4, bodies] = y[:4]
        chunk.rate(y[4:], self._state[4:, bodies])
        if translation:
            self.position[:, bodies] = position
            self.velocity[:, bodies] = velocity
        return taken

    def kinetic_energy(self) -> FloatArray:
        """(N,) rotational kinetic energies ``½ ωᵀ J' ω`` [J] (``J' = J`` without wheels),
        plus the wheels' ``Σ Hᵢ²/(2 Jₛᵢ)``."""
        omega = self._state[4:]
        tensor = np.broadcast_to(self._tensor, (3, 3, self.count))
        energy: FloatArray = 0.5 * np.einsum('in,ijn,jn->n', omega, tensor, omega)
        for effect, state, parameters in self._wheel_states():
            energy += wheel_batch.energies(effect, parameters, state)
        return energy

    def momentum_body(self) -> FloatArray:
        """(N, 3) body-frame angular momenta ``J' ω + Σ Hᵢ âᵢ`` [N m s] (wheels included)."""
        omega = self._state[4:]
        tensor = np.broadcast_to(self._tensor, (3, 3, self.count))
        momentum: FloatArray = np.einsum('ijn,jn->in', tensor, omega)
        for effect, state, parameters in self._wheel_states():
            momentum += wheel_batch.momenta(effect, parameters, state)
        return np.ascontiguousarray(momentum.T)

    def _wheel_states(self) -> list[tuple[RotorState, FloatArray, dict[str, Any]]]:
        """Each wheel array with its state rows and batch parameters."""
        return [(effect, state, parameters) for effect, state, (parameters, _) in zip(
            self.effects, self.effect_states, self._parameters)
            if isinstance(effect, RotorState) and state is not None]

    def effect_totals(self, name: str) -> dict[str, FloatArray]:
        """Per-body totals (N,) of the effect ``name``: a wheel array's ``peak_speed``
        [rad/s], ``time_saturated`` [s], ``motor_work`` and ``friction_loss`` [J]; the
        magnetorquers' ``torque_impulse`` [N m s]."""
        for effect, state in zip(self.effects, self.effect_states):
            if effect.name != name or state is None:
                continue
            if isinstance(effect, RotorState):
                return wheel_batch.totals(effect, state)
            if effect.name == 'magnetorquers':
                return {'torque_impulse': state[3].copy()}
        raise InputError(f'Scene {self.scene.name!r} has no wheel array or magnetorquers '
                         f'{name!r}')


class _Steps:
    """``(t, h)`` of the propagator's steps from ``t`` to ``t_end`` (the last shorter),
    generated one at a time (a long segment is never held as a list); true when there is at
    least one."""

    def __init__(self, t: float, t_end: float, step: float) -> None:
        self.t, self.t_end, self.step = t, t_end, step
        self.tolerance = 1e-12 * max(1.0, abs(t_end))

    def __bool__(self) -> bool:
        return self.t_end - self.t > self.tolerance

    def __iter__(self) -> Iterator[tuple[float, float]]:
        t, t_end, step, tolerance = self.t, self.t_end, self.step, self.tolerance
        remaining = t_end - t
        while remaining > tolerance:
            h = step if step < remaining else remaining
            yield t, h
            t += h
            remaining = t_end - t


def _tensors(scene: Scene, inertia: ArrayLike | None,
             count: int) -> tuple[FloatArray, FloatArray]:
    """Per-body inertia tensors and inverses, shape (3, 3, N) (validated as :class:`Inertia`),
    or (3, 3, 1) when every body has the same (NumPy then broadcasts one value: less memory
    traffic per operation)."""
    if inertia is None or np.shape(inertia) in ((3,), (3, 3)):
        shared = scene.inertia if inertia is None else Inertia(inertia)
        return (np.ascontiguousarray(shared.tensor[:, :, None]),
                np.ascontiguousarray(shared.inverse[:, :, None]))
    else:
        tensors = np.asarray(inertia, dtype=np.float64)
        if tensors.shape != (count, 3, 3):
            raise InputError(f'Expected `inertia` (3, 3) or ({count}, 3, 3), got '
                             f'{tensors.shape}')
        _principal(tensors, count)  # validates every tensor
    inverse = np.linalg.inv(tensors)
    return (np.ascontiguousarray(tensors.transpose(1, 2, 0)),
            np.ascontiguousarray(inverse.transpose(1, 2, 0)))


def _state_rows(effect: Effect) -> int:
    """Rows of per-body state an effect keeps in a batch."""
    if isinstance(effect, SampledTorque):
        return effect.STATE_ROWS
    if isinstance(effect, HeldOverStep):
        return effect.batch_state_rows()
    return 0


def _without_wheels(tensor: FloatArray, inverse: FloatArray, effects: list[Effect],
                    parameters: list[tuple[dict[str, Any], frozenset[str]]],
                    count: int) -> tuple[FloatArray, FloatArray]:
    """``J' = J − Σ Jₛ â âᵀ`` per body (3, 3, N or 1) and its inverse (``J`` and its
    ``inverse`` as they are without wheels)."""
    spins = [effect.batch_spin_inertia(params, count)
             for effect, (params, _) in zip(effects, parameters)
             if isinstance(effect, RotorState)]
    if not spins:
        return tensor, inverse
    reduced = tensor - sum(spins)
    reduced_inverse = np.linalg.inv(reduced.transpose(2, 0, 1)).transpose(1, 2, 0)
    return np.ascontiguousarray(reduced), np.ascontiguousarray(reduced_inverse)


def _effect_parameters(effect: Effect, dispersed: Mapping[str, ArrayLike],
                       count: int) -> tuple[dict[str, Any], frozenset[str]]:
    """An effect's numeric parameters as batch arrays: shared ones as floats or (3, 1),
    dispersed ones (one value per body) as (N,) or (3, N); and the dispersed names."""
    unknown = sorted(set(dispersed) - set(effect.params))
    if unknown:
        raise InputError(f'Effect {effect.name!r} has no parameter {unknown[0]!r}')
    shared = sorted(set(dispersed) & effect.shared_parameters)
    if shared:
        raise InputError(f'Effect {effect.name!r}: {shared[0]!r} is shared by every body')
    result: dict[str, Any] = {}
    for name, value in effect.params.items():
        if name in dispersed:
            array = np.asarray(dispersed[name], dtype=np.float64)
            expected = (count,) + np.shape(value)
            if array.shape != expected or not np.all(np.isfinite(array)):
                raise InputError(f'Expected {effect.name}.{name} as finite values of shape '
                                 f'{expected}, got shape {array.shape}')
            result[name] = np.ascontiguousarray(array.T)
        elif isinstance(value, np.ndarray) and value.shape == (3,):
            result[name] = value[:, None]
        else:
            result[name] = value
    return result, frozenset(dispersed)
