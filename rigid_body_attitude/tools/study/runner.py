"""Measurements and the job runner: what one run of a method on a case records.

A :class:`Job` is a closure that runs one method once at one step (or tolerance) and returns a
:class:`Outcome`; :func:`run_jobs` times it (:func:`timed`) and turns it into a :class:`Row`.
CPU time is ``time.process_time``, the best of three repeats for runs under 0.2 s (five under
20 ms), to shed the load of other processes on a shared machine.
"""

from __future__ import annotations

import math
import sys
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import TypeVar

__all__ = ['Job', 'Outcome', 'Row', 'run_jobs', 'timed']

T = TypeVar('T')


@dataclass(frozen=True)
class Outcome:
    """What a run reports: its error [rad], the invariant's drift, its step count (``None``:
    ``duration/step``) and a note (e.g. a refused step)."""

    error: float
    drift: float = math.nan
    steps: int | None = None
    note: str = ''


@dataclass
class Row:
    """One measurement: a method at one step (or tolerance) on one case.

    Attributes:
        case: case name.
        method: method name (with its input in brackets where a case offers several).
        family: ``strapdown``, ``kinematic``, ``angles``, ``dynamics``, ``stepped`` or
            ``scipy``.
        step: step [s] (``nan`` for adaptive runs).
        steps: steps taken.
        error: attitude error at the end time [rad].
        cpu: CPU time of the run [s].
        duration: simulated time [s].
        invariant: what :attr:`drift` measures.
        drift: the invariant's drift (``nan`` if none).
        note: remarks (tolerance, refused step, unresolved error).
        floor: the reference's resolution [rad]: errors below it are not resolved.
    """

    case: str
    method: str
    family: str
    step: float
    steps: int
    error: float
    cpu: float
    duration: float
    invariant: str = ''
    drift: float = math.nan
    note: str = ''
    floor: float = 0.0

    @property
    def cpu_per_second(self) -> float:
        """CPU seconds per simulated second."""
        return self.cpu / self.duration

    @property
    def resolved(self) -> bool:
        """Whether the error is finite and at or above the reference's floor."""
        return math.isfinite(self.error) and self.error >= self.floor


@dataclass
class Job:
    """A measurement to run: ``run()`` is timed and returns the :class:`Outcome`."""

    case: str
    method: str
    family: str
    step: float
    duration: float
    run: Callable[[], Outcome]
    invariant: str = ''
    floor: float = 0.0


def timed(function: Callable[[], T]) -> tuple[float, T]:
    """CPU seconds of ``function()`` (best of three below 0.2 s, of five below 20 ms) and its
    last result."""
    best = math.inf
    start = time.process_time()
    result = function()
    best = time.process_time() - start
    for attempt in range(1, 5):
        if best > 0.2 or (best > 0.02 and attempt >= 3):
            break
        start = time.process_time()
        result = function()
        best = min(best, time.process_time() - start)
    return best, result


def _row(job: Job, cpu: float, outcome: Outcome) -> Row:
    steps = outcome.steps if outcome.steps is not None else int(round(job.duration / job.step))
    note = outcome.note
    if math.isfinite(outcome.error) and outcome.error < job.floor:
        note = (note + '; ' if note else '') + (
            f'below the reference floor {job.floor:.0e}: not resolved')
    return Row(job.case, job.method, job.family, job.step, steps, float(outcome.error), cpu,
               job.duration, job.invariant, float(outcome.drift), note, job.floor)


def run_jobs(jobs: Sequence[Job], progress: bool = True) -> list[Row]:
    """Run and time every job, in order; a tqdm bar on stderr when ``progress``."""
    bar = None
    if progress:
        from tqdm import tqdm
        bar = tqdm(total=len(jobs), desc='accuracy study', unit='run', file=sys.stderr)
    rows = []
    for job in jobs:
        cpu, outcome = timed(job.run)
        rows.append(_row(job, cpu, outcome))
        if bar is not None:
            bar.update(1)
    if bar is not None:
        bar.close()
    return rows
