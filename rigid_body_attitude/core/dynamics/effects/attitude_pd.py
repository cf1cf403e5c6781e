"""attitude_pd: a quaternion-feedback PD attitude controller in the loop, sampled and held.

Every ``control_period`` seconds (a whole number of the scene's steps) the controller reads
the body's attitude ``q`` and rate ``ω`` and commands the body torque of
:func:`~rigid_body_attitude.core.control.quaternion_pd.pd_torque_body`,
``τ = −k_p sign(q_err,w) q_err,xyz − k_d ω`` with ``q_err = q_target* ⊗ q``, each component
clipped to ``±torque_limit``; the torque is held until the next sample (a zero-order hold,
as a digital controller's actuator command). Source: the regulator of B. Wie, H. Weiss and
A. Arapostathis, "Quaternion feedback regulator for spacecraft eigenaxis rotations",
J. Guidance, Control, and Dynamics 12(3):375-380, 1989. The same law, on the same samples,
runs in the single-body propagator and in the batch engine (every body with its own held
torque and, when dispersed, its own gains, limit and target).

Parameters: ``kp`` [N m] and ``kd`` [N m s] (one number or one per body axis, ≥ 0),
``torque_limit`` [N m] (one or three, ≥ 0; 0: none), ``control_period`` [s],
``target_rpy`` [rad] (roll, pitch, yaw of the target attitude: ``Rz(yaw) Ry(pitch)
Rx(roll)``, as tf2's ``setRPY``; default the identity, body axes on world axes) or
``target_attitude_wxyz`` (w, x, y, z; normalised; replaces ``target_rpy``), ``actuator``:
``body`` (default: the torque acts on the body as given) or ``reaction_wheels`` (the torque is
allocated over the scene's ``reaction_wheels``, which apply it within their limits).
"""

from __future__ import annotations

from typing import Any, ClassVar

import numpy as np

from rigid_body_attitude.core.attitude import quaternion
from rigid_body_attitude.core.control.quaternion_pd import pd_torque_body, pd_torque_floats
from rigid_body_attitude.core.dynamics.effects.base import (
    as_quat, as_vec, BatchChunk, BodyProperties, FloatArray, nonnegative, Parameter, positive,
    Quat, real, register, REQUIRED, vector3, Vec)
from rigid_body_attitude.core.dynamics.effects.sampled import SampledTorque


def _axes(value: Any) -> float | FloatArray:
    """One number ≥ 0, or a list of 3."""
    if isinstance(value, (list, tuple)):
        if len(value) != 3:
            raise TypeError('one number or a list of 3 numbers >= 0')
        return np.array([nonnegative(item) for item in value])
    return nonnegative(value)


def _attitude(value: Any) -> FloatArray | None:
    """Empty (none), or 4 numbers (w, x, y, z) of a non-zero quaternion, normalised."""
    if isinstance(value, (list, tuple)) and not value:
        return None
    if not isinstance(value, (list, tuple)) or len(value) != 4:
        raise TypeError('a list of 4 numbers (w, x, y, z)')
    q = np.array([real(item) for item in value])
    scale = float(np.max(np.abs(q)))
    if not scale > 1e-12:
        raise ValueError('a non-zero quaternion')
    scaled = q / scale  # normalised without squaring numbers up to 1e75
    result: FloatArray = scaled / np.linalg.norm(scaled)
    return result


def _actuator(value: Any) -> str:
    """``body`` or ``reaction_wheels``."""
    if value not in ('body', 'reaction_wheels'):
        raise ValueError('body or reaction_wheels')
    return str(value)


def _per_body(value: Any) -> float | FloatArray:
    """A batch parameter as the law takes it: a float, or (bodies or 1, 3)."""
    array = np.asarray(value, dtype=np.float64)
    if array.ndim == 0:
        return float(array)
    if array.ndim == 1:
        return np.repeat(array[:, None], 3, axis=1)
    result: FloatArray = array.T
    return result


@register
class AttitudePD(SampledTorque):
    """Quaternion-feedback PD controller, sampled every ``control_period`` and held."""

    name = 'attitude_pd'
    description = ('quaternion-feedback PD torque towards a target attitude, sampled every '
                   'control_period and held, clipped to torque_limit')
    parameters = {
        'kp': Parameter(_axes, REQUIRED, 'proportional gain(s) [N m]'),
        'kd': Parameter(_axes, REQUIRED, 'derivative gain(s) [N m s]'),
        'torque_limit': Parameter(_axes, 0.0, 'largest torque per body axis [N m]; 0: none'),
        'control_period': Parameter(positive, REQUIRED,
                                    'sample period [s], a whole number of steps'),
        'target_rpy': Parameter(vector3, [0.0, 0.0, 0.0],
                                'target roll, pitch, yaw [rad] (Rz Ry Rx)'),
        'target_attitude_wxyz': Parameter(_attitude, [],
                                          'target (w, x, y, z); replaces target_rpy'),
        'actuator': Parameter(_actuator, 'body',
                              'body (the torque itself) or reaction_wheels (allocated)'),
    }
    shared_parameters: ClassVar[frozenset[str]] = frozenset({'control_period',
                                                             'target_attitude_wxyz',
                                                             'actuator'})
    renamed_parameters: ClassVar[dict[str, str]] = {'target_attitude': 'target_attitude_wxyz'}

    def __init__(self, params: dict[str, Any], body: BodyProperties) -> None:
        """Keep gains, limit and target as plain floats for the single-body path."""
        super().__init__(params, body)
        self.gains = (as_vec(np.broadcast_to(self.params['kp'], (3,))),
                      as_vec(np.broadcast_to(self.params['kd'], (3,))),
                      as_vec(np.broadcast_to(self.params['torque_limit'], (3,))))
        given = self.params['target_attitude_wxyz']
        self.target: Quat = as_quat(given if given is not None else
                                    quaternion.from_rpy(self.params['target_rpy']))
        self.actuator = self.params['actuator']
        self.applies_torque = self.actuator == 'body'

    @property
    def period(self) -> float:
        """``control_period`` [s]."""
        return float(self.params['control_period'])

    def control(self, t: float, q: Quat, omega: Vec) -> Vec:
        """The law on plain floats."""
        kp, kd, limit = self.gains
        return pd_torque_floats(q, omega, self.target, kp, kd, limit)

    def control_batch(self, t: float, q: FloatArray, omega: FloatArray, chunk: BatchChunk,
                      out: FloatArray) -> None:
        """The law on every body of the chunk (its own gains, limit and target if
        dispersed)."""
        parameters = chunk.parameters
        if self.params['target_attitude_wxyz'] is not None:
            target = np.array(self.target)
        else:
            target = quaternion.from_rpy(np.asarray(parameters['target_rpy']).T)
        torque = pd_torque_body(q.T, omega.T, target, _per_body(parameters['kp']),
                                _per_body(parameters['kd']),
                                _per_body(parameters['torque_limit']))
        out[:] = torque.T
