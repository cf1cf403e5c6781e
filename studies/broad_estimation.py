"""The node's attitude filter on the BROAD trials with magnetometer, beside VQF, in one table.

Each trial of the given folders (default: ``shared/data/broad_mag`` beside or above the
checkout) is written as a bag (Imu, MagneticField, ground truth) and replayed through the
replay tool with the shipped ``imu_filter`` scene and the node's default parameters, one set
for all trials, plus the IMU's two calibration files, made once for the dataset's IMU as a
user makes them and shipped beside this script (each figure's source in its comments):
``studies/broad_imu.yaml`` (``calibration_file``: the noise ``imu_noise`` measures on a rest,
the data-sheet figures) and ``studies/broad_magnetometer.yaml``
(``magnetometer_calibration_file``: noise density, delay, timing). The same session fed in
this process must give the same outputs (the largest difference is printed). Prints per trial
the total, heading and inclination RMSE [deg] of the node and of VQF (``offlineVQF``,
defaults) on the same samples, the ratio of the totals, the share of motion samples whose NEES
lies inside the chi-square 99 % bound (3 dof, tilt 2 dof, heading 1 dof) and the median 1σ
over the RMSE (total, tilt over inclination, heading); then the means per group (undisturbed,
disturbed) and over all trials. Trials without a magnetometer (``shared/data/broad``) run the
same way: VQF 6D, the node's heading propagated (only the inclination is comparable).

Usage: ``python studies/broad_estimation.py [DATA_DIR ...] [--calibration-file FILE]
[--magnetometer-calibration-file FILE]``. Needs ``vqf`` (requirements-test.txt).
Data: D. Laidig, M. Caruso, A. Cereatti, T. Seel. "BROAD — A Benchmark for Robust Inertial
Orientation Estimation". Data 6(7):72, 2021. doi:10.3390/data6070072 (CC BY 4.0).
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

import numpy as np

from typing import Any

from rigid_body_attitude.tools.broad import BroadTrial, load_trial
from rigid_body_attitude.tools.estimation_study import (
    Run, TrialFigures, figures, run_replay, run_session, study_values)

REPO_ROOT = Path(__file__).resolve().parent.parent
#: The calibration files of BROAD's IMU, shipped beside this script.
IMU_FILE = REPO_ROOT / 'studies' / 'broad_imu.yaml'
MAGNETOMETER_FILE = REPO_ROOT / 'studies' / 'broad_magnetometer.yaml'


def default_folders() -> list[Path]:
    """Any ``shared/data/broad_mag`` beside or above the checkout."""
    return [parent / 'shared' / 'data' / 'broad_mag' for parent in REPO_ROOT.parents
            if (parent / 'shared' / 'data' / 'broad_mag').is_dir()][:1]


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


def _header() -> None:
    print('| trial | node total / heading / incl. [deg] | VQF total / heading / incl. '
          '[deg] | total ratio | NEES inside 99 %: 3-dof / tilt / heading | median 1σ / '
          'RMSE: total / tilt / heading |')
    print('| --- | --- | --- | --- | --- | --- |')


def main(argv: list[str] | None = None) -> int:
    """Print the table of the module docstring."""
    parser = argparse.ArgumentParser(description=__doc__.split('\n', 1)[0])
    parser.add_argument('folders', nargs='*', type=Path)
    parser.add_argument('--calibration-file', type=Path, default=IMU_FILE)
    parser.add_argument('--magnetometer-calibration-file', type=Path, default=MAGNETOMETER_FILE)
    args = parser.parse_args(argv)
    paths = sorted(path for folder in (args.folders or default_folders())
                   for path in folder.glob('*.npz'))
    if not paths:
        print('error: no BROAD trial (.npz) found', file=sys.stderr)
        return 1
    files = {'calibration_file': str(args.calibration_file),
             'magnetometer_calibration_file': str(args.magnetometer_calibration_file)}
    for name, path in files.items():
        print(f'{name}: {path}')
    values = study_values(**files)
    _header()
    groups: dict[str, list[tuple[float, ...]]] = {}
    largest = 0.0
    with tempfile.TemporaryDirectory() as temporary:
        for path in paths:
            trial = load_trial(path)
            replayed = run_replay(trial, values, Path(temporary))
            largest = max(largest, float(np.nanmax(np.abs(
                replayed.attitude - run_session(trial, values).attitude))))
            ours, vqf = figures(trial, replayed), figures(trial, run_vqf(trial))
            _row(trial.name, ours, vqf)
            group = 'disturbed' if 'disturbed' in trial.name.replace('undisturbed', '') else (
                'undisturbed')
            groups.setdefault(group, []).append((*ours.rmse, *vqf.rmse, *ours.inside,
                                                 *_sigma_ratios(ours)))
    groups['all'] = [row for rows in list(groups.values()) for row in rows]
    for name, rows in groups.items():
        m = np.mean(np.array(rows), axis=0)
        print(f'| mean, {name} ({len(rows)}) | {m[0]:.2f} / {m[1]:.2f} / {m[2]:.2f} | '
              f'{m[3]:.2f} / {m[4]:.2f} / {m[5]:.2f} | {m[0] / m[3]:.2f} | '
              + ' / '.join(f'{100 * share:.1f} %' for share in m[6:9]) + ' | '
              + ' / '.join(f'{ratio:.1f}' for ratio in m[9:12]) + ' |')
    print(f'replay against the session fed in this process: largest quaternion component '
          f'difference {largest:.3g}')
    return 0


def _sigma_ratios(ours: TrialFigures) -> tuple[float, float, float]:
    """Median 1σ over the RMSE: total, tilt over inclination, heading."""
    t, h, i = ours.rmse
    return ours.median_sigma[0] / t, ours.median_sigma[1] / i, ours.median_sigma[2] / h


def _row(name: str, ours: TrialFigures, vqf: TrialFigures) -> None:
    """One trial's row."""
    t, h, i = ours.rmse
    useful = _sigma_ratios(ours)
    print(f'| {name} | {t:.2f} / {h:.2f} / {i:.2f} | {vqf.rmse[0]:.2f} / '
          f'{vqf.rmse[1]:.2f} / {vqf.rmse[2]:.2f} | {t / vqf.rmse[0]:.2f} | '
          + ' / '.join(f'{100 * share:.1f} %' for share in ours.inside) + ' | '
          + ' / '.join(f'{ratio:.1f}' for ratio in useful) + ' |', flush=True)


if __name__ == '__main__':
    sys.exit(main())
