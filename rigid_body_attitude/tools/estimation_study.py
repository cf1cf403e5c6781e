"""The attitude filter on BROAD trials beside VQF: accuracy and covariance, one table.

Per trial (a BROAD archive, :mod:`rigid_body_attitude.tools.broad`), with one set of settings
for all trials and nothing taken from the trial's truth:

* **the filter** (:class:`~rigid_body_attitude.core.estimation.filtered_strapdown.
  FilteredStrapdown`), fed sample by sample as a gyro session feeds it: levelling at the
  start's rest over ``align_seconds`` (the node's default), then the strapdown step, the
  filter's per-sample calls and its updates; the magnetometer when the trial has one;
* **VQF** (``vqf.offlineVQF`` with its defaults, D. Laidig, T. Seel, Information Fusion 91,
  2023) on the same samples: its 9D quaternion with a magnetometer, else its 6D one.

The benchmark's metric (BROAD: D. Laidig, M. Caruso, A. Cereatti, T. Seel, "BROAD — A
Benchmark for Robust Inertial Orientation Estimation", Data 6(7):72, 2021, section 4): with
``q_diff = q_est ⊗ q_ref⁻¹`` over the motion samples with truth, total error
``2 acos(|w|)``, heading ``2 atan(|z/w|)``, inclination ``2 acos(√(w² + z²))``, each an RMSE
[deg]. The covariance against the truth: ``δθ = log(q_ref ⊗ q_est*)`` (world frame), its NEES
``δθᵀ P⁻¹ δθ`` inside the chi-square 99 % bound for 3 dof (tilt: the horizontal pair, 2 dof;
heading: 1 dof), as the share of motion samples; and the median 1σ (total ``√tr P``, tilt
``√(P_xx + P_yy)``, heading ``√P_zz``) against the RMSE of the same error.

Sensor figures: the gyro's, accelerometer's and magnetometer's noise densities from
``imu_noise``'s Allan fit on one trial's initial rest and the magnetometer's delay from the
same trial, as a user calibrates an IMU once (:func:`dataset_model`); every other figure the
documented default.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Any

import numpy as np
from numpy.typing import NDArray

from rigid_body_attitude.core.attitude import quaternion
from rigid_body_attitude.core.estimation.alignment import GravityAligner
from rigid_body_attitude.core.estimation.estimator import AttitudeEstimator
from rigid_body_attitude.core.estimation.estimator_settings import EstimatorSettings
from rigid_body_attitude.core.estimation.filtered_strapdown import FilteredStrapdown
from rigid_body_attitude.core.estimation.gyro_error_model import GyroErrorModel
from rigid_body_attitude.core.estimation.magnetometer_timing import magnetometer_delay
from rigid_body_attitude.core.estimation.rest import RestDetector
from rigid_body_attitude.tools.allan import allan_curve, fit_noise
from rigid_body_attitude.tools.broad import BroadTrial

__all__ = ['ALIGN_SECONDS', 'CHI2_99', 'MagnetometerFigures', 'Run', 'TrialFigures',
           'broad_errors', 'dataset_model', 'figures', 'run_filter', 'run_vqf', 'settings_for']

FloatArray = NDArray[np.float64]

#: The node's default ``align_seconds`` [s].
ALIGN_SECONDS = 1.0
#: Chi-square 99 % quantiles for 1, 2 and 3 degrees of freedom.
CHI2_99 = {1: 6.635, 2: 9.210, 3: 11.345}


@dataclass(frozen=True)
class Run:
    """An estimate per sample (N, 4) (NaN before it starts) and its 3×3 attitude covariance
    (N, 3, 3), or None for an estimator without one."""

    attitude: FloatArray
    covariance: FloatArray | None


@dataclass(frozen=True)
class TrialFigures:
    """RMSE [deg] (total, heading, inclination); NEES shares inside the 99 % bound (3 dof,
    tilt, heading); median 1σ [deg] (total, tilt, heading)."""

    rmse: tuple[float, float, float]
    inside: tuple[float, float, float] = (math.nan, math.nan, math.nan)
    median_sigma: tuple[float, float, float] = (math.nan, math.nan, math.nan)


@dataclass(frozen=True)
class MagnetometerFigures:
    """A magnetometer's figures measured on one recording: white-noise density [T/√Hz],
    delay behind the gyro [s] and the 1σ of its sample instants [s] (NaN: no magnetometer)."""

    noise_density: float = math.nan
    delay: float = math.nan
    timing: float = math.nan


def dataset_model(trial: BroadTrial) -> tuple[GyroErrorModel, MagnetometerFigures]:
    """The IMU's figures from one trial, as a user measures an IMU once: the white-noise
    densities of gyro, accelerometer and magnetometer by ``imu_noise``'s Allan fit on the
    initial rest; the magnetometer's delay behind the gyro by
    :func:`~rigid_body_attitude.core.estimation.magnetometer_timing.magnetometer_delay` on the
    whole trial; the 1σ of its sample instants from its own output rate (a sample repeated
    while the magnetometer has none newer: its age spreads uniformly over the magnetometer's
    period ``P``, ``P/√12``). Other figures: the documented defaults."""
    rest = trial.first_motion_index
    rate = trial.sampling_rate
    duration = rest / rate
    gyro = fit_noise(allan_curve(np.asarray(trial.gyro[:rest]), rate), duration)
    accel = fit_noise(allan_curve(np.asarray(trial.acc[:rest]), rate), duration)
    model = GyroErrorModel(gyroscope_noise_density=gyro.white,
                           accelerometer_noise_density=accel.white)
    field = trial.field
    if field is None:
        return model, MagnetometerFigures()
    noise = fit_noise(allan_curve(np.asarray(field[:rest]), rate), duration).white
    delay = magnetometer_delay(np.asarray(trial.gyro), np.asarray(field), rate).delay
    repeated = float(np.mean(np.all(np.diff(np.asarray(field), axis=0) == 0.0, axis=1)))
    period = 1.0 / (rate * max(1.0 - repeated, 1e-3))
    return model, MagnetometerFigures(noise, delay, period / math.sqrt(12.0))


def run_filter(trial: BroadTrial, model: GyroErrorModel, settings: EstimatorSettings,
               use_magnetometer: bool = True) -> Run:
    """The filter over the trial (module docstring)."""
    rate = trial.sampling_rate
    estimator = AttitudeEstimator(model, settings, 'enu', sample_rate=rate)
    gyro_noise = model.gyroscope_noise_density * math.sqrt(rate)
    aligner = GravityAligner(ALIGN_SECONDS, detector=RestDetector(gyro_noise=gyro_noise))
    strapdown = FilteredStrapdown(estimator, aligner, use_magnetometer)
    count = trial.sample_count
    attitude = np.full((count, 4), np.nan)
    covariance = np.full((count, 3, 3), np.nan)
    gyro, acc = trial.gyro.tolist(), trial.acc.tolist()
    fields = trial.field.tolist() if trial.field is not None and use_magnetometer else None
    dt = 1.0 / rate
    for k in range(count):
        field = fields[k] if fields is not None else None
        if strapdown.add(gyro[k], acc[k], field, dt):
            attitude[k] = strapdown.attitude
            covariance[k] = estimator.published_covariance(strapdown.attitude, strapdown.rate)
    return Run(attitude, covariance)


def run_vqf(trial: BroadTrial, use_magnetometer: bool = True) -> Run:
    """VQF (offline, defaults) over the trial's samples: 9D with a magnetometer, else 6D."""
    from vqf import offlineVQF  # type: ignore[import-untyped]  # test requirements' VQF

    gyro = np.ascontiguousarray(trial.gyro, dtype=np.float64)
    acc = np.ascontiguousarray(trial.acc, dtype=np.float64)
    if use_magnetometer and trial.field is not None:
        field = np.ascontiguousarray(trial.field * 1e6, dtype=np.float64)
        out: dict[str, Any] = offlineVQF(gyro, acc, field, 1.0 / trial.sampling_rate, None)
        return Run(np.asarray(out['quat9D']), None)
    out = offlineVQF(gyro, acc, None, 1.0 / trial.sampling_rate, None)
    return Run(np.asarray(out['quat6D']), None)


def _evaluated(trial: BroadTrial, run: Run) -> NDArray[np.bool_]:
    return np.asarray(trial.movement & ~trial.ground_truth_lost
                      & np.all(np.isfinite(run.attitude), axis=1))


def broad_errors(q_estimate: FloatArray, q_reference: FloatArray) -> FloatArray:
    """(n, 3) total, heading and inclination errors [rad] (module docstring)."""
    diff = quaternion.multiply(q_estimate, quaternion.conjugate(q_reference))
    w, z = np.abs(diff[:, 0]), diff[:, 3]
    total = 2.0 * np.arccos(np.clip(w, 0.0, 1.0))
    heading = 2.0 * np.arctan(np.abs(z / np.where(w == 0.0, 1e-300, w)))
    inclination = 2.0 * np.arccos(np.clip(np.sqrt(w * w + z * z), 0.0, 1.0))
    return np.stack([total, heading, inclination], axis=1)


def figures(trial: BroadTrial, run: Run) -> TrialFigures:
    """The figures of one run against the trial's truth (module docstring)."""
    mask = _evaluated(trial, run)
    estimate, reference = run.attitude[mask], np.asarray(trial.ground_truth)[mask]
    errors = broad_errors(estimate, reference)
    rmse = np.degrees(np.sqrt(np.mean(errors ** 2, axis=0)))
    rmse_tuple = (float(rmse[0]), float(rmse[1]), float(rmse[2]))
    if run.covariance is None:
        return TrialFigures(rmse_tuple)
    p = run.covariance[mask]
    delta = quaternion.log(quaternion.multiply(reference, quaternion.conjugate(estimate)))
    nees = np.einsum('ni,nij,nj->n', delta, np.linalg.inv(p), delta)
    tilt = np.einsum('ni,nij,nj->n', delta[:, :2], np.linalg.inv(p[:, :2, :2]), delta[:, :2])
    heading = delta[:, 2] ** 2 / p[:, 2, 2]
    inside = (float(np.mean(nees <= CHI2_99[3])), float(np.mean(tilt <= CHI2_99[2])),
              float(np.mean(heading <= CHI2_99[1])))
    sigma = np.degrees(np.median(np.sqrt(np.stack(
        [np.trace(p, axis1=1, axis2=2), p[:, 0, 0] + p[:, 1, 1], p[:, 2, 2]], axis=1)), axis=0))
    return TrialFigures(rmse_tuple, inside, (float(sigma[0]), float(sigma[1]), float(sigma[2])))


def settings_for(magnetometer: MagnetometerFigures,
                 settings: EstimatorSettings | None = None) -> EstimatorSettings:
    """``settings`` (default: the defaults) with the measured magnetometer figures."""
    base = settings or EstimatorSettings()
    if math.isfinite(magnetometer.noise_density):
        base = replace(base, magnetometer_noise_density=magnetometer.noise_density,
                       magnetometer_delay=magnetometer.delay,
                       magnetometer_timing=magnetometer.timing)
    return base
