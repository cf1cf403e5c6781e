"""What a campaign will cost, estimated from its spec before anything runs, and its limits.

From the runs, the steps per run (``duration / step``, plus a short step at each command and
output time), the output times and the runs per task (``chunk``), :func:`estimate` gives:

* ``steps_per_run`` and ``body_steps`` (runs × steps): the time (the batch engine's work is
  proportional to the body-steps; ``docs/performance.md`` gives its throughput);
* ``row_bytes``: one run's result row (parameters, final state, each metric at ``t = 0`` and
  every output time); ``result_bytes``: every run's rows, which the client gathers for the
  statistics;
* ``task_bytes``: the working memory of one task: a fixed part (:data:`TASK_FIXED_BYTES`),
  the engine's state and work arrays per body (:data:`ENGINE_BYTES_PER_BODY`) and three
  copies of its rows (the metrics, the result sent back, its Parquet table).

:func:`budget_problem` names the first key whose value exceeds a limit: at most
:data:`MAX_STEPS_PER_RUN` steps per run and :data:`MAX_BODY_STEPS` body-steps in all (time);
the gathered results at most a quarter of this machine's memory (they are concatenated and
sorted once, so held up to three times) and one task's working memory at most an eighth (a
local cluster runs one task per CPU beside the client); at most :data:`MAX_CHUNKS` tasks.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass
from typing import Any, Protocol

__all__ = ['ENGINE_BYTES_PER_BODY', 'Estimate', 'MAX_BODY_STEPS', 'MAX_CHUNKS',
           'MAX_STEPS_PER_RUN', 'TASK_FIXED_BYTES', 'budget_problem', 'estimate',
           'machine_memory']


class _Step(Protocol):
    """A scene, as far as the estimate reads it."""

    @property
    def step(self) -> float:
        """The integration step [s]."""

    @property
    def effects(self) -> tuple[tuple[str, Any], ...]:
        """The scene's ``(effect name, parameters)``."""


class CampaignSpec(Protocol):
    """What the estimate reads of a :class:`~.spec.CampaignSpec` (which checks itself with
    :func:`budget_problem`, so this module does not import it)."""

    @property
    def scene(self) -> _Step:
        """The scene."""

    @property
    def runs(self) -> int:
        """The spec's ``runs``."""

    @property
    def duration(self) -> float:
        """The spec's ``duration``."""

    @property
    def output_times(self) -> tuple[float, ...]:
        """The spec's ``output_times``."""

    @property
    def chunk(self) -> int:
        """The spec's ``chunk``."""

    @property
    def inertia(self) -> Any:
        """The spec's ``inertia``."""

    @property
    def effects(self) -> Any:
        """The spec's ``effects``."""

    @property
    def commands(self) -> tuple[Any, ...]:
        """The spec's ``commands``."""

    @property
    def closed_loop(self) -> bool:
        """The spec's ``closed_loop``."""


#: Most integration steps of one run.
MAX_STEPS_PER_RUN = 10 ** 9
#: Most body-steps (runs × steps per run) of one campaign.
MAX_BODY_STEPS = 10 ** 14
#: Most tasks (chunks) of one campaign.
MAX_CHUNKS = 100_000
#: The batch engine's state, work arrays, per-body tensors and the drawn parameters of one
#: body [bytes], an upper bound (``test/tools/test_campaign.py`` measures a task's peak).
ENGINE_BYTES_PER_BODY = 2048
#: A task's memory whatever its size (the scene, its effects, the spec) [bytes], a bound.
TASK_FIXED_BYTES = 2 ** 20
#: Metrics recorded per run and output time (:data:`.statistics.METRICS`), and per-run
#: scalars of closed-loop campaigns (settling time, torque used and peak).
_METRIC_COLUMNS = 5
_CLOSED_LOOP_COLUMNS = 3
_FIXED_ROW_BYTES = 8 + 8 + 1 + 1 + 8 + 32 + 24 + 32 + 24  # run, seed, failure, states


@dataclass(frozen=True)
class Estimate:
    """A campaign's cost (see the module)."""

    steps_per_run: int
    body_steps: int
    chunks: int
    row_bytes: int
    result_bytes: int
    task_bytes: int


def machine_memory() -> int:
    """This machine's physical memory [bytes]."""
    return int(os.sysconf('SC_PAGE_SIZE') * os.sysconf('SC_PHYS_PAGES'))


def _row_bytes(spec: CampaignSpec) -> int:
    """One run's result row [bytes]."""
    outputs = 1 + len(spec.output_times)
    row = _FIXED_ROW_BYTES + 8 * _METRIC_COLUMNS * outputs
    if spec.inertia is not None:
        row += 9 * 8
    row += 24 * len(spec.commands)
    for parameters in spec.effects.values():
        row += sum(8 * max(spread.sigma.size, spread.low.size) for spread in parameters.values())
    if spec.closed_loop:
        row += 8 * _CLOSED_LOOP_COLUMNS
    names = {name for name, _ in spec.scene.effects}
    row += 8 * (2 * ('reaction_wheels' in names) + ('magnetorquers' in names))
    return row


def estimate(spec: CampaignSpec) -> Estimate:
    """The cost of ``spec`` (see the module)."""
    steps = math.ceil(spec.duration / spec.scene.step * (1.0 - 1e-12))
    steps += len(spec.commands) + len(spec.output_times)
    per_task = min(spec.chunk, spec.runs)
    row = _row_bytes(spec)
    return Estimate(steps_per_run=steps, body_steps=steps * spec.runs,
                    chunks=-(-spec.runs // spec.chunk), row_bytes=row,
                    result_bytes=row * spec.runs,
                    task_bytes=TASK_FIXED_BYTES + per_task * (ENGINE_BYTES_PER_BODY + 3 * row))


def budget_problem(spec: CampaignSpec, memory: int = 0) -> str:
    """The first spec key whose value exceeds a limit, as ``key: value gives cost; at most
    limit``, or ``''`` when the campaign fits (``memory``: bytes, default this machine's)."""
    memory = memory or machine_memory()
    cost = estimate(spec)
    step = spec.scene.step
    if cost.steps_per_run > MAX_STEPS_PER_RUN:
        return (f'duration: {spec.duration:g} s gives {cost.steps_per_run:.3g} steps of '
                f'{step:g} s per run; at most {MAX_STEPS_PER_RUN:.0e}')
    if cost.body_steps > MAX_BODY_STEPS:
        return (f'runs: {spec.runs} runs of {cost.steps_per_run:.3g} steps give '
                f'{cost.body_steps:.3g} body-steps; at most {MAX_BODY_STEPS:.0e}')
    if cost.chunks > MAX_CHUNKS:
        return (f'chunk: {spec.chunk} runs per task give {cost.chunks} tasks; at most '
                f'{MAX_CHUNKS}')
    if cost.result_bytes > memory // 4:
        return (f'runs: {spec.runs} runs of {len(spec.output_times)} output times give '
                f'{_size(cost.result_bytes)} of results; at most {_size(memory // 4)} (a '
                f'quarter of this machine\'s memory)')
    if cost.task_bytes > memory // 8:
        return (f'chunk: {min(spec.chunk, spec.runs)} runs per task need {_size(cost.task_bytes)}'
                f' per task; at most {_size(memory // 8)} (an eighth of this machine\'s '
                f'memory)')
    return ''


def _size(count: int) -> str:
    """Bytes in GiB or MiB."""
    if count >= 2 ** 30:
        return f'{count / 2 ** 30:.3g} GiB'
    return f'{count / 2 ** 20:.3g} MiB'
