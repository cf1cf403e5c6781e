"""The node's parameters, declared once: name, type, default, bounds, description, read-only.

The node's ROS descriptors (:mod:`rigid_body_attitude.ros.node`), ``propagation_node --help``
(:mod:`rigid_body_attitude.ros.cli_help`),
the replay tool's options and command line (:mod:`rigid_body_attitude.tools.replay`) and the
validation of every value (at start, at run time, from the command line) are all derived from
:data:`PARAMETERS`. A value is checked by :func:`check_values`: its type, its bounds, and the
rules that tie parameters together.
"""

from __future__ import annotations

import math
import re
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

from rigid_body_attitude.core.estimation.estimator_settings import EstimatorSettings
from rigid_body_attitude.core.estimation.gyro_error_model import GyroErrorModel
from rigid_body_attitude.msgs.untrusted import QUOTED_CHARACTERS, quoted

__all__ = ['PARAMETERS', 'Parameter', 'check_values', 'defaults', 'values_problem']


@dataclass(frozen=True)
class Parameter:
    """One parameter.

    Attributes:
        name: the ROS parameter name.
        type: ``float``, ``bool``, ``str`` or ``tuple`` (a double array: a tuple of
            :attr:`length` floats, or empty when ``may_be_empty``; ROS type
            ``double_array``).
        default: the default value (of ``type``).
        description: one line, with the unit first for numbers (``'s: ...'``).
        low, high: bounds of a number (``None``: unbounded on that side).
        low_open: ``low`` itself is refused (``> low`` instead of ``>= low``).
        read_only: fixed at start; otherwise it may be changed at run time.
        choices: the allowed values of a string (empty: any non-empty name, or any string
            when ``may_be_empty``).
        may_be_empty: an empty string or array is allowed (it means "the scene's" or "not
            set").
        length: the number of floats of a double array.
    """

    name: str
    type: type
    default: Any
    description: str
    low: float | None = None
    high: float | None = None
    low_open: bool = False
    read_only: bool = True
    choices: tuple[str, ...] = ()
    may_be_empty: bool = False
    length: int = 3

    @property
    def type_text(self) -> str:
        """The type as an error message names it."""
        if self.type is tuple:
            return (f'double array of {self.length} numbers with decimal points'
                    + (' (or [] for none)' if self.may_be_empty else ''))
        return _TYPE_TEXT[self.type]

    def problem(self, value: Any) -> str:
        """Why ``value`` is not a valid value of this parameter, or ``''``."""
        if type(value) is not self.type:  # bool is not a float, 1 is not 1.0
            return (f'Expected parameter `{self.name}` to be a {self.type_text}, '
                    f'got {_quoted(value)}')
        if isinstance(value, tuple):
            return self._array_problem(value)
        if isinstance(value, float):
            return self._number_problem(value)
        if isinstance(value, str):
            return self._text_problem(value)
        return ''

    def _number_problem(self, value: float) -> str:
        low_ok = self.low is None or (value > self.low if self.low_open else value >= self.low)
        high_ok = self.high is None or value <= self.high
        if math.isfinite(value) and low_ok and high_ok:
            return ''
        return (f'Expected parameter `{self.name}` to be a finite number in '
                f'{self.range_text()}, got {value!r}')

    def _array_problem(self, value: tuple[Any, ...]) -> str:
        if not value and self.may_be_empty:
            return ''
        if len(value) != self.length or any(type(item) is not float for item in value):
            return (f'Expected parameter `{self.name}` to be a {self.type_text}, got '
                    f'{_quoted(value)}')
        for item in value:
            if self._number_problem(item):
                bounds = f' in {self.range_text()}' if self.range_text() else ''
                return (f'Expected parameter `{self.name}` to hold finite numbers{bounds}, '
                        f'got {_quoted(value)}')
        return ''

    def _text_problem(self, value: str) -> str:
        if self.choices and value not in self.choices:
            return (f'Expected parameter `{self.name}` to be one of '
                    f'{", ".join(map(repr, self.choices))}, got {_quoted(value)}')
        if not self.may_be_empty and not value.strip():
            return (f'Expected parameter `{self.name}` to be a non-empty name, got '
                    f'{_quoted(value)}')
        if len(value) > MAX_TEXT_LENGTH:
            return (f'Expected parameter `{self.name}` to be at most {MAX_TEXT_LENGTH} '
                    f'characters, got {len(value)}')
        return ''

    def range_text(self) -> str:
        """The bounds as an interval, e.g. ``(0, 1000]``; ``''`` for non-numbers and for
        arrays without bounds."""
        if self.type is not float and (self.type is not tuple or (
                self.low is None and self.high is None)):
            return ''
        low = '-inf' if self.low is None else _number_text(self.low)
        high = 'inf' if self.high is None else _number_text(self.high)
        return f'{"(" if self.low_open or self.low is None else "["}{low}, {high}]'


#: Longest string value accepted (frame ids, scene paths, integrator names).
MAX_TEXT_LENGTH = 4096

_TYPE_TEXT = {float: 'double (written with a decimal point, e.g. 50.0)',
              bool: 'boolean (true or false)', str: 'string'}


def _number_text(value: float) -> str:
    """A bound as people write it: ``1e6``, not ``1e+06``."""
    return re.sub(r'e\+?(-?)0*(\d)', r'e\1\2', f'{value:g}')


def _quoted(value: Any) -> str:
    """A value as an error quotes it: a string as :func:`~rigid_body_attitude.msgs.untrusted.
    quoted` writes it (a short prefix, non-printables escaped, the length of what was cut),
    anything else as ``repr`` cut to 100 characters (a hostile value may be huge)."""
    if isinstance(value, str):
        return quoted(value)
    text = repr(value)
    return text if len(text) <= 100 else text[:97] + '...'


def _plain(name: Any) -> bool:
    """Whether ``name`` can be shown as it is: a short printable string."""
    return isinstance(name, str) and len(name) <= QUOTED_CHARACTERS and name.isprintable()


_GYRO_DEFAULTS = GyroErrorModel()
_SETTINGS = EstimatorSettings()

#: Every parameter, in the order the README and ``--help`` list them.
PARAMETERS: tuple[Parameter, ...] = (
    Parameter('scene', str, 'torque_free_box',
              'built-in scene name or path to a scene YAML file'),
    Parameter('world_frame', str, 'world',
              'frame of pose, orientation and angular_momentum; set_pose must carry it',
              read_only=False),
    Parameter('body_frame', str, 'base_link', 'frame of twist (the body)', read_only=False),
    Parameter('publish_rate', float, 50.0,
              'Hz: dynamics ticks; energy and angular_momentum output', 0.0, 1000.0,
              low_open=True),
    Parameter('use_header_stamps', bool, True,
              'gyro and command times from header stamps (else the receive time on the node '
              'clock)', read_only=False),
    Parameter('constant_dt', float, 0.0,
              's: integrate each gyro sample over this step (0 = the stamp differences)',
              0.0, 10.0, read_only=False),
    Parameter('max_dt', float, 0.1,
              's: a longer gap between gyro samples is not integrated across', 0.0, 3600.0,
              low_open=True, read_only=False),
    Parameter('time_jump_threshold', float, 1.0,
              's: a larger backward jump of input stamps or node clock resets to the initial '
              'state; a larger forward jump of the clock is not integrated across', 0.0,
              1.0e6, low_open=True, read_only=False),
    Parameter('max_angular_rate', float, 1000.0,
              'rad/s: a gyro sample of a larger magnitude is rejected (out_of_range)', 0.0,
              1.0e6, low_open=True, read_only=False),
    Parameter('torque_timeout', float, 0.0,
              's: commands (torque, force, rotor torque, wheels, dipole) are held this long, '
              'then zeroed '
              '(0 = the scene\'s)', 0.0, 3600.0),
    Parameter('integrator', str, '',
              'integrator (dynamics) or strapdown method (gyro) overriding the scene\'s '
              '("" = the scene\'s)', may_be_empty=True),
    Parameter('step', float, 0.0,
              's: integration step of dynamics scenes (0 = the scene\'s)', 0.0, 10.0),
    # Sim clock and lockstep (dynamics scenes; docs/closed-loop.md).
    Parameter('publish_clock', bool, False,
              'dynamics scenes: be the graph\'s clock: sim time from 0 on /clock at each tick, '
              'outputs stamped with it'),
    Parameter('real_time_factor', float, 1.0,
              '1: sim seconds per wall second the ticks are paced at with publish_clock or '
              'lockstep (0 = as fast as the loop allows)', 0.0, 1.0e6),
    Parameter('lockstep', bool, False,
              'dynamics scenes: advance past tick t_k only once the commands stamped t_k '
              'arrived (sim time from 0)'),
    Parameter('lockstep_timeout', float, 1.0,
              's: wall time lockstep waits for a command; then it warns, holds the last '
              'command, counts it and advances', 0.0, 3600.0, low_open=True),
    # A real IMU: mount, world axes, levelling, bias, calibration (gyro scenes).
    Parameter('mount_rpy', tuple, (),
              'rad: [roll, pitch, yaw] of the IMU (sensor) frame in body_frame, as '
              'static_transform_publisher takes them ([] = from /tf_static when the Imu '
              'frame_id differs from body_frame, else none)', may_be_empty=True),
    Parameter('world_axes', str, 'enu',
              'axes of world_frame for levelling: enu (REP-103), ned or nwu',
              choices=('enu', 'ned', 'nwu')),
    Parameter('align_seconds', float, 1.0,
              's: rest averaged at start to level from gravity (Imu input with '
              'accelerometer; 0 = no levelling: the scene\'s attitude)', 0.0, 60.0),
    Parameter('align_timeout', float, 10.0,
              's: a body not at rest by then is levelled from its quietest window', 0.0,
              3600.0, low_open=True),
    Parameter('initial_yaw', float, 0.0,
              'rad: heading of the levelled attitude about the world z axis', -10.0, 10.0),
    Parameter('refine_bias_at_rest', bool, False,
              'after levelling, refine the gyro bias estimate whenever the body is at rest'),
    Parameter('calibration_file', str, '',
              'kalibr imu.yaml or imu-camera result, or a plain bias/scale/misalignment file, '
              'applied to every sample; its noise and sensor figures override the parameters\' '
              '("" = none)', may_be_empty=True),
    Parameter('calibration_imu_key', str, '',
              'the IMU of a kalibr result holding several (e.g. imu0; "" = the only one)',
              may_be_empty=True),
    # TF: the transform world_frame -> body_frame out, the sensor's mount in.
    Parameter('publish_tf', bool, False,
              'publish world_frame -> body_frame on /tf at the output stamps'),
    Parameter('tf_rate', float, 100.0,
              'Hz: most transforms per second of stamps on /tf (0 = one per output)', 0.0,
              1.0e6),
    Parameter('tf_timeout', float, 5.0,
              's: how long gyro samples wait for the mount body_frame -> sensor frame on '
              '/tf_static before they are dropped', 0.0, 3600.0, low_open=True),
    # -- attitude uncertainty (gyro scenes; see docs/uncertainty.md) ---------------------
    Parameter('covariance', bool, True,
              'propagate the attitude-error covariance (imu/data orientation_covariance, '
              'pose_with_covariance, 1-sigma tilt and yaw in /diagnostics)'),
    Parameter('gyroscope_noise_density', float, _GYRO_DEFAULTS.gyroscope_noise_density,
              'rad/s/sqrt(Hz): gyro white noise (kalibr name; default BMI088 typical)',
              0.0, 1.0),
    Parameter('gyroscope_random_walk', float, _GYRO_DEFAULTS.gyroscope_random_walk,
              'rad/s^2/sqrt(Hz): gyro bias random walk (kalibr name)', 0.0, 1.0),
    Parameter('gyroscope_turn_on_bias', float, _GYRO_DEFAULTS.gyroscope_turn_on_bias,
              'rad/s: 1-sigma gyro bias when no rest window estimates it', 0.0, 1.0),
    Parameter('gyroscope_scale_stddev', float, _GYRO_DEFAULTS.gyroscope_scale_stddev,
              '1: 1-sigma scale-factor error of each gyro axis', 0.0, 0.5),
    Parameter('gyroscope_misalignment_stddev', float,
              _GYRO_DEFAULTS.gyroscope_misalignment_stddev,
              '1: 1-sigma cross-axis (misalignment) error of each gyro axis pair', 0.0, 0.5),
    Parameter('initial_yaw_stddev', float, _GYRO_DEFAULTS.initial_yaw_stddev,
              'rad: 1-sigma of the initial heading (pi = unknown)', 0.0, 10.0),
    Parameter('set_pose_stddev', float, 0.01,
              'rad: 1-sigma per axis of the attitude after a set_pose without covariance',
              0.0, math.pi, low_open=True, read_only=False),
    Parameter('tilt_stddev_warn', float, 0.1745,
              'rad: /diagnostics warns while the 1-sigma tilt exceeds this (0 = never)',
              0.0, 10.0, read_only=False),
    # -- the attitude filter (scenes with an estimation section; see docs/estimation.md) ----
    Parameter('magnetic_declination', float, 0.0,
              'rad: magnetic north east of true north at the site (the imu/mag heading is then '
              'about true north)', -math.pi, math.pi),
    Parameter('magnetometer_calibration_file', str, '',
              'YAML file of the magnetometer\'s hard_iron [T], soft_iron (m = S b + h), '
              'noise_density, delay, timing ("" = none)', may_be_empty=True),
    Parameter('accelerometer_noise_density', float, _GYRO_DEFAULTS.accelerometer_noise_density,
              'm/s^2/sqrt(Hz): accelerometer white noise (kalibr name; default BMI088 typical)',
              0.0, 10.0),
    Parameter('accelerometer_random_walk', float, _SETTINGS.accelerometer_random_walk,
              'm/s^3/sqrt(Hz): accelerometer bias random walk (kalibr name)', 0.0, 10.0),
    Parameter('magnetometer_noise_density', float, _SETTINGS.magnetometer_noise_density,
              'T/sqrt(Hz): magnetometer white noise', 0.0, 1.0e-3),
    Parameter('attitude_measurement_period', float, 0.0,
              's: period P of attitude_measurement (a star tracker stamped at multiples of P): '
              'a gyro sample stamped t waits for the one stamped at the last multiple of P '
              'before t (0 = none waits)', 0.0, 3600.0),
)

_BY_NAME = {parameter.name: parameter for parameter in PARAMETERS}


def defaults() -> dict[str, Any]:
    """Parameter name → default."""
    return {p.name: p.default for p in PARAMETERS}


def values_problem(values: Mapping[str, Any], declared: Mapping[str, Parameter]) -> str:
    """The first value of ``values`` that is not a valid value of its parameter in
    ``declared`` (or names none), then distinct ``world_frame`` and ``body_frame``; ``''``
    when there is none. Strings are quoted as untrusted (:func:`_quoted`)."""
    for name, value in values.items():
        parameter = declared.get(name)
        if parameter is None:
            shown = f'`{name}`' if _plain(name) else _quoted(name)
            return f'Unknown parameter {shown}; parameters: {", ".join(declared)}'
        problem = parameter.problem(value)
        if problem:
            return problem
    if values.get('world_frame', 'world') == values.get('body_frame', 'base_link'):
        return (f'Expected `world_frame` and `body_frame` to differ, both are '
                f'{_quoted(values["world_frame"])}')
    return ''


def check_values(values: Mapping[str, Any], dynamics_step: float = 0.0,
                 max_steps_per_tick: int = 0) -> str:
    """Why these parameter values are unusable, or ``''`` when they are fine.

    Checks each value against its declaration, then the rules between parameters: distinct
    frames and, with the ``dynamics_step`` [s] of a dynamics scene, that a clock jump just
    below ``time_jump_threshold`` (integrated in one tick) stays within
    ``max_steps_per_tick`` steps.
    """
    problem = values_problem(values, _BY_NAME)
    if problem:
        return problem
    threshold = values.get('time_jump_threshold', 0.0)
    if dynamics_step > 0.0 and max_steps_per_tick and (
            threshold / dynamics_step > max_steps_per_tick):
        return (f'Expected parameter `time_jump_threshold` to be at most '
                f'{max_steps_per_tick * dynamics_step:g} s ({max_steps_per_tick} steps of '
                f'{dynamics_step:g} s in one tick), got {threshold!r}')
    return ''
