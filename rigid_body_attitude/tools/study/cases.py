"""The standard set of cases: name → function ``(quick) -> jobs``.

Rate-driven cases are in :mod:`.rate_cases`, dynamics cases (built from scenes and effects)
in :mod:`.dynamics_cases`. ``quick`` runs two steps per method and shorter runs (a smoke
test).
"""

from __future__ import annotations

from collections.abc import Callable

from rigid_body_attitude.tools.study.dynamics_cases import DYNAMICS_CASES, dynamics_jobs
from rigid_body_attitude.tools.study.rate_cases import coning_jobs, generic_jobs, gimbal_jobs
from rigid_body_attitude.tools.study.runner import Job

__all__ = ['CASES', 'TARGETS', 'case_jobs']


def _dynamics(name: str) -> Callable[[bool], list[Job]]:
    def jobs(quick: bool) -> list[Job]:
        return dynamics_jobs(DYNAMICS_CASES[name](quick))
    return jobs


CASES: dict[str, Callable[[bool], list[Job]]] = {
    'coning': coning_jobs,
    'generic': generic_jobs,
    'gimbal': gimbal_jobs,
    **{name: _dynamics(name) for name in DYNAMICS_CASES},
}

#: The attitude error [rad] at which a case's methods are compared (with scipy's DOP853 where
#: the case runs it); the figure draws it as a dashed line.
TARGETS: dict[str, float] = {name: 1e-9 for name in DYNAMICS_CASES}


def case_jobs(names: list[str], quick: bool) -> list[Job]:
    """The jobs of the named cases, in order."""
    return [job for name in names for job in CASES[name](quick)]
