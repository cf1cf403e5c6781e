"""Batch throughput: body-steps per second of TorqueFreeBatch (RK4) for N torque-free bodies.

A Monte-Carlo dispersion (per-body inertia tensors with random principal axes, random
attitudes and rates) of ``--bodies`` bodies (default 10⁵) is advanced ``--steps`` RK4 steps of
1 ms per repetition; the best of ``--repeats`` repetitions gives body-steps per second (the
issue asks for ≥ 10⁷ at N = 10⁵). The same run checks ``--check`` bodies, spread over the
batch, against the single-body ``rk4`` integrator (``test/core/test_batch.py`` does the same on a
small dispersion): every component within 1e-12, or exit 1. ``--bodies`` takes a list, so the
scaling with N shows too.

Usage: ``python bench/batch_throughput.py [--bodies 1000,10000,100000] [--steps 20]
[--repeats 5] [--json PATH]``.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path
import sys
import time

import numpy as np

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO))

from rigid_body_attitude.core import quaternion  # noqa: E402
from rigid_body_attitude.core.batch import TorqueFreeBatch  # noqa: E402
from rigid_body_attitude.core.integrators import dynamics_integrator  # noqa: E402
from rigid_body_attitude.core.integrators.base import SimpleBodyModel  # noqa: E402

STEP = 1e-3
TARGET_BODY_STEPS_PER_S = 1e7
TARGET_BODIES = 100_000
AGREEMENT = 1e-12


def dispersion(count: int, seed: int = 1) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per-body inertia tensors (moments 1.5-2.8 kg m², gaps ≥ 0.2, random axes), attitudes
    and rates up to 3 rad/s, drawn with NumPy (no Python loop)."""
    rng = np.random.default_rng(seed)
    moments = np.array([1.5, 2.0, 2.5]) + rng.uniform(0.0, 0.3, (count, 3))
    axes = quaternion.to_matrix(quaternion.normalize(rng.normal(size=(count, 4))))
    tensors = np.einsum('nij,nj,nkj->nik', axes, moments, axes)
    attitudes = quaternion.normalize(rng.normal(size=(count, 4)))
    omegas = rng.uniform(-1.0, 1.0, (count, 3)) * 3.0 / np.sqrt(3.0)
    return tensors, attitudes, omegas


def run(count: int, steps: int, repeats: int, check: int) -> dict:
    """Time ``repeats`` calls of ``rk4(STEP, steps)``; check ``check`` bodies afterwards."""
    tensors, attitudes, omegas = dispersion(count)
    batch = TorqueFreeBatch(tensors, attitudes, omegas)
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        batch.rk4(STEP, steps)
        times.append(time.perf_counter() - start)
    total_steps = steps * repeats
    rk4 = dynamics_integrator('rk4')
    worst = 0.0
    for index in np.linspace(0, count - 1, min(check, count)).astype(int):
        q, omega = rk4.integrate(attitudes[index], omegas[index], 0.0, STEP, total_steps,
                                 SimpleBodyModel(tensors[index]))
        worst = max(worst, float(np.max(np.abs(batch.attitude[index] - q))),
                    float(np.max(np.abs(batch.omega_body[index] - omega))))
    best = min(times)
    return {'bodies': count, 'steps_per_call': steps, 'repeats': repeats,
            'best_s': best, 'median_s': float(np.median(times)),
            'body_steps_per_s': count * steps / best,
            'median_body_steps_per_s': count * steps / float(np.median(times)),
            'checked_bodies': min(check, count), 'checked_steps': total_steps,
            'max_difference': worst}


def main(argv: list[str] | None = None) -> int:
    """Measure every N, print a Markdown table, optionally save JSON; 1 on a disagreement."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--bodies', default='1000,10000,100000')
    parser.add_argument('--steps', type=int, default=20)
    parser.add_argument('--repeats', type=int, default=5)
    parser.add_argument('--check', type=int, default=50, help='bodies checked per N')
    parser.add_argument('--json', type=Path, default=None)
    args = parser.parse_args(argv)
    rows = [run(int(count), args.steps, args.repeats, args.check)
            for count in args.bodies.split(',') if count]
    print('| N bodies | steps per call | body-steps/s (best) | body-steps/s (median) | '
          'max |Δ| vs single-body rk4 (checked bodies × steps) |')
    print('|---:|---:|---:|---:|---:|')
    for row in rows:
        print(f'| {row["bodies"]} | {row["steps_per_call"]} | {row["body_steps_per_s"]:.3g} | '
              f'{row["median_body_steps_per_s"]:.3g} | {row["max_difference"]:.1e} '
              f'({row["checked_bodies"]} × {row["checked_steps"]}) |')
    problems = [f'N={row["bodies"]}: batch differs from the single-body rk4 by '
                f'{row["max_difference"]:.3e} > {AGREEMENT:g}'
                for row in rows if not row['max_difference'] <= AGREEMENT]
    if args.json is not None:
        args.json.parent.mkdir(parents=True, exist_ok=True)
        args.json.write_text(json.dumps({'step_s': STEP, 'rows': rows, 'problems': problems,
                                         'target_body_steps_per_s': TARGET_BODY_STEPS_PER_S,
                                         'target_bodies': TARGET_BODIES}, indent=1))
    for problem in problems:
        print(f'error: {problem}', file=sys.stderr)
    return 1 if problems else 0


if __name__ == '__main__':
    sys.exit(main())
