"""Dynamics scenes: CPU per simulated second and accuracy over 10 s, plain RK4 against shipped.

Each shipped dynamics scene is run the way the node runs it: ``DynamicsPropagator.advance_to``
at 50 Hz ticks, with commanded inputs (torque, force, rotor torque: smooth sinusoids sampled at
10 Hz, each held until the next) fed through ``DynamicsPropagator.command`` as the node does.

* **CPU** [ms per simulated second]: ``time.process_time`` over ``--cpu-seconds`` of simulated
  time (best of ``--repeats``), for the scene as shipped and for plain RK4 at a fine step
  (``RK4_SETTINGS``: 1 ms, 0.5 ms for the heavy top, 0.1 s for the satellite). The real-time
  factor is 1000 ms over the shipped scene's figure.
* **Accuracy** over ``--accuracy-seconds`` (10 s): the largest attitude error [rad] at the
  ticks against a reference run of the same scene and inputs (RK4 at 1/16 of that step: its
  error is 16⁴ ≈ 65 000 times below plain RK4's), the energy-balance residual
  ``|T − T₀ − W|`` relative to ``max(T₀, T)`` and, for torque-free scenes, the drift of the
  world angular momentum ``|H − H₀|/|H₀|`` at the end.

Both settings run through the same code in the same process, so the accuracy columns compare
methods, not implementations. Exit code 1 if a shipped scene costs more than
``TARGET_MS_PER_SIMULATED_S`` or is less accurate than plain RK4.

Usage: ``python bench/dynamics_scenes.py [--json PATH] [--cpu-only]``: the table to stdout.
"""

from __future__ import annotations

import argparse
import json
import math
from pathlib import Path
import sys
import time
from typing import Any

import numpy as np

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO))

from rigid_body_attitude.core.propagator import DynamicsPropagator  # noqa: E402
from rigid_body_attitude.core.dynamics.scene import Scene, load_scene  # noqa: E402

SCENES = ('torque_free_box', 'dzhanibekov', 'gravity_gradient_satellite', 'commanded_torque',
          'gyrostat', 'free_flyer', 'heavy_top')
#: Plain RK4 at a fine step: what every shipped scene is compared with.
RK4_SETTINGS = {name: ('rk4', 0.001) for name in SCENES}
RK4_SETTINGS['gravity_gradient_satellite'] = ('rk4', 0.1)
RK4_SETTINGS['heavy_top'] = ('rk4', 0.0005)
TICK = 0.02
COMMAND_PERIOD = 0.1
#: Amplitude of the commanded inputs per input name (torque [N m], force [N], rotor torque).
AMPLITUDE = {'torque': 0.01, 'force': 0.5, 'rotor_torque': 0.01}
TARGET_MS_PER_SIMULATED_S = 10.0
REFERENCE_REFINEMENT = 16
ACCURACY_KEYS = ('attitude_error_rad', 'energy_balance_residual', 'momentum_drift',
                 'position_error_m')


def command_value(input_name: str, t: float) -> list[float]:
    """The commanded input at ``t``: smooth sinusoids of different periods per axis."""
    amplitude = AMPLITUDE[input_name]
    return [amplitude * math.sin(0.9 * t + 0.3), amplitude * math.cos(1.3 * t),
            amplitude * math.sin(0.7 * t + 1.1)]


def run(scene: Scene, seconds: float
        ) -> tuple[DynamicsPropagator, list[tuple[np.ndarray, np.ndarray]], float]:
    """Tick the scene's propagator at 50 Hz for ``seconds``; attitudes and positions at the
    ticks, CPU seconds."""
    propagator = DynamicsPropagator(scene)
    inputs = sorted(propagator.input_names)
    ticks = int(round(seconds / TICK))
    per_command = int(round(COMMAND_PERIOD / TICK))
    attitudes = []
    start = time.process_time()
    for index in range(1, ticks + 1):
        now = index * TICK
        if inputs and (index - 1) % per_command == 0:
            for name in inputs:
                propagator.command(name, now - TICK, command_value(name, now - TICK))
        propagator.advance_to(now)
        attitudes.append((propagator.state.attitude.copy(), propagator.state.position.copy()))
    return propagator, attitudes, time.process_time() - start


def cpu_ms_per_second(scene: Scene, seconds: float, repeats: int) -> float:
    """Best of ``repeats`` runs: CPU [ms] per simulated second."""
    return min(run(scene, seconds)[2] for _ in range(repeats)) * 1e3 / seconds


def attitude_error(a: np.ndarray, b: np.ndarray) -> float:
    """Rotation angle [rad] between two unit quaternions."""
    return 2.0 * math.asin(min(1.0, float(np.linalg.norm(
        [a[0] * b[1] - a[1] * b[0] - a[2] * b[3] + a[3] * b[2],
         a[0] * b[2] + a[1] * b[3] - a[2] * b[0] - a[3] * b[1],
         a[0] * b[3] - a[1] * b[2] + a[2] * b[1] - a[3] * b[0]]))))


def accuracy(scene: Scene, reference: list[tuple[np.ndarray, np.ndarray]],
             seconds: float) -> dict[str, float]:
    """Attitude (and position) error against ``reference`` and the invariants' drift after
    ``seconds``."""
    propagator, states, _ = run(scene, seconds)
    diagnostics = propagator.diagnostics()
    scale = max(abs(propagator.tracker.initial_energy), abs(diagnostics.kinetic_energy))
    result = {'attitude_error_rad': max(attitude_error(a[0], r[0])
                                        for a, r in zip(states, reference)),
              'energy_balance_residual': abs(diagnostics.energy_balance_residual) / scale}
    if propagator.has_translation:
        result['position_error_m'] = max(float(np.linalg.norm(a[1] - r[1]))
                                         for a, r in zip(states, reference))
    if propagator.model.torque_free:
        result['momentum_drift'] = diagnostics.momentum_drift
    return result


def measure(name: str, args: argparse.Namespace) -> dict[str, Any]:
    """One scene's row: CPU and accuracy, plain RK4 and as shipped."""
    shipped = load_scene(name)
    if name in args.try_settings:
        shipped = shipped.with_overrides(*args.try_settings[name])
    old = shipped.with_overrides(*RK4_SETTINGS[name])
    row: dict[str, Any] = {'scene': name,
                           'old': {'integrator': old.integrator, 'step': old.step},
                           'new': {'integrator': shipped.integrator, 'step': shipped.step}}
    row['new']['cpu_ms_per_s'] = cpu_ms_per_second(shipped, args.cpu_seconds, args.repeats)
    if args.cpu_only:
        return row
    row['old']['cpu_ms_per_s'] = cpu_ms_per_second(old, args.cpu_seconds, args.repeats)
    reference_scene = shipped.with_overrides('rk4', old.step / REFERENCE_REFINEMENT)
    reference = run(reference_scene, args.accuracy_seconds)[1]
    for key, scene in (('old', old), ('new', shipped)):
        row[key].update(accuracy(scene, reference, args.accuracy_seconds))
    return row


def table(rows: list[dict[str, Any]]) -> str:
    """Markdown table of the rows."""
    lines = ['| scene | RK4: method, step | CPU RK4 [ms/s] | '
             'shipped: method, step | CPU shipped [ms/s] | real-time factor | attitude error '
             'RK4 / shipped [rad] | energy residual RK4 / shipped | momentum drift RK4 / '
             'shipped |', '|---|---|---:|---|---:|---:|---:|---:|---:|']
    for row in rows:
        old, new = row['old'], row['new']
        momentum = (f'{old["momentum_drift"]:.1e} / {new["momentum_drift"]:.1e}'
                    if 'momentum_drift' in new else '—')
        lines.append(
            f'| {row["scene"]} | {old["integrator"]}, {old["step"] * 1e3:g} ms | '
            f'{old.get("cpu_ms_per_s", math.nan):.1f}'
            f' | {new["integrator"]}, {new["step"] * 1e3:g} ms | {new["cpu_ms_per_s"]:.2f} | '
            f'{1e3 / new["cpu_ms_per_s"]:.0f}× | '
            f'{old.get("attitude_error_rad", math.nan):.1e} / '
            f'{new.get("attitude_error_rad", math.nan):.1e} | '
            f'{old.get("energy_balance_residual", math.nan):.1e} / '
            f'{new.get("energy_balance_residual", math.nan):.1e} | {momentum} |')
    return '\n'.join(lines)


def main(argv: list[str] | None = None) -> int:
    """Measure every scene; print the table; 1 if a target or an accuracy bound is missed."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--scenes', default=','.join(SCENES))
    parser.add_argument('--cpu-seconds', type=float, default=2.0)
    parser.add_argument('--accuracy-seconds', type=float, default=10.0)
    parser.add_argument('--repeats', type=int, default=3)
    parser.add_argument('--cpu-only', action='store_true')
    parser.add_argument('--json', type=Path)
    parser.add_argument('--try', dest='try_settings', default='',
                        help='settings to try instead of the shipped ones: '
                             'scene=integrator:step,... (for choosing them)')
    args = parser.parse_args(argv)
    args.try_settings = {
        item.split('=')[0]: (item.split('=')[1].split(':')[0],
                             float(item.split('=')[1].split(':')[1]))
        for item in args.try_settings.split(',') if item}
    rows = [measure(name, args) for name in args.scenes.split(',')]
    print(table(rows))
    failures = [row['scene'] for row in rows
                if row['new']['cpu_ms_per_s'] > TARGET_MS_PER_SIMULATED_S
                or (not args.cpu_only and any(
                    row['new'][key] > row['old'][key] * 1.0001 + 1e-15
                    for key in ACCURACY_KEYS if key in row['new']))]
    if args.json is not None:
        args.json.parent.mkdir(parents=True, exist_ok=True)
        args.json.write_text(json.dumps({'rows': rows,
                                         'tick_s': TICK, 'command_period_s': COMMAND_PERIOD,
                                         'target_ms_per_s': TARGET_MS_PER_SIMULATED_S,
                                         'failures': failures}, indent=1) + '\n')
    if failures:
        print(f'missed: {", ".join(failures)}')
    return 1 if failures else 0


if __name__ == '__main__':
    sys.exit(main())
