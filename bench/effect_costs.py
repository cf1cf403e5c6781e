"""Effects priced: each effect's cost per evaluation and each integrator's cost per step with
no, one and three effects, in one run.

* **Per evaluation** [µs]: the plain-float method the integrators call (``torque``, ``rotor``,
  ``force``; ``corrected_rate`` for the gyro corrections, which take arrays) against the same
  effect through its array API (``torque_body`` etc.: a NumPy round trip per call).
  ``timeit``, best of ``--repeats``.
* **Per step** [µs]: ``DynamicsPropagator.advance_to`` over ``--steps`` steps of 1 ms (in
  calls of 20 steps, a 50 Hz tick) on a 1/2/3 kg m² body at 1 rad/s, for every integrator that
  takes torques, with no effect, with gravity gradient, and with gravity gradient, viscous
  damping and a world-fixed constant torque, and with actuators (four reaction wheels driven by
  a PD controller, torque rods dumping their momentum in the tilted-dipole field). This is the
  whole propagator step: integrator, effects, energy-balance work.
* **RK4 kernel**: the written-out RK4 step (:mod:`.integrators.rk4_kernel`) against the generic
  one (:func:`.integrators.rk4_kernel.rk4_work_step`) on the same models.

Usage: ``python bench/effect_costs.py [--steps 2000] [--repeats 5] [--json PATH]``.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path
import sys
import time
import timeit
from typing import Any, Callable

import numpy as np

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO))

from rigid_body_attitude.core.attitude import quaternion  # noqa: E402
from rigid_body_attitude.core.dynamics.effects import (  # noqa: E402
    BodyProperties, EFFECTS, Environment, ForceEffect, HeldOverStep, RateCorrection,
    RotorEffect, RotorState, TorqueEffect)
from rigid_body_attitude.core.environment.orbit import CircularOrbit  # noqa: E402
from rigid_body_attitude.core.environment.tilted_dipole import TiltedDipoleField  # noqa: E402
from rigid_body_attitude.core.dynamics.inertia import Inertia  # noqa: E402
from rigid_body_attitude.core.dynamics.integrators import torque_integrators  # noqa: E402
from rigid_body_attitude.core.dynamics.integrators.rk4_kernel import (  # noqa: E402
    rk4_kernel, rk4_work_step)
from rigid_body_attitude.core.propagator import DynamicsPropagator  # noqa: E402
from rigid_body_attitude.core.dynamics.scene import scene_from_mapping  # noqa: E402

#: Parameters of every effect for the per-evaluation table.
EFFECT_PARAMETERS: dict[str, dict[str, Any]] = {
    'commanded_torque': {}, 'commanded_force': {}, 'translation': {}, 'uniform_gravity': {},
    'constant_torque': {'torque': [0.1, 0.0, 0.2], 'frame': 'world'},
    'gravity_gradient': {'orbit_radius': 7.0e6},
    'gravity_about_pivot': {'centre_of_mass': [0.0, 0.0, 0.1]},
    'viscous_damping': {'coefficient': [0.1, 0.2, 0.3]},
    'rotor': {'momentum': [0.0, 2.0, 0.0]},
    'attitude_pd': {'kp': 0.5, 'kd': 2.0, 'control_period': 0.02},
    'gyro_bias': {'bias': [0.01, 0.0, 0.0]}, 'earth_rate': {'latitude': 48.0},
    'reaction_wheels': {'axes': [[1, 0, 0], [0, 1, 0], [0, 0, 1], [1, 1, 1]],
                        'spin_inertia': 0.01, 'max_torque': 0.05, 'max_speed': 600.0,
                        'coulomb_friction': 1e-4, 'viscous_friction': 1e-6,
                        'initial_speed': [100.0, -50.0, 80.0, 20.0]},
    'magnetorquers': {'max_dipole': 1.0}, 'residual_dipole': {'dipole': [0.05, 0.0, -0.02]},
    'bdot': {'gain': 1.0e5, 'control_period': 0.1},
}
#: The orbit and field of the effects that act through the magnetic field.
MAGNETIC_EFFECTS = ('magnetorquers', 'residual_dipole', 'bdot')
ORBIT_SECTIONS = {'orbit': {'altitude': 500000.0, 'inclination_deg': 97.4},
                  'magnetic_field': {'model': 'tilted_dipole'}}
#: Effect sets of the per-step table.
EFFECT_SETS = {
    'none': [],
    'one (gravity gradient)': [{'gravity_gradient': {'orbit_radius': 7.0e6}}],
    'three (+ damping, world torque)': [
        {'gravity_gradient': {'orbit_radius': 7.0e6}},
        {'viscous_damping': {'coefficient': 0.01}},
        {'constant_torque': {'torque': [0.0, 0.01, 0.0], 'frame': 'world'}}],
    'actuators (4 wheels, PD on them, rods dumping)': [
        {'reaction_wheels': EFFECT_PARAMETERS['reaction_wheels']},
        {'attitude_pd': {'kp': 0.5, 'kd': 2.0, 'control_period': 0.02,
                         'actuator': 'reaction_wheels'}},
        {'magnetorquers': {'max_dipole': 1.0, 'dumping_gain': 0.001}}],
}
STEP = 1e-3
TICK_STEPS = 20
Q = tuple(quaternion.normalize([0.9, 0.1, -0.3, 0.2]).tolist())
W = (0.3, -1.0, 0.2)


def best_us(function: Callable[[], object], repeats: int, number: int) -> float:
    """Best of ``repeats`` timings of ``number`` calls, µs per call."""
    return min(timeit.repeat(function, number=number, repeat=repeats)) / number * 1e6


def evaluation_calls(effect: Any) -> tuple[Callable[[], object], Callable[[], object]] | None:
    """The plain-float and the array call of ``effect``'s kind (None for stateful effects)."""
    q_array, w_array = np.array(Q), np.array(W)
    if isinstance(effect, TorqueEffect):
        return (lambda: effect.torque(1.0, Q, W),
                lambda: effect.torque_body(1.0, q_array, w_array))
    if isinstance(effect, RotorEffect):
        return lambda: effect.rotor(1.0), lambda: effect.rotor_momentum(1.0)
    if isinstance(effect, ForceEffect):
        return lambda: effect.force(1.0, Q), lambda: effect.force_world(1.0, q_array)
    if isinstance(effect, RateCorrection):
        call = (lambda: effect.corrected_rate(1.0, q_array, w_array))
        return call, call
    return None


def effect_rows(repeats: int) -> list[dict[str, Any]]:
    """Cost per evaluation of every registered effect."""
    orbit = CircularOrbit(6878137.0, 1.7)
    body = BodyProperties(Inertia([1.0, 2.0, 3.0]), 2.0)
    magnetic = BodyProperties(body.inertia, body.mass,
                              Environment(orbit, TiltedDipoleField(orbit)))
    rows = []
    for name in sorted(EFFECTS):
        effect = EFFECTS[name](EFFECT_PARAMETERS.get(name, {}),
                               magnetic if name in MAGNETIC_EFFECTS else body)
        calls = evaluation_calls(effect)
        if calls is None:
            continue
        if name in ('commanded_torque', 'commanded_force', 'magnetorquers'):
            effect.accept_input(next(iter(effect.inputs)), 0.0, np.array([0.1, 0.2, 0.3]))
        if isinstance(effect, RotorState):
            effect.start(W)
        if isinstance(effect, HeldOverStep):
            effect.hold(1.0, STEP, Q, W)
        rows.append({'effect': name, 'kind': _kind(effect),
                     'plain_float_us': best_us(calls[0], repeats, 20000),
                     'array_us': best_us(calls[1], repeats, 20000)})
    return rows


def _kind(effect: Any) -> str:
    """The effect's kind (the kind base class it derives from)."""
    for kind in (TorqueEffect, RotorEffect, ForceEffect, RateCorrection):
        if isinstance(effect, kind):
            return kind.__name__
    return ''


def step_rows(steps: int, repeats: int) -> list[dict[str, Any]]:
    """Cost per propagator step of every torque integrator with each effect set."""
    rows = []
    for integrator in torque_integrators():
        row: dict[str, Any] = {'integrator': integrator}
        for label, effects in EFFECT_SETS.items():
            scene = scene_from_mapping({
                'rate_source': 'dynamics', 'integrator': integrator, 'step': STEP,
                'body': {'inertia': {'moments': [1.0, 2.0, 3.0]}},
                'initial_state': {'attitude': list(Q), 'omega_body': list(W)},
                'effects': effects, **_sections(effects)})
            row[label] = min(_propagate(scene, steps) for _ in range(repeats))
        rows.append(row)
    return rows


def _sections(effects: list[dict[str, Any]]) -> dict[str, Any]:
    """The orbit and field sections when an effect acts through the field."""
    return ORBIT_SECTIONS if any(name in MAGNETIC_EFFECTS for effect in effects
                                 for name in effect) else {}


def _propagate(scene: Any, steps: int) -> float:
    """CPU µs per step of ``advance_to`` over ``steps`` steps in 50 Hz ticks."""
    propagator = DynamicsPropagator(scene)
    start = time.process_time()
    for tick in range(1, steps // TICK_STEPS + 1):
        propagator.advance_to(tick * TICK_STEPS * STEP)
    return (time.process_time() - start) / steps * 1e6


def kernel_rows(repeats: int) -> list[dict[str, Any]]:
    """The written-out RK4 step against the generic one, per effect set."""
    rows = []
    for label, effects in EFFECT_SETS.items():
        scene = scene_from_mapping({'rate_source': 'dynamics',
                                    'body': {'inertia': {'moments': [1.0, 2.0, 3.0]}},
                                    'effects': effects, **_sections(effects)})
        model = DynamicsPropagator(scene).model
        kernel = rk4_kernel(model)
        state = Q + W
        rows.append({'effects': label,
                     'kernel_us': best_us(lambda: kernel(0.0, state, STEP), repeats, 5000),
                     'generic_us': best_us(lambda: rk4_work_step(model, 0.0, state, STEP),
                                           repeats, 5000)})
    return rows


def render(result: dict[str, Any]) -> str:
    """Markdown tables of the three measurements."""
    lines = ['| effect | kind | plain-float call [µs] | array API [µs] |', '|---|---|---:|---:|']
    lines += [f'| {r["effect"]} | {r["kind"]} | {r["plain_float_us"]:.2f} | '
              f'{r["array_us"]:.2f} |' for r in result['effects']]
    labels = list(EFFECT_SETS)
    lines += ['', '| integrator | ' + ' | '.join(f'µs per step, effects: {label}'
                                                 for label in labels) + ' |',
              '|---|' + '---:|' * len(labels)]
    lines += [f'| {r["integrator"]} | ' + ' | '.join(f'{r[label]:.1f}' for label in labels)
              + ' |' for r in result['steps']]
    lines += ['', '| RK4 step, effects | written-out kernel [µs] | generic step [µs] |',
              '|---|---:|---:|']
    lines += [f'| {r["effects"]} | {r["kernel_us"]:.2f} | {r["generic_us"]:.2f} |'
              for r in result['kernel']]
    return '\n'.join(lines)


def main(argv: list[str] | None = None) -> int:
    """Measure, print the tables, optionally save JSON."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--steps', type=int, default=2000)
    parser.add_argument('--repeats', type=int, default=5)
    parser.add_argument('--json', type=Path)
    args = parser.parse_args(argv)
    result = {'effects': effect_rows(args.repeats),
              'steps': step_rows(args.steps, args.repeats),
              'kernel': kernel_rows(args.repeats), 'step_s': STEP,
              'repeats': args.repeats, 'step_count': args.steps,
              'effect_sets': EFFECT_SETS}
    print(render(result))
    if args.json is not None:
        args.json.parent.mkdir(parents=True, exist_ok=True)
        args.json.write_text(json.dumps(result, indent=1) + '\n')
    return 0


if __name__ == '__main__':
    sys.exit(main())
