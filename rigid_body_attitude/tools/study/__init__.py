"""Accuracy / work-precision study of the integrator menu: what accuracy costs in time.

``accuracy_study [--output DIR] [--cases a,b] [--quick]`` sweeps the step of every applicable
method over a standard set of cases, measures the error against a closed form or a reference
at least 100× more accurate, the CPU time per simulated second and an invariant's drift, and
writes ``results.csv``, ``README.md`` (led by a "which method should I use" table) and
``work_precision.png``.

Modules: :mod:`.runner` (measurements, timing), :mod:`.rate_cases` (coning, generic,
gimbal), :mod:`.dynamics_cases` (scenes and effects: torque_free, near_separatrix, heavy_top,
gravity_gradient, commanded_torque), :mod:`.cases` (the standard set), :mod:`.report` (CSV,
Markdown), :mod:`.figure` (the plot), :mod:`.cli` (``main``).
"""

from rigid_body_attitude.tools.study.cases import CASES, TARGETS
from rigid_body_attitude.tools.study.cli import main, run_study
from rigid_body_attitude.tools.study.report import cheapest, cpu_at_error
from rigid_body_attitude.tools.study.runner import Job, Outcome, Row

__all__ = ['CASES', 'Job', 'Outcome', 'Row', 'TARGETS', 'cheapest', 'cpu_at_error', 'main',
           'run_study']
