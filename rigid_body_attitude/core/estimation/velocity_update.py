"""Gravity through the velocity: the accelerometer's velocity change and a bounded velocity.

**Motion model.** A body that stays within reach (a hand, a robot arm, a mobile robot that
stops and turns) has a bounded velocity; its acceleration is the derivative of that velocity,
so the acceleration's mean over a window ``T`` is ``Δv/T`` and its spectrum vanishes at low
frequency. The filter models the world-frame velocity as a first-order Gauss-Markov process
of correlation time ``τ_v`` and 1σ ``σ_v`` per axis (A. Gelb, "Applied Optimal Estimation",
MIT Press 1974, table 3.8-1): over an update interval ``T``, ``v ← φ v + w`` with
``φ = exp(−T/τ_v)``, ``var(w) = σ_v² (1 − φ²)``; its acceleration spectrum
``2 σ_v² τ_v ω² / (1 + ω² τ_v²)`` vanishes at ``ω = 0``. D. Laidig and T. Seel's VQF exploits
the same property by low-passing the specific force in an almost-inertial frame (Information
Fusion 91, 2023, section 3.2).

``τ_v`` (``velocity_time``) is the time the body takes to reverse its motion: a hand or an
arm swings back within a second. ``σ_v`` is **measured** as the body moves
(:class:`VelocityPower`): a Gauss-Markov velocity changes over ``τ_v`` by
``var(v(t + τ_v) − v(t)) = 2 σ_v² (1 − e⁻¹)`` per axis, and the accelerometer measures that
change (the sum of the last ``τ_v`` of intervals' ``Δv``, gravity removed); its exponential
average over ``motion_power_time`` (the current window included, so a blow raises it at once)
gives ``σ_v²``. A slow hand then bounds the velocity tightly, a violent shake loosely, and at
rest the bound is the accelerometer's noise: the velocity cannot change unseen, and a tilt
error shows at once.

**Measurement** (:func:`velocity_change_measurement`). Over an update interval the specific
force rotated into the world frame with the estimated attitude and summed,
``F = Σ R̂ (f − b̂_a) Δt`` (:class:`.interval_sums.ImuInterval`), is the velocity change plus
gravity: with ``q_true = exp(δθ) ⊗ q_est``, ``R̂ = (I − [δθ×]) R``, to first order::

    F − g up T − (v̂ − v̂₀) = (δv − δv₀) + [F×] δθ + R̄ T δb_a + n,

``v̂₀``, ``δv₀`` the velocity and its error at the interval's start (the clone of
:mod:`.filter_covariance`), ``R̄`` the interval's mean rotation, ``g`` the specific force
measured at rest during levelling, ``n`` the accelerometer's white noise integrated
(variance ``N_a² T`` per axis: the velocity random walk). A tilt error makes the velocity
drift by ``g δθ`` per second; the bounded velocity refuses a drift that lasts longer than
``τ_v``, and that is how the tilt is measured. The linearisation holds the interval's
attitude error at its value at the interval's end: the error of that is second order in ``T``.

**The vertical row measures no tilt.** Its tilt term ``(F × δθ)·up = F_x δθ_y − F_y δθ_x``
needs a horizontal velocity change, and the largest come from blows and taps, whose
integrated specific force is the least reliable (ringing, the accelerometer's nonlinearity
near full scale): a tap would turn a vertical velocity error into a tilt. The term is taken as
noise instead (its variance from the tilt's covariance); the horizontal rows carry the tilt
through gravity, ``g T [up×] δθ``.

**No heading.** A heading error rotates the whole velocity path about the vertical, and a
bounded velocity is as likely turned as not: the velocity says nothing about heading. The
linearised model would still find some (the heading column ``F × up`` of ``[F×]``, a false
observability of the kind G. P. Huang, A. I. Mourikis and S. I. Roumeliotis analyse in
"Observability-based rules for designing consistent EKF SLAM estimators", IJRR 29(5), 2010),
so the velocity is kept in the frame of the estimated heading: that column is zero, and a
heading correction turns the velocity with it (:mod:`.estimator`). World frames here have
their vertical on the z axis (``enu``, ``ned``, ``nwu``).

**Clipping.** An accelerometer at its full scale (``accelerometer_range``; a blow or a fall)
reports less than the specific force: an interval with such a sample measures no velocity
change; its step's variance grows by ``(range · t_clipped)²``, the most the clipped samples
may hide.

**At rest** (:func:`zero_velocity_measurement`): the velocity is zero (P. D. Groves,
"Principles of GNSS, Inertial, and Multisensor Integrated Navigation Systems", 2nd ed., 2013,
section 15.3.1, the zero-velocity update), with noise ``σ_zv``, never gated: the rest test
has already judged the samples.

Assumptions and limitations: the velocity reverses within ``τ_v`` and stays within ``σ_v``
of zero. A vehicle cruising for minutes breaks this model and needs a velocity aid.
"""

from __future__ import annotations

import math
from collections import deque

import numpy as np
from numpy.typing import NDArray

from rigid_body_attitude.core.estimation.filter_covariance import (
    ACCEL_BIAS, FILTER_STATE_SIZE, VELOCITY, VELOCITY_START, FilterCovariance)

__all__ = ['BoundedVelocity', 'VelocityPower', 'velocity_change_measurement',
           'zero_velocity_measurement']

FloatArray = NDArray[np.float64]


class VelocityPower:
    """The measured velocity power ``σ_v²`` [(m/s)² per axis] and the velocity's step
    (module docstring).

    Args:
        velocity_time: ``τ_v`` [s].
        averaging_time: ``motion_power_time`` [s].
        noise_density: the accelerometer's ``N_a`` [m/s²/√Hz] (the floor: ``N_a² τ_v``).
    """

    def __init__(self, velocity_time: float, averaging_time: float,
                 noise_density: float) -> None:
        self.velocity_time = velocity_time
        self.averaging_time = averaging_time
        self.floor = noise_density * noise_density * velocity_time
        self.power = self.floor
        self._changes: deque[tuple[float, FloatArray]] = deque()
        self._window = np.zeros(3)
        self._window_seconds = 0.0

    def step(self, velocity_change: FloatArray, duration: float) -> tuple[float, float]:
        """Fold one interval's velocity change ``Δv`` [m/s] (world frame, gravity removed)
        of length ``duration`` [s]; returns the velocity's step ``(φ, var(w))``."""
        if np.all(np.isfinite(velocity_change)):
            self._changes.append((duration, velocity_change))
            self._window = self._window + velocity_change
            self._window_seconds += duration
            while self._window_seconds - self._changes[0][0] >= self.velocity_time:
                old_duration, old = self._changes.popleft()
                self._window = self._window - old
                self._window_seconds -= old_duration
        change = float(self._window @ self._window) / 3.0
        weight = min(duration / self.averaging_time, 1.0)
        self.power += weight * (max(change, self.floor) - self.power)
        return self.decay(max(self.power, change), duration)

    def decay(self, power: float, duration: float) -> tuple[float, float]:
        """``(φ, var(w))`` over ``duration`` [s] for the velocity-change power ``power``
        [(m/s)²] over ``τ_v``."""
        variance = power / (2.0 * (1.0 - math.exp(-1.0)))
        decay = math.exp(-duration / self.velocity_time)
        return decay, variance * (1.0 - decay * decay)


def velocity_change_measurement(force_sum: FloatArray, mean_rotation: FloatArray,
                                duration: float, gravity: float, up: FloatArray,
                                velocity_change: FloatArray, noise_density: float,
                                tilt_covariance: FloatArray | None = None
                                ) -> tuple[FloatArray, FloatArray, FloatArray]:
    """``(h, y, r)`` of the velocity change (module docstring): ``force_sum`` ``F`` [m/s]
    (world), ``mean_rotation`` ``R̄``, ``duration`` ``T`` [s], ``gravity`` ``g`` [m/s²],
    ``up`` the world's up, ``velocity_change`` ``v̂ − v̂₀`` [m/s], ``noise_density`` ``N_a``
    [m/s²/√Hz], ``tilt_covariance`` the 2×2 covariance [rad²] of the tilt about the world's
    x and y (the vertical row's tilt term, taken as noise; None: zero)."""
    if tilt_covariance is None:
        tilt_covariance = np.zeros((2, 2))
    fx, fy, fz = (float(value) for value in force_sum)
    h = np.zeros((3, FILTER_STATE_SIZE))
    h[:, VELOCITY] = np.eye(3)
    h[:, VELOCITY_START] = -np.eye(3)
    h[0, 1], h[1, 0] = -fz, fz
    h[:, ACCEL_BIAS] = mean_rotation * duration
    residual = force_sum - gravity * duration * up - velocity_change
    r = np.eye(3) * noise_density ** 2 * duration
    tilt = np.array([-fy, fx])
    r[2, 2] += float(tilt @ tilt_covariance @ tilt)
    return h, residual, r


def zero_velocity_measurement(velocity: FloatArray, stddev: float
                              ) -> tuple[FloatArray, FloatArray, FloatArray]:
    """``(h, y, r)`` of the zero-velocity update: ``velocity`` ``v̂`` [m/s], ``stddev``
    ``σ_zv`` [m/s]."""
    h = np.zeros((3, FILTER_STATE_SIZE))
    h[:, VELOCITY] = np.eye(3)
    return h, -velocity, np.eye(3) * stddev ** 2


class BoundedVelocity:
    """The velocity estimate ``v̂`` [m/s] (world frame, in the estimated heading's frame) and
    its clone ``v̂₀``, with the measured power (module docstring); the estimator's velocity
    channel.

    Args:
        velocity_time: ``τ_v`` [s]; averaging_time: ``motion_power_time`` [s].
        noise_density: the accelerometer's ``N_a`` [m/s²/√Hz].
        zero_velocity_stddev: ``σ_zv`` [m/s].
    """

    def __init__(self, velocity_time: float, averaging_time: float, noise_density: float,
                 zero_velocity_stddev: float) -> None:
        self.noise_density = noise_density
        self.zero_velocity_stddev = zero_velocity_stddev
        self.power = VelocityPower(velocity_time, averaging_time, noise_density)
        self.velocity = np.zeros(3)
        self.velocity_start = np.zeros(3)

    def restart(self, covariance: FilterCovariance) -> None:
        """Zero velocity (a start at rest); the clone taken."""
        self.velocity = np.zeros(3)
        self.clone(covariance)

    def clone(self, covariance: FilterCovariance) -> None:
        """``v̂₀ ← v̂``, ``δv₀ ← δv``: the next interval starts here."""
        self.velocity_start = self.velocity.copy()
        covariance.clone_velocity()

    def _step(self, covariance: FilterCovariance, decay: float, variance: float) -> None:
        covariance.velocity_step(decay, variance)
        self.velocity *= decay

    def change(self, covariance: FilterCovariance, force_sum: FloatArray, duration: float,
               gravity: float, up: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray]:
        """The interval's Gauss-Markov step, then ``(h, y, r)`` of its velocity change:
        ``force_sum`` ``F`` [m/s] (world), ``duration`` [s], ``gravity`` [m/s²]."""
        self._step(covariance, *self.power.step(force_sum - gravity * duration * up,
                                                duration))
        return velocity_change_measurement(
            force_sum, covariance.mean_rotation, duration, gravity, up,
            self.velocity - self.velocity_start, self.noise_density, covariance.p[:2, :2])

    def unseen(self, covariance: FilterCovariance, duration: float,
               extra_variance: float = 0.0) -> None:
        """An interval of ``duration`` [s] whose velocity change is not measured (no
        specific force, or a clipped one): the step only, its variance raised by
        ``extra_variance`` [(m/s)²] (what the clipped samples may hide)."""
        decay, variance = self.power.decay(self.power.power, duration)
        self._step(covariance, decay, variance + extra_variance)

    def at_rest(self) -> tuple[FloatArray, FloatArray, FloatArray]:
        """``(h, y, r)`` of the zero-velocity update."""
        return zero_velocity_measurement(self.velocity, self.zero_velocity_stddev)

    def inject(self, dx: FloatArray) -> None:
        """Add an update's correction; the velocity turns with the heading correction
        ``dx[2]`` (module docstring)."""
        self.velocity = _turned(self.velocity + dx[VELOCITY], float(dx[2]))
        self.velocity_start = _turned(self.velocity_start + dx[VELOCITY_START], float(dx[2]))


def _turned(vector: FloatArray, angle: float) -> FloatArray:
    """``vector`` turned by ``angle`` [rad] about the world's z axis (the vertical)."""
    if angle == 0.0:
        return vector
    c, s = math.cos(angle), math.sin(angle)
    return np.array([c * vector[0] - s * vector[1], s * vector[0] + c * vector[1], vector[2]])
