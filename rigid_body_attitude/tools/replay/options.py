"""Replay options: the node's parameters, derived from the one parameter table, and the
replay's own (topics, ground truth, outputs, storage).

The node's parameters are the entries of
:data:`rigid_body_attitude.session.parameters.PARAMETERS` but the TF ones: the same names,
defaults, bounds and checks (:func:`~rigid_body_attitude.session.parameters.check_values`).
:class:`ReplayOptions` declares them as typed fields (so ``mypy`` and readers see them); the
check at the end of this module fails at import when the fields and the table part ways.

``start_from_ground_truth`` is an explicit initial attitude: it wins over levelling, so the
replay then runs with ``align_seconds`` 0 (no levelling; the gyro bias, if any, comes from the
scene's ``gyro_bias`` effect and every sample is integrated from the first).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields
from typing import Any

from rigid_body_attitude.bag import STORAGES
from rigid_body_attitude.core.errors import InputError
from rigid_body_attitude.session.parameters import PARAMETERS, Parameter, check_values
from rigid_body_attitude.session.interface import NODE_INTERFACE

__all__ = ['NODE_PARAMETERS', 'REPLAYED_OUTPUTS', 'ReplayOptions', 'TF_PARAMETERS',
           'WALL_PARAMETERS', 'check_options']

#: Node parameters about TF only (a bag has no ``/tf_static`` to wait for, the replay writes
#: no ``/tf``): the replay does not take them.
TF_PARAMETERS = ('publish_tf', 'tf_rate', 'tf_timeout')
#: Node parameters about wall time only (a bag is replayed on its own time axis): the replay
#: does not take them. ``lockstep`` it takes: its ticks then follow the command stamps.
WALL_PARAMETERS = ('publish_clock', 'real_time_factor', 'lockstep_timeout')
#: The node's parameters the replay takes: every one of the table but :data:`TF_PARAMETERS`
#: and :data:`WALL_PARAMETERS`.
NODE_PARAMETERS: tuple[Parameter, ...] = tuple(
    p for p in PARAMETERS if p.name not in TF_PARAMETERS + WALL_PARAMETERS)
_DEFAULT = {p.name: p.default for p in NODE_PARAMETERS}
#: The node's outputs a replay can write (besides the topics a scene names for its simulated
#: sensors).
REPLAYED_OUTPUTS = tuple(dict.fromkeys(
    endpoint.name for endpoint in NODE_INTERFACE
    if endpoint.direction == 'out' and endpoint.replayed and not endpoint.named_by))


@dataclass(frozen=True)
class ReplayOptions:
    """Replay settings.

    The first fields are the node's parameters, with the node's names, defaults and bounds
    (:data:`NODE_PARAMETERS`; their meaning: ``propagation_node --help`` or the README's
    parameter tables). Receive times are the bag times. The replay's own:

    Attributes:
        gyro_topic: gyro topic (``''``: ``imu`` or else ``angular_velocity``, as the node).
        torque_topic: WrenchStamped commands.
        rotor_torque_topic: Vector3Stamped rotor motor torque commands.
        set_pose_topic: PoseStamped re-initialisations of the attitude (and position); a
            ``set_pose_with_covariance`` topic (PoseWithCovarianceStamped) is read as well.
        ground_truth_topic: QuaternionStamped or PoseStamped attitude to compare with.
        start_from_ground_truth: stamp [s] from which on the attitude starts from the ground
            truth (at the first output at or after it); ``None``: the scene's.
        outputs: output topics to write (empty: all the node publishes for the scene).
        storage: storage plugin of the output bag (``sqlite3`` or ``mcap``).
    """

    scene: str = _DEFAULT['scene']
    world_frame: str = _DEFAULT['world_frame']
    body_frame: str = _DEFAULT['body_frame']
    publish_rate: float = _DEFAULT['publish_rate']
    use_header_stamps: bool = _DEFAULT['use_header_stamps']
    constant_dt: float = _DEFAULT['constant_dt']
    max_dt: float = _DEFAULT['max_dt']
    time_jump_threshold: float = _DEFAULT['time_jump_threshold']
    max_angular_rate: float = _DEFAULT['max_angular_rate']
    torque_timeout: float = _DEFAULT['torque_timeout']
    integrator: str = _DEFAULT['integrator']
    step: float = _DEFAULT['step']
    lockstep: bool = _DEFAULT['lockstep']
    mount_rpy: tuple[float, ...] = _DEFAULT['mount_rpy']
    world_axes: str = _DEFAULT['world_axes']
    align_seconds: float = _DEFAULT['align_seconds']
    align_timeout: float = _DEFAULT['align_timeout']
    initial_yaw: float = _DEFAULT['initial_yaw']
    refine_bias_at_rest: bool = _DEFAULT['refine_bias_at_rest']
    calibration_file: str = _DEFAULT['calibration_file']
    calibration_imu_key: str = _DEFAULT['calibration_imu_key']
    covariance: bool = _DEFAULT['covariance']
    gyroscope_noise_density: float = _DEFAULT['gyroscope_noise_density']
    gyroscope_random_walk: float = _DEFAULT['gyroscope_random_walk']
    gyroscope_turn_on_bias: float = _DEFAULT['gyroscope_turn_on_bias']
    gyroscope_scale_stddev: float = _DEFAULT['gyroscope_scale_stddev']
    gyroscope_misalignment_stddev: float = _DEFAULT['gyroscope_misalignment_stddev']
    initial_yaw_stddev: float = _DEFAULT['initial_yaw_stddev']
    set_pose_stddev: float = _DEFAULT['set_pose_stddev']
    tilt_stddev_warn: float = _DEFAULT['tilt_stddev_warn']
    magnetic_declination: float = _DEFAULT['magnetic_declination']
    magnetometer_calibration_file: str = _DEFAULT['magnetometer_calibration_file']
    accelerometer_noise_density: float = _DEFAULT['accelerometer_noise_density']
    accelerometer_random_walk: float = _DEFAULT['accelerometer_random_walk']
    magnetometer_noise_density: float = _DEFAULT['magnetometer_noise_density']
    attitude_measurement_period: float = _DEFAULT['attitude_measurement_period']
    gyro_topic: str = ''
    torque_topic: str = NODE_INTERFACE.endpoint('torque').name
    rotor_torque_topic: str = NODE_INTERFACE.endpoint('rotor_torque').name
    set_pose_topic: str = NODE_INTERFACE.endpoint('set_pose').name
    ground_truth_topic: str = ''
    start_from_ground_truth: float | None = None
    outputs: tuple[str, ...] = ()
    storage: str = 'sqlite3'

    def parameters(self) -> dict[str, Any]:
        """The node's parameters by name (an ``int`` given for a double becomes a float, a
        list for a double array a tuple)."""
        values = {}
        for parameter in NODE_PARAMETERS:
            value = getattr(self, parameter.name)
            if parameter.type is float and type(value) is int:  # Python callers write 50
                value = float(value)
            elif parameter.type is tuple and isinstance(value, list):
                value = tuple(float(item) if type(item) is int else item for item in value)
            values[parameter.name] = value
        return values


def check_options(options: ReplayOptions) -> dict[str, Any]:
    """The node's parameter values of ``options``, checked as the node checks them, and the
    replay's own options; raises :class:`InputError` naming the bad value."""
    values = options.parameters()
    problem = check_values(values)
    if problem:
        raise InputError(problem)
    if options.storage not in STORAGES:
        raise InputError(f'Expected `storage` to be one of {sorted(STORAGES)}, got '
                         f'{options.storage!r}')
    start = options.start_from_ground_truth
    if start is not None:
        if not options.ground_truth_topic:
            raise InputError('Expected a ground-truth topic with `start_from_ground_truth`, '
                             'got none (use --ground-truth TOPIC)')
        if not math.isfinite(start):
            raise InputError(f'Expected `start_from_ground_truth` to be a finite stamp [s], '
                             f'got {start!r}')
        # The ground truth gives the initial attitude: no levelling (module docstring).
        values['align_seconds'] = 0.0
    return values


def _check_fields() -> None:
    """The dataclass declares the table's parameters, in its order, with its defaults."""
    declared = [(f.name, f.default) for f in fields(ReplayOptions)][:len(NODE_PARAMETERS)]
    table = [(p.name, p.default) for p in NODE_PARAMETERS]
    if declared != table:
        raise ImportError(f'ReplayOptions does not declare the node parameters of '
                          f'session/parameters.py: fields {declared}, table {table}')


_check_fields()
