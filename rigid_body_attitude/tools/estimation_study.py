"""The attitude filter on BROAD trials beside VQF: accuracy and covariance, one table.

Per trial (a BROAD archive, :mod:`rigid_body_attitude.tools.broad`), with one set of
parameters for all trials and nothing taken from the trial's truth:

* **the node** on the trial: the shipped ``imu_filter`` scene (levelling at the start's rest
  over ``align_seconds``, the strapdown step, the filter's updates, the magnetometer on
  ``imu/mag``), either through the replay tool (:func:`run_replay`: the trial as a bag, the
  bag through ``replay``, the output bag read back) or the same session fed in this process
  (:func:`run_session`: what the replay does, without the bag; the two agree exactly);
* the reference estimator of the study script (``studies/broad_estimation.py``: VQF) as a
  :class:`Run` without covariance, scored by :func:`figures` alike.

The benchmark's metric (BROAD: D. Laidig, M. Caruso, A. Cereatti, T. Seel, "BROAD — A
Benchmark for Robust Inertial Orientation Estimation", Data 6(7):72, 2021, section 4): with
``q_diff = q_est ⊗ q_ref⁻¹`` over the motion samples with truth, total error
``2 acos(|w|)``, heading ``2 atan(|z/w|)``, inclination ``2 acos(√(w² + z²))``, each an RMSE
[deg]. The covariance against the truth: ``δθ = log(q_ref ⊗ q_est*)`` (world frame), its NEES
``δθᵀ P⁻¹ δθ`` inside the chi-square 99 % bound for 3 dof (tilt: the horizontal pair, 2 dof;
heading: 1 dof), as the share of motion samples; and the median 1σ (total ``√tr P``, tilt
``√(P_xx + P_yy)``, heading ``√P_zz``) against the RMSE of the same error.

The IMU's figures are the node's calibration files, made once for an IMU as a user makes
them; :func:`dataset_calibration` measures the figures a recording gives, on one trial: a
kalibr ``imu.yaml`` written by ``imu_noise`` (Allan deviation of the gyro and accelerometer on
the initial rest), given as ``calibration_file``; and the magnetometer's calibration file with
its figures only (white-noise density by the same Allan fit, its delay behind the gyro by
:func:`~rigid_body_attitude.core.estimation.magnetometer_timing.magnetometer_delay` on the
whole trial, the 1σ of its sample instants ``P/√12`` from its own output period ``P``: a
sample repeated while the magnetometer has none newer), given as
``magnetometer_calibration_file``. The study script ships the files it uses, with the
data-sheet figures beside the measured ones (``studies/broad_imu.yaml``,
``studies/broad_magnetometer.yaml``). Every other parameter is the shipped default.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from rigid_body_attitude.bag import BagReader
from rigid_body_attitude.core.attitude import quaternion
from rigid_body_attitude.core.estimation.magnetometer_timing import magnetometer_delay
from rigid_body_attitude.msgs.cdr import stamp_to_ns
from rigid_body_attitude.msgs.decoders import (
    decode_pose_with_covariance_stamped, decode_quaternion_stamped)
from rigid_body_attitude.session.parameters import defaults
from rigid_body_attitude.session.reports import DiagnosticReport
from rigid_body_attitude.session.settings import load_node_scene, open_session
from rigid_body_attitude.session.times import split_ns
from rigid_body_attitude.session.filtered_gyro import FilteredGyroSession
from rigid_body_attitude.tools.allan import Recording, allan_curve, fit_noise, kalibr_yaml
from rigid_body_attitude.tools.broad import BroadTrial, trial_to_bag
from rigid_body_attitude.tools.replay.options import ReplayOptions
from rigid_body_attitude.tools.replay.run import replay_bag

__all__ = ['CHI2_99', 'Run', 'SCENE', 'TrialFigures', 'broad_errors', 'dataset_calibration',
           'figures', 'run_replay', 'run_session', 'study_values']

FloatArray = NDArray[np.float64]

#: The node's scene of the study: the shipped attitude filter.
SCENE = 'imu_filter'
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


def dataset_calibration(trial: BroadTrial, folder: Path) -> dict[str, str]:
    """Write the trial's ``imu.yaml`` and ``magnetometer.yaml`` (module docstring) into
    ``folder``; the node's parameters naming them."""
    rest = trial.first_motion_index
    rate = trial.sampling_rate
    duration = rest / rate
    recording = Recording(rate=rate, gyro=np.asarray(trial.gyro[:rest]),
                          acc=np.asarray(trial.acc[:rest]), topic='/imu')
    gyro = fit_noise(allan_curve(recording.gyro, rate), duration)
    acc = fit_noise(allan_curve(np.asarray(recording.acc), rate), duration)
    imu = folder / 'imu.yaml'
    imu.write_text(kalibr_yaml(recording, gyro, acc, '/imu'), encoding='utf-8')
    parameters = {'calibration_file': str(imu)}
    field = trial.field
    if field is not None:
        noise = fit_noise(allan_curve(np.asarray(field[:rest]), rate), duration).white
        delay = magnetometer_delay(np.asarray(trial.gyro), np.asarray(field), rate).delay
        repeated = float(np.mean(np.all(np.diff(np.asarray(field), axis=0) == 0.0, axis=1)))
        period = 1.0 / (rate * max(1.0 - repeated, 1e-3))
        magnetometer = folder / 'magnetometer.yaml'
        magnetometer.write_text(f'noise_density: {noise:.6e}\ndelay: {max(delay, 0.0):.6e}\n'
                                f'timing: {period / math.sqrt(12.0):.6e}\n', encoding='utf-8')
        parameters['magnetometer_calibration_file'] = str(magnetometer)
    return parameters


def study_values(**parameters: Any) -> dict[str, Any]:
    """The node's parameters of the study: the defaults, the scene :data:`SCENE`, and
    ``parameters`` (e.g. ``calibration_file``)."""
    return {**defaults(), 'scene': SCENE, **parameters}


def _index(stamps_ns: FloatArray, rate: float) -> NDArray[np.int64]:
    """The sample index of each stamp ``i / rate``."""
    return np.rint(stamps_ns * (rate * 1e-9)).astype(np.int64)


class _SeriesSink:
    """A session's sink keeping each attitude and the covariance it was published with."""

    use_header_stamps = True

    def __init__(self) -> None:
        self.stamps: list[int] = []
        self.attitudes: list[tuple[float, ...]] = []
        self.covariances: list[tuple[float, ...]] = []
        self.covariance: tuple[float, ...] = (math.nan,) * 9

    def attitude(self, sec: int, nanosec: int, attitude: tuple[float, ...],
                 imu: bytes | None) -> None:
        self.stamps.append(sec * 1_000_000_000 + nanosec)
        self.attitudes.append(attitude)
        self.covariances.append(self.covariance)

    def attitude_covariance(self, covariance: tuple[float, ...]) -> None:
        self.covariance = covariance

    def sensor_mount(self, q_body_sensor: Any) -> None:
        """Nothing: ``imu/data`` is not kept."""

    def acceleration(self, sec: int, nanosec: int, estimate: Any) -> None:
        """Nothing: ``accel/filtered`` is not kept."""

    def odometry(self, *args: Any) -> None:
        """Nothing: ``odom`` is not kept."""

    def dynamics(self, *args: Any) -> None:
        """Nothing: a gyro scene."""

    def invariants(self, *args: Any) -> None:
        """Nothing: a gyro scene."""

    def sensor_wanted(self, topic: str) -> bool:
        """No simulated sensor: a gyro scene."""
        return False

    def simulated_sensor(self, topic: str, data: bytes) -> None:
        """Nothing: a gyro scene."""

    def wheel_state(self, data: bytes) -> None:
        """Nothing: a gyro scene."""

    def diagnostics(self, report: DiagnosticReport) -> None:
        """Nothing: no diagnostics kept."""

    def log(self, level: int, text: str) -> None:
        """Nothing: no log kept."""


def _run(trial: BroadTrial, stamps_ns: FloatArray, attitudes: FloatArray,
         covariances: FloatArray) -> Run:
    """Per-sample arrays of the outputs at ``stamps_ns``."""
    count = trial.sample_count
    attitude = np.full((count, 4), np.nan)
    covariance = np.full((count, 3, 3), np.nan)
    index = _index(stamps_ns, trial.sampling_rate)
    attitude[index] = attitudes
    covariance[index] = covariances.reshape(-1, 3, 3)
    return Run(attitude, covariance)


def run_session(trial: BroadTrial, values: Mapping[str, Any]) -> Run:
    """The node's session over the trial's samples, fed in this process as the replay feeds
    it (the bag's stamps ``stamp_to_ns(i / rate)``, the field before the Imu of its sample;
    no diagnostics)."""
    sink = _SeriesSink()
    scene = load_node_scene(values['scene'])
    session = open_session(scene, values, sink, lambda: 0, lambda: 0.0)
    assert isinstance(session, FilteredGyroSession)
    gyro, acc = trial.gyro.tolist(), trial.acc.tolist()
    fields = trial.field.tolist() if trial.field is not None else None
    frame = values['body_frame']
    for k, stamp in enumerate(trial.stamps.tolist()):
        sec, nanosec = split_ns(stamp_to_ns(stamp))
        if fields is not None:
            session.magnetic_field(sec, nanosec, frame, fields[k])
        session.gyro(sec, nanosec, gyro[k], None, acc[k])
    return _run(trial, np.array(sink.stamps, dtype=np.float64), np.array(sink.attitudes),
                np.array(sink.covariances))


def run_replay(trial: BroadTrial, values: Mapping[str, Any], folder: Path) -> Run:
    """The trial as a bag (``folder/<trial>``) through the replay tool with ``values``
    (``folder/<trial>_out``), the outputs read back from the output bag."""
    bag, out = folder / trial.name, folder / f'{trial.name}_out'
    trial_to_bag(trial, bag)
    options = ReplayOptions(**{key: value for key, value in values.items()
                               if key in ReplayOptions.__dataclass_fields__},
                            outputs=('orientation', 'pose_with_covariance'))
    replay_bag(bag, out, options, keep_series=False)
    with BagReader(out) as reader:
        stamps, attitudes, covariances = [], [], []
        for topic, _, _, data in reader.messages(['orientation', 'pose_with_covariance']):
            if topic == 'orientation':
                sec, nanosec, _, q = decode_quaternion_stamped(data)
                stamps.append(sec * 1_000_000_000 + nanosec)
                attitudes.append(q)
            else:
                block = np.array(decode_pose_with_covariance_stamped(data)[5]).reshape(6, 6)
                covariances.append(block[3:, 3:].reshape(9))
    return _run(trial, np.array(stamps, dtype=np.float64), np.array(attitudes),
                np.array(covariances))


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
