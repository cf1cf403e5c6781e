"""BROAD trials (real IMU data with optical ground truth) as arrays and as rosbag2 bags.

Data source, to be cited with any use or copy (licence CC BY 4.0):
D. Laidig, M. Caruso, A. Cereatti, T. Seel. "BROAD — A Benchmark for Robust Inertial
Orientation Estimation". Data 6(7):72, 2021. doi:10.3390/data6070072.
See ``docs/data.md``; converted bags carry the citation in their ``custom_data`` metadata.

A trial archive (``.npz``, converted from BROAD's HDF5 files, values unchanged) holds
``sampling_rate`` (Hz), ``imu_gyr`` (N, 3) rad/s and ``imu_acc`` (N, 3) m/s² in the IMU (body)
frame, ``imu_mag`` (N, 3) µT in the trials that carry a magnetometer
(:attr:`BroadTrial.field` holds it in tesla), ``opt_quat_wxyz`` (N, 4) the optical attitude
of the IMU frame w.r.t. an ENU world frame
(scalar first, body → world as in :mod:`rigid_body_attitude.core.attitude.quaternion`; NaN rows
where the
cameras lost the body), ``movement`` (N,) bool, and ``info``. Sample ``i`` is at
``i / sampling_rate`` s. Each trial starts and ends at rest; the initial rest phase gives the
gyroscope bias estimate (:meth:`BroadTrial.rest_gyro_bias`).

Command line: ``python -m rigid_body_attitude.tools.broad TRIAL.npz OUT_BAG [--storage mcap]``.
"""

from __future__ import annotations

import argparse
import sys
import zipfile
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from rigid_body_attitude.bag import STORAGES, write_bag
from rigid_body_attitude.core.errors import AttitudeError, InputError

__all__ = ['CITATION', 'LICENSE', 'BroadTrial', 'attribution', 'load_trial', 'main',
           'trial_to_bag']

FloatArray = NDArray[np.float64]

CITATION = ('D. Laidig, M. Caruso, A. Cereatti, T. Seel. "BROAD — A Benchmark for Robust '
            'Inertial Orientation Estimation". Data 6(7):72, 2021. doi:10.3390/data6070072')
LICENSE = 'CC BY 4.0 (https://creativecommons.org/licenses/by/4.0/)'
#: Largest accepted deviation of a ground-truth quaternion's norm from 1 (the files give 7e−16).
UNIT_NORM_TOLERANCE = 1e-6


@dataclass(frozen=True)
class BroadTrial:
    """One BROAD trial: uniformly sampled IMU data, optical ground truth, motion mask.

    Arrays are read-only. ``ground_truth`` is scalar-first ``(w, x, y, z)``, body → ENU world,
    with all-NaN rows where the optical system lost the body.
    """

    name: str
    sampling_rate: float
    gyro: FloatArray
    acc: FloatArray
    ground_truth: FloatArray
    movement: NDArray[np.bool_]
    info: str
    #: The magnetometer [T], IMU frame, (N, 3); None in a trial without one.
    field: FloatArray | None = None

    @property
    def sample_count(self) -> int:
        """Number of samples N."""
        return int(self.gyro.shape[0])

    @property
    def stamps(self) -> FloatArray:
        """Sample stamps ``i / sampling_rate`` (s), shape (N,)."""
        return np.arange(self.sample_count) / self.sampling_rate

    @property
    def first_motion_index(self) -> int:
        """Index of the first sample of the motion phase (the initial rest ends before it)."""
        return int(np.argmax(self.movement))

    @property
    def ground_truth_lost(self) -> NDArray[np.bool_]:
        """Mask of samples without optical ground truth (NaN rows), shape (N,)."""
        lost: NDArray[np.bool_] = np.all(np.isnan(self.ground_truth), axis=1)
        return lost

    def rest_gyro_bias(self) -> FloatArray:
        """Gyroscope bias estimate (rad/s, body frame): mean rate over the initial rest phase.

        The rest phase is every sample before :attr:`first_motion_index`; the standard error of
        the mean is σ/√n ≈ 2·10⁻³/√7500 ≈ 2·10⁻⁵ rad/s for the shipped trials.
        """
        bias: FloatArray = self.gyro[:self.first_motion_index].mean(axis=0)
        return bias


def _read_archive(path: Path) -> dict[str, np.ndarray]:
    if not path.is_file():
        raise InputError(f'Expected a BROAD trial archive (.npz) at {str(path)!r}; '
                         f'no such file')
    try:
        with np.load(path, allow_pickle=False) as archive:
            return {key: archive[key] for key in archive.files}
    except (OSError, ValueError, zipfile.BadZipFile) as err:
        raise InputError(f'Expected {str(path)!r} to be a NumPy .npz archive: {err}') from err


def _array(arrays: dict[str, np.ndarray], key: str, path: Path,
           shape: tuple[int | None, ...]) -> np.ndarray:
    """``arrays[key]`` if it has ``shape`` (``None``: any length), else InputError."""
    if key not in arrays:
        raise InputError(f'Expected key {key!r} in BROAD archive {str(path)!r}, got keys '
                         f'{sorted(arrays)}')
    array = arrays[key]
    if array.ndim != len(shape) or any(want is not None and got != want
                                       for got, want in zip(array.shape, shape)):
        expected = tuple('N' if want is None else want for want in shape)
        raise InputError(f'Expected {key!r} in {str(path)!r} to have shape {expected}, got '
                         f'{array.shape}'.replace("'N'", 'N'))
    return array


def _readonly(array: np.ndarray, dtype: type) -> np.ndarray:
    result: np.ndarray = np.array(array, dtype=dtype)
    result.flags.writeable = False
    return result


def load_trial(path: str | Path) -> BroadTrial:
    """Load and check a BROAD trial archive (keys and shapes as in the module docstring)."""
    path = Path(path)
    arrays = _read_archive(path)
    gyro = _array(arrays, 'imu_gyr', path, (None, 3))
    count = gyro.shape[0]
    acc = _array(arrays, 'imu_acc', path, (count, 3))
    ground_truth = _array(arrays, 'opt_quat_wxyz', path, (count, 4)).astype(np.float64)
    movement = _array(arrays, 'movement', path, (count,))
    field = _array(arrays, 'imu_mag', path, (count, 3)) * 1e-6 if 'imu_mag' in arrays else None
    rate = float(_array(arrays, 'sampling_rate', path, ()))
    info = str(_array(arrays, 'info', path, ())) if 'info' in arrays else ''
    if not np.isfinite(rate) or rate <= 0.0:
        raise InputError(f'Expected `sampling_rate` in {str(path)!r} to be positive, got {rate}')
    for key, array in (('imu_gyr', gyro), ('imu_acc', acc), ('imu_mag', field)):
        if array is not None and not np.all(np.isfinite(array)):
            raise InputError(f'Expected {key!r} in {str(path)!r} to be finite')
    if movement.dtype != np.bool_:
        raise InputError(f'Expected `movement` in {str(path)!r} to be bool, got {movement.dtype}')
    _check_ground_truth(ground_truth, path)
    if not movement.any() or movement[0]:
        raise InputError(f'Expected `movement` in {str(path)!r} to start with a rest phase and '
                         f'contain motion, got {int(movement.sum())} motion samples with '
                         f'movement[0] = {bool(movement[:1].any())}')
    return BroadTrial(name=path.stem, sampling_rate=rate, gyro=_readonly(gyro, np.float64),
                      acc=_readonly(acc, np.float64),
                      ground_truth=_readonly(ground_truth, np.float64),
                      movement=_readonly(movement, np.bool_), info=info,
                      field=None if field is None else _readonly(field, np.float64))


def _check_ground_truth(ground_truth: FloatArray, path: Path) -> None:
    lost = np.all(np.isnan(ground_truth), axis=1)
    present = ground_truth[~lost]
    if not np.all(np.isfinite(present)):
        raise InputError(f'Expected `opt_quat_wxyz` rows in {str(path)!r} to be finite or all '
                         f'NaN (lost)')
    norm_error = np.abs(np.linalg.norm(present, axis=1) - 1.0)
    if norm_error.size and norm_error.max() > UNIT_NORM_TOLERANCE:
        raise InputError(f'Expected `opt_quat_wxyz` in {str(path)!r} to be unit quaternions, '
                         f'got a norm error of {norm_error.max()}')


def attribution(trial: BroadTrial) -> dict[str, str]:
    """``custom_data`` metadata of a converted bag: source, citation, licence, bias estimate."""
    bias = trial.rest_gyro_bias()
    return {
        'dataset': 'BROAD (Berlin Robust Orientation Estimation Assessment Dataset)',
        'citation': CITATION,
        'license': LICENSE,
        'broad_trial': trial.name,
        'conversion': 'values unchanged; stamps i / sampling_rate; NaN ground-truth rows '
                      'skipped; ground truth is the IMU frame w.r.t. ENU',
        'sampling_rate_hz': repr(trial.sampling_rate),
        'first_motion_stamp_s': repr(trial.first_motion_index / trial.sampling_rate),
        'rest_gyro_bias_rad_s': ' '.join(repr(float(value)) for value in bias),
    }


def trial_to_bag(trial: BroadTrial, path: str | Path, *, storage: str = 'sqlite3',
                 imu_topic: str = 'imu', ground_truth_topic: str = 'ground_truth',
                 frame_id: str = 'base_link', world_frame: str = 'world') -> dict[str, int]:
    """Write ``trial`` as a bag; returns the message count per topic.

    ``sensor_msgs/msg/Imu`` (raw gyro and accelerometer, bias *not* removed) on ``imu_topic``,
    ``geometry_msgs/msg/QuaternionStamped`` on ``ground_truth_topic`` (lost samples skipped)
    and, when the trial has a magnetometer, ``sensor_msgs/msg/MagneticField`` [T] on
    ``imu/mag`` (each before the Imu of its sample), with header stamps and bag times
    ``i / sampling_rate``. The ``frame_id`` defaults to ``base_link``, the node's
    ``body_frame``: the optical truth is the attitude of the IMU itself, so the IMU is the body
    and no mount is needed. The citation, licence and the rest-phase bias estimate go into the
    bag's ``custom_data`` (:func:`attribution`).
    """
    return write_bag(path, stamps=trial.stamps, rates=trial.gyro, accelerations=trial.acc,
                     ground_truth=trial.ground_truth, imu_topic=imu_topic,
                     ground_truth_topic=ground_truth_topic, frame_id=frame_id,
                     world_frame=world_frame, storage=storage, custom_data=attribution(trial),
                     magnetic_fields=trial.field)


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog='python -m rigid_body_attitude.tools.broad',
        description='Convert a BROAD trial (.npz) into a rosbag2 bag (Imu + ground truth). '
                    f'Data: {CITATION}. Licence: {LICENSE}.')
    parser.add_argument('trial', help='BROAD trial archive (.npz)')
    parser.add_argument('out_bag', help='bag directory to create (must not exist)')
    parser.add_argument('--storage', choices=sorted(STORAGES), default='sqlite3')
    parser.add_argument('--imu-topic', default='imu')
    parser.add_argument('--ground-truth-topic', default='ground_truth')
    parser.add_argument('--frame-id', default='base_link')
    parser.add_argument('--world-frame', default='world')
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Command-line entry point; returns the exit code (1 with ``error: ...`` on bad input)."""
    args = _parser().parse_args(argv)
    try:
        trial = load_trial(args.trial)
        counts = trial_to_bag(trial, args.out_bag, storage=args.storage,
                              imu_topic=args.imu_topic,
                              ground_truth_topic=args.ground_truth_topic,
                              frame_id=args.frame_id, world_frame=args.world_frame)
    except AttitudeError as err:
        print(f'error: {err}', file=sys.stderr)
        return 1
    lost = int(trial.ground_truth_lost.sum())
    print(f'{args.out_bag}: {counts[args.imu_topic]} Imu messages on {args.imu_topic!r}, '
          f'{counts[args.ground_truth_topic]} ground-truth messages on '
          f'{args.ground_truth_topic!r} ({lost} lost samples skipped); rest gyro bias '
          f'{trial.rest_gyro_bias().tolist()} rad/s. Data: {CITATION} ({LICENSE}).')
    return 0


if __name__ == '__main__':
    sys.exit(main())
