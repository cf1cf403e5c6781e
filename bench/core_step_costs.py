"""Core step costs: the exp-map strapdown step and the RK4 dynamics step, against the same
updates written with scipy.spatial.transform.Rotation and with ahrs, in one run.

Each contender runs the same update over the same ``--steps`` samples in a loop (timeit,
garbage collector off, ``--repeats`` repetitions; the minimum is the cost without interference
from other load, the median is reported beside it). Before timing, every contender's final
state is checked against ours (the updates are the same, so only round-off may differ).

Strapdown step, one gyro sample ``q ← q ⊗ exp(h ω)`` renormalised:

* ``quaternion.scalar_exp_step`` (plain floats) and ``ExpMap.propagate`` (the ``exp_map``
  strapdown method the propagator and the node call), fed float tuples as the node's decoder
  gives them;
* scipy: ``rotation = rotation * Rotation.from_rotvec(omega * h)`` over the rows of an array;
* ahrs: ``q = AngularRate().update(q, omega, method='closed', dt=h)`` (its closed form is the
  same exponential map, right-multiplied: body rates).

RK4 dynamics step, torque-free body (classical RK4 on ``(q, ω)`` jointly, ``q`` renormalised):

* ``RigidBodyRk4.integrate`` (the ``rk4`` integrator's plain-float loop: what the propagator
  runs per step) and the public single-step ``dynamics.rk4_step`` (arrays in and out, checks);
* no library offers this step, so the baselines are the same RK4 written the usual NumPy way
  (``np.cross``, ``J⁻¹ @``), with the attitude kept and renormalised as a scipy ``Rotation``
  (``Rotation.from_quat`` each step) or with ahrs' quaternion product
  (``ahrs.common.orientation.q_prod``) for ``q ⊗ (0, ω)``.

Usage: ``python bench/core_step_costs.py [--steps 20000] [--repeats 7] [--json PATH]``.
Prints the Markdown tables of ``docs/performance.md``; ``--json PATH`` also saves the figures.
Exit 1 if a contender disagrees with ours.
"""

from __future__ import annotations

import argparse
import gc
import json
from pathlib import Path
import platform
import statistics
import sys
import time
from typing import Any, Callable

import numpy as np

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO))

from rigid_body_attitude.core.attitude import quaternion  # noqa: E402
from rigid_body_attitude.core.dynamics.euler import RigidBodyModel, rk4_step  # noqa: E402
from rigid_body_attitude.core.dynamics.inertia import Inertia  # noqa: E402
from rigid_body_attitude.core.attitude.integrators import strapdown_method  # noqa: E402
from rigid_body_attitude.core.dynamics.integrators import dynamics_integrator  # noqa: E402
from rigid_body_attitude.core.dynamics.integrators.base import SimpleBodyModel  # noqa: E402

#: Targets [µs per step] and the required speed-up over every baseline.
TARGET_STRAPDOWN_US = 3.0
TARGET_RK4_US = 20.0
TARGET_SPEEDUP = 10.0
#: Strapdown: 1 kHz gyro; dynamics: the shipped scenes' 1 ms step on a tumbling box.
GYRO_STEP = 1e-3
DYNAMICS_STEP = 1e-3
INERTIA = np.array([[2.0, 0.1, 0.0], [0.1, 3.0, 0.05], [0.0, 0.05, 4.0]])
OMEGA0 = np.array([0.3, 1.5, 0.2])
Q0 = quaternion.normalize(np.array([0.9, 0.1, -0.3, 0.2]))


def gyro_samples(count: int) -> np.ndarray:
    """Smoothly varying body rates [rad/s] (coning-like), one row per sample."""
    t = np.arange(count) * GYRO_STEP
    return np.stack([0.5 * np.cos(7.0 * t), 0.5 * np.sin(7.0 * t), 2.0 + 0.1 * t], axis=1)


def timed(loop: Callable[[], object], steps: int, repeats: int) -> dict[str, Any]:
    """Per-step seconds (min and median over ``repeats`` runs of ``loop``) and its result."""
    result = loop()  # warm-up and the state compared across contenders
    times = []
    gc.disable()
    try:
        for _ in range(repeats):
            start = time.perf_counter()
            loop()
            times.append((time.perf_counter() - start) / steps)
    finally:
        gc.enable()
    return {'min_us': min(times) * 1e6, 'median_us': statistics.median(times) * 1e6,
            'result': result}


# -- strapdown ---------------------------------------------------------------------------------

def strapdown_contenders(samples: np.ndarray) -> dict[str, Callable[[], np.ndarray]]:
    """Loops doing ``q ← q ⊗ exp(h ω)`` over ``samples``; each returns the final (w, x, y, z)."""
    from ahrs.filters import AngularRate
    from scipy.spatial.transform import Rotation
    rates = [tuple(row) for row in samples.tolist()]
    h, q0 = GYRO_STEP, tuple(Q0.tolist())
    exp_map = strapdown_method('exp_map')

    def scalar_exp_step() -> np.ndarray:
        q, step = q0, quaternion.scalar_exp_step
        for omega in rates:
            q = step(q, omega, h)
        return np.array(q)

    def exp_map_method() -> np.ndarray:
        q, propagate = q0, exp_map.propagate
        for omega in rates:
            q = propagate(q, omega, omega, h)
        return np.array(q)

    def scipy_rotation() -> np.ndarray:
        rotation = Rotation.from_quat(quaternion.to_ros(Q0))
        from_rotvec = Rotation.from_rotvec
        for omega in samples:
            rotation = rotation * from_rotvec(omega * h)
        return quaternion.from_ros(rotation.as_quat())

    def ahrs_angular_rate() -> np.ndarray:
        q, update = Q0.copy(), AngularRate().update
        for omega in samples:
            q = update(q, omega, method='closed', dt=h)
        return np.asarray(q)

    return {'scalar_exp_step (ours)': scalar_exp_step, 'exp_map method (ours)': exp_map_method,
            'scipy Rotation loop': scipy_rotation, 'ahrs AngularRate loop': ahrs_angular_rate}


# -- RK4 dynamics ------------------------------------------------------------------------------

def _numpy_derivative(q: np.ndarray, omega: np.ndarray, tensor: np.ndarray,
                      inverse: np.ndarray,
                      product: Callable[..., Any]) -> tuple[np.ndarray, np.ndarray]:
    """``(½ q ⊗ (0, ω), J⁻¹(−ω × Jω))`` the usual NumPy way, ``product`` the quaternion one."""
    return (0.5 * product(q, np.concatenate(([0.0], omega))),
            inverse @ (-np.cross(omega, tensor @ omega)))


def _numpy_rk4(q: np.ndarray, omega: np.ndarray, h: float, tensor: np.ndarray,
               inverse: np.ndarray, product: Callable[..., Any]) -> tuple[np.ndarray, np.ndarray]:
    """One classical RK4 step of ``(q, ω)`` with arrays (not renormalised)."""
    dq1, dw1 = _numpy_derivative(q, omega, tensor, inverse, product)
    dq2, dw2 = _numpy_derivative(q + 0.5 * h * dq1, omega + 0.5 * h * dw1, tensor, inverse,
                                 product)
    dq3, dw3 = _numpy_derivative(q + 0.5 * h * dq2, omega + 0.5 * h * dw2, tensor, inverse,
                                 product)
    dq4, dw4 = _numpy_derivative(q + h * dq3, omega + h * dw3, tensor, inverse, product)
    return (q + h / 6.0 * (dq1 + 2.0 * dq2 + 2.0 * dq3 + dq4),
            omega + h / 6.0 * (dw1 + 2.0 * dw2 + 2.0 * dw3 + dw4))


def rk4_contenders(steps: int) -> dict[str, Callable[[], np.ndarray]]:
    """Loops of ``steps`` torque-free RK4 steps; each returns the final (q, ω) as 7 floats."""
    from ahrs.common.orientation import q_prod
    from scipy.spatial.transform import Rotation
    h, tensor = DYNAMICS_STEP, INERTIA
    inverse = np.linalg.inv(tensor)
    rk4 = dynamics_integrator('rk4')
    simple_model = SimpleBodyModel(tensor)
    array_model = RigidBodyModel(Inertia(tensor))

    def rk4_integrate() -> np.ndarray:
        q, omega = rk4.integrate(Q0, OMEGA0, 0.0, h, steps, simple_model)
        return np.concatenate((q, omega))

    def rk4_single_steps() -> np.ndarray:
        q, omega = Q0, OMEGA0
        for k in range(steps):
            q, omega = rk4_step(array_model, k * h, q, omega, h)
        return np.concatenate((q, omega))

    def scipy_rotation() -> np.ndarray:
        rotation, omega = Rotation.from_quat(quaternion.to_ros(Q0)), OMEGA0
        for _ in range(steps):
            q = quaternion.from_ros(rotation.as_quat())
            q, omega = _numpy_rk4(q, omega, h, tensor, inverse, quaternion.multiply)
            rotation = Rotation.from_quat(quaternion.to_ros(q))  # renormalises
        return np.concatenate((quaternion.from_ros(rotation.as_quat()), omega))

    def ahrs_product() -> np.ndarray:
        q, omega = Q0, OMEGA0
        for _ in range(steps):
            q, omega = _numpy_rk4(q, omega, h, tensor, inverse, q_prod)
            q = q / np.linalg.norm(q)
        return np.concatenate((q, omega))

    return {'rk4 integrator loop (ours)': rk4_integrate,
            'dynamics.rk4_step, arrays (ours)': rk4_single_steps,
            'NumPy RK4 + scipy Rotation loop': scipy_rotation,
            'NumPy RK4 + ahrs q_prod loop': ahrs_product}


# -- driver ------------------------------------------------------------------------------------

def measure(contenders: dict[str, Callable[[], np.ndarray]], steps: int, repeats: int,
            tolerance: float) -> tuple[list[dict[str, Any]], list[str]]:
    """Time every contender; compare its final state with the first one's (ours)."""
    rows, problems = [], []
    reference = None
    for label, loop in contenders.items():
        figures = timed(loop, steps, repeats)
        result = figures.pop('result')
        if reference is None:
            reference = result
        difference = float(np.max(np.abs(result - reference)))
        if not difference <= tolerance:
            problems.append(f'{label}: final state differs from ours by {difference:.3e} '
                            f'(> {tolerance:g})')
        rows.append({'label': label, 'difference': difference, **figures})
    return rows, problems


def machine() -> dict[str, Any]:
    """CPU model, core count and library versions."""
    import importlib.metadata
    model = platform.processor()
    with open('/proc/cpuinfo') as cpuinfo:
        for line in cpuinfo:
            if line.startswith('model name'):
                model = line.split(':', 1)[1].strip()
                break
    versions = {name: importlib.metadata.version(name) for name in ('numpy', 'scipy', 'AHRS')}
    return {'cpu_model': model, 'python': platform.python_version(), **versions}


def table(title: str, rows: list[dict[str, Any]], target_us: float) -> list[str]:
    """Markdown table of one comparison with the speed-up of ours (first row) over each."""
    ours = rows[0]['min_us']
    lines = [f'**{title}** (target ≤ {target_us:g} µs, ≥ {TARGET_SPEEDUP:g}× every baseline)',
             '', '| contender | µs/step (min) | µs/step (median) | cost ÷ first row | '
             'final state vs first row |', '|---|---:|---:|---:|---:|']
    for row in rows:
        lines.append(f'| {row["label"]} | {row["min_us"]:.2f} | {row["median_us"]:.2f} | '
                     f'{row["min_us"] / ours:.1f}× | {row["difference"]:.1e} |')
    return lines


def main(argv: list[str] | None = None) -> int:
    """Measure both comparisons, print them, optionally save JSON; 1 on a disagreement."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--steps', type=int, default=20000)
    parser.add_argument('--repeats', type=int, default=7)
    parser.add_argument('--json', type=Path, default=None)
    args = parser.parse_args(argv)
    samples = gyro_samples(args.steps)
    # Exact same update, different operation order: ~steps × a few ε of round-off.
    tolerance = 10 * args.steps * np.finfo(float).eps
    strapdown, problems = measure(strapdown_contenders(samples), args.steps, args.repeats,
                                  tolerance)
    steps_rk4 = max(1, args.steps // 4)
    dynamics, more = measure(rk4_contenders(steps_rk4), steps_rk4, args.repeats,
                             10 * steps_rk4 * np.finfo(float).eps * 4)
    problems += more
    result = {'machine': machine(), 'steps': args.steps, 'rk4_steps': steps_rk4,
              'repeats': args.repeats, 'strapdown': strapdown, 'rk4': dynamics,
              'target_strapdown_us': TARGET_STRAPDOWN_US, 'target_rk4_us': TARGET_RK4_US,
              'target_speedup': TARGET_SPEEDUP, 'problems': problems}
    print('\n'.join(table(f'Exp-map strapdown step ({args.steps} samples)', strapdown,
                          TARGET_STRAPDOWN_US)))
    print()
    print('\n'.join(table(f'RK4 dynamics step, torque-free ({steps_rk4} steps)', dynamics,
                          TARGET_RK4_US)))
    if args.json is not None:
        args.json.parent.mkdir(parents=True, exist_ok=True)
        args.json.write_text(json.dumps(result, indent=1))
    for problem in problems:
        print(f'error: {problem}', file=sys.stderr)
    return 1 if problems else 0


if __name__ == '__main__':
    sys.exit(main())
