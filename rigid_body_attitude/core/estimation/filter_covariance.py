"""The error-state covariance of the attitude filter: the gyro's 15 states and ten more.

Error state (:data:`FILTER_STATE_SIZE` = 25 entries), all small quantities about the estimate:

* ``δθ`` (0-2): the attitude error about fixed **world** axes, ``q_true = exp(δθ) ⊗ q_est``
  (REP-145), as in :mod:`~rigid_body_attitude.core.estimation.attitude_covariance`;
* ``δb`` (3-5): the gyro bias error [rad/s], body frame;
* ``e`` (6-14): the gyro's intrinsic errors (scale factor, misalignment), row-major, as in
  :mod:`~rigid_body_attitude.core.estimation.gyro_error_model`;
* ``δb_a`` (15-17): the accelerometer bias error [m/s²], body frame;
* ``d`` (18): the magnetic heading disturbance [rad] about the world vertical: the angle by
  which the local field's horizontal direction differs from the reference, a first-order
  Gauss-Markov process of 1σ ``σ_d`` and correlation time ``τ_d``;
* ``δv`` (19-21): the body's velocity error [m/s], world frame, and ``δv₀`` (22-24) the same
  at the start of the current update interval (a *clone*: S. I. Roumeliotis, J. W. Burdick,
  "Stochastic cloning: a generalized framework for processing relative state measurements",
  ICRA 2002), which the accelerometer's velocity change over the interval refers to
  (:mod:`.velocity_update`). The velocity itself is a first-order Gauss-Markov process of 1σ
  ``σ_v`` whose step :mod:`.velocity_update` sets (:meth:`FilterCovariance.velocity_step`);
  the clone does not move.

Between measurements (a *fold* of the gyro steps, every update interval) the first 15 states
propagate exactly as the gyro covariance does
(:func:`~rigid_body_attitude.core.estimation.attitude_covariance.propagated_covariance`,
``Φ = [[I, B], [0, I]]`` with the coupling ``B`` of
:func:`~rigid_body_attitude.core.estimation.attitude_covariance.transition_blocks`); their
cross-covariance with the four extra states follows (``P_θx ← P_θx + B P_(b,e)x``). The
accelerometer bias walks with density ``accelerometer_random_walk`` (kalibr's name); the
disturbance ``d`` decays by ``φ = exp(−T/τ_d)`` and gains ``σ_d² (1 − φ²)`` (A. Gelb,
"Applied Optimal Estimation", MIT Press 1974, table 3.8-1, the first-order Markov process).

Which states the updates estimate (:data:`ESTIMATED`): the attitude and the gyro bias always;
the intrinsic errors and the accelerometer bias only when asked (else *considered*: their
uncertainty and correlations shape every gain and covariance, their estimates stay zero:
S. F. Schmidt's consider filter, R. Y. Novoselov et al., "Mitigating the effects of
residual biases with Schmidt-Kalman filtering", FUSION 2005, eq. 9); ``d`` is always
considered (a disturbance is not separable from the heading by a magnetometer); the velocity
and its clone always estimated.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from rigid_body_attitude.core.errors import InputError
from rigid_body_attitude.core.estimation.attitude_covariance import (
    propagated_covariance, transition_blocks)
from rigid_body_attitude.core.estimation.gyro_error_model import ERROR_STATE_SIZE, GyroErrorModel

__all__ = ['ACCEL_BIAS', 'ATTITUDE', 'DISTURBANCE', 'FILTER_STATE_SIZE', 'FilterCovariance',
           'GYRO_BIAS', 'INTRINSIC', 'VELOCITY', 'VELOCITY_START', 'estimated_mask']

FloatArray = NDArray[np.float64]
BoolArray = NDArray[np.bool_]

#: Slices of the error state.
ATTITUDE = slice(0, 3)
GYRO_BIAS = slice(3, 6)
INTRINSIC = slice(6, 15)
ACCEL_BIAS = slice(15, 18)
#: Index of the magnetic heading disturbance.
DISTURBANCE = 18
VELOCITY = slice(19, 22)
VELOCITY_START = slice(22, 25)
FILTER_STATE_SIZE = 25
_VARIANCE_FLOOR = 1e-24


def estimated_mask(intrinsic: bool, accelerometer_bias: bool) -> BoolArray:
    """Which of the :data:`FILTER_STATE_SIZE` states the updates estimate (the others are
    considered): attitude and gyro bias always, ``d`` never."""
    mask = np.zeros(FILTER_STATE_SIZE, dtype=np.bool_)
    mask[ATTITUDE] = True
    mask[GYRO_BIAS] = True
    mask[INTRINSIC] = intrinsic
    mask[ACCEL_BIAS] = accelerometer_bias
    mask[VELOCITY] = True
    mask[VELOCITY_START] = True
    return mask


class FilterCovariance:
    """The 25×25 covariance of the filter's error state (module docstring).

    Args:
        model: the gyro error budget (noise, bias walk, intrinsic priors).
        start: the 15×15 covariance of the gyro states at the start.
        accelerometer_bias_stddev: prior 1σ of each accelerometer bias [m/s²].
        accelerometer_random_walk: its walk density [m/s³/√Hz].
        disturbance_stddev: ``σ_d`` [rad]; ``disturbance_time``: ``τ_d`` [s].
        velocity_start_stddev: 1σ of the velocity at the start [m/s].
    """

    def __init__(self, model: GyroErrorModel, start: FloatArray,
                 accelerometer_bias_stddev: float, accelerometer_random_walk: float,
                 disturbance_stddev: float, disturbance_time: float,
                 velocity_start_stddev: float = 0.5) -> None:
        self.model = model
        self.accelerometer_random_walk = accelerometer_random_walk
        self.disturbance_stddev = disturbance_stddev
        self.disturbance_time = disturbance_time
        self.p = np.zeros((FILTER_STATE_SIZE, FILTER_STATE_SIZE))
        self.p[:ERROR_STATE_SIZE, :ERROR_STATE_SIZE] = start
        self.p[ACCEL_BIAS, ACCEL_BIAS] = np.eye(3) * accelerometer_bias_stddev ** 2
        self.p[DISTURBANCE, DISTURBANCE] = disturbance_stddev ** 2
        self.p[VELOCITY, VELOCITY] = np.eye(3) * velocity_start_stddev ** 2
        self.clone_velocity()
        #: ``∫ R(q) dt / T`` over the last fold: the mean body → world rotation.
        self.mean_rotation = np.eye(3)
        self._samples: list[tuple[float, ...]] = []

    def add_sample(self, q: tuple[float, float, float, float],
                   rate: tuple[float, float, float], dt: float) -> None:
        """Record one strapdown step (attitude at its start, the body rate held [rad/s], its
        length [s]); folded at the next :meth:`fold`. A plain append: the per-sample cost."""
        self._samples.append((*q, *rate, dt))

    def fold(self) -> float:
        """``P ← Φ P Φᵀ + Q`` over the recorded steps; returns their total length [s]."""
        if not self._samples:
            return 0.0
        rows = np.array(self._samples, dtype=np.float64)
        self._samples.clear()
        good = np.isfinite(rows).all(axis=1) & (rows[:, 7] > 0.0)
        if not good.all():
            rows = rows[good]
            if rows.shape[0] == 0:
                return 0.0
        dt = rows[:, 7]
        duration = float(dt.sum())
        coupling = transition_blocks(rows[:, :4], rows[:, 4:7], dt)
        self.mean_rotation = -coupling[:, :3] / duration
        p = self.p
        n = ERROR_STATE_SIZE
        extra = p[:n, n:].copy()
        extra[:3] += coupling @ extra[3:n]
        p[:n, :n] = propagated_covariance(p[:n, :n], coupling, duration, self.model)
        p[:n, n:] = extra
        p[n:, :n] = extra.T
        walk = self.accelerometer_random_walk ** 2 * duration
        p[15, 15] += walk
        p[16, 16] += walk
        p[17, 17] += walk
        decay = math.exp(-duration / self.disturbance_time)
        _markov_step(p, DISTURBANCE, DISTURBANCE + 1, decay,
                     self.disturbance_stddev ** 2 * (1.0 - decay * decay))
        return duration

    def velocity_step(self, decay: float, variance: float) -> None:
        """The velocity's Gauss-Markov step: ``δv ← φ δv + w``, ``var(w)`` = ``variance``
        [(m/s)²] per axis (:mod:`.velocity_update`)."""
        _markov_step(self.p, VELOCITY.start, VELOCITY.stop, decay, variance)

    def clone_velocity(self) -> None:
        """``δv₀ ← δv``: the clone takes the velocity's rows and columns (module docstring)."""
        p = self.p
        p[VELOCITY_START, :] = p[VELOCITY, :]
        p[:, VELOCITY_START] = p[:, VELOCITY]

    def reset_attitude_block(self, covariance: FloatArray) -> None:
        """A pose set from outside: the attitude block replaced, its correlations cleared."""
        self.fold()
        self.p[ATTITUDE, :] = 0.0
        self.p[:, ATTITUDE] = 0.0
        self.p[ATTITUDE, ATTITUDE] = covariance

    def set(self, covariance: FloatArray) -> None:
        """The covariance after an update: symmetrised, its diagonal floored; InputError if
        it is not finite (a measurement far outside the model)."""
        if not np.all(np.isfinite(covariance)):
            raise InputError('Expected the updated covariance to stay finite')
        p = 0.5 * (covariance + covariance.T)
        diagonal = np.einsum('ii->i', p)
        np.maximum(diagonal, _VARIANCE_FLOOR, out=diagonal)
        self.p = p

    @property
    def attitude(self) -> FloatArray:
        """3×3 attitude covariance [rad²] about fixed world axes (at the last fold)."""
        return self.p[ATTITUDE, ATTITUDE].copy()


def _markov_step(p: FloatArray, start: int, stop: int, decay: float, variance: float) -> None:
    """States ``start:stop`` of ``p`` take one first-order Gauss-Markov step: ``x ← φ x + w``
    with ``var(w)`` = ``variance`` (in place)."""
    p[start:stop, :] *= decay
    p[:, start:stop] *= decay
    for index in range(start, stop):
        p[index, index] += variance
