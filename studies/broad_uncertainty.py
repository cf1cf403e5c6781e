"""Predicted 1σ tilt against the measured tilt error, per strapdown method, on BROAD trials.

For every strapdown method of the package and every BROAD trial: level over the first
:data:`LEVEL_SECONDS` of rest (roll and pitch from the mean accelerometer, heading from the
optical truth so that only the tilt is compared), remove the rest-phase gyro bias, integrate
with the method from the end of the levelling window and carry the node's
:class:`AttitudeCovariance` along (fed as the node feeds it: the attitude at the start of each
step, the rate that held over the step makes the rotation the method made, the step). The
error model: the gyro and accelerometer white-noise densities measured on the trial's own rest
phase, :class:`GyroErrorModel`'s documented defaults for everything else, nothing tuned per
trial. At every :data:`EVALUATE_EVERY`-th sample with optical truth: the world-frame tilt error
(x and y of ``δθ``, ``q_true = exp(δθ) ⊗ q_est``) against the covariance.

Columns: RMS of the measured tilt error, RMS of the predicted 1σ tilt (``√(σ_x² + σ_y²)``, the
same quantity), the median of the 1σ tilt (the worst horizontal axis, as the diagnostics show
it), and the share of samples whose tilt error lies inside 3σ on both axes.

``--budget``: the error budget instead, for one method (``exp_map``): the same figures with
white noise alone (and the levelling), then each of the bias random walk, the scale-factor
prior and the misalignment prior added alone, then all of them (the defaults).

``--priors SCALE,MISALIGNMENT``: other 1σ priors for the scale-factor and misalignment errors
than the defaults (what a user with a calibrated or better-specified gyro would set).

Usage: ``python studies/broad_uncertainty.py [DATA_DIR ...] [--methods a,b] [--budget]
[--priors S,M]`` (default: the repository's ``data/broad`` and a ``shared/data/broad`` beside
or above the checkout).
Data: BROAD, Laidig et al., Data 6(7):72, 2021, doi:10.3390/data6070072, CC BY 4.0.
"""

from __future__ import annotations

import argparse
import math
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np

from rigid_body_attitude.core.attitude import quaternion
from rigid_body_attitude.core.estimation.attitude_covariance import AttitudeCovariance
from rigid_body_attitude.core.estimation.gyro_error_model import GyroErrorModel, initial_covariance
from rigid_body_attitude.core.attitude.integrators.strapdown import (
    STRAPDOWN_METHODS, strapdown_method)
from rigid_body_attitude.core.attitude.quaternion import scalar_step_rate
from rigid_body_attitude.tools.broad import BroadTrial, load_trial

REPO_ROOT = Path(__file__).resolve().parent.parent
LEVEL_SECONDS = 1.0
EVALUATE_EVERY = 29


def trial_paths(folders: list[Path]) -> list[Path]:
    """Every ``*.npz`` trial of ``folders`` (one per name, the later folders first)."""
    paths = {path.name: path for folder in reversed(folders) for path in folder.glob('*.npz')}
    return [paths[name] for name in sorted(paths)]


def default_folders() -> list[Path]:
    """The repository's ``data/broad`` and any ``shared/data/broad`` beside or above it."""
    return [REPO_ROOT / 'data' / 'broad'] + [
        parent / 'shared' / 'data' / 'broad' for parent in REPO_ROOT.parents
        if (parent / 'shared' / 'data' / 'broad').is_dir()]


def noise_density(samples: np.ndarray, rate: float) -> float:
    """White-noise density [unit/√Hz]: sample standard deviation over √rate, mean over axes."""
    return float(np.mean(np.std(samples, axis=0, ddof=1)) / math.sqrt(rate))


def levelled(trial: BroadTrial, window: int) -> tuple[float, float, float, float]:
    """Roll and pitch from the mean accelerometer, heading from the optical truth at rest."""
    up_body = trial.acc[:window].mean(axis=0)
    up_body = up_body / np.linalg.norm(up_body)
    axis = np.cross(up_body, [0.0, 0.0, 1.0])
    angle = math.atan2(np.linalg.norm(axis), float(up_body[2]))
    q = quaternion.exp(axis / max(float(np.linalg.norm(axis)), 1e-300) * angle)
    seen = np.flatnonzero(~trial.ground_truth_lost[:trial.first_motion_index])
    residual = quaternion.multiply(trial.ground_truth[seen[0]], quaternion.conjugate(q))
    twist = quaternion.normalize(np.array([residual[0], 0.0, 0.0, residual[3]]))
    w, x, y, z = (float(c) for c in quaternion.multiply(twist, q))
    return w, x, y, z


#: Error budgets of ``--budget``: the defaults' fields set to zero in each.
BUDGETS = {
    'white noise alone': ('gyroscope_random_walk', 'gyroscope_scale_stddev',
                          'gyroscope_misalignment_stddev'),
    '+ bias random walk': ('gyroscope_scale_stddev', 'gyroscope_misalignment_stddev'),
    '+ scale factor': ('gyroscope_random_walk', 'gyroscope_misalignment_stddev'),
    '+ misalignment': ('gyroscope_random_walk', 'gyroscope_scale_stddev'),
    'all (the defaults)': (),
}


def held_rate(method_name: str, q_before: tuple[float, float, float, float],
              q_after: tuple[float, float, float, float], previous: tuple[float, float, float],
              current: tuple[float, float, float], dt: float) -> tuple[float, float, float]:
    """The rate the node's gyro session hands the covariance for one step."""
    if method_name == 'exp_map':
        return previous
    if method_name == 'delta_single':
        return current
    return scalar_step_rate(q_before, q_after, dt)


def figures(trial: BroadTrial, method_name: str, zeroed: tuple[str, ...] = (),
            priors: dict[str, float] | None = None) -> tuple[float, float, float, float]:
    """RMS tilt error [deg], RMS predicted 1σ tilt [deg], median 1σ tilt [deg], share inside
    3σ; the defaults' fields ``priors`` replaced, those named in ``zeroed`` set to zero."""
    rate, rest = trial.sampling_rate, trial.first_motion_index
    window = int(round(LEVEL_SECONDS * rate))
    model = GyroErrorModel(
        gyroscope_noise_density=noise_density(trial.gyro[:rest], rate),
        accelerometer_noise_density=noise_density(trial.acc[:rest], rate))
    model = replace(model, **(priors or {}))
    model = replace(model, **{name: 0.0 for name in zeroed})
    start = initial_covariance(model, LEVEL_SECONDS)
    start[3:6, 3:6] = np.eye(3) * model.gyroscope_noise_density ** 2 * rate / rest
    tracker = AttitudeCovariance(model, covariance=start)
    rates = [tuple(row) for row in (trial.gyro - trial.rest_gyro_bias()).tolist()]
    method = strapdown_method(method_name)
    dt = 1.0 / rate
    q = levelled(trial, window)
    evaluate = set(range(window - 1 + EVALUATE_EVERY, trial.sample_count, EVALUATE_EVERY))
    errors, sigmas = [], []
    for k in range(window - 1, trial.sample_count - 1):
        after = method.propagate(q, rates[k], rates[k + 1], dt)
        tracker.add_sample(q, held_rate(method_name, q, after, rates[k], rates[k + 1], dt), dt)
        q = after
        if k + 1 in evaluate and not trial.ground_truth_lost[k + 1]:
            delta = quaternion.log(quaternion.multiply(trial.ground_truth[k + 1],
                                                       quaternion.conjugate(np.array(q))))
            covariance = tracker.attitude_covariance
            errors.append(delta[:2])
            sigmas.append(covariance[:2, :2])
    error, horizontal = np.array(errors), np.array(sigmas)
    variance = np.stack([horizontal[:, 0, 0], horizontal[:, 1, 1]], axis=1)
    inside = np.all(np.abs(error) <= 3.0 * np.sqrt(variance), axis=1)
    rms_error = math.degrees(math.sqrt(float(np.mean(np.sum(error ** 2, axis=1)))))
    rms_sigma = math.degrees(math.sqrt(float(np.mean(np.sum(variance, axis=1)))))
    median_tilt = math.degrees(float(np.median(np.sqrt(np.linalg.eigvalsh(horizontal)[:, -1]))))
    return rms_error, rms_sigma, median_tilt, float(np.mean(inside))


def main(argv: list[str] | None = None) -> int:
    """Print one row per method and trial."""
    parser = argparse.ArgumentParser(description=__doc__.split('\n', 1)[0])
    parser.add_argument('folders', nargs='*', type=Path)
    parser.add_argument('--methods', default=','.join(sorted(STRAPDOWN_METHODS)))
    parser.add_argument('--budget', action='store_true',
                        help='the error budget term by term (exp_map) instead')
    parser.add_argument('--priors', help='SCALE,MISALIGNMENT 1-sigma priors')
    args = parser.parse_args(argv)
    priors = None
    if args.priors:
        scale, misalignment = (float(value) for value in args.priors.split(','))
        priors = {'gyroscope_scale_stddev': scale,
                  'gyroscope_misalignment_stddev': misalignment}
    paths = trial_paths(args.folders or default_folders())
    first = 'budget' if args.budget else 'method'
    print(f'| {first} | trial | RMS tilt error [deg] | RMS predicted 1σ tilt [deg] | '
          'median 1σ tilt [deg] | inside 3σ |')
    print('| --- | --- | --- | --- | --- | --- |')
    rows = ([(name, 'exp_map', zeroed) for name, zeroed in BUDGETS.items()] if args.budget
            else [(name, name, ()) for name in args.methods.split(',')])
    for label, method_name, zeroed in rows:
        for path in paths:
            trial = load_trial(path)
            rms_error, rms_sigma, median_tilt, inside = figures(trial, method_name, zeroed,
                                                                priors)
            print(f'| {label} | {trial.name} | {rms_error:.2f} | {rms_sigma:.2f} | '
                  f'{median_tilt:.2f} | {100 * inside:.1f} % |', flush=True)
    return 0


if __name__ == '__main__':
    sys.exit(main())
