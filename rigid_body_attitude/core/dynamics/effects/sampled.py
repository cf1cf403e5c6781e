"""The sampled-torque kind (a digital controller in the loop) and where steps end.

:class:`SampledTorque` is the kind of effect that samples the state at instants a whole
number of steps apart and holds its torque in between; :func:`segment_end` is the one rule by
which the single-body propagator and the batch end a segment of steps (at a commanded input's
switch or a controller's sample instant).
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from collections.abc import Mapping, Sequence
from typing import Any, ClassVar

import numpy as np

from rigid_body_attitude.core.dynamics.effects.base import (
    _ZERO, BatchChunk, BodyProperties, CommandedEffect, Effect, FloatArray, Quat, TorqueEffect,
    Vec)
from rigid_body_attitude.core.errors import SceneError

__all__ = ['SampledTorque', 'segment_end']


class SampledTorque(TorqueEffect, ABC):
    """A digital controller's torque [N m, body]: computed by :meth:`control` from the state
    at the first advance after a reset and then at every whole multiple ``n T`` of the period
    (``T`` = :attr:`period`, a whole number of the scene's steps), held until the next
    (zero-order hold), with the torque used so far. This is the rule of
    ``attitude_controller`` (:mod:`rigid_body_attitude.session.controller`): recompute at the
    first tick of each interval ``[n T, (n+1) T)``, hold otherwise; so a scene started at
    ``t = 0`` samples where the controller, ticked at the same instants, recomputes.

    The propagators end a step at every sample instant and call :meth:`sample` there
    (:meth:`sample_batch` for a batch, with each body's own held torque), so within a step
    the torque is a constant the integrator's stages all see. ``∫|τ| dt`` and the peak
    ``|τ|`` (Euclidean norm) are kept as the torque used (:meth:`torque_used`). In a batch
    the per-body state is :attr:`STATE_ROWS` rows of ``chunk.state``: the held torque (3),
    ``∫|τ| dt`` up to the last sample, the peak.
    """

    STATE_ROWS: ClassVar[int] = 5

    def __init__(self, params: Mapping[str, Any], body: BodyProperties) -> None:
        """Validate the parameters; nothing is held before the first sample."""
        super().__init__(params, body)
        #: The effect that turns the held output into a torque (``body``: applied directly).
        self.actuator = 'body'
        self.reset()

    def bind(self, effects: Sequence[Effect]) -> None:
        """A controller driving an actuator effect needs that effect in the scene."""
        if self.actuator != 'body' and not any(e.name == self.actuator for e in effects):
            raise SceneError(f'Effect {self.name!r}: actuator {self.actuator!r} needs effect '
                             f'{self.actuator!r} in the same scene')

    @property
    @abstractmethod
    def period(self) -> float:
        """The control period ``T`` [s]."""

    @abstractmethod
    def control(self, t: float, q: Quat, omega: Vec) -> Vec:
        """The torque commanded at a sample instant ``t`` from ``q`` and ``omega``."""

    @abstractmethod
    def control_batch(self, t: float, q: FloatArray, omega: FloatArray, chunk: BatchChunk,
                      out: FloatArray) -> None:
        """:meth:`control` for every body of ``chunk`` into ``out`` (3, n); ``q`` (4, n),
        ``omega`` (3, n)."""

    def reset(self) -> None:
        """Nothing held, no sample taken, no torque used."""
        self.held: Vec = _ZERO
        self.origin: float | None = None  # the first sample's time
        self.samples = 0  # the next sample is at samples · T
        self.last_sample = 0.0
        self.integral = 0.0
        self.peak = 0.0

    def next_sample(self) -> float:
        """The next sample instant [s] (−inf before the first: a sample is due)."""
        return -math.inf if self.origin is None else self.samples * self.period

    def due(self, t: float) -> bool:
        """Whether a sample is due at ``t`` (a sample instant, within round-off)."""
        return t >= self.next_sample() - 1e-12 * max(1.0, abs(t))

    def _mark(self, t: float) -> None:
        """Record a sample taken at ``t`` (every body of a batch sampled)."""
        if self.origin is None:
            self.origin = t
        # the next multiple of T after t (t itself a multiple within round-off, or the start)
        ratio = t / self.period
        self.samples = math.floor(ratio + 1e-6 + 1e-12 * abs(ratio)) + 1
        self.last_sample = t

    def sample(self, t: float, q: Quat, omega: Vec) -> None:
        """Take a sample at ``t``: hold the new command; account the torque used."""
        x, y, z = self.held
        if self.origin is not None:
            self.integral += math.sqrt(x * x + y * y + z * z) * (t - self.last_sample)
        self.held = x, y, z = self.control(t, q, omega)
        self.peak = max(self.peak, math.sqrt(x * x + y * y + z * z))
        self._mark(t)

    def torque_used(self, t: float) -> tuple[float, float]:
        """``∫|τ| dt`` [N m s] from the first sample to ``t`` and the peak ``|τ|`` [N m]."""
        x, y, z = self.held
        return self.integral + math.sqrt(x * x + y * y + z * z) * (t - self.last_sample), \
            self.peak

    def sample_batch(self, t: float, q: FloatArray, omega: FloatArray,
                     chunk: BatchChunk) -> None:
        """:meth:`sample` for every body of ``chunk`` (its ``state`` rows); the batch calls
        :meth:`sampled` once every chunk is sampled."""
        state = chunk.state
        norm = chunk.scratch('sampled_norm', 1)[0]
        np.sqrt(np.einsum('in,in->n', state[:3], state[:3]), out=norm)
        if self.origin is not None:
            state[3] += norm * (t - self.last_sample)
        self.control_batch(t, q, omega, chunk, state[:3])
        np.sqrt(np.einsum('in,in->n', state[:3], state[:3]), out=norm)
        np.fmax(state[4], norm, out=state[4])

    def sampled(self, t: float) -> None:
        """Every body of the batch was sampled at ``t``."""
        self._mark(t)

    def batch_torque_used(self, t: float, state: FloatArray) -> tuple[FloatArray, FloatArray]:
        """:meth:`torque_used` of every body from its state rows (5, n)."""
        norm = np.sqrt(np.einsum('in,in->n', state[:3], state[:3]))
        return state[3] + norm * (t - self.last_sample), state[4].copy()

    def torque(self, t: float, q: Quat, omega: Vec) -> Vec:
        """The held torque (zero when an actuator effect applies it)."""
        return self.held if self.applies_torque else _ZERO

    def add_batch_torque(self, t: float, q: FloatArray, omega: FloatArray, chunk: BatchChunk,
                         out: FloatArray) -> None:
        """Each body's held torque (none when an actuator effect applies it)."""
        if self.applies_torque:
            out += chunk.state[:3]


def segment_end(t: float, t_end: float, switching: Sequence[CommandedEffect],
                sampled: Sequence[SampledTorque]) -> float:
    """Where an integration segment from ``t`` towards ``t_end`` ends: at the first commanded
    input switch or controller sample instant after ``t`` (beyond round-off), or ``t_end``.
    The single-body propagator and the batch cut their steps by this one rule."""
    tolerance = 1e-12 * max(1.0, abs(t_end))
    end = t_end
    for effect in switching:
        for time in effect.switch_times():
            if t + tolerance < time < end:
                end = time
    for controller in sampled:
        time = controller.next_sample()
        if t + tolerance < time < end:
            end = time
    return end
