"""The ``/diagnostics`` report of a session: level, message and key/value strings.

Honest by construction: the level is OK only while inputs are accepted and the invariants hold.
The values fit the scene: a dynamics scene simulates a body, so it reports its kinetic energy,
angular momentum and their drift (:func:`body_values`); a gyro (strapdown) scene integrates
measured rates, where those mean nothing, so it reports the rotation from the initial
attitude, the gyro bias estimate and the alignment state (:func:`strapdown_values`). Both
report the input counts and rates.

* ERROR: a drift above :data:`DRIFT_ERROR_THRESHOLD`, or a refused integration in the last
  period (``integration_failed``, ``non_finite_result``).
* WARN: a drift above :data:`DRIFT_WARN_THRESHOLD`; any rejection of :data:`WARN_REASONS` or
  missed samples in the last period; inputs that arrived with none accepted (the main reason
  named); a gyro scene that received no input, or that is still levelling (nothing
  integrated yet: the message starts ``aligning: ...``); a dynamics scene behind its clock.

Each problem names the parameter that governs it (:data:`GOVERNING_PARAMETER`). The period
figures come from :class:`PeriodCounts`, which the sessions fill.
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Mapping
from dataclasses import dataclass, field

import math

from rigid_body_attitude.core.attitude import quaternion
from rigid_body_attitude.core.dynamics.effects.gyro_bias import GyroBias
from rigid_body_attitude.core.propagator import DynamicsPropagator, GyroPropagator
from rigid_body_attitude.session.actuators import WHEEL_REASONS
from rigid_body_attitude.session.stream import REASONS

__all__ = [
    'DRIFT_ERROR_THRESHOLD', 'DRIFT_WARN_THRESHOLD', 'DiagnosticReport', 'GOVERNING_PARAMETER',
    'LEVEL_ERROR', 'LEVEL_OK', 'LEVEL_WARN', 'NOT_ALIGNED', 'PeriodCounts', 'REJECTION_KEYS',
    'TRANSFORM_KEYS', 'inactive_report',
    'StrapdownState', 'WARN_REASONS', 'alignment_state', 'body_frame_velocity', 'body_summary',
    'body_values',
    'diagnostic_report', 'gyro_bias_text', 'rotation_from_initial_deg', 'stale_command_count',
    'state_summary', 'strapdown_summary', 'strapdown_values',
]

#: diagnostic_msgs/DiagnosticStatus levels.
LEVEL_OK, LEVEL_WARN, LEVEL_ERROR = 0, 1, 2

#: The alignment state of a strapdown scene: its initial attitude comes from the scene or
#: ``set_pose``, never from the gravity an accelerometer measures.
NOT_ALIGNED = ('not aligned: no accelerometer levelling (initial attitude from the scene or '
               'set_pose)')

#: Relative energy-balance residual or momentum drift above which the status is WARN / ERROR.
#: RK4 at the shipped steps stays below 1e-12 over minutes (torque_free_box: 1.2e-14 after
#: 60 s); 1e-6 flags a step too coarse for the motion, 1e-3 a result no longer worth using.
DRIFT_WARN_THRESHOLD = 1e-6
DRIFT_ERROR_THRESHOLD = 1e-3

#: Static transforms refused (``/tf_static``, :mod:`~rigid_body_attitude.session.mount`) and
#: gyro samples in a frame other than the IMU's.
TRANSFORM_KEYS = ('foreign_frame', 'tf_bad_frames', 'tf_non_finite', 'tf_denormalized',
                  'tf_evicted')
#: Rejection counters reported, in order: the stream reasons, the session's own (malformed
#: messages, invalid or zero stamps, poses), expired commands, refused integrations, gyro
#: samples dropped without a mount, commands superseded by a newer one before use, Imu
#: samples whose specific force is beyond any accelerometer's range and inputs that reached a
#: managed node while it was not active.
REJECTION_KEYS = (*REASONS, 'malformed', 'invalid_stamp', 'zero_stamp', 'invalid_pose',
                  'invalid_covariance', 'wrong_frame', 'stale_torque', 'integration_failed',
                  'non_finite_result', 'internal_error', 'no_mount', 'superseded',
                  'accel_out_of_range', 'inactive', *TRANSFORM_KEYS)

#: Rejections that make the status WARN / ERROR when they happened during the last period.
WARN_REASONS = ('non_finite', 'out_of_range', 'outlier_stamp', 'gap', 'time_jump',
                'future_stamp', 'malformed', 'invalid_stamp', 'zero_stamp', 'invalid_pose',
                'wrong_frame', 'no_mount', 'accel_out_of_range', 'invalid_covariance',
                *TRANSFORM_KEYS, *WHEEL_REASONS)
ERROR_REASONS = ('integration_failed', 'non_finite_result', 'internal_error')

#: The parameter a user changes about each problem (gyro scenes; dynamics in the second map).
GOVERNING_PARAMETER = {
    'out_of_range': 'max_angular_rate', 'stale_stamp': 'use_header_stamps',
    'outlier_stamp': 'max_dt', 'gap': 'max_dt', 'time_jump': 'time_jump_threshold',
    'invalid_stamp': 'use_header_stamps', 'zero_stamp': 'use_header_stamps',
    'invalid_pose': 'world_frame', 'wrong_frame': 'world_frame',
    'integration_failed': 'integrator', 'non_finite_result': 'integrator',
    'no_input': 'use_header_stamps', 'behind': 'step', 'no_mount': 'mount_rpy',
    'future_stamp': 'lockstep',
}
DYNAMICS_GOVERNING_PARAMETER = {
    **{key: value for key, value in GOVERNING_PARAMETER.items() if key != 'out_of_range'},
    'gap': 'time_jump_threshold'}


@dataclass
class PeriodCounts:
    """What happened to the inputs during one diagnostics period, and so far.

    Attributes:
        elapsed: length of the period [s].
        received: inputs received in the period (every message, whatever became of it).
        accepted: inputs used in the period (gyro samples, commands, poses; not clock ticks).
        accepted_total: inputs used so far.
        received_total: inputs received so far.
        rejections: rejections so far by reason.
        new_rejections: rejections in the period by reason.
        missed: samples lost upstream in the period (gyro).
        missed_total: samples lost upstream so far.
        missed_cause: what the gaps of the period look like and their likely cause.
        malformed_by_topic: malformed messages so far by topic.
        gyro_scene: the session integrates gyro samples (no input is then a problem).
        real_time_factor: dynamics: simulated seconds per second of work in the period
            (``inf`` when no work was timed).
        lag: dynamics: the largest delay of the propagated time behind the clock [s].
        tick_period: dynamics: the tick period [s].
        clock_values: dynamics on the node's own sim clock: its values (achieved real-time
            factor, lockstep timeouts) for the report.
        clock_problems: what about that clock makes the status WARN (a silent controller).
        actuator_values: dynamics: the scene's actuators (wheels, torque rods) for the report.
        actuator_problems: what about them makes the status WARN (a wheel at its speed
            limit).
    """

    elapsed: float
    received: int
    accepted: int
    accepted_total: int
    rejections: Counter[str]
    new_rejections: Counter[str]
    received_total: int = 0
    missed: int = 0
    missed_total: int = 0
    missed_cause: str = ''
    malformed_by_topic: Counter[str] = field(default_factory=Counter)
    gyro_scene: bool = False
    real_time_factor: float = float('inf')
    lag: float = 0.0
    tick_period: float = 0.0
    clock_values: tuple[tuple[str, str], ...] = ()
    clock_problems: tuple[str, ...] = ()
    actuator_values: tuple[tuple[str, str], ...] = ()
    actuator_problems: tuple[str, ...] = ()


@dataclass(frozen=True)
class StrapdownState:
    """What a strapdown session knows beyond its propagator (its start and bias).

    Attributes:
        alignment: the alignment state in words (levelling from gravity, or why not).
        gyro_bias: the bias estimate in words (``None``: the scene's ``gyro_bias`` effect).
        aligning: nothing is integrated yet: the session is levelling (the status is WARN
            and its message starts with the alignment state).
    """

    alignment: str = NOT_ALIGNED
    gyro_bias: str | None = None
    aligning: bool = False


@dataclass(frozen=True)
class DiagnosticReport:
    """The content of one ``DiagnosticStatus``.

    Attributes:
        level: :data:`LEVEL_OK`, :data:`LEVEL_WARN` or :data:`LEVEL_ERROR`.
        message: ``'propagating'``, or why the level is raised.
        values: ``(key, value)`` strings in display order.
    """

    level: int
    message: str
    values: tuple[tuple[str, str], ...]


def body_frame_velocity(propagator: DynamicsPropagator | GyroPropagator
                        ) -> tuple[float, float, float]:
    """Centre-of-mass velocity in body axes [m/s], ``R(q)ᵀ v_world``; zero without translation.

    ``v_world`` is the ``velocity`` output of the scene's stateful effects (translation).
    """
    for effect in propagator.stateful:
        velocity_world = effect.outputs().get('velocity')
        if velocity_world is not None:
            return quaternion.rotate_inverse_floats(propagator.state.attitude_tuple(),
                                                    velocity_world.tolist())
    return (0.0, 0.0, 0.0)


def stale_command_count(counters: Mapping[str, int]) -> int:
    """Commands (torque, force, rotor torque) that expired: the effects' ``*.stale`` counters."""
    return sum(value for key, value in counters.items() if key.endswith('.stale'))


def _relative(change: float, scale: float) -> float:
    """``|change| / scale``; the absolute change when the scale is zero (nothing to relate to)."""
    return abs(change) / scale if scale > 0.0 else abs(change)


def _drift_problems(propagator: DynamicsPropagator | GyroPropagator,
                    energy_residual: float, momentum_drift: float) -> tuple[int, list[str]]:
    """Level and reasons from the invariants a dynamics scene must keep.

    The energy balance ``T − T₀ − W`` holds for every dynamics scene, relative to
    ``max(|T₀|, |T|)``; the world momentum is conserved only without external torques (rotors
    are internal). Gyro scenes integrate measured rates: nothing is conserved, no check.
    """
    if not isinstance(propagator, DynamicsPropagator):
        return LEVEL_OK, []
    energy_scale = max(abs(propagator.tracker.initial_energy), abs(propagator.energy()))
    checks = [('energy-balance residual', _relative(energy_residual, energy_scale))]
    if not propagator.model.torque_functions:
        checks.append(('momentum drift', abs(momentum_drift)))
    level, problems = LEVEL_OK, []
    for name, value in checks:
        if not value <= DRIFT_WARN_THRESHOLD:  # NaN included
            threshold = DRIFT_WARN_THRESHOLD
            if not value <= DRIFT_ERROR_THRESHOLD:
                level, threshold = LEVEL_ERROR, DRIFT_ERROR_THRESHOLD
            else:
                level = max(level, LEVEL_WARN)
            problems.append(f'{name} {value:.3g} > {threshold:.0e} (parameters `step`, '
                            f'`integrator`)')
    return level, problems


def _governed(text: str, key: str, parameters: Mapping[str, str]) -> str:
    parameter = parameters.get(key)
    return f'{text} (parameter `{parameter}`)' if parameter else text


def _input_problems(counts: PeriodCounts, parameters: Mapping[str, str]
                    ) -> tuple[int, list[str]]:
    """Level and reasons from what happened to the inputs in the last period."""
    level, problems = LEVEL_OK, []
    for reasons, reason_level in ((ERROR_REASONS, LEVEL_ERROR), (WARN_REASONS, LEVEL_WARN)):
        for reason in reasons:
            if counts.new_rejections.get(reason, 0) > 0:
                level = max(level, reason_level)
                problems.append(_governed(
                    f'{counts.new_rejections[reason]} {reason} in the last period', reason,
                    parameters))
    if counts.missed:  # the cause (and the parameter, when one helps) in the session's words
        level = max(level, LEVEL_WARN)
        text = f'{counts.missed} samples missed upstream in the last period'
        problems.append(f'{text}: {counts.missed_cause}' if counts.missed_cause else text)
    if counts.received and not counts.accepted:
        main = max(counts.new_rejections.items(), key=lambda item: item[1], default=('', 0))
        if main[0] not in WARN_REASONS + ERROR_REASONS:  # not named above already
            level = max(level, LEVEL_WARN)
            problems.append(_governed(
                f'{counts.received} inputs and none accepted in the last period, mostly '
                f'{main[0] or "pending"}', main[0] or 'outlier_stamp', parameters))
    elif counts.gyro_scene and not counts.received:
        level = max(level, LEVEL_WARN)
        problems.append('no gyro input in the last period (topics imu, angular_velocity)')
    return level, problems


def _timing_problems(counts: PeriodCounts, parameters: Mapping[str, str]
                     ) -> tuple[int, list[str]]:
    """A dynamics scene behind its clock: the work takes longer than the time simulated."""
    if counts.gyro_scene or (counts.real_time_factor >= 1.0
                             and counts.lag <= counts.tick_period):
        return LEVEL_OK, []
    return LEVEL_WARN, [_governed(
        f'behind the clock: lag {counts.lag:.3f} s, real-time factor '
        f'{counts.real_time_factor:.2f} (also `integrator`, `publish_rate`)', 'behind',
        parameters)]


def _vector_text(vector: tuple[float, ...]) -> str:
    return ' '.join(f'{float(value):.9g}' for value in vector)


def body_values(propagator: DynamicsPropagator) -> list[tuple[str, str]]:
    """What a simulated body reports: kinetic energy, angular momentum and their drift."""
    diagnostics = propagator.diagnostics()
    momentum = diagnostics.world_angular_momentum.tolist()
    return [
        ('kinetic_energy [J]', f'{diagnostics.kinetic_energy:.12g}'),
        ('energy_drift', f'{diagnostics.energy_drift:.3e}'),
        ('energy_balance_residual [J]', f'{diagnostics.energy_balance_residual:.3e}'),
        ('world_angular_momentum [N m s]', _vector_text(tuple(momentum))),
        ('momentum_drift', f'{diagnostics.momentum_drift:.3e}'),
    ]


def rotation_from_initial_deg(propagator: GyroPropagator) -> float:
    """Angle [deg] of the rotation from the scene's initial attitude to the current one."""
    return math.degrees(float(quaternion.attitude_error(propagator.scene.initial_attitude,
                                                        propagator.state.attitude)))


def gyro_bias_text(propagator: GyroPropagator) -> str:
    """The bias the scene's ``gyro_bias`` effect subtracts [rad/s, body axes]: the vector,
    ``estimating (N samples)`` during its rest window, or ``none`` without the effect."""
    for effect in propagator.corrections:
        if isinstance(effect, GyroBias):
            if effect.estimating:
                return f'estimating ({effect.sample_count} samples)'
            return _vector_text(tuple(effect.bias.tolist()))
    return 'none'


def alignment_state(propagator: GyroPropagator, state: StrapdownState | None = None) -> str:
    """How the strapdown attitude was aligned to the world frame (:data:`NOT_ALIGNED` when the
    session says nothing)."""
    return NOT_ALIGNED if state is None else state.alignment


def _bias_text(propagator: GyroPropagator, state: StrapdownState | None) -> str:
    if state is None or state.gyro_bias is None:
        return gyro_bias_text(propagator)
    return state.gyro_bias


def strapdown_values(propagator: GyroPropagator, state: StrapdownState | None = None
                     ) -> list[tuple[str, str]]:
    """What a strapdown scene reports: rotation from the initial (levelled) attitude, the gyro
    bias, the alignment state."""
    return [
        ('rotation_from_initial [deg]', f'{rotation_from_initial_deg(propagator):.6f}'),
        ('gyro_bias [rad/s]', _bias_text(propagator, state)),
        ('alignment', alignment_state(propagator, state)),
    ]


def strapdown_summary(propagator: GyroPropagator, state: StrapdownState | None = None) -> str:
    """The scene-specific part of a strapdown session's INFO line."""
    return (f'rotation {rotation_from_initial_deg(propagator):.3f} deg from the initial '
            f'attitude, gyro bias [rad/s] {_bias_text(propagator, state)}, '
            f'{alignment_state(propagator, state)}')


def body_summary(propagator: DynamicsPropagator) -> str:
    """The scene-specific part of a dynamics session's INFO line: energy and momentum."""
    diagnostics = propagator.diagnostics()
    momentum = math.sqrt(sum(h * h for h in diagnostics.world_angular_momentum.tolist()))
    return (f'energy {diagnostics.kinetic_energy:.9g} J (drift {diagnostics.energy_drift:.2e}, '
            f'balance residual {diagnostics.energy_balance_residual:.2e} J), |H| '
            f'{momentum:.9g} N m s (drift {diagnostics.momentum_drift:.2e})')


def state_summary(propagator: DynamicsPropagator | GyroPropagator,
                  state: StrapdownState | None = None) -> str:
    """The scene-specific part of the node's INFO line (and the replay's summary)."""
    if isinstance(propagator, GyroPropagator):
        return strapdown_summary(propagator, state)
    return body_summary(propagator)


def diagnostic_report(propagator: DynamicsPropagator | GyroPropagator, counts: PeriodCounts,
                      step_text: str, time_s: float, state: StrapdownState | None = None
                      ) -> DiagnosticReport:
    """Level, message and values of a session's status (see the module docstring).

    ``step_text`` describes the step; ``time_s`` is the propagated time shown [s]; ``state``:
    a strapdown session's alignment and bias (while it levels the message starts with its
    ``aligning: ...`` status instead of ``propagating``).
    """
    parameters = GOVERNING_PARAMETER if counts.gyro_scene else DYNAMICS_GOVERNING_PARAMETER
    diagnostics = propagator.diagnostics()
    level, problems = _drift_problems(propagator, diagnostics.energy_balance_residual,
                                      diagnostics.momentum_drift)
    for check in (_input_problems, _timing_problems):
        check_level, check_problems = check(counts, parameters)
        level, problems = max(level, check_level), problems + check_problems
    for extra in (counts.clock_problems, counts.actuator_problems):
        if extra:
            level, problems = max(level, LEVEL_WARN), problems + list(extra)
    scene = propagator.scene
    values = [
        ('scene', scene.name),
        ('rate_source', scene.rate_source),
        ('integrator', scene.integrator),
        ('step [s]', step_text),
        ('time [s]', f'{time_s:.9f}'),
        *(strapdown_values(propagator, state) if isinstance(propagator, GyroPropagator)
          else body_values(propagator)),
        ('quaternion_norm_error', f'{diagnostics.quaternion_norm_error:.3e}'),
        ('input_rate [Hz]', f'{counts.accepted / counts.elapsed:.1f}'),
        ('received_rate [Hz]', f'{counts.received / counts.elapsed:.1f}'),
        ('received', str(counts.received_total)),
        ('accepted', str(counts.accepted_total)),
        ('missed_samples', str(counts.missed_total)),
    ]
    if not counts.gyro_scene:
        values += [('real_time_factor', f'{counts.real_time_factor:.3g}'),
                   ('lag [s]', f'{counts.lag:.6f}'), *counts.clock_values,
                   *counts.actuator_values]
    values += [(f'rejected {key}', str(counts.rejections.get(key, 0)))
               for key in REJECTION_KEYS]
    values += [(f'malformed {topic}', str(count))
               for topic, count in sorted(counts.malformed_by_topic.items())]
    values += [(key, str(value)) for key, value in sorted(propagator.counters().items())]
    if state is not None and state.aligning:  # nothing integrated yet: never OK
        level = max(level, LEVEL_WARN)
        problems.insert(0, state.alignment)
    message = '; '.join(problems) or 'propagating'
    return DiagnosticReport(level, message, tuple(values))


def inactive_report(report: DiagnosticReport) -> DiagnosticReport:
    """``report`` of a managed node that is not active: nothing is integrated, so the level is
    at least WARN and the message starts ``inactive``."""
    message = 'inactive: inputs are not integrated until the node is activated'
    if report.message != 'propagating':
        message += '; ' + report.message
    return DiagnosticReport(max(report.level, LEVEL_WARN), message,
                            (('lifecycle_state', 'inactive'), *report.values))
