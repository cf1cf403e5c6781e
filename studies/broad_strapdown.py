"""Plain strapdown integration of the BROAD trials: which gyro sample convention, what error.

For each shipped trial: remove the rest-phase gyro bias, start from the optical ground truth
at the first motion sample k0, integrate the body rates over the first 10 s and report the
largest attitude error against the ground truth at the sample stamps. Updates compared, with
``h = 1 / sampling_rate``:

* ``exp, ω_k``: ``q_{k+1} = q_k ⊗ exp(h ω_k)`` (rate sample at the start of the interval),
* ``exp, ω_{k+1}``: ``q_{k+1} = q_k ⊗ exp(h ω_{k+1})`` (rate sample at the end),
* ``trapezoid + coning``: ``q_{k+1} = q_k ⊗ exp(½h(ω_k + ω_{k+1}) + (h²/12) ω_k × ω_{k+1})``.

Usage: ``python studies/broad_strapdown.py [DATA_DIR]`` (default the repository's ``data/broad``).
Data: BROAD, Laidig et al., Data 6(7):72, 2021, doi:10.3390/data6070072, CC BY 4.0.
"""

from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np

from rigid_body_attitude.tools.broad import BroadTrial, load_trial
from rigid_body_attitude.core.attitude.quaternion import attitude_error, scalar_exp_step

DEFAULT_DATA_DIR = Path(__file__).resolve().parent.parent / 'data' / 'broad'
TRIALS = ('07_undisturbed_fast_rotation_B', '15_undisturbed_fast_translation_A')
SCHEMES = ('exp, ω_k', 'exp, ω_{k+1}', 'trapezoid + coning')
WINDOW_S = 10.0


def _rotation_vector(scheme: str, rate_now: list[float], rate_next: list[float],
                     h: float) -> tuple[float, float, float]:
    if scheme == 'exp, ω_k':
        return rate_now[0] * h, rate_now[1] * h, rate_now[2] * h
    if scheme == 'exp, ω_{k+1}':
        return rate_next[0] * h, rate_next[1] * h, rate_next[2] * h
    ax, ay, az = rate_now
    bx, by, bz = rate_next
    coning = h * h / 12.0
    return (0.5 * h * (ax + bx) + coning * (ay * bz - az * by),
            0.5 * h * (ay + by) + coning * (az * bx - ax * bz),
            0.5 * h * (az + bz) + coning * (ax * by - ay * bx))


def max_error_deg(trial: BroadTrial, scheme: str, window_s: float = WINDOW_S) -> float:
    """Largest attitude error (degrees) over the first ``window_s`` after the first motion."""
    start = trial.first_motion_index
    steps = math.floor(window_s * trial.sampling_rate)
    h = 1.0 / trial.sampling_rate
    rates = (trial.gyro - trial.rest_gyro_bias()).tolist()
    attitude = tuple(trial.ground_truth[start])
    path = np.empty((steps, 4))
    for step, k in enumerate(range(start, start + steps)):
        attitude = scalar_exp_step(attitude, _rotation_vector(scheme, rates[k], rates[k + 1], h),
                                   1.0)
        path[step] = attitude
    errors = attitude_error(path, trial.ground_truth[start + 1:start + steps + 1])
    return float(np.degrees(np.nanmax(errors)))


def main(argv: list[str] | None = None) -> int:
    """Print the table of largest errors per trial and scheme."""
    argv = sys.argv[1:] if argv is None else argv
    data_dir = Path(argv[0]) if argv else DEFAULT_DATA_DIR
    print(f'max attitude error (deg) over the first {WINDOW_S:g} s of motion, rest bias removed')
    print(f'{"trial":40s}' + ''.join(f'{scheme:>22s}' for scheme in SCHEMES))
    for name in TRIALS:
        trial = load_trial(data_dir / f'{name}.npz')
        row = ''.join(f'{max_error_deg(trial, scheme):22.3f}' for scheme in SCHEMES)
        print(f'{name:40s}{row}')
    return 0


if __name__ == '__main__':
    sys.exit(main())
