"""One campaign task: a set of runs on the batch engine (:class:`.SceneBatch`).

:func:`run_chunk` draws the runs' parameters (:func:`.sample_runs`), builds one
:class:`~rigid_body_attitude.core.dynamics.batch.SceneBatch`, applies the commands at their
times and advances to every output time, recording each run's metrics (:mod:`.statistics`). In a
closed loop (a scene with ``attitude_pd``) the pointing error is also checked at every
controller sample instant, for each run's settling time, and the controller's torque used is
read at the end. A run fails
without stopping the others when its dispersed effect parameters are outside the effect's
range, its rate exceeds RK4's limit of 2 rad per step (checked at every output and command
time) or its state stops being finite: it is taken out of the batch
(:meth:`.SceneBatch.discard`) and recorded with the reason and the time; its later metrics
and final state are NaN. The result is plain NumPy arrays (what a Dask worker sends back).
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from rigid_body_attitude.core.dynamics.batch import SceneBatch
from rigid_body_attitude.core.dynamics.effects import (
    BodyProperties, EFFECTS, RotorState, SampledTorque)
from rigid_body_attitude.tools.campaign.sampling import RunParameters, sample_runs
from rigid_body_attitude.tools.campaign.spec import (
    CampaignSpec, COMMAND_EFFECT, CONTROLLER_EFFECT)
from rigid_body_attitude.tools.campaign.statistics import (
    BodyState, METRICS, metrics, pointing_error_deg)

__all__ = ['FAILURE_REASONS', 'run_chunk']

FloatArray = NDArray[np.float64]

FAILURE_REASONS = ('effect parameter out of range', 'rate beyond the RK4 step limit',
                   'non-finite state')


class _Failures:
    """Which runs failed, why (index into :data:`FAILURE_REASONS`) and when [s]."""

    def __init__(self, n: int) -> None:
        self.failed = np.zeros(n, dtype=bool)
        self.reason = np.full(n, -1, dtype=np.int8)
        self.time = np.full(n, np.nan)

    def mark(self, mask: NDArray[np.bool_], reason: int, time: float) -> NDArray[np.bool_]:
        """Record the runs of ``mask`` not yet failed; returns them."""
        new: NDArray[np.bool_] = mask & ~self.failed
        self.failed |= new
        self.reason[new] = reason
        self.time[new] = time
        return new


def _check_effect_parameters(spec: CampaignSpec, parameters: RunParameters,
                             failures: _Failures) -> None:
    """Fail runs whose dispersed effect parameters the effect would refuse; give them the
    nominal value so the batch can be built."""
    nominal = dict(spec.scene.effects)
    for name, dispersed in parameters.effects.items():
        specs = EFFECTS[name].parameters
        for parameter, values in dispersed.items():
            convert = specs[parameter].convert
            bad = np.zeros(values.shape[0], dtype=bool)
            if not _accepts(convert, values.min(axis=0)) or \
                    not _accepts(convert, values.max(axis=0)):
                bad = np.array([not _accepts(convert, row) for row in values])
            if np.any(bad):
                failures.mark(bad, 0, 0.0)
                body = BodyProperties(spec.scene.inertia, spec.scene.mass)
                values[bad] = EFFECTS[name](nominal[name], body).params[parameter]


def _accepts(convert: Any, row: FloatArray) -> bool:
    """Whether the effect's converter takes one run's value (a number or nested lists)."""
    try:
        convert(row.tolist() if row.ndim else float(row))
    except (TypeError, ValueError):
        return False
    return True


def _check_dynamics(batch: SceneBatch, failures: _Failures, time: float) -> None:
    """Fail and discard runs whose state is not finite or turns too fast for RK4."""
    attitude, omega = batch.attitude, batch.omega_body
    with np.errstate(all='ignore'):
        finite = np.all(np.isfinite(attitude), axis=1) & np.all(np.isfinite(omega), axis=1)
        fast = finite & (np.linalg.norm(np.where(np.isfinite(omega), omega, 0.0), axis=1)
                         * batch.scene.step > 2.0)
    newly = failures.mark(~finite, 2, time) | failures.mark(fast, 1, time)
    if np.any(newly):
        batch.discard(failures.failed)


def _events(spec: CampaignSpec) -> list[tuple[float, int, int]]:
    """``(time, command index or −1, output index or −1)`` in time order."""
    events = [(time, index, -1) for index, (time, _) in enumerate(spec.commands)]
    events += [(time, -1, index) for index, time in enumerate(spec.output_times)]
    return sorted(events, key=lambda event: (event[0], -event[1]))


def run_chunk(spec: CampaignSpec, runs: ArrayLike) -> dict[str, NDArray[Any]]:
    """Run the campaign's ``runs`` (indices) together; each result array has one row per
    run: ``run``, ``seed``, ``failed``, ``reason`` (−1 or an index of
    :data:`FAILURE_REASONS`), ``failed_at`` [s], the parameters (``attitude0``,
    ``omega_body0``, ``inertia`` (n, 9), ``effect.<name>.<parameter>``, ``commands``
    (n, 3k)), the final ``attitude`` and ``omega_body``, and each metric of
    :data:`~.statistics.METRICS` at ``t = 0`` and each output time (n, 1 + T)."""
    indices = np.asarray(runs, dtype=np.int64)
    count = indices.shape[0]
    # One body takes other arithmetic paths in the batch (no per-body einsum): pad to two.
    padded = np.concatenate([indices, indices[:1]]) if count == 1 else indices
    parameters = sample_runs(spec, padded)
    failures = _Failures(padded.shape[0])
    with np.errstate(all='ignore'):
        _check_effect_parameters(spec, parameters, failures)
        values = _simulate(spec, parameters, failures)
    result: dict[str, NDArray[Any]] = {
        'run': parameters.runs, 'seed': parameters.seeds, 'failed': failures.failed,
        'reason': failures.reason, 'failed_at': failures.time,
        'attitude0': parameters.attitude, 'omega_body0': parameters.omega_body}
    if parameters.inertia is not None:
        result['inertia'] = parameters.inertia.reshape(-1, 9)
    for name, dispersed in parameters.effects.items():
        for parameter, array in dispersed.items():
            result[f'effect.{name}.{parameter}'] = (array if array.ndim < 3 else
                                                    array.reshape(array.shape[0], -1))
    if spec.commands:
        result['commands'] = parameters.commands.transpose(1, 0, 2).reshape(padded.shape[0], -1)
    result.update(values)
    return {key: value[:count] for key, value in result.items()}


def _simulate(spec: CampaignSpec, parameters: RunParameters,
              failures: _Failures) -> dict[str, FloatArray]:
    """Advance the runs through the commands and output times; metrics and final states."""
    n = parameters.runs.shape[0]
    batch = SceneBatch(spec.scene, parameters.attitude, parameters.omega_body,
                       inertia=parameters.inertia, effect_parameters=parameters.effects)
    inertia = spec.scene.inertia.tensor if parameters.inertia is None else parameters.inertia
    initial = _body_state(batch, inertia)
    series = {name: np.full((n, 1 + len(spec.output_times)), np.nan) for name in METRICS}
    _record(series, 0, initial, initial, spec, failures)
    _check_dynamics(batch, failures, 0.0)
    settling = _Settling(spec, n) if spec.closed_loop else None
    if settling is not None:
        settling.check(batch, 0.0)
    for time, command, output in _events(spec):
        if settling is not None:
            settling.advance(batch, time)
        batch.advance_to(time)
        _check_dynamics(batch, failures, time)
        if command >= 0:
            batch.set_effect_parameters({COMMAND_EFFECT: {
                'torque': parameters.commands[command]}})
        if output >= 0:
            state = _body_state(batch, inertia)
            _record(series, output + 1, state, initial, spec, failures)
    closed = {} if settling is None else settling.columns(batch, spec, failures)
    return {**series, **closed, **_actuator_columns(batch, failures),
            'attitude': np.where(failures.failed[:, None], np.nan, batch.attitude),
            'omega_body': np.where(failures.failed[:, None], np.nan, batch.omega_body)}


class _Settling:
    """Closed loop: the pointing error checked at every controller sample instant; the last
    time it was above ``statistics.settling_deg`` (no list of checks is kept)."""

    def __init__(self, spec: CampaignSpec, n: int) -> None:
        self.period = next(effect.period for effect in spec.scene.build_effects()
                           if isinstance(effect, SampledTorque))
        self.spec = spec
        self.checks = 0
        self.last_above = np.full(n, -np.inf)

    def check(self, batch: SceneBatch, time: float) -> None:
        """Record the runs above the threshold at ``time`` (the batch is there)."""
        error = pointing_error_deg(batch.attitude, self.spec.boresight, self.spec.target)
        self.last_above[~(error <= self.spec.settling_deg)] = time

    def advance(self, batch: SceneBatch, until: float) -> None:
        """Advance through the sample instants before ``until``, checking at each."""
        while True:
            time = (self.checks + 1) * self.period
            if time >= until * (1.0 - 1e-12):
                return
            batch.advance_to(time)
            self.checks += 1
            self.check(batch, time)

    def columns(self, batch: SceneBatch, spec: CampaignSpec,
                failures: _Failures) -> dict[str, FloatArray]:
        """Per run (NaN for failed runs): ``settling_time_s``, the first check after the
        last one above the threshold (0: never above; inf: above at the end),
        ``torque_integral`` ``∫|τ| dt`` [N m s] and ``torque_peak`` [N m]."""
        self.check(batch, spec.duration)
        above = self.last_above
        settling = np.where(above >= spec.duration, np.inf,
                            np.where(above < 0.0, 0.0,
                                     np.minimum(above + self.period, spec.duration)))
        integral, peak = batch.torque_used(CONTROLLER_EFFECT)
        return {name: np.where(failures.failed, np.nan, value) for name, value in
                (('settling_time_s', settling), ('torque_integral', integral),
                 ('torque_peak', peak))}


def _record(series: dict[str, FloatArray], column: int, state: BodyState, initial: BodyState,
            spec: CampaignSpec, failures: _Failures) -> None:
    for name, value in metrics(state, initial, spec.boresight, spec.target,
                               spec.nutation_min_rate).items():
        series[name][:, column] = np.where(failures.failed, np.nan, value)


def _body_state(batch: SceneBatch, inertia: FloatArray) -> BodyState:
    """The runs' state; with wheels, their momentum and energy included."""
    if not any(isinstance(effect, RotorState) for effect in batch.effects):
        return BodyState(batch.attitude, batch.omega_body, inertia)
    return BodyState(batch.attitude, batch.omega_body, inertia, batch.momentum_body(),
                     batch.kinetic_energy())


def _actuator_columns(batch: SceneBatch, failures: _Failures) -> dict[str, FloatArray]:
    """Per run (NaN for failed runs): peak wheel speed [rad/s] and time saturated [s] of
    the scene's wheel array, momentum dumped [N m s] by its magnetorquers
    (:data:`.statistics.ACTUATORS`); only those the scene has."""
    columns: dict[str, FloatArray] = {}
    names = {effect.name for effect in batch.effects}
    if 'reaction_wheels' in names:
        totals = batch.effect_totals('reaction_wheels')
        columns['wheel_speed_peak'] = totals['peak_speed']
        columns['wheel_time_saturated_s'] = totals['time_saturated']
    if 'magnetorquers' in names:
        columns['momentum_dumped'] = batch.effect_totals('magnetorquers')['torque_impulse']
    return {name: np.where(failures.failed, np.nan, value) for name, value in columns.items()}
