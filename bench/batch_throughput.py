"""Batch throughput: body-steps per second of TorqueFreeBatch and SceneBatch (RK4).

**Torque-free** (``TorqueFreeBatch``):
A Monte-Carlo dispersion (per-body inertia tensors with random principal axes, random
attitudes and rates) of ``--bodies`` bodies (default 10⁵) is advanced ``--steps`` RK4 steps of
1 ms per repetition; the best of ``--repeats`` repetitions gives body-steps per second
(target ≥ 10⁷ at N = 10⁵). The same run checks ``--check`` bodies, spread over the
batch, against the single-body ``rk4`` integrator (``test/core/dynamics/test_batch.py`` does the
same on a
small dispersion): every component within 1e-12, or exit 1. ``--bodies`` takes a list, so the
scaling with N shows too.

**With effects** (``SceneBatch``): a satellite scene with gravity gradient (7000 km orbit) and
viscous damping, 1 ms RK4 steps, each body with its own attitude, rate and damping
coefficients; once with the scene's (diagonal) inertia for every body and once with a
dispersed full inertia tensor per body (its products read nine entries per body instead of
three numbers shared by every body). Target: ≥ 3·10⁶ body-steps/s at N = 10⁵.
``--check`` bodies are compared with the single-body ``DynamicsPropagator`` of the same scene
and parameters (every component within 1e-12, or exit 1).

``--chunk`` sets SceneBatch's bodies per chunk (default ``SCENE_CHUNK``), for a sweep.

Usage: ``python bench/batch_throughput.py [--bodies 1000,10000,100000] [--steps 20]
[--repeats 5] [--chunk BODIES] [--json PATH]``.
"""

from __future__ import annotations

import argparse
import json
import os
from pathlib import Path
import sys
import time
from typing import Any

import numpy as np

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO))

import dataclasses  # noqa: E402

from rigid_body_attitude.core.attitude import quaternion  # noqa: E402
from rigid_body_attitude.core.dynamics.batch import (  # noqa: E402
    SCENE_CHUNK, SceneBatch, TorqueFreeBatch)
from rigid_body_attitude.core.dynamics.inertia import Inertia  # noqa: E402
from rigid_body_attitude.core.propagator import DynamicsPropagator  # noqa: E402
from rigid_body_attitude.core.dynamics.scene import scene_from_mapping  # noqa: E402
from rigid_body_attitude.core.dynamics.integrators import dynamics_integrator  # noqa: E402
from rigid_body_attitude.core.dynamics.integrators.base import SimpleBodyModel  # noqa: E402

STEP = 1e-3
TARGET_BODY_STEPS_PER_S = 1e7
TARGET_EFFECTS_BODY_STEPS_PER_S = 3e6
TARGET_BODIES = 100_000
#: The scene of the batch with effects: gravity gradient and viscous damping.
EFFECTS_SCENE = {'name': 'gravity_gradient_damped', 'rate_source': 'dynamics',
                 'integrator': 'rk4', 'step': STEP,
                 'body': {'mass': 500.0, 'inertia': {'moments': [400.0, 200.0, 300.0]}},
                 'effects': [{'gravity_gradient': {'orbit_radius': 7.0e6}},
                             {'viscous_damping': {'coefficient': 0.5}}]}
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


def run(count: int, steps: int, repeats: int, check: int) -> dict[str, Any]:
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


def run_scene(count: int, steps: int, repeats: int, check: int,
              disperse_inertia: bool, chunk: int = SCENE_CHUNK) -> dict[str, Any]:
    """Time ``repeats`` calls of ``SceneBatch.advance_to`` over ``steps`` steps; check
    ``check`` bodies against the single-body propagator afterwards."""
    scene = scene_from_mapping(EFFECTS_SCENE)
    rng = np.random.default_rng(2)
    attitudes = quaternion.normalize(rng.normal(size=(count, 4)))
    omegas = rng.uniform(-0.01, 0.01, (count, 3))
    damping = rng.uniform(0.0, 1.0, (count, 3))
    tensors = None
    if disperse_inertia:
        axes = quaternion.to_matrix(quaternion.normalize(rng.normal(size=(count, 4))))
        moments = np.array([400.0, 200.0, 300.0]) * rng.uniform(0.9, 1.1, (count, 3))
        tensors = np.einsum('nij,nj,nkj->nik', axes, moments, axes)
    batch = SceneBatch(scene, attitudes, omegas, inertia=tensors,
                       effect_parameters={'viscous_damping': {'coefficient': damping}},
                       chunk=chunk)
    times = []
    for repeat in range(repeats):
        start = time.perf_counter()
        batch.advance_to((repeat + 1) * steps * STEP)
        times.append(time.perf_counter() - start)
    worst = 0.0
    for index in np.linspace(0, count - 1, min(check, count)).astype(int):
        single = dataclasses.replace(
            scene.with_overrides(effect_parameters={'viscous_damping': {
                'coefficient': damping[index].tolist()}}),
            initial_attitude=attitudes[index], initial_omega_body=omegas[index],
            inertia=scene.inertia if tensors is None else Inertia(tensors[index]))
        propagator = DynamicsPropagator(single)
        propagator.advance_to(repeats * steps * STEP)
        worst = max(worst, float(np.max(np.abs(batch.attitude[index]
                                               - propagator.state.attitude))),
                    float(np.max(np.abs(batch.omega_body[index]
                                        - propagator.state.omega_body))))
    best = min(times)
    return {'bodies': count, 'steps_per_call': steps, 'repeats': repeats, 'chunk': chunk,
            'inertia': 'dispersed tensors' if disperse_inertia else 'the scene\'s (diagonal)',
            'best_s': best, 'median_s': float(np.median(times)),
            'body_steps_per_s': count * steps / best,
            'median_body_steps_per_s': count * steps / float(np.median(times)),
            'checked_bodies': min(check, count), 'checked_steps': repeats * steps,
            'max_difference': worst}


def main(argv: list[str] | None = None) -> int:
    """Measure every N, print a Markdown table, optionally save JSON; 1 on a disagreement."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--bodies', default='1000,10000,100000')
    parser.add_argument('--steps', type=int, default=20)
    parser.add_argument('--repeats', type=int, default=5)
    parser.add_argument('--check', type=int, default=50, help='bodies checked per N')
    parser.add_argument('--json', type=Path, default=None)
    parser.add_argument('--chunk', type=int, default=SCENE_CHUNK,
                        help='bodies per chunk of SceneBatch')
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
    scene_rows = [run_scene(int(count), args.steps, args.repeats, min(args.check, 10), dispersed,
                            args.chunk)
                  for count in args.bodies.split(',') if count for dispersed in (False, True)]
    print()
    print('| N bodies (gravity gradient + damping) | inertia | body-steps/s (best) | '
          'body-steps/s (median) | max |Δ| vs single-body propagator |')
    print('|---:|---|---:|---:|---:|')
    for row in scene_rows:
        print(f'| {row["bodies"]} | {row["inertia"]} | {row["body_steps_per_s"]:.3g} | '
              f'{row["median_body_steps_per_s"]:.3g} | {row["max_difference"]:.1e} '
              f'({row["checked_bodies"]} × {row["checked_steps"]}) |')
    problems = [f'N={row["bodies"]}: batch differs from the single body by '
                f'{row["max_difference"]:.3e} > {AGREEMENT:g}'
                for row in rows + scene_rows if not row['max_difference'] <= AGREEMENT]
    if args.json is not None:
        args.json.parent.mkdir(parents=True, exist_ok=True)
        args.json.write_text(json.dumps({
            'step_s': STEP, 'rows': rows, 'scene_rows': scene_rows, 'problems': problems,
            'target_body_steps_per_s': TARGET_BODY_STEPS_PER_S,
            'target_effects_body_steps_per_s': TARGET_EFFECTS_BODY_STEPS_PER_S,
            'effects_scene': EFFECTS_SCENE, 'target_bodies': TARGET_BODIES,
            'load_average_1min': os.getloadavg()[0]}, indent=1))
    for problem in problems:
        print(f'error: {problem}', file=sys.stderr)
    return 1 if problems else 0


if __name__ == '__main__':
    sys.exit(main())
