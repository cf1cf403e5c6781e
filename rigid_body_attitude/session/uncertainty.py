"""The attitude uncertainty of a gyro session: the covariance carried with the attitude.

:class:`Uncertainty` owns a :class:`~rigid_body_attitude.core.estimation.attitude_covariance.
AttitudeCovariance` and feeds it each integrated strapdown step (the session's
``_after_step``). It starts from the levelling's uncertainty when levelling completes
(:meth:`Uncertainty.aligned`), or, without levelling, from the scene's attitude with the
unlevelled prior (tilt and yaw 1σ ``initial_yaw_stddev``, bias 1σ ``gyroscope_turn_on_bias``);
``~/reset`` starts it again; ``set_pose`` replaces the attitude block (the message's covariance,
or ``set_pose_stddev`` on each axis).

Published values (REP-145: about fixed **world** axes, rad²): :attr:`Uncertainty.published` is
the row-major 3×3 attitude covariance at the last fold (every :data:`BATCH_SIZE` samples or
:data:`FOLD_SECONDS` of steps, whichever comes first, so a read is free per sample and the
value is less than :data:`FOLD_SECONDS` of stamp time behind the attitude);
:func:`pose_covariance` the 6×6 of ``pose_with_covariance`` with the position block marked
unknown (:data:`UNKNOWN_POSITION_VARIANCE` on its diagonal).

A ``set_pose`` during levelling gives the heading: when levelling completes, the covariance
starts with the levelling's tilt and the pose's yaw variance.

Noise from a kalibr calibration file (``calibration_file``) overrides the parameters:
:func:`error_model_from`.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from rigid_body_attitude.core.estimation.attitude_covariance import (
    AttitudeCovariance, checked_attitude_covariance)
from rigid_body_attitude.core.errors import InputError
from rigid_body_attitude.core.estimation.gyro_error_model import GyroErrorModel, initial_covariance
from rigid_body_attitude.session.levelling import AlignmentResult

__all__ = ['BATCH_SIZE', 'FOLD_SECONDS', 'MODEL_PARAMETERS', 'UNKNOWN_POSITION_VARIANCE',
           'Uncertainty', 'attitude_stddev_deg', 'error_model_from', 'orientation_block',
           'pose_covariance']

#: Variance [m²] on the diagonal of the position block of ``pose_with_covariance``: the
#: position is not estimated. Large and finite, so the 6×6 stays symmetric positive definite
#: (fuse refuses anything else) and a filter that fuses it anyway gives it no weight; a
#: robot_localization user excludes the position with ``pose0_config``.
UNKNOWN_POSITION_VARIANCE = 1e9
#: Integrated steps gathered before a fold (the transition is exact for any batch): a fold
#: costs about as much as 100-200 strapdown steps, whatever the batch (docs/performance.md).
BATCH_SIZE = 256
#: Stamp time [s] of steps gathered before a fold, if :data:`BATCH_SIZE` is not reached first:
#: the published covariance is always less than this behind the attitude (at 1 kHz a fold every
#: 50 samples, at 100 Hz every 5).
FOLD_SECONDS = 0.05
_FOLD_AFTER = FOLD_SECONDS - 1e-9  # steps sum stamp differences: 50 × 1 ms may come out short
#: Node parameters that are fields of :class:`GyroErrorModel` (same names).
MODEL_PARAMETERS = ('gyroscope_noise_density', 'gyroscope_random_walk',
                    'gyroscope_turn_on_bias', 'gyroscope_scale_stddev',
                    'gyroscope_misalignment_stddev', 'initial_yaw_stddev',
                    'accelerometer_noise_density')
#: Keys of a calibration file (a kalibr ``imu.yaml``'s noise, the IMU's further figures) that
#: override the parameters of the same name.
CALIBRATION_KEYS = ('gyroscope_noise_density', 'gyroscope_random_walk',
                    'gyroscope_turn_on_bias', 'gyroscope_scale_stddev',
                    'gyroscope_misalignment_stddev')

Quaternion = tuple[float, float, float, float]
Vector = tuple[float, float, float]


def error_model_from(values: Mapping[str, Any],
                     calibration: Mapping[str, Any] | None = None,
                     keys: Sequence[str] = CALIBRATION_KEYS) -> GyroErrorModel:
    """The gyro error model of the parameters ``values``; the noise of a kalibr
    ``calibration`` (an ``imu.yaml`` mapping: by default ``gyroscope_noise_density``,
    ``gyroscope_random_walk``; ``keys``) overrides the parameters. Raises InputError naming
    the key."""
    fields = {name: values[name] for name in MODEL_PARAMETERS if name in values}
    for key in keys:
        if calibration is not None and key in calibration:
            value = calibration[key]
            if isinstance(value, bool) or not isinstance(value, (int, float)) or not (
                    math.isfinite(value) and value >= 0.0):
                raise InputError(f'Expected calibration `{key}` to be a finite number >= 0, '
                                 f'got {value!r}')
            fields[key] = float(value)
    return GyroErrorModel(**fields)


def orientation_block(covariance: Sequence[float]) -> tuple[float, ...]:
    """The row-major 3×3 orientation block (rows and columns 3-5) of the 36 row-major values
    of a ``PoseWithCovariance``, checked as the covariance will take it
    (:func:`~rigid_body_attitude.core.estimation.attitude_covariance.checked_attitude_covariance`:
    finite, symmetric, positive semi-definite, variances at most π² rad²; else InputError
    saying which), symmetrised and with its diagonal floored."""
    values = tuple(covariance)
    if len(values) != 36:
        raise InputError(f'Expected a covariance of 36 values, got {len(values)}')
    block = np.array(values, dtype=np.float64).reshape(6, 6)[3:, 3:]
    checked = checked_attitude_covariance(block, 'orientation covariance')
    return tuple(checked.reshape(9).tolist())


def attitude_stddev_deg(published: Sequence[float]) -> tuple[float, float]:
    """1σ tilt (worst horizontal axis) and yaw [deg] of a row-major 3×3 attitude covariance
    about world axes [rad²]."""
    xx, xy, _, _, yy, _, _, _, zz = published
    half_trace, half_gap = 0.5 * (xx + yy), math.hypot(0.5 * (xx - yy), xy)
    return math.degrees(math.sqrt(half_trace + half_gap)), math.degrees(math.sqrt(zz))


def pose_covariance(attitude: Sequence[float]) -> tuple[float, ...]:
    """The row-major 6×6 of a ``PoseWithCovariance`` from the row-major 3×3 attitude block:
    position block diagonal :data:`UNKNOWN_POSITION_VARIANCE`, no cross terms."""
    unknown = UNKNOWN_POSITION_VARIANCE
    a = attitude
    return (unknown, 0.0, 0.0, 0.0, 0.0, 0.0,
            0.0, unknown, 0.0, 0.0, 0.0, 0.0,
            0.0, 0.0, unknown, 0.0, 0.0, 0.0,
            0.0, 0.0, 0.0, a[0], a[1], a[2],
            0.0, 0.0, 0.0, a[3], a[4], a[5],
            0.0, 0.0, 0.0, a[6], a[7], a[8])


class Uncertainty:
    """The attitude-error covariance of one gyro session (see the module docstring).

    Args:
        values: the node parameters (:mod:`~rigid_body_attitude.session.parameters`).
        calibration: a kalibr ``imu.yaml`` mapping whose noise overrides the parameters.
    """

    def __init__(self, values: Mapping[str, Any],
                 calibration: Mapping[str, Any] | None = None) -> None:
        """The model of ``values``; the covariance starts unlevelled (:meth:`start`)."""
        self.model = error_model_from(values, calibration)
        self.apply(values)
        self._pose_yaw_variance: float | None = None
        self.start(None)

    def apply(self, values: Mapping[str, Any]) -> None:
        """Take the run-time parameters (``set_pose_stddev``, ``tilt_stddev_warn``)."""
        self.set_pose_stddev: float = values['set_pose_stddev']
        self.tilt_stddev_warn: float = values['tilt_stddev_warn']

    def start(self, window_seconds: float | None) -> None:
        """A new covariance: levelled over ``window_seconds`` of rest, or unlevelled (None);
        yaw 1σ ``initial_yaw_stddev`` (a ``set_pose``'s heading is forgotten)."""
        self._pose_yaw_variance = None
        self._restart(window_seconds)

    def _restart(self, window_seconds: float | None) -> None:
        yaw = self._pose_yaw_variance
        start = initial_covariance(self.model, window_seconds,
                                   None if yaw is None else math.sqrt(yaw))
        self.covariance = AttitudeCovariance(self.model, covariance=start,
                                             batch_size=BATCH_SIZE)
        self._pending = 0
        self._elapsed = 0.0
        self._publish()

    def aligned(self, result: AlignmentResult) -> None:
        """The session's ``on_aligned`` hook: levelled over ``result.window_seconds`` of rest,
        or unlevelled (not ``at_rest``: levelled from the quietest window after the timeout,
        or a window of 0). The yaw variance of a ``set_pose`` received since the last start
        (the levelling's heading came from it) is kept."""
        window = result.window_seconds if result.at_rest else 0.0
        self._restart(window if window > 0.0 else None)

    def step(self, q_before: Quaternion, rate_body: Vector, dt: float) -> bool:
        """One integrated step (attitude at its start, body rate held [rad/s], length [s]);
        returns whether :attr:`published` changed (a fold: every :data:`BATCH_SIZE` steps or
        :data:`FOLD_SECONDS` of them)."""
        self.covariance.add_sample(q_before, rate_body, dt)
        self._pending += 1
        self._elapsed += dt
        if self._pending < BATCH_SIZE and self._elapsed < _FOLD_AFTER:
            return False
        self._pending = 0
        self._elapsed = 0.0
        self._publish()
        return True

    def set_pose(self, covariance: Sequence[float] | None = None) -> None:
        """After ``set_pose``: the row-major 3×3 world-frame ``covariance`` [rad²] of the
        message (as :func:`orientation_block` returns it), or ``set_pose_stddev`` on each axis
        (None). Raises InputError for a matrix :func:`orientation_block` refuses."""
        if covariance is None:
            self.covariance.set_pose(stddev=self.set_pose_stddev)
        else:
            self.covariance.set_pose(covariance=np.reshape(np.array(covariance, dtype=float),
                                                           (3, 3)))
        self._pending = 0
        self._elapsed = 0.0
        self._publish()
        self._pose_yaw_variance = self.published[8]

    def _publish(self) -> None:
        block = self.covariance.attitude_covariance
        #: Row-major 3×3 attitude covariance [rad²] about fixed world axes, as published.
        self.published: tuple[float, ...] = tuple(block.reshape(9).tolist())

    def stddev_deg(self) -> tuple[float, float]:
        """1σ tilt (worst horizontal axis) and yaw [deg] of :attr:`published` (read without
        folding, so reading never changes when the folds happen)."""
        return attitude_stddev_deg(self.published)

    def diagnostic(self) -> tuple[str, list[tuple[str, str]]]:
        """The WARN problem (``''`` when none) and the values of ``/diagnostics``."""
        tilt, yaw = self.stddev_deg()
        values = [('tilt_stddev [deg]', f'{tilt:.3f}'), ('yaw_stddev [deg]', f'{yaw:.3f}')]
        bound = math.degrees(self.tilt_stddev_warn)
        problem = ''
        if self.tilt_stddev_warn > 0.0 and tilt > bound:
            problem = (f'1-sigma tilt {tilt:.2f} deg above {bound:.2f} deg '
                       f'(parameter `tilt_stddev_warn`)')
        return problem, values
