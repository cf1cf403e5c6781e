"""Conversions at the ROS message boundary that need no ROS import (node and replay tool).

* :class:`TimeBase`: ROS stamps (integer ``sec``, ``nanosec``) ↔ float seconds relative to
  an epoch, so that stamps near 1.7e9 s keep sub-nanosecond resolution in float arithmetic
  (a float near 1.7e9 has a spacing of 2.4e-7 s, which would put a 2.4e-4 relative error on
  the step of a 1 kHz gyro).
* :func:`body_frame_velocity`: the centre-of-mass velocity in body axes (the linear part of
  a body-frame twist), zero without translation.
* :func:`diagnostic_report`: the propagator's diagnostics and the input counters as the
  level, message and key/value strings of a ``diagnostic_msgs/DiagnosticStatus``.

Quaternions are converted to message order with :func:`rigid_body_attitude.core.quaternion.to_ros`
(or field by field from :class:`rigid_body_attitude.session.outputs.OutputTracker`'s scalar-first
tuple); this module states no convention of its own.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from rigid_body_attitude.core import quaternion
from rigid_body_attitude.core.propagator import DynamicsPropagator, GyroPropagator
from rigid_body_attitude.session.stream import REASONS

__all__ = [
    'DRIFT_ERROR_THRESHOLD',
    'DRIFT_WARN_THRESHOLD',
    'DiagnosticReport',
    'LEVEL_ERROR',
    'LEVEL_OK',
    'LEVEL_WARN',
    'NANOSECONDS_PER_SECOND',
    'REJECTION_KEYS',
    'TimeBase',
    'body_frame_velocity',
    'diagnostic_report',
    'stale_command_count',
]

NANOSECONDS_PER_SECOND = 1_000_000_000

#: diagnostic_msgs/DiagnosticStatus levels.
LEVEL_OK, LEVEL_WARN, LEVEL_ERROR = 0, 1, 2

#: Relative energy-balance residual or momentum drift above which the status is WARN / ERROR.
#: RK4 at the shipped steps stays below 1e-12 over minutes (torque_free_box: 1.2e-14 after
#: 60 s); 1e-6 flags a step too coarse for the motion, 1e-3 a result no longer worth using.
DRIFT_WARN_THRESHOLD = 1e-6
DRIFT_ERROR_THRESHOLD = 1e-3

#: Rejection counters reported, in order: the stream reasons, stale commands, bad poses, and
#: clock ticks the integrator refused (the state was then reset).
REJECTION_KEYS = (*REASONS, 'stale_torque', 'invalid_pose', 'integration_failed')

#: Rejections that make the status WARN / ERROR when they happened during the last period.
_WARNING_REASONS = ('non_finite', 'gap', 'time_jump', 'invalid_pose')
_ERROR_REASONS = ('integration_failed',)


class TimeBase:
    """Integer ROS times ↔ float seconds since an epoch fixed by the first time converted.

    The epoch is the first time's whole seconds, so the first time maps to ``[0, 1)`` s and
    later ones to their exact distance from it (float resolution ~1e-10 s within ±1e6 s of
    the epoch). Times far before the epoch (a jump back to stamp zero) lose resolution like
    any float of their size.
    """

    def __init__(self) -> None:
        """No epoch until the first conversion."""
        self.epoch_sec: int | None = None

    def seconds(self, sec: int, nanosec: int) -> float:
        """Seconds since the epoch of the stamp ``(sec, nanosec)``."""
        if self.epoch_sec is None:
            self.epoch_sec = sec
        return (sec - self.epoch_sec) + nanosec * 1e-9

    def seconds_from_nanoseconds(self, nanoseconds: int) -> float:
        """Seconds since the epoch of a time given in integer nanoseconds (rclpy Time)."""
        sec, nanosec = divmod(nanoseconds, NANOSECONDS_PER_SECOND)
        return self.seconds(sec, nanosec)

    def stamp(self, seconds: float) -> tuple[int, int]:
        """``(sec, nanosec)`` of ``seconds`` since the epoch, rounded to the nanosecond."""
        epoch = self.epoch_sec if self.epoch_sec is not None else 0
        total = epoch * NANOSECONDS_PER_SECOND + round(seconds * NANOSECONDS_PER_SECOND)
        sec, nanosec = divmod(total, NANOSECONDS_PER_SECOND)
        return sec, nanosec


def body_frame_velocity(propagator: DynamicsPropagator | GyroPropagator
                        ) -> tuple[float, float, float]:
    """Centre-of-mass velocity in body axes [m/s], ``R(q)ᵀ v_world``; zero without translation.

    ``v_world`` is the ``velocity`` output of the scene's stateful effects (translation).
    """
    for effect in propagator.stateful:
        velocity_world = effect.outputs().get('velocity')
        if velocity_world is not None:
            velocity_body = quaternion.rotate_inverse(propagator.state.attitude, velocity_world)
            return tuple(velocity_body.tolist())
    return (0.0, 0.0, 0.0)


def stale_command_count(counters: Mapping[str, int]) -> int:
    """Commands (torque, force, rotor torque) that expired: the effects' ``*.stale`` counters."""
    return sum(value for key, value in counters.items() if key.endswith('.stale'))


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
            problems.append(f'{name} {value:.3g} > {threshold:.0e}')
    return level, problems


def _rejection_problems(new_rejections: Mapping[str, int]) -> tuple[int, list[str]]:
    """Level and reasons (gaps, time jumps, non-finite inputs...) of the last period."""
    level, problems = LEVEL_OK, []
    for reasons, reason_level in ((_ERROR_REASONS, LEVEL_ERROR),
                                  (_WARNING_REASONS, LEVEL_WARN)):
        for reason in reasons:
            if new_rejections.get(reason, 0) > 0:
                level = max(level, reason_level)
                problems.append(f'{new_rejections[reason]} {reason} in the last period')
    return level, problems


def _vector_text(vector: NDArray[np.float64] | tuple[float, ...]) -> str:
    return ' '.join(f'{float(value):.9g}' for value in vector)


def diagnostic_report(propagator: DynamicsPropagator | GyroPropagator,
                      rejections: Mapping[str, int], new_rejections: Mapping[str, int],
                      accepted: int, input_rate: float, step_text: str) -> DiagnosticReport:
    """Level, message and values of the propagator's status.

    ``rejections`` are the totals by reason (:data:`REJECTION_KEYS`), ``new_rejections``
    those of the last period, ``accepted`` the inputs used so far, ``input_rate`` [Hz] the
    input messages per second of the last period and ``step_text`` the step description.
    WARN: a drift above :data:`DRIFT_WARN_THRESHOLD`, or gaps, time jumps, non-finite inputs
    or invalid poses in the last period; ERROR: a drift above :data:`DRIFT_ERROR_THRESHOLD`
    or a refused integration in the last period.
    """
    diagnostics = propagator.diagnostics()
    level, problems = _drift_problems(propagator, diagnostics.energy_balance_residual,
                                      diagnostics.momentum_drift)
    rejection_level, rejection_problems = _rejection_problems(new_rejections)
    level = max(level, rejection_level)
    scene = propagator.scene
    values = [
        ('scene', scene.name),
        ('rate_source', scene.rate_source),
        ('integrator', scene.integrator),
        ('step [s]', step_text),
        ('time [s]', f'{propagator.state.time:.9f}'),
        ('kinetic_energy [J]', f'{diagnostics.kinetic_energy:.12g}'),
        ('energy_drift', f'{diagnostics.energy_drift:.3e}'),
        ('energy_balance_residual [J]', f'{diagnostics.energy_balance_residual:.3e}'),
        ('world_angular_momentum [N m s]', _vector_text(diagnostics.world_angular_momentum)),
        ('momentum_drift', f'{diagnostics.momentum_drift:.3e}'),
        ('quaternion_norm_error', f'{diagnostics.quaternion_norm_error:.3e}'),
        ('input_rate [Hz]', f'{input_rate:.1f}'),
        ('accepted', str(accepted)),
    ]
    values += [(f'rejected {key}', str(rejections.get(key, 0))) for key in REJECTION_KEYS]
    values += [(key, str(value)) for key, value in sorted(propagator.counters().items())]
    message = '; '.join(problems + rejection_problems) or 'propagating'
    return DiagnosticReport(level, message, tuple(values))
