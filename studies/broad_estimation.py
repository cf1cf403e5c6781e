"""The attitude filter on the BROAD trials with magnetometer, beside VQF, in one table.

Runs :mod:`rigid_body_attitude.tools.estimation_study` on every trial of the given folders
(default: ``shared/data/broad_mag`` beside or above the checkout), one set of settings for all:
the documented defaults, with the IMU's figures measured once on the first trial
(:func:`~rigid_body_attitude.tools.estimation_study.dataset_model`: noise densities
by ``imu_noise``'s Allan fit on its rest, the magnetometer's delay behind the gyro).
Prints per trial the total, heading and inclination RMSE [deg] of the filter and of VQF
(``offlineVQF``, defaults), the ratio of the totals, the share of motion samples whose NEES
lies inside the chi-square 99 % bound (3 dof, tilt 2 dof, heading 1 dof) and the median 1σ
over the RMSE (total, tilt over inclination, heading); then the means per group (undisturbed,
disturbed) and over all trials.

Usage: ``python studies/broad_estimation.py [DATA_DIR ...]``. Needs ``vqf``
(requirements-test.txt).
Data: D. Laidig, M. Caruso, A. Cereatti, T. Seel. "BROAD — A Benchmark for Robust Inertial
Orientation Estimation". Data 6(7):72, 2021. doi:10.3390/data6070072 (CC BY 4.0).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

from rigid_body_attitude.tools.broad import load_trial
from rigid_body_attitude.tools.estimation_study import (
    dataset_model, figures, run_filter, run_vqf, settings_for)

REPO_ROOT = Path(__file__).resolve().parent.parent


def default_folders() -> list[Path]:
    """Any ``shared/data/broad_mag`` beside or above the checkout."""
    return [parent / 'shared' / 'data' / 'broad_mag' for parent in REPO_ROOT.parents
            if (parent / 'shared' / 'data' / 'broad_mag').is_dir()][:1]


def main(argv: list[str] | None = None) -> int:
    """Print the table of the module docstring."""
    parser = argparse.ArgumentParser(description=__doc__.split('\n', 1)[0])
    parser.add_argument('folders', nargs='*', type=Path)
    args = parser.parse_args(argv)
    paths = sorted(path for folder in (args.folders or default_folders())
                   for path in folder.glob('*.npz'))
    if not paths:
        print('error: no BROAD trial (.npz) found', file=sys.stderr)
        return 1
    model, magnetometer = dataset_model(load_trial(paths[0]))
    settings = settings_for(magnetometer)
    print(f'first trial\'s figures: noise densities gyro {model.gyroscope_noise_density:.3g} '
          f'rad/s/√Hz, accelerometer {model.accelerometer_noise_density:.3g} m/s²/√Hz, '
          f'magnetometer {magnetometer.noise_density:.3g} T/√Hz; magnetometer delay '
          f'{1e3 * magnetometer.delay:.2f} ms, timing 1σ {1e3 * magnetometer.timing:.2f} ms')
    print('| trial | filter total / heading / incl. [deg] | VQF total / heading / incl. '
          '[deg] | total ratio | NEES inside 99 %: 3-dof / tilt / heading | median 1σ / '
          'RMSE: total / tilt / heading |')
    print('| --- | --- | --- | --- | --- | --- |')
    groups: dict[str, list[tuple[float, ...]]] = {}
    for path in paths:
        trial = load_trial(path)
        ours, vqf = figures(trial, run_filter(trial, model, settings)), figures(
            trial, run_vqf(trial))
        t, h, i = ours.rmse
        useful = (ours.median_sigma[0] / t, ours.median_sigma[1] / i, ours.median_sigma[2] / h)
        print(f'| {trial.name} | {t:.2f} / {h:.2f} / {i:.2f} | {vqf.rmse[0]:.2f} / '
              f'{vqf.rmse[1]:.2f} / {vqf.rmse[2]:.2f} | {t / vqf.rmse[0]:.2f} | '
              + ' / '.join(f'{100 * share:.1f} %' for share in ours.inside) + ' | '
              + ' / '.join(f'{ratio:.1f}' for ratio in useful) + ' |', flush=True)
        group = 'disturbed' if 'disturbed' in trial.name.replace('undisturbed', '') else (
            'undisturbed')
        groups.setdefault(group, []).append((*ours.rmse, *vqf.rmse))
    groups['all'] = [row for rows in list(groups.values()) for row in rows]
    for name, rows in groups.items():
        mean = np.mean(np.array(rows), axis=0)
        print(f'| mean, {name} ({len(rows)}) | {mean[0]:.2f} / {mean[1]:.2f} / {mean[2]:.2f} | '
              f'{mean[3]:.2f} / {mean[4]:.2f} / {mean[5]:.2f} | {mean[0] / mean[3]:.2f} | | |')
    return 0


if __name__ == '__main__':
    sys.exit(main())
