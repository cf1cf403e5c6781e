"""Tests of the constant_torque effect: M_body = M (body frame) or R(q)ᵀ M (world frame).

The dynamics closed form about a principal axis (θ = ω₀ t + M t²/(2 J_k)) is in
test_dynamics.py; here the frames are checked by hand and, for a world-fixed torque, through
the law dH/dt = M_world for any body: the world angular momentum grows linearly.
"""

import re

import numpy as np
import pytest

from rigid_body_attitude.core.attitude import quaternion as quat
from rigid_body_attitude.core.dynamics.effects import BodyProperties, EFFECTS
from rigid_body_attitude.core.errors import SceneError
from rigid_body_attitude.core.dynamics.inertia import Inertia
from rigid_body_attitude.core.propagator import DynamicsPropagator
from rigid_body_attitude.core.dynamics.scene import scene_from_mapping

BODY = BodyProperties(Inertia([1.0, 2.0, 3.0]), 1.0)
QUARTER_TURN_Z = quat.exp([0.0, 0.0, 0.5 * np.pi])


def test_body_frame_torque_is_returned_as_is():
    effect = EFFECTS['constant_torque']({'torque': [0.1, -0.2, 0.3]}, BODY)
    for attitude in (quat.identity(), QUARTER_TURN_Z):
        np.testing.assert_array_equal(effect.torque_body(1.0, attitude, np.ones(3)),
                                      [0.1, -0.2, 0.3])


def test_world_frame_torque_hand_value():
    # body turned 90° about z: world x is body −y, world y is body x
    effect = EFFECTS['constant_torque']({'torque': [1.0, 2.0, 3.0], 'frame': 'world'}, BODY)
    np.testing.assert_allclose(effect.torque_body(0.0, QUARTER_TURN_Z, np.zeros(3)),
                               [2.0, -1.0, 3.0], atol=4e-16)


def test_world_torque_grows_world_momentum_linearly():
    # dH/dt = M_world whatever the body does: H(t) = H₀ + M t. A tumbling triaxial body,
    # RK4 at 1 ms for 2 s (|ω| ≲ 2): the O(h⁴) error is ~1e−13 (bound 1e−11)
    torque = np.array([0.05, -0.1, 0.2])
    scene = scene_from_mapping({
        'rate_source': 'dynamics', 'step': 0.001, 'body': {'inertia': {'moments': [1, 2, 2.5]}},
        'initial_state': {'attitude': [0.9, 0.3, -0.2, 0.1], 'omega_body': [0.4, 1.5, -0.3]},
        'effects': [{'constant_torque': {'torque': torque.tolist(), 'frame': 'world'}}]})
    propagator = DynamicsPropagator(scene)
    initial = propagator.world_momentum()
    propagator.advance_to(2.0)
    np.testing.assert_allclose(propagator.world_momentum(), initial + 2.0 * torque, atol=1e-11)
    # the body really turned: a body-fixed torque would not give this
    assert quat.attitude_error(propagator.state.attitude, scene.initial_attitude) > 1.0


@pytest.mark.parametrize('params, message', [
    ({}, "Effect 'constant_torque': missing parameter 'torque'"),
    ({'torque': [1, 2, 3], 'frame': 'inertial'},
     "parameter 'frame' must be 'body' or 'world', got 'inertial'"),
    ({'torque': [1, 'x', 3]}, "parameter 'torque' must be a number, got [1, 'x', 3]"),
])
def test_bad_parameters(params, message):
    with pytest.raises(SceneError, match=re.escape(message)):
        EFFECTS['constant_torque'](params, BODY)
