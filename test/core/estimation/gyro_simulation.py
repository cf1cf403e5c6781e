"""Monte-Carlo gyro runs for the covariance consistency tests, independent of the filter code.

The truth: a body turning with the analytic rate :func:`true_rate` (several rad/s about
changing axes), integrated from identity with :data:`SUBSTEPS` exact exponential steps per
sample at the substep midpoints (one shared motion ``Q(t)``; run ``r`` has the attitude
``q0_r ⊗ Q(t)``). The gyro of run ``r`` samples ``(I + E_r) ω(t_k + Δt/2) + b_r(t_k) + n``
with ``E_r``, the initial bias error and the initial attitude error drawn from their priors, a
bias that walks with density K and white noise of density N. The estimate starts at
``exp(−δθ₀) ⊗ q_true(0)`` and integrates ``ω_m − b_est`` with the exponential map, all runs
at once (NumPy over runs). Nothing here calls the covariance code.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from rigid_body_attitude.core.attitude import quaternion

SAMPLE_RATE = 100.0
SUBSTEPS = 8
#: Known bias estimate of every run [rad/s] (the truth differs from it by the drawn error).
BIAS_ESTIMATE = np.array([0.004, -0.003, 0.002])


def true_rate(t: np.ndarray) -> np.ndarray:
    """Body rate [rad/s] (len(t), 3): magnitudes up to about 4 rad/s about a turning axis."""
    t = np.asarray(t, dtype=np.float64)[:, None]
    amplitude = np.array([2.5, 2.0, 3.0])
    frequency = 2.0 * np.pi * np.array([0.23, 0.37, 0.17])
    phase = np.array([0.3, 1.9, 4.0])
    return amplitude * np.sin(frequency * t + phase) + np.array([0.8, -0.5, 0.6])


def _product(p: tuple[float, ...], q: tuple[float, ...]) -> tuple[float, ...]:
    """Hamilton product of two plain-float quaternions."""
    pw, px, py, pz = p
    qw, qx, qy, qz = q
    return (pw * qw - px * qx - py * qy - pz * qz, pw * qx + px * qw + py * qz - pz * qy,
            pw * qy - px * qz + py * qw + pz * qx, pw * qz + px * qy - py * qx + pz * qw)


def shared_motion(step_count: int) -> np.ndarray:
    """``Q(t_k)`` (step_count + 1, 4) from identity, fine exact steps (see module docstring)."""
    h = 1.0 / (SAMPLE_RATE * SUBSTEPS)
    mids = (np.arange(step_count * SUBSTEPS) + 0.5) * h
    increments = [tuple(row) for row in quaternion.exp(true_rate(mids) * h).tolist()]
    out = np.empty((step_count + 1, 4))
    q: tuple[float, ...] = (1.0, 0.0, 0.0, 0.0)
    out[0] = q
    for k in range(step_count):
        for step in increments[k * SUBSTEPS:(k + 1) * SUBSTEPS]:
            q = _product(q, step)
        out[k + 1] = q
    return out / np.linalg.norm(out, axis=1, keepdims=True)


@dataclass
class Runs:
    """State of all runs at the current sample (arrays over runs)."""

    q_true0: np.ndarray   # (R, 4) initial true attitudes
    q_est: np.ndarray     # (R, 4) current estimates
    bias: np.ndarray      # (R, 3) current true biases
    intrinsic: np.ndarray  # (R, 3, 3) E
    rng: np.random.Generator


def draw_runs(count: int, initial: np.ndarray, seed: int) -> Runs:
    """Draw ``count`` runs: errors from the 15×15 initial covariance ``initial``."""
    rng = np.random.default_rng(seed)
    q_true0 = quaternion.normalize(rng.normal(size=(count, 4)))
    errors = rng.multivariate_normal(np.zeros(15), initial, size=count)
    q_est = quaternion.multiply(quaternion.exp(-errors[:, :3]), q_true0)
    return Runs(q_true0=q_true0, q_est=q_est, bias=BIAS_ESTIMATE + errors[:, 3:6],
                intrinsic=errors[:, 6:].reshape(count, 3, 3), rng=rng)


def advance(runs: Runs, first_step: int, steps: int, noise_density: float,
            random_walk: float) -> tuple[np.ndarray, np.ndarray]:
    """Advance every run ``steps`` samples; returns the estimates at each step's start
    (steps, R, 4) and the estimated rates held over each step (steps, R, 3)."""
    dt = 1.0 / SAMPLE_RATE
    mids = (first_step + np.arange(steps) + 0.5) * dt
    rates = true_rate(mids)
    count = runs.q_est.shape[0]
    q_starts = np.empty((steps, count, 4))
    estimated = np.empty((steps, count, 3))
    for k in range(steps):
        noise = runs.rng.normal(size=(count, 3)) * (noise_density / np.sqrt(dt))
        measured = rates[k] + runs.intrinsic @ rates[k] + runs.bias + noise
        estimated[k] = measured - BIAS_ESTIMATE
        q_starts[k] = runs.q_est
        runs.q_est = quaternion.multiply(runs.q_est, quaternion.exp(estimated[k] * dt))
        runs.bias = runs.bias + runs.rng.normal(size=(count, 3)) * (random_walk * np.sqrt(dt))
    runs.q_est = runs.q_est / np.linalg.norm(runs.q_est, axis=1, keepdims=True)
    return q_starts, estimated


def world_errors(runs: Runs, motion_now: np.ndarray) -> np.ndarray:
    """``δθ`` (R, 3) with ``q_true = exp(δθ) ⊗ q_est``, ``q_true = q0 ⊗ Q(t)``."""
    q_true = quaternion.multiply(runs.q_true0, motion_now)
    return quaternion.log(quaternion.multiply(q_true, quaternion.conjugate(runs.q_est)))
