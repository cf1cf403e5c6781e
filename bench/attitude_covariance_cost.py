"""Per-sample cost of the attitude covariance against the exp-map strapdown step, in one run.

Each contender runs over the same ``--steps`` gyro samples (a body turning at several rad/s),
timeit-style with the garbage collector off, ``--repeats`` rounds in which every contender runs
once (so that all see the same load); the minimum is the cost with the least interference from
other load, the median is printed beside it:

* ``scalar_exp_step``: the strapdown step alone (``q ← q ⊗ exp(h ω)``, plain floats);
* ``step + covariance``: the step, then ``AttitudeCovariance.add_sample`` with the default batch
  (a fold every :data:`DEFAULT_BATCH_SIZE` samples), covariance read once at the end;
* ``step + covariance read every sample``: as above, plus ``attitude_covariance`` read after
  each sample (a fold per sample);
* ``step + folded covariance read every sample``: ``folded_attitude_covariance`` read after each
  sample (the value at the last fold, at most a batch old);
* ``step + covariance (batch 256)``: a fold every
  :data:`rigid_body_attitude.session.uncertainty.BATCH_SIZE` samples;
* ``step + session covariance (the node's at 1 kHz)``: as the gyro session does it,
  :meth:`Uncertainty.step` (a fold every ``BATCH_SIZE`` samples or
  :data:`~rigid_body_attitude.session.uncertainty.FOLD_SECONDS` of them: 50 at 1 kHz);
* ``step + step rate + session covariance``: as above, with the held rate recovered from the
  two attitudes (``scalar_step_rate``, what the session does for the methods other than
  ``exp_map`` and ``delta_single``);
* ``step + covariance, batch 1``: a fold per sample, read at the end.

Usage: ``python bench/attitude_covariance_cost.py [--steps 20000] [--repeats 5] [--json PATH]``.
Prints µs/sample and the ratio to the strapdown step alone.
"""

from __future__ import annotations

import argparse
import gc
import json
import statistics
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np

from rigid_body_attitude.core.estimation.attitude_covariance import (
    AttitudeCovariance, DEFAULT_BATCH_SIZE)
from rigid_body_attitude.core.attitude.quaternion import scalar_exp_step, scalar_step_rate
from rigid_body_attitude.session.parameters import defaults
from rigid_body_attitude.session.uncertainty import BATCH_SIZE, FOLD_SECONDS, Uncertainty

DT = 0.001


def rates(steps: int) -> list[tuple[float, float, float]]:
    """Body rates [rad/s] at 1 kHz: several rad/s about a turning axis."""
    t = np.arange(steps) * DT
    rows = np.stack([2.5 * np.sin(1.4 * t), 2.0 * np.cos(2.3 * t), 3.0 * np.sin(1.1 * t + 1)], 1)
    return [tuple(row) for row in rows.tolist()]


def strapdown(samples: list[tuple[float, float, float]]) -> None:
    """The strapdown step alone."""
    q = (1.0, 0.0, 0.0, 0.0)
    for rate in samples:
        q = scalar_exp_step(q, rate, DT)


def with_covariance(batch_size: int, read: str = ''
                    ) -> Callable[[list[tuple[float, float, float]]], None]:
    """The strapdown step followed by the covariance update (and read)."""
    def run(samples: list[tuple[float, float, float]]) -> None:
        covariance = AttitudeCovariance(batch_size=batch_size)
        add = covariance.add_sample
        q = (1.0, 0.0, 0.0, 0.0)
        for rate in samples:
            add(q, rate, DT)
            q = scalar_exp_step(q, rate, DT)
            if read:
                getattr(covariance, read)
        covariance.attitude_covariance
    return run


def with_session(step_rate: bool) -> Callable[[list[tuple[float, float, float]]], None]:
    """The strapdown step followed by the session's :meth:`Uncertainty.step`."""
    def run(samples: list[tuple[float, float, float]]) -> None:
        uncertainty = Uncertainty(defaults())
        step = uncertainty.step
        q = (1.0, 0.0, 0.0, 0.0)
        for rate in samples:
            after = scalar_exp_step(q, rate, DT)
            step(q, scalar_step_rate(q, after, DT) if step_rate else rate, DT)
            q = after
    return run


def timed(function: Callable[[list[tuple[float, float, float]]], None],
          samples: list[tuple[float, float, float]], repeats: int) -> list[float]:
    """µs per sample of each repetition."""
    costs = []
    for _ in range(repeats):
        gc.disable()
        start = time.perf_counter()
        function(samples)
        costs.append((time.perf_counter() - start) / len(samples) * 1e6)
        gc.enable()
    return costs


def main() -> None:
    """Run the contenders and print the table."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--steps', type=int, default=20000)
    parser.add_argument('--repeats', type=int, default=5)
    parser.add_argument('--json', type=Path)
    args = parser.parse_args()
    samples = rates(args.steps)
    contenders = {
        'scalar_exp_step': strapdown,
        f'step + covariance (batch {DEFAULT_BATCH_SIZE})': with_covariance(DEFAULT_BATCH_SIZE),
        f'step + covariance (batch {BATCH_SIZE})': with_covariance(BATCH_SIZE),
        f'step + covariance (batch {round(FOLD_SECONDS / DT)})': with_covariance(
            round(FOLD_SECONDS / DT)),
        'step + session covariance (the node\'s at 1 kHz)': with_session(False),
        'step + step rate + session covariance': with_session(True),
        'step + covariance read every sample': with_covariance(DEFAULT_BATCH_SIZE,
                                                               'attitude_covariance'),
        'step + folded covariance read every sample': with_covariance(
            DEFAULT_BATCH_SIZE, 'folded_attitude_covariance'),
        'step + covariance, batch 1': with_covariance(1),
    }
    figures: dict[str, list[float]] = {name: [] for name in contenders}
    for _ in range(args.repeats):  # round-robin: every contender sees the same load
        for name, function in contenders.items():
            figures[name] += timed(function, samples, 1)
    base = min(figures['scalar_exp_step'])
    print('| contender | µs/sample (min) | median | ratio to the step alone |')
    print('|---|---|---|---|')
    for name, costs in figures.items():
        print(f'| {name} | {min(costs):.2f} | {statistics.median(costs):.2f} | '
              f'{min(costs) / base:.2f} |')
    if args.json:
        args.json.write_text(json.dumps({name: {'min_us': min(c), 'median_us':
                                                statistics.median(c)}
                                         for name, c in figures.items()}, indent=2))


if __name__ == '__main__':
    main()
