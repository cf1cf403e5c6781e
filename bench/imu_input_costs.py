"""Per-sample costs of the IMU input pieces beside the strapdown step, in one run.

Each contender runs over the same ``--samples`` BROAD-like samples (200 Hz rest noise plus a
slow turn; values do not change the cost) in a loop (garbage collector off, ``--repeats``
repetitions, minimum and median reported), fed plain float tuples as the node's decoder gives
them:

* the strapdown steps ``ExpMap.propagate`` and ``DeltaSingle.propagate``;
* ``ImuCalibration.correct`` (a kalibr scale-misalignment file with g-sensitivity: both
  corrections) and ``correct_gyro`` without the accelerometer;
* ``RestDetector.update`` (sliding window, running sums), ``RestBiasEstimator.update`` at rest,
  and ``GravityAligner.update`` once aligned (what every later sample costs).

Usage: ``python bench/imu_input_costs.py [--samples 20000] [--repeats 7]``. Prints a Markdown
table with each cost as a ratio to the ``delta_single`` step of the same run.
"""

from __future__ import annotations

import argparse
import gc
from pathlib import Path
import statistics
import sys
import time
from typing import Callable

import numpy as np

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO))

from rigid_body_attitude.core.imu.alignment import GravityAligner  # noqa: E402
from rigid_body_attitude.core.imu.calibration import ImuCalibration  # noqa: E402
from rigid_body_attitude.core.attitude.integrators.strapdown import (  # noqa: E402
    DeltaSingle, ExpMap)
from rigid_body_attitude.core.imu.rest import RestBiasEstimator, RestDetector  # noqa: E402

Rows = list[tuple[float, float, float]]


def _samples(count: int) -> tuple[Rows, Rows]:
    rng = np.random.default_rng(1)
    gyro = 2e-3 * rng.standard_normal((count, 3)) + [0.003, -0.002, 0.01]
    acc = 0.05 * rng.standard_normal((count, 3)) + [0.0, 0.0, 9.81]
    return ([tuple(row) for row in gyro.tolist()],  # type: ignore[misc]
            [tuple(row) for row in acc.tolist()])  # type: ignore[misc]


def _contenders(gyro: Rows, acc: Rows, dt: float) -> dict[str, Callable[[], object]]:
    calibration = ImuCalibration(
        gyro_matrix=np.array([[1.01, 0.0, 0.0], [0.002, 0.99, 0.0], [0.001, -0.003, 1.0]]),
        g_sensitivity=1e-4 * np.ones((3, 3)), accelerometer_matrix=np.eye(3) * 1.002)
    aligner = GravityAligner()
    for w, a in zip(gyro[:400], acc[:400]):
        aligner.update(*w, *a, dt)
    assert aligner.done

    def strapdown(method: object) -> Callable[[], object]:
        def run() -> object:
            q = (1.0, 0.0, 0.0, 0.0)
            previous = gyro[0]
            for w in gyro:
                q = method.propagate(q, previous, w, dt)  # type: ignore[attr-defined]
                previous = w
            return q
        return run

    def correct() -> object:
        return [calibration.correct(*w, *a) for w, a in zip(gyro, acc)]

    def correct_gyro() -> object:
        return [calibration.correct_gyro(*w) for w in gyro]

    def detect() -> object:
        detector = RestDetector()
        return [detector.update(*w, *a, dt) for w, a in zip(gyro, acc)]

    def refine() -> object:
        estimator = RestBiasEstimator()
        return [estimator.update(True, w, dt) for w in gyro]

    def aligned() -> object:
        return [aligner.update(*w, *a, dt) for w, a in zip(gyro, acc)]

    return {'ExpMap.propagate': strapdown(ExpMap()),
            'DeltaSingle.propagate': strapdown(DeltaSingle()),
            'ImuCalibration.correct (gyro + accelerometer)': correct,
            'ImuCalibration.correct_gyro': correct_gyro,
            'RestDetector.update': detect, 'RestBiasEstimator.update': refine,
            'GravityAligner.update (aligned)': aligned}


def main(argv: list[str] | None = None) -> int:
    """Time every contender and print the table."""
    parser = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    parser.add_argument('--samples', type=int, default=20000)
    parser.add_argument('--repeats', type=int, default=7)
    args = parser.parse_args(argv)
    gyro, acc = _samples(args.samples)
    results: dict[str, tuple[float, float]] = {}
    for name, run in _contenders(gyro, acc, 1.0 / 200.0).items():
        times = []
        gc.disable()
        try:
            for _ in range(args.repeats):
                start = time.perf_counter()
                run()
                times.append((time.perf_counter() - start) / args.samples * 1e6)
        finally:
            gc.enable()
        results[name] = (min(times), statistics.median(times))
    reference = results['DeltaSingle.propagate'][0]
    print('| per sample | min [µs] | median [µs] | / delta_single step |\n|---|---|---|---|')
    for name, (best, median) in results.items():
        print(f'| `{name}` | {best:.2f} | {median:.2f} | {best / reference:.2f} |')
    return 0


if __name__ == '__main__':
    sys.exit(main())
