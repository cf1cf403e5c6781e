"""Reports of the study: CSV, and Markdown that leads with which method to use.

Costs are CPU seconds per simulated second. The cost of a method at an accuracy level is read
off its step sweep: log-log interpolation between the two measured points that bracket the
level (:func:`cpu_at_error`), using only resolved points (error at or above the reference's
floor); a sweep that never reaches the level has no cost there.
"""

from __future__ import annotations

import csv
import math
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

from rigid_body_attitude.tools.study.cases import TARGETS
from rigid_body_attitude.tools.study.runner import Row

__all__ = ['ACCURACY_LEVELS', 'SITUATIONS', 'Choice', 'cheapest', 'cpu_at_error',
           'target_costs', 'write_csv', 'write_markdown']

#: Attitude errors [rad] at the end time for which the lead table names the cheapest method.
ACCURACY_LEVELS = (1e-3, 1e-6, 1e-9, 1e-12)

#: Rows of the lead table: (label, case, families competing). Euler/Bryant/DCM forms
#: (``angles``) are never recommended; ``scipy`` is compared separately.
SITUATIONS: tuple[tuple[str, str, tuple[str, ...]], ...] = (
    ('coning, gyro samples', 'coning', ('strapdown',)),
    ('wandering rate, gyro samples', 'generic', ('strapdown',)),
    ('wandering rate, ω(t) known', 'generic', ('kinematic',)),
    ('through gimbal lock, ω(t) known', 'gimbal', ('kinematic',)),
    ('torque-free triaxial body', 'torque_free', ('dynamics', 'stepped')),
    ('near the separatrix', 'near_separatrix', ('dynamics', 'stepped')),
    ('fast symmetric heavy top', 'heavy_top', ('dynamics',)),
    ('triaxial body, gravity gradient', 'gravity_gradient', ('dynamics',)),
    ('triaxial body, torque commanded at 10 Hz', 'commanded_torque', ('dynamics',)),
)

SIGN_CONVENTION = (
    'Coning drift: the long-run rate [rad/s] of the cone-axis component of the error rotation '
    '`log(q_computed* ⊗ q_true)`, measured between the ends of the first and the last cone '
    'period; positive means the computed attitude lags the truth about the cone axis '
    '(`rigid_body_attitude/core/attitude/integrators/strapdown.py`, where each method declares '
    'its coefficient).')


def cpu_at_error(rows: Sequence[Row], target: float) -> float:
    """CPU seconds per simulated second to reach ``target`` error along one method's sweep,
    log-log interpolated between its points (sorted by cost); ``nan`` if never reached.

    An unresolved error (below the reference's floor) counts as the floor: it reaches every
    target at or above the floor, and none below it.
    """
    points = sorted((r.cpu_per_second, max(r.error, r.floor)) for r in rows
                    if math.isfinite(r.error) and max(r.error, r.floor) > 0.0)
    for (c0, e0), (c1, e1) in zip(points, points[1:]):
        if e0 >= target >= e1 and e0 > e1:
            fraction = math.log(e0 / target) / math.log(e0 / e1)
            return math.exp(math.log(c0) + fraction * (math.log(c1) - math.log(c0)))
    reached = [c for c, e in points if e <= target]
    return min(reached) if reached else math.nan


@dataclass(frozen=True)
class Choice:
    """The cheapest method at a level: its name, its cost [CPU s per simulated s], and
    whether that cost is only a bound (the sweep's cheapest run is already more accurate)."""

    method: str
    cost: float
    bound: bool = False


def _sweeps(rows: Sequence[Row], case: str,
            families: Sequence[str]) -> dict[str, list[Row]]:
    sweeps: dict[str, list[Row]] = {}
    for row in rows:
        if row.case == case and row.family in families:
            sweeps.setdefault(row.method, []).append(row)
    return sweeps


def cheapest(rows: Sequence[Row], case: str, families: Sequence[str],
             level: float) -> Choice | None:
    """The cheapest method of ``families`` on ``case`` reaching ``level`` [rad], if any."""
    sweeps = _sweeps(rows, case, families)
    costs = sorted((cost, method) for method, sweep in sweeps.items()
                   if math.isfinite(cost := cpu_at_error(sweep, level)))
    if not costs:
        return None
    cost, method = costs[0]
    return Choice(method, cost, cost <= min(r.cpu_per_second for r in sweeps[method]))


def target_costs(rows: Sequence[Row], case: str) -> dict[str, float]:
    """CPU per simulated second of every method to reach the case's target."""
    target = TARGETS.get(case, math.nan)
    sweeps = _sweeps(rows, case, ('dynamics', 'stepped', 'scipy', 'kinematic', 'strapdown'))
    return {method: cpu_at_error(sweep, target) for method, sweep in sweeps.items()}


def write_csv(rows: Sequence[Row], path: Path) -> None:
    """One line per measurement."""
    with path.open('w', newline='') as handle:
        writer = csv.writer(handle)
        writer.writerow(['case', 'method', 'family', 'step_s', 'steps', 'error_rad', 'cpu_s',
                         'cpu_per_simulated_s', 'invariant', 'invariant_drift',
                         'reference_floor_rad', 'note'])
        for r in rows:
            writer.writerow([r.case, r.method, r.family, f'{r.step:.6g}', r.steps,
                             f'{r.error:.3e}', f'{r.cpu:.4e}', f'{r.cpu_per_second:.4e}',
                             r.invariant, f'{r.drift:.3e}', f'{r.floor:.1e}', r.note])


def _fmt(value: float) -> str:
    return '–' if not math.isfinite(value) else f'{value:.2e}'


def _ms(seconds: float) -> str:
    """A cost in ms with three significant digits."""
    return '–' if not math.isfinite(seconds) else f'{1e3 * seconds:.3g}'


def _level(value: float) -> str:
    return f'1e−{-int(round(math.log10(value)))} rad'


def lead_table(rows: Sequence[Row]) -> list[str]:
    """The 'which method should I use' table: per situation and level, the cheapest method."""
    present = {r.case for r in rows}
    lines = ['| situation (case) | ' + ' | '.join(_level(v) for v in ACCURACY_LEVELS) + ' |',
             '|---|' + '---|' * len(ACCURACY_LEVELS)]
    for label, case, families in SITUATIONS:
        if case not in present:
            continue
        cells = []
        for level in ACCURACY_LEVELS:
            choice = cheapest(rows, case, families, level)
            cells.append('–' if choice is None else
                         f'`{choice.method}` {"≤ " if choice.bound else ""}{_ms(choice.cost)}')
        lines.append(f'| {label} (`{case}`) | ' + ' | '.join(cells) + ' |')
    return lines


def target_table(rows: Sequence[Row]) -> list[str]:
    """CPU per simulated second to reach 1e−9 rad, methods × dynamics cases."""
    cases = [c for c in dict.fromkeys(r.case for r in rows) if c in TARGETS]
    if not cases:
        return []
    costs = {case: target_costs(rows, case) for case in cases}
    methods = list(dict.fromkeys(m for case in cases for m in costs[case]))
    lines = ['| method | ' + ' | '.join(cases) + ' |', '|---|' + '---|' * len(cases)]
    for method in methods:
        cells = [_ms(costs[case].get(method, math.nan)) for case in cases]
        lines.append(f'| {method} | ' + ' | '.join(cells) + ' |')
    ratios = []
    for case in cases:
        own = {m: c for m, c in costs[case].items()
               if m != 'scipy DOP853' and math.isfinite(c)}
        scipy_cost = costs[case].get('scipy DOP853', math.nan)
        if own and math.isfinite(scipy_cost):
            best = min(own, key=lambda m: own[m])
            ratios.append(f'{case}: `{best}` {own[best] / scipy_cost:.3g}×')
    lines += ['', 'Best project method / scipy DOP853 at 1e−9 rad (same run, same model): '
              + '; '.join(ratios) + '.' if ratios else '']
    return lines


def _case_table(subset: Sequence[Row]) -> list[str]:
    invariant = next((r.invariant for r in subset if r.invariant), '')
    lines = [f'| method | step [s] | steps | error [rad] | CPU [s] | CPU per simulated s | '
             f'{invariant or "invariant"} | note |', '|---|---|---|---|---|---|---|---|']
    for r in subset:
        lines.append(f'| {r.method} | {r.step:.4g} | {r.steps} | {_fmt(r.error)} | '
                     f'{r.cpu:.2e} | {r.cpu_per_second:.2e} | {_fmt(r.drift)} | {r.note} |')
    return lines


def write_markdown(rows: Sequence[Row], path: Path, elapsed: float) -> None:
    """The lead table, the comparison at 1e−9 rad, then every case's measurements."""
    lines = ['# Accuracy study: what accuracy costs in time', '',
             '## Which method should I use', '',
             'Cheapest method reaching each attitude error at the end time, and its CPU time '
             '[ms per simulated second], read off the measured sweeps below (log-log '
             'interpolation between the bracketing points; ≤ : the sweep\'s cheapest run is '
             'already more accurate; – : nothing in the sweep reaches it, or it is below the '
             'reference\'s resolution). Euler/Bryant angles and DCMs are never the answer '
             '(`generic`, `gimbal`). Each row holds for its case only: the case sets the '
             'conditions (body, torque, rates, duration; see its section).', '']
    lines += lead_table(rows)
    lines += ['', f'Generated by `accuracy_study` (rigid_body_attitude.tools.study); CPU time is '
              f'`time.process_time` on this machine, best of three repeats for runs under 0.2 s '
              f'(five under 20 ms). Whole study: {elapsed:.0f} s. Errors are attitude errors (the '
              f'rotation angle of q_ref* ⊗ q) at the end time against the closed form or a '
              f'reference at least 100× more accurate; errors below that reference floor are '
              f'marked "not resolved" and not used. Dynamics cases are scenes built from the '
              f'package\'s effects; every method integrates the propagator\'s model and scipy '
              f'evaluates the same model. Figure: `work_precision.png`; data: `results.csv`.',
              '', SIGN_CONVENTION, '']
    comparison = target_table(rows)
    if comparison:
        lines += ['## CPU per simulated second to reach 1e−9 rad [ms]', ''] + comparison + ['']
    for case in dict.fromkeys(r.case for r in rows):
        lines += [f'## {case}', ''] + _case_table([r for r in rows if r.case == case]) + ['']
    path.write_text('\n'.join(lines), encoding='utf-8')
