"""The attitude covariance against the optical truth of a BROAD trial (test and bench harness).

Per trial, with nothing tuned to it: level over the first :data:`LEVEL_SECONDS` of rest
(roll and pitch from the mean accelerometer, heading taken from the optical truth so that only
the tilt is compared), remove the gyro bias estimated over the whole initial rest phase,
integrate ``q ⊗ exp((ω − b) Δt)`` from the end of the levelling window, and carry an
:class:`AttitudeCovariance` along. The gyro's white-noise density (and the accelerometer's) is
estimated from the trial's own rest phase (sample standard deviation / √rate, mean over axes);
every other figure is :class:`GyroErrorModel`'s documented default (or zero, for the
white-noise-only budget). At every :data:`EVALUATE_EVERY`-th sample with optical truth, the
world-frame tilt error (``q_true = exp(δθ) ⊗ q_est``, x and y of δθ) is compared with the
covariance: inside the 3σ bound when ``|δθ_x| ≤ 3σ_x`` and ``|δθ_y| ≤ 3σ_y``.

Data: D. Laidig, M. Caruso, A. Cereatti, T. Seel. "BROAD — A Benchmark for Robust Inertial
Orientation Estimation". Data 6(7):72, 2021. doi:10.3390/data6070072 (CC BY 4.0).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from rigid_body_attitude.core.attitude import quaternion
from rigid_body_attitude.core.estimation.attitude_covariance import AttitudeCovariance
from rigid_body_attitude.core.estimation.gyro_error_model import GyroErrorModel, initial_covariance
from rigid_body_attitude.tools.broad import BroadTrial, load_trial

REPO_ROOT = Path(__file__).resolve().parents[2]
LEVEL_SECONDS = 1.0
EVALUATE_EVERY = 29


@dataclass(frozen=True)
class Coverage:
    """Figures of one trial: fraction of evaluated samples inside 3σ, median and final 1σ
    tilt [deg], largest tilt error [deg], number of evaluated samples."""

    trial: str
    inside_3_sigma: float
    median_tilt_sigma_deg: float
    final_tilt_sigma_deg: float
    max_tilt_error_deg: float
    evaluated: int


def trial_paths() -> list[Path]:
    """Every BROAD trial: the repository's ``data/broad`` and, where a ``shared/data/broad``
    lies beside the checkout or above it, the shared trials (one path per trial name)."""
    folders = [REPO_ROOT / 'data' / 'broad'] + [
        parent / 'shared' / 'data' / 'broad' for parent in REPO_ROOT.parents
        if (parent / 'shared' / 'data' / 'broad').is_dir()]
    paths = {path.name: path for folder in reversed(folders) for path in folder.glob('*.npz')}
    return [paths[name] for name in sorted(paths)]


def rest_noise_density(samples: np.ndarray, rate: float) -> float:
    """White-noise density [unit/√Hz]: sample standard deviation over √rate, mean over axes."""
    return float(np.mean(np.std(samples, axis=0, ddof=1)) / math.sqrt(rate))


def levelled_attitude(trial: BroadTrial, window: int) -> tuple[float, ...]:
    """Attitude from the mean accelerometer over ``window`` samples, heading from the first
    optical truth of the rest phase."""
    up_body = trial.acc[:window].mean(axis=0)
    up_body = up_body / np.linalg.norm(up_body)
    axis = np.cross(up_body, [0.0, 0.0, 1.0])  # rotates body 'up' onto world z
    angle = math.atan2(np.linalg.norm(axis), float(up_body[2]))
    axis = axis / max(float(np.linalg.norm(axis)), 1e-300)
    levelled = quaternion.exp(axis * angle)
    seen = np.flatnonzero(~trial.ground_truth_lost[:trial.first_motion_index])  # at rest
    residual = quaternion.multiply(trial.ground_truth[seen[0]], quaternion.conjugate(levelled))
    twist = quaternion.normalize(np.array([residual[0], 0.0, 0.0, residual[3]]))
    return tuple(float(c) for c in quaternion.multiply(twist, levelled))


def trial_model(trial: BroadTrial, white_noise_only: bool) -> GyroErrorModel:
    """The documented defaults with the noise densities measured on the trial's rest phase."""
    rest = trial.first_motion_index
    model = GyroErrorModel(
        gyroscope_noise_density=rest_noise_density(trial.gyro[:rest], trial.sampling_rate),
        accelerometer_noise_density=rest_noise_density(trial.acc[:rest], trial.sampling_rate))
    if white_noise_only:
        model = replace(model, gyroscope_random_walk=0.0, gyroscope_scale_stddev=0.0,
                        gyroscope_misalignment_stddev=0.0)
    return model


def coverage(path: Path, white_noise_only: bool = False) -> Coverage:
    """Run the harness of the module docstring on one trial."""
    trial = load_trial(path)
    rate = trial.sampling_rate
    window = int(round(LEVEL_SECONDS * rate))
    rest = trial.first_motion_index
    model = trial_model(trial, white_noise_only)
    start = initial_covariance(model, LEVEL_SECONDS)
    start[3:6, 3:6] = np.eye(3) * model.gyroscope_noise_density ** 2 * rate / rest
    tracker = AttitudeCovariance(model, covariance=start)
    rates = trial.gyro - trial.rest_gyro_bias()
    dt = 1.0 / rate
    q = levelled_attitude(trial, window)
    estimates = np.empty((trial.sample_count, 4))
    for k in range(window - 1, trial.sample_count):
        estimates[k] = q
        q = quaternion.scalar_exp_step(q, rates[k], dt)
    stops = np.arange(window - 1 + EVALUATE_EVERY, trial.sample_count, EVALUATE_EVERY)
    stops = stops[~trial.ground_truth_lost[stops]]
    covariances = np.empty((stops.size, 3, 3))
    last = window - 1
    for index, stop in enumerate(stops):
        tracker.add_samples(estimates[last:stop], rates[last:stop], dt)
        covariances[index] = tracker.attitude_covariance
        last = stop
    errors = quaternion.log(quaternion.multiply(trial.ground_truth[stops],
                                                quaternion.conjugate(estimates[stops])))[:, :2]
    sigma = np.sqrt(np.stack([covariances[:, 0, 0], covariances[:, 1, 1]], axis=1))
    inside = np.all(np.abs(errors) <= 3.0 * sigma, axis=1)
    tilt_sigma = np.sqrt(np.linalg.eigvalsh(covariances[:, :2, :2])[:, -1])
    return Coverage(trial=trial.name, inside_3_sigma=float(np.mean(inside)),
                    median_tilt_sigma_deg=math.degrees(float(np.median(tilt_sigma))),
                    final_tilt_sigma_deg=math.degrees(float(tilt_sigma[-1])),
                    max_tilt_error_deg=math.degrees(float(np.linalg.norm(errors, axis=1).max())),
                    evaluated=int(stops.size))
