"""Tests of uniform_gravity: the weight m g on the centre of mass, world frame (ENU default).

The motion it causes (free fall, x = x₀ + v₀ t + g t²/2) is tested with translation in
test_translation.py; here the force itself and its scene rules.
"""

import re

import numpy as np
import pytest

from rigid_body_attitude.core.attitude import quaternion as quat
from rigid_body_attitude.core.dynamics.effects import BodyProperties, EFFECTS
from rigid_body_attitude.core.errors import SceneError
from rigid_body_attitude.core.dynamics.inertia import Inertia
from rigid_body_attitude.core.dynamics.scene import scene_from_mapping

BODY = BodyProperties(Inertia([1.0, 1.0, 1.0]), 2.5)


def test_weight_is_world_frame_and_attitude_independent():
    gravity = EFFECTS['uniform_gravity']({}, BODY)
    for attitude in (quat.identity(), quat.exp([0.4, -1.0, 2.0])):
        np.testing.assert_allclose(gravity.force_world(3.0, attitude), [0.0, 0.0, -24.516625],
                                   rtol=1e-15)
    moon = EFFECTS['uniform_gravity']({'gravity': [0.0, -1.62, 0.0]}, BODY)
    np.testing.assert_allclose(moon.force_world(0.0, quat.identity()), [0.0, -4.05, 0.0],
                               rtol=1e-15)


def test_needs_translation():
    with pytest.raises(SceneError, match=re.escape(
            "Effect 'uniform_gravity' needs effect 'translation' in the same scene")):
        scene_from_mapping({'rate_source': 'dynamics',
                            'body': {'inertia': {'moments': [1, 1, 1]}},
                            'effects': ['uniform_gravity']})


def test_bad_gravity():
    with pytest.raises(SceneError, match=re.escape(
            "Effect 'uniform_gravity': parameter 'gravity' must be a finite number, "
            "got [0, 0, inf]")):
        EFFECTS['uniform_gravity']({'gravity': [0, 0, float('inf')]}, BODY)
