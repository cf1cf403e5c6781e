"""``accuracy_study [--output DIR] [--cases a,b] [--quick] [--no-progress]``.

Runs the named cases (default: the standard set), then writes ``results.csv`` (one row per
run), ``README.md`` (which method to use, then the tables) and ``work_precision.png`` into
``DIR``. Returns 0, or 2 with an ``error:`` line for bad arguments.
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from collections.abc import Sequence
from pathlib import Path

from rigid_body_attitude.console import closed_pipe_safe
from rigid_body_attitude.tools.study.cases import CASES, TARGETS, case_jobs
from rigid_body_attitude.tools.study.figure import write_figure
from rigid_body_attitude.tools.study.report import target_costs, write_csv, write_markdown
from rigid_body_attitude.tools.study.runner import Row, run_jobs

__all__ = ['main', 'run_study']


def run_study(cases: Sequence[str], quick: bool = False, progress: bool = True) -> list[Row]:
    """Run the named cases; one :class:`Row` per measurement."""
    return run_jobs(case_jobs(list(cases), quick), progress)


def _parse(argv: Sequence[str] | None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(
        prog='accuracy_study', description='Accuracy / work-precision study of the '
        'integrators (error vs CPU time, invariant drift).')
    parser.add_argument('--output', default='accuracy_study_output',
                        help='folder for results.csv, README.md and work_precision.png')
    parser.add_argument('--cases', default=','.join(CASES),
                        help=f'comma-separated subset of: {", ".join(CASES)}')
    parser.add_argument('--quick', action='store_true',
                        help='two steps per method and shorter runs (a smoke test)')
    parser.add_argument('--no-progress', action='store_true', help='no progress bar')
    return parser.parse_args(argv)


def _summary(rows: Sequence[Row], case: str) -> str:
    """One line: the best project method and scipy's DOP853 at the case's target."""
    costs = target_costs(rows, case)
    own = {m: c for m, c in costs.items() if m != 'scipy DOP853' and math.isfinite(c)}
    if not own:
        return f'{case}: no method reached {TARGETS[case]:.0e} rad'
    best = min(own, key=lambda m: own[m])
    scipy_cost = costs.get('scipy DOP853', math.nan)
    ratio = f', ratio {own[best] / scipy_cost:.3g}' if math.isfinite(scipy_cost) else ''
    return (f'{case}, {TARGETS[case]:.0e} rad: best {best} {1e3 * own[best]:.3g} ms/s, '
            f'scipy DOP853 {1e3 * scipy_cost:.3g} ms/s{ratio}')


@closed_pipe_safe
def main(argv: Sequence[str] | None = None) -> int:
    """Console entry point; returns 0, or 2 with an ``error:`` line for bad arguments."""
    try:
        args = _parse(argv)
    except SystemExit as exit_request:
        return int(exit_request.code or 0)
    cases = [c.strip() for c in args.cases.split(',') if c.strip()]
    unknown = [c for c in cases if c not in CASES]
    if unknown or not cases:
        print(f'error: unknown case(s) {unknown or cases!r}; expected a comma-separated '
              f'subset of {", ".join(CASES)}', file=sys.stderr)
        return 2
    output = Path(args.output)
    try:
        output.mkdir(parents=True, exist_ok=True)
    except OSError as err:
        print(f'error: cannot create output folder {str(output)!r}: {err}', file=sys.stderr)
        return 2
    start = time.perf_counter()
    rows = run_study(cases, quick=args.quick, progress=not args.no_progress)
    elapsed = time.perf_counter() - start
    write_csv(rows, output / 'results.csv')
    write_markdown(rows, output / 'README.md', elapsed)
    write_figure(rows, output / 'work_precision.png')
    for case in cases:
        if case in TARGETS:
            print(_summary(rows, case))
    print(f'wrote {output / "results.csv"}, {output / "README.md"}, '
          f'{output / "work_precision.png"} ({len(rows)} runs, {elapsed:.0f} s)')
    return 0
