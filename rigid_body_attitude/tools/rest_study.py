"""Levelling and bias-at-rest on the BROAD trials, against the optical ground truth.

Two measurements, each fed sample by sample exactly as a session feeds the core:

* **Levelling** (:func:`levelling_error`): a
  :class:`~rigid_body_attitude.core.estimation.alignment.GravityAligner` from the trial's
  first sample; the tilt of its attitude is compared with the ground truth's at the first
  sample with optical data from the moment it is aligned on, inside the initial rest phase
  (the body does not move there, and the cameras see it only after a few seconds in some
  trials).
* **Bias at rest** (:func:`strapdown_error`): the aligned attitude, with the heading of the
  ground truth (gravity gives none), is propagated through the whole trial with a strapdown
  method of :mod:`rigid_body_attitude.core.attitude.integrators.strapdown`, the gyro bias either
  fixed
  at the alignment window's mean or refined while the
  :class:`~rigid_body_attitude.core.estimation.rest.RestDetector` reports rest
  (:class:`~rigid_body_attitude.core.estimation.rest.RestBiasEstimator`). The attitude error
  against the ground truth is summarised over the motion phase.

Command line: ``python -m rigid_body_attitude.tools.rest_study [DATA_DIR] [--method-table]``
prints both tables (and, with ``--method-table``, every strapdown method with the fixed bias).
Data: BROAD, Laidig et al., Data 6(7):72, 2021, doi:10.3390/data6070072, CC BY 4.0.
"""

from __future__ import annotations

import argparse
import math
import sys
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from rigid_body_attitude.core.estimation.alignment import (
    GravityAligner, levelled_attitude, tilt_angle)
from rigid_body_attitude.core.attitude.integrators.strapdown import (
    STRAPDOWN_METHODS, strapdown_method)
from rigid_body_attitude.core.attitude.quaternion import attitude_error, to_matrix
from rigid_body_attitude.core.estimation.rest import RestBiasEstimator, RestDetector
from rigid_body_attitude.tools.broad import BroadTrial, load_trial

__all__ = ['DEFAULT_DATA_DIR', 'LevellingResult', 'StrapdownResult', 'TRIALS', 'align',
           'levelling_error', 'main', 'strapdown_error']

DEFAULT_DATA_DIR = Path(__file__).resolve().parents[2] / 'data' / 'broad'
TRIALS = ('05_undisturbed_slow_rotation_with_breaks_B', '07_undisturbed_fast_rotation_B',
          '15_undisturbed_fast_translation_A', '24_disturbed_tapping_A')


@dataclass(frozen=True)
class LevellingResult:
    """Outcome of levelling one trial.

    Attributes:
        tilt_error_deg: tilt of the levelled attitude against the ground truth [deg].
        aligned_index: index of the sample that completed the alignment.
        truth_index: index of the ground-truth sample compared.
        state: the aligner's final state.
        gyro_bias: the alignment window's mean rate [rad/s].
    """

    tilt_error_deg: float
    aligned_index: int
    truth_index: int
    state: str
    gyro_bias: tuple[float, float, float]


@dataclass(frozen=True)
class StrapdownResult:
    """Attitude error [deg] against the ground truth over the motion phase.

    Attributes:
        max_deg: largest error.
        mean_deg: mean error.
        final_deg: mean error over the final rest phase (after the last motion sample).
        rest_seconds: time the bias was refined for [s] (0 when fixed).
    """

    max_deg: float
    mean_deg: float
    final_deg: float
    rest_seconds: float


def align(trial: BroadTrial, aligner: GravityAligner) -> int:
    """Feed ``trial`` to ``aligner`` until it is done; returns the completing sample's index."""
    dt = 1.0 / trial.sampling_rate
    gyro, acc = trial.gyro.tolist(), trial.acc.tolist()
    for index in range(trial.sample_count):
        w, a = gyro[index], acc[index]
        if aligner.update(w[0], w[1], w[2], a[0], a[1], a[2], dt):
            return index
    return trial.sample_count - 1


def _truth_index(trial: BroadTrial, start: int) -> int:
    """First sample from ``start`` on with ground truth, inside the initial rest phase."""
    seen = np.flatnonzero(~trial.ground_truth_lost[start:trial.first_motion_index])
    if seen.size == 0:
        raise ValueError(f'{trial.name}: no ground truth in the initial rest phase after '
                         f'sample {start}')
    return start + int(seen[0])


def levelling_error(trial: BroadTrial, align_seconds: float = 1.0) -> LevellingResult:
    """Level ``trial`` from its first sample and compare the tilt with the ground truth."""
    aligner = GravityAligner(align_seconds=align_seconds)
    index = align(trial, aligner)
    truth_index = _truth_index(trial, index)
    truth = tuple(float(value) for value in trial.ground_truth[truth_index])
    tilt = tilt_angle(aligner.attitude, (truth[0], truth[1], truth[2], truth[3]))
    return LevellingResult(math.degrees(tilt), index, truth_index, aligner.state,
                           aligner.gyro_bias)


def _heading(q: Sequence[float]) -> float:
    """ZYX yaw [rad] of a body → ENU attitude (rotation about the world z axis)."""
    matrix = to_matrix(np.asarray(q, dtype=float))
    return math.atan2(float(matrix[1, 0]), float(matrix[0, 0]))


def strapdown_error(trial: BroadTrial, method: str = 'delta_single', refine: bool = False,
                    time_constant: float = 60.0, align_seconds: float = 1.0
                    ) -> StrapdownResult:
    """Align, then integrate the whole trial with ``method``; the bias fixed or ``refine``d."""
    detector = RestDetector()
    aligner = GravityAligner(align_seconds=align_seconds, detector=detector)
    start = align(trial, aligner)
    truth_start = trial.ground_truth[_truth_index(trial, start)]
    attitude = levelled_attitude(aligner.specific_force, _heading(truth_start))
    estimator = RestBiasEstimator(aligner.gyro_bias, align_seconds, time_constant)
    stepper = strapdown_method(method)
    dt = 1.0 / trial.sampling_rate
    gyro, acc = trial.gyro.tolist(), trial.acc.tolist()
    path = np.full((trial.sample_count, 4), np.nan)
    bias = aligner.gyro_bias
    previous = (gyro[start][0] - bias[0], gyro[start][1] - bias[1], gyro[start][2] - bias[2])
    for index in range(start + 1, trial.sample_count):
        w, a = gyro[index], acc[index]
        if refine and detector.update(w[0], w[1], w[2], a[0], a[1], a[2], dt):
            bias = estimator.update(True, detector.delayed_gyro, dt)
            detector.set_gyro_bias(bias)
        current = (w[0] - bias[0], w[1] - bias[1], w[2] - bias[2])
        attitude = stepper.propagate(attitude, previous, current, dt)
        previous = current
        path[index] = attitude
    return _summary(trial, path, estimator.rest_seconds - align_seconds if refine else 0.0)


def _summary(trial: BroadTrial, path: np.ndarray, rest_seconds: float) -> StrapdownResult:
    errors = np.degrees(np.asarray(attitude_error(path, trial.ground_truth)))
    motion = trial.movement & np.isfinite(errors)
    last_motion = int(np.flatnonzero(trial.movement)[-1])
    final = np.isfinite(errors) & (np.arange(trial.sample_count) > last_motion)
    return StrapdownResult(float(errors[motion].max()), float(errors[motion].mean()),
                           float(errors[final].mean()), rest_seconds)


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog='python -m rigid_body_attitude.tools.rest_study',
                                     description=__doc__.split('\n\n')[0])
    parser.add_argument('data_dir', nargs='?', type=Path, default=DEFAULT_DATA_DIR)
    parser.add_argument('--methods', default='exp_map,delta_single',
                        help="strapdown methods of the bias table, comma-separated, or 'all'")
    parser.add_argument('--time-constants', default='10,60,600')
    parser.add_argument('--method-table', action='store_true',
                        help='also print every strapdown method with the fixed bias')
    return parser


def _method_table(trials: list[BroadTrial]) -> None:
    print('\n| method | ' + ' | '.join(trial.name[:2] + ' max / mean [deg]' for trial in trials)
          + ' |\n|---|' + '---|' * len(trials))
    for method in STRAPDOWN_METHODS:
        rows = [strapdown_error(trial, method) for trial in trials]
        print(f'| `{method}` | ' + ' | '.join(f'{row.max_deg:.3f} / {row.mean_deg:.3f}'
                                              for row in rows) + ' |')


def main(argv: Sequence[str] | None = None) -> int:
    """Print the levelling table and the bias-at-rest table (Markdown)."""
    args = _parser().parse_args(argv)
    trials = [load_trial(args.data_dir / f'{name}.npz') for name in TRIALS]
    print('| trial | tilt error after levelling [deg] | aligned at [s] |\n|---|---|---|')
    for trial in trials:
        result = levelling_error(trial)
        print(f'| {trial.name} | {result.tilt_error_deg:.3f} | '
              f'{result.aligned_index / trial.sampling_rate:.2f} |')
    constants = [float(text) for text in args.time_constants.split(',')]
    print('\n| trial | method | bias | max [deg] | mean [deg] | final rest [deg] |\n'
          '|---|---|---|---|---|---|')
    methods = list(STRAPDOWN_METHODS) if args.methods == 'all' else args.methods.split(',')
    for trial in trials:
        for method in methods:
            rows = [('initial window', strapdown_error(trial, method))] + [
                (f'refined, τ = {tau:g} s', strapdown_error(trial, method, True, tau))
                for tau in constants]
            for label, row in rows:
                print(f'| {trial.name} | {method} | {label} | {row.max_deg:.3f} | '
                      f'{row.mean_deg:.3f} | {row.final_deg:.3f} |')
    if args.method_table:
        _method_table(trials)
    return 0


if __name__ == '__main__':
    sys.exit(main())
