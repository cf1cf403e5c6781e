"""Tests of earth_rate: ω = ω_measured − R(q)ᵀ Ω_E (0, cos φ, sin φ) in an ENU world frame.

A gyro at rest on the Earth measures the Earth's rotation; with the correction the strapdown
attitude holds still (to round-off: each step multiplies by exp of a ~1e−21 rad rotation and
renormalises, ≤ 2.2e−16 per step), without it it drifts by Ω_E t.
"""

import math
import re

import numpy as np
import pytest

from rigid_body_attitude.core.attitude import quaternion as quat
from rigid_body_attitude.core.dynamics.effects import BodyProperties, EFFECTS
from rigid_body_attitude.core.dynamics.effects.earth_rate import WGS84_EARTH_RATE
from rigid_body_attitude.core.errors import SceneError
from rigid_body_attitude.core.dynamics.inertia import Inertia
from rigid_body_attitude.core.propagator import GyroPropagator
from rigid_body_attitude.core.dynamics.scene import scene_from_mapping
from rigid_body_attitude.session.stream import GyroStream

BODY = BodyProperties(Inertia([1.0, 1.0, 1.0]), 1.0)
LATITUDE = 48.1
ATTITUDE = quat.normalize([0.7, -0.2, 0.4, 0.55])   # how the gyro sits in the ENU frame


def earth_rate_world(latitude_degrees):
    latitude = math.radians(latitude_degrees)
    return WGS84_EARTH_RATE * np.array([0.0, math.cos(latitude), math.sin(latitude)])


def test_correction_hand_values():
    equator = EFFECTS['earth_rate']({'latitude': 0.0}, BODY)
    corrected = equator.corrected_rate(0.0, quat.identity(), np.array([0.1, 0.2, 0.3]))
    np.testing.assert_allclose(corrected, [0.1, 0.2 - WGS84_EARTH_RATE, 0.3], rtol=1e-15)
    pole = EFFECTS['earth_rate']({'latitude': 90.0, 'rate': 1e-4}, BODY)
    # body turned 90° about x: body y points along world z (the pole axis), so a gyro at
    # rest reads (0, Ω, 0) and the correction subtracts exactly that
    turned = quat.exp([0.5 * np.pi, 0.0, 0.0])
    np.testing.assert_allclose(pole.corrected_rate(0.0, turned, np.zeros(3)), [0.0, -1e-4, 0.0],
                               atol=1e-4 * 4e-16)   # cos 90° and the rotation: round-off


def run_at_rest(effects, seconds=600.0, rate_hz=10.0):
    scene = scene_from_mapping({'rate_source': 'gyro', 'body': {'inertia': {'moments': [1, 1, 1]}},
                                'initial_state': {'attitude': ATTITUDE.tolist()},
                                'effects': effects})
    propagator = GyroPropagator(scene)
    stream = GyroStream(propagator, max_dt=1.0, time_jump_threshold=10.0)
    measured = quat.rotate_inverse(ATTITUDE, earth_rate_world(LATITUDE))
    count = int(seconds * rate_hz)
    for k in range(count + 1):
        assert stream.add(round(k * 1e9 / rate_hz), measured).accepted
    return propagator, count


def test_gyro_at_rest_measuring_earth_rate_holds_still():
    propagator, count = run_at_rest([{'earth_rate': {'latitude': LATITUDE}}])
    assert np.max(np.abs(propagator.state.omega_body)) <= 1e-20    # Ω_E × round-off
    assert quat.attitude_error(propagator.state.attitude, ATTITUDE) <= count * 2.2e-16
    # the same samples without the correction turn the attitude by Ω_E t about the Earth axis
    uncorrected, _ = run_at_rest([])
    assert quat.attitude_error(uncorrected.state.attitude, ATTITUDE) == pytest.approx(
        WGS84_EARTH_RATE * 600.0, rel=1e-9)


@pytest.mark.parametrize('latitude', [91.0, -90.5])
def test_latitude_out_of_range(latitude):
    with pytest.raises(SceneError, match=re.escape(
            "Effect 'earth_rate': parameter 'latitude' must be a latitude in degrees within "
            f"[-90, 90], got {latitude}")):
        EFFECTS['earth_rate']({'latitude': latitude}, BODY)


def test_not_for_dynamics_scenes():
    with pytest.raises(SceneError, match=re.escape(
            "Effect 'earth_rate' applies to gyro scenes, not to rate_source 'dynamics'")):
        scene_from_mapping({'rate_source': 'dynamics', 'body': {'inertia': {'moments': [1, 1, 1]}},
                            'effects': [{'earth_rate': {'latitude': 10.0}}]})
