"""Real-data table: BROAD trials replayed with every strapdown method, error vs optical truth.

For each shipped trial (07: fast rotation up to 25 rad/s; 15: translation, small rotations) and
each strapdown method the propagator offers
(:func:`rigid_body_attitude.core.attitude.integrators.strapdown_method`), the trial is converted to
a bag
(``rigid_body_attitude.tools.broad.trial_to_bag``) and replayed with ``replay`` exactly as
``test/tools/test_real_data.py`` does: the ``gyro_bias`` effect averages the initial rest phase,
the attitude starts from the ground truth at the first motion sample, and the largest attitude
error against the ground truth is reported for the first 10 s of motion and for the whole trial.
Prints a Markdown table (the README's).

Data: D. Laidig, M. Caruso, A. Cereatti, T. Seel, "BROAD — A Benchmark for Robust Inertial
Orientation Estimation", Data 6(7):72, 2021, doi:10.3390/data6070072, CC BY 4.0.

Usage: ``python studies/replay_real_data.py [DATA_DIR] [--methods a,b,...]``
(default the repository's ``data/broad``, all methods).
"""

from __future__ import annotations

import argparse
import shutil
import sys
import tempfile
from pathlib import Path

import numpy as np
import yaml

from rigid_body_attitude.tools import broad
from rigid_body_attitude.core.attitude.integrators import STRAPDOWN_METHODS
from rigid_body_attitude.tools.replay import ReplayOptions, replay_bag

DEFAULT_DATA_DIR = Path(__file__).resolve().parent.parent / 'data' / 'broad'
TRIALS = ('07_undisturbed_fast_rotation_B', '15_undisturbed_fast_translation_A')
WINDOW_NS = 10 * 10**9


def max_errors_deg(trial: broad.BroadTrial, bag: Path, method: str,
                   workdir: Path) -> tuple[float, float]:
    """Largest error [deg] in the first 10 s of motion and over the whole trial."""
    motion_stamp = trial.first_motion_index / trial.sampling_rate
    scene = {'name': f'broad_{method}', 'rate_source': 'gyro', 'integrator': method,
             'body': {'mass': 1.0, 'inertia': {'moments': [1.0, 1.0, 1.0]}},
             'effects': [{'gyro_bias': {
                 'estimate_seconds': motion_stamp - 0.5 / trial.sampling_rate}}]}
    scene_path = workdir / 'scene.yaml'
    scene_path.write_text(yaml.safe_dump(scene), encoding='utf-8')
    out = workdir / 'out'
    shutil.rmtree(out, ignore_errors=True)
    result = replay_bag(bag, out, ReplayOptions(
        scene=str(scene_path), ground_truth_topic='ground_truth',
        start_from_ground_truth=motion_stamp, outputs=('orientation',)))
    start = result.alignment_stamp_ns
    errors = result.errors.within(start, 10**20)
    first = errors.within(start, start + WINDOW_NS)
    return float(np.degrees(first.errors.max())), float(np.degrees(errors.errors.max()))


def main(argv: list[str] | None = None) -> int:
    """Print the per-method table for both trials."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('data_dir', nargs='?', type=Path, default=DEFAULT_DATA_DIR)
    parser.add_argument('--methods', default='', help='comma-separated (default: all)')
    args = parser.parse_args(argv)
    methods = [m for m in args.methods.split(',') if m] or list(STRAPDOWN_METHODS)
    workdir = Path(tempfile.mkdtemp(prefix='replay_broad_'))
    rows: dict[str, dict[str, tuple[float, float]]] = {method: {} for method in methods}
    try:
        for trial_name in TRIALS:
            trial = broad.load_trial(args.data_dir / f'{trial_name}.npz')
            bag = workdir / trial_name
            broad.trial_to_bag(trial, bag)
            for method in methods:
                rows[method][trial_name] = max_errors_deg(trial, bag, method, workdir)
                print(f'{trial_name} {method}: {rows[method][trial_name]}', file=sys.stderr)
    finally:
        shutil.rmtree(workdir, ignore_errors=True)
    print('| method | order | 07: max error, first 10 s | 07: whole trial | '
          '15: max error, first 10 s | 15: whole trial |')
    print('|---|---|---|---|---|---|')
    for method in methods:
        first_07, whole_07 = rows[method][TRIALS[0]]
        first_15, whole_15 = rows[method][TRIALS[1]]
        order = getattr(STRAPDOWN_METHODS.get(method), 'order', '')
        print(f'| `{method}` | {order} | {first_07:.3f}° | {whole_07:.3f}° | {first_15:.3f}° | '
              f'{whole_15:.3f}° |')
    return 0


if __name__ == '__main__':
    sys.exit(main())
