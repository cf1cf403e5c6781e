"""The ``attitude_controller``'s parameters, declared once, and their checks.

``world_frame`` and ``body_frame`` are the propagation node's own declarations
(:data:`~rigid_body_attitude.session.parameters.PARAMETERS`), so the two nodes agree on them;
the rest belong to the controller. ``attitude_controller --help``, the node's ROS descriptors
and :func:`check_controller_values` derive from :data:`CONTROLLER_PARAMETERS`.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

from rigid_body_attitude.session.parameters import Parameter, PARAMETERS, values_problem

__all__ = ['CONTROLLER_PARAMETERS', 'RENAMED_CONTROLLER_PARAMETERS', 'STATE_INPUTS',
           'UNIT_TOLERANCE', 'check_controller_values', 'controller_defaults',
           'renamed_problem']

#: Largest ``| |q| − 1 |`` of a quaternion taken as an attitude (parameter or message).
UNIT_TOLERANCE = 1e-3

_NODE = {parameter.name: parameter for parameter in PARAMETERS}

#: ``state_input`` → the quantities of the controller's interface
#: (:data:`~rigid_body_attitude.session.interface.CONTROLLER_INTERFACE`) it subscribes to.
STATE_INPUTS: dict[str, tuple[str, ...]] = {
    'odom': ('odometry',),
    'orientation_twist': ('attitude', 'twist'),
}

#: Every parameter of the controller, in the order ``--help`` and the README list them.
CONTROLLER_PARAMETERS: tuple[Parameter, ...] = (
    _NODE['world_frame'],
    _NODE['body_frame'],
    Parameter('state_input', str, 'odom',
              "the plant's state: odom (nav_msgs/Odometry, pose and twist in one message) or "
              'orientation_twist (QuaternionStamped and TwistStamped, paired by stamp)',
              choices=tuple(STATE_INPUTS)),
    Parameter('target_rpy', tuple, (),
              'rad: [roll, pitch, yaw] of the target attitude of body_frame in world_frame, as '
              'static_transform_publisher takes them ([] = target_quaternion_xyzw, or the '
              'identity)',
              -10.0, 10.0, may_be_empty=True, read_only=False),
    Parameter('target_quaternion_xyzw', tuple, (),
              '[x, y, z, w] of the target attitude, of unit norm ([] = target_rpy, or the '
              'identity: body axes on world axes)', -2.0, 2.0, may_be_empty=True,
              read_only=False, length=4),
    Parameter('kp', float, 0.1, 'N m: gain on the vector part of the attitude error', 0.0, 1e6,
              read_only=False),
    Parameter('kd', float, 0.04, 'N m s: gain on the body rate', 0.0, 1e6, read_only=False),
    Parameter('torque_limit', float, 0.0,
              'N m: each torque component clipped to +-this (0 = no limit)', 0.0, 1e12,
              read_only=False),
    Parameter('actuator', str, 'body',
              'what the controller drives: body (torque, WrenchStamped), reaction_wheels (the '
              "scene's wheel array, wheels/command: JointState efforts) or magnetorquers "
              '(B-dot detumbling on the measured field, dipole: Vector3Stamped)',
              choices=('body', 'reaction_wheels', 'magnetorquers')),
    Parameter('scene', str, '',
              "the plant's scene (built-in name or file) whose reaction_wheels the controller "
              'drives (actuator reaction_wheels)', may_be_empty=True),
    Parameter('control_period', float, 0.0,
              's: the torque is recomputed when the input stamps reach a multiple of this and '
              'held in between (0 = at every tick)', 0.0, 3600.0, read_only=False),
    Parameter('bdot_gain', float, 0.0,
              'A m2 s/T: k of B-dot, m = -k dB/dt from the magnetometer (actuator '
              'magnetorquers: > 0)', 0.0, 1e12),
    Parameter('dumping_gain', float, 0.0,
              "1/s: k of the rods' momentum dumping, m = k (h_w x B)/|B|^2 from wheels/state "
              'and the magnetometer (actuator reaction_wheels; 0 = a zero dipole)', 0.0, 1e6),
    Parameter('magnetometer_period', float, 0.0,
              's: period P of the magnetometer (imu/mag): a tick stamped t uses its sample '
              "stamped floor(t/P) P (0 = the scene's sensors.magnetometer rate)", 0.0, 3600.0),
    Parameter('magnetometer_mount_rpy', tuple, (),
              'rad: [roll, pitch, yaw] of the magnetometer frame in body_frame ([] = from '
              '/tf_static, none for samples in body_frame)', -10.0, 10.0, may_be_empty=True),
)

_BY_NAME = {parameter.name: parameter for parameter in CONTROLLER_PARAMETERS}

#: Retired parameter names → the names in use: a value given for a retired name is refused
#: with a message naming its successor.
RENAMED_CONTROLLER_PARAMETERS = {'target_quaternion': 'target_quaternion_xyzw'}


def renamed_problem(name: str) -> str:
    """Why the retired parameter ``name`` cannot be set."""
    return (f'Parameter `{name}` is named `{RENAMED_CONTROLLER_PARAMETERS[name]}` '
            f'(its components in the order of the name): set that one instead')


def controller_defaults() -> dict[str, Any]:
    """Parameter name → default."""
    return {p.name: p.default for p in CONTROLLER_PARAMETERS}


def check_controller_values(values: Mapping[str, Any]) -> str:
    """Why these parameter values are unusable, or ``''`` when they are fine.

    Each value against its declaration, then: a ``scene`` with ``actuator``
    ``reaction_wheels``, a ``bdot_gain`` with ``magnetorquers``, ``reaction_wheels`` with a
    ``dumping_gain``, at most one of ``target_rpy`` and ``target_quaternion_xyzw``, and a
    target quaternion of unit norm within :data:`UNIT_TOLERANCE`.
    """
    problem = values_problem(values, _BY_NAME)
    if problem:
        return problem
    if values.get('actuator') == 'reaction_wheels' and not values.get('scene'):
        return ('Expected parameter `scene` (the plant\'s scene, with its reaction_wheels) '
                'with `actuator` reaction_wheels, got none')
    if values.get('actuator') == 'magnetorquers' and not values.get('bdot_gain', 0.0) > 0.0:
        return ('Expected parameter `bdot_gain` > 0 (A m2 s/T) with `actuator` magnetorquers '
                '(B-dot), got 0.0')
    if values.get('dumping_gain', 0.0) > 0.0 and values.get('actuator') != 'reaction_wheels':
        return ('Expected `actuator` reaction_wheels with parameter `dumping_gain` > 0 (the '
                f'rods dump the wheels\' momentum), got actuator {values.get("actuator")!r}')
    if values.get('target_rpy') and values.get('target_quaternion_xyzw'):
        return ('Expected at most one of `target_rpy` and `target_quaternion_xyzw`, got both: '
                f'{list(values["target_rpy"])} and {list(values["target_quaternion_xyzw"])}')
    xyzw = values.get('target_quaternion_xyzw') or (0.0, 0.0, 0.0, 1.0)
    norm = math.sqrt(sum(value * value for value in xyzw))
    if abs(norm - 1.0) > UNIT_TOLERANCE:
        return (f'Expected parameter `target_quaternion_xyzw` to have norm 1 (within '
                f'{UNIT_TOLERANCE:g}), got norm {norm:.6g} for {list(xyzw)}')
    return ''
