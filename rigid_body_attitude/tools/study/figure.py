"""The work-precision figure: one panel per case, error against CPU per simulated second.

Every method of a panel has its own colour and its own marker (no repeats within a panel);
legends sit outside the axes, to the right; errors below the reference's floor (not
resolved) are drawn hollow, at the floor, and not joined to the resolved points; a dashed
line marks the case's target error where it has one
(:data:`~rigid_body_attitude.tools.study.cases.TARGETS`). Invariant-drift panels follow for
the cases that measure a conserved quantity (every run drawn: the drift needs no reference).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from rigid_body_attitude.tools.study.cases import TARGETS
from rigid_body_attitude.tools.study.runner import Row

__all__ = ['MARKERS', 'method_styles', 'write_figure']

#: Distinct markers, enough for the largest panel (``generic``: 22 methods).
MARKERS = ('o', 's', '^', 'v', 'D', 'P', 'X', '<', '>', 'p', 'h', '*', 'd', 'H', '8',
           '1', '2', '3', '4', '+', 'x', '|', '_', '.')
#: Drift panels: cases whose invariant is conserved by the exact motion.
DRIFT_CASES = ('coning', 'torque_free', 'heavy_top')


def _colours(count: int) -> list[tuple[float, float, float, float]]:
    """``count`` distinct colours: tab10, then tab20's light shades, then Dark2."""
    from matplotlib import colormaps
    palette = [colormaps['tab10'](i) for i in range(10)]
    palette += [colormaps['tab20'](i) for i in range(1, 20, 2)]
    palette += [colormaps['Dark2'](i) for i in range(8)]
    if count > len(palette):
        raise ValueError(f'Expected at most {len(palette)} methods in a panel, got {count}')
    return palette[:count]


def method_styles(methods: Sequence[str]
                  ) -> dict[str, tuple[tuple[float, float, float, float], str]]:
    """A distinct (colour, marker) per method, in order."""
    if len(methods) > len(MARKERS):
        raise ValueError(f'Expected at most {len(MARKERS)} methods in a panel, got '
                         f'{len(methods)}')
    return dict(zip(methods, zip(_colours(len(methods)), MARKERS)))


def _points(rows: Sequence[Row], method: str,
            drift: bool) -> tuple[list[tuple[float, float]], list[tuple[float, float]]]:
    """(CPU per simulated s, value) of a method's runs, by cost: resolved ones, and those
    below the reference's floor placed at the floor (drift panels: every run)."""
    resolved, unresolved = [], []
    for r in rows:
        if r.method != method:
            continue
        value = abs(r.drift) if drift else r.error
        if not (math.isfinite(value) and (value > 0.0 or not drift)):
            continue
        if drift or r.resolved:
            resolved.append((r.cpu_per_second, value))
        else:
            unresolved.append((r.cpu_per_second, r.floor))
    return sorted(resolved), sorted(unresolved)


def _panel(axis: Any, rows: Sequence[Row], case: str, drift: bool) -> None:
    from matplotlib.ticker import NullFormatter
    subset = [r for r in rows if r.case == case]
    methods = list(dict.fromkeys(r.method for r in subset))
    styles = method_styles(methods)
    for method in methods:
        resolved, unresolved = _points(subset, method, drift)
        colour, marker = styles[method]
        if resolved:
            axis.plot(*zip(*resolved), color=colour, marker=marker, markersize=5,
                      linewidth=1.0, label=method)
        if unresolved:
            axis.plot(*zip(*unresolved), linestyle='none', marker=marker, markersize=6,
                      markerfacecolor='none', markeredgecolor=colour,
                      label=None if resolved else f'{method} (below floor)')
    invariant = subset[0].invariant
    if not drift and case in TARGETS:
        axis.axhline(TARGETS[case], color='0.3', linestyle='--', linewidth=1.0,
                     label=f'target {TARGETS[case]:.0e} rad')
    axis.set_xscale('log')
    axis.set_yscale('log')
    axis.xaxis.set_minor_formatter(NullFormatter())  # decade labels only: no overlaps
    axis.set_title(f'{case}: |{invariant}|' if drift else case)
    axis.set_xlabel('CPU time per simulated second [s]')
    axis.set_ylabel(f'|{invariant}|' if drift else 'attitude error at the end [rad]')
    axis.grid(True, which='both', alpha=0.3)
    axis.legend(fontsize=7, loc='upper left', bbox_to_anchor=(1.02, 1.0), borderaxespad=0.0,
                frameon=False)


def write_figure(rows: Sequence[Row], path: Path) -> None:
    """Work-precision panels per case, then drift panels; two panels per line."""
    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt
    cases = list(dict.fromkeys(r.case for r in rows))
    panels = [(case, False) for case in cases] + [
        (case, True) for case in DRIFT_CASES if case in cases]
    columns = min(2, len(panels))
    lines = (len(panels) + columns - 1) // columns
    figure, axes = plt.subplots(lines, columns, figsize=(9.0 * columns, 4.6 * lines),
                                squeeze=False)
    flat = list(axes.ravel())
    for axis, (case, drift) in zip(flat, panels):
        _panel(axis, rows, case, drift)
    for axis in flat[len(panels):]:
        axis.set_visible(False)
    figure.suptitle('Work-precision per case, then invariant drift. Hollow markers: errors '
                    'below the reference floor (not resolved), drawn at the floor', fontsize=12)
    figure.tight_layout(rect=(0.0, 0.0, 1.0, 0.985))
    figure.savefig(path, dpi=72)
    plt.close(figure)
