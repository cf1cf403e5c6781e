"""Tests of gravity_gradient: M = 3μ/r³ r̂_b × (J r̂_b), r̂_b = R(q)ᵀ r̂_w(t) on a circular orbit.

The torque is checked against the formula evaluated independently (rotation matrix, explicit
cross product) to 1e−12 relative, as Basilisk's GravityGradientEffector test does (Kenneally,
Piggott & Schaub, "Basilisk: a flexible, scalable and modular astrodynamics simulation framework",
J. Aerosp. Inf. Syst. 17(9), 2020); the orbit geometry (unit radial vector turning at the mean
motion n = √(μ/r³) about the
normal) and the energy balance of a propagated satellite are checked too.
"""

import math
import re

import numpy as np
import pytest

from rigid_body_attitude.core.attitude import quaternion as quat
from rigid_body_attitude.core.dynamics.effects import BodyProperties, EFFECTS
from rigid_body_attitude.core.dynamics.effects.gravity_gradient import EARTH_MU
from rigid_body_attitude.core.errors import SceneError
from rigid_body_attitude.core.dynamics.inertia import Inertia
from rigid_body_attitude.core.propagator import DynamicsPropagator
from rigid_body_attitude.core.dynamics.scene import load_scene

RADIUS = 7.0e6
SATELLITE = BodyProperties(Inertia([500.0, 200.0, 300.0]), 500.0)


def effect(**params):
    return EFFECTS['gravity_gradient']({'orbit_radius': RADIUS, **params}, SATELLITE)


def hand_torque(inertia, attitude, radial_world, mu=EARTH_MU, radius=RADIUS):
    radial_body = quat.to_matrix(attitude).T @ radial_world
    tensor = inertia.tensor
    j_r = tensor @ radial_body
    cross = np.array([radial_body[1] * j_r[2] - radial_body[2] * j_r[1],
                      radial_body[2] * j_r[0] - radial_body[0] * j_r[2],
                      radial_body[0] * j_r[1] - radial_body[1] * j_r[0]])
    return 3.0 * mu / radius ** 3 * cross


def test_orbit_geometry():
    normal = np.array([0.0, -0.6, 0.8])
    gradient = effect(orbit_normal=[0.0, -3.0, 4.0], initial_anomaly=0.4)
    mean_motion = math.sqrt(EARTH_MU / RADIUS ** 3)
    assert gradient.mean_motion == pytest.approx(mean_motion, rel=1e-15)
    start = gradient.radial_world(0.0)
    for t in (0.0, 100.0, 1234.5):
        radial = gradient.radial_world(t)
        assert np.linalg.norm(radial) == pytest.approx(1.0, abs=4e-16)
        assert abs(radial @ normal) <= 4e-16
    later = gradient.radial_world(1234.5)
    # turned by n t about the orbit normal, counter-clockwise seen from the normal
    angle = math.atan2(np.cross(start, later) @ normal, start @ later)
    assert angle == pytest.approx(mean_motion * 1234.5, rel=1e-13)
    # initial_anomaly is measured the same way
    assert np.allclose(gradient.radial_world(0.0), effect(orbit_normal=[0, -3, 4]).radial_world(
        0.4 / mean_motion), atol=1e-15)


@pytest.mark.parametrize('seed', range(5))
def test_torque_matches_formula(seed):
    rng = np.random.default_rng(seed)
    attitude = quat.normalize(rng.normal(size=4))
    tensor = Inertia.box(500.0, [1.0, 2.0, 1.5], about='corner')
    gradient = EFFECTS['gravity_gradient']({'orbit_radius': RADIUS, 'initial_anomaly': 1.1,
                                            'orbit_normal': [0.3, 0.1, 1.0]},
                                           BodyProperties(tensor, 500.0))
    t = rng.uniform(0.0, 6000.0)
    torque = gradient.torque_body(t, attitude, np.zeros(3))
    expected = hand_torque(tensor, attitude, gradient.radial_world(t))
    np.testing.assert_allclose(torque, expected, rtol=1e-12, atol=1e-12 * np.linalg.norm(expected))
    assert np.linalg.norm(expected) > 1e-5      # a real torque: ~3n² ΔJ ≈ 1e−3 N m


def test_torque_hand_value_and_equilibrium():
    # body x along the radial direction: r̂_b = e_x, J r̂_b ∥ e_x, no torque (equilibrium) up
    # to round-off of the torque scale 3n² J_max ≈ 1.7e−3 N m
    gradient = effect()
    n2 = EARTH_MU / RADIUS ** 3
    radial = gradient.radial_world(0.0)
    aligned = quat.from_matrix(np.column_stack([radial, np.cross([0, 0, 1.0], radial),
                                                [0, 0, 1.0]]))
    assert np.linalg.norm(gradient.torque_body(0.0, aligned, np.zeros(3))) <= 1e-15 * (
        3.0 * n2 * 500.0)
    # tilted by 0.1 rad about the orbit normal (body z): M_z = 3n² (J_y − J_x) sin θ cos θ
    tilted = quat.multiply(aligned, quat.exp([0.0, 0.0, 0.1]))
    expected_z = 3.0 * n2 * (200.0 - 500.0) * math.sin(-0.1) * math.cos(0.1)
    torque = gradient.torque_body(0.0, tilted, np.zeros(3))
    assert torque[2] == pytest.approx(expected_z, rel=1e-12)
    assert np.all(np.abs(torque[:2]) <= 1e-12 * abs(expected_z))


def test_satellite_scene_energy_balance():
    # 100 s of the shipped scene: the torque's work closes T − T₀ − W to round-off
    propagator = DynamicsPropagator(load_scene('gravity_gradient_satellite'))
    propagator.advance_to(100.0)
    diagnostics = propagator.diagnostics()
    assert abs(diagnostics.energy_balance_residual) <= 1e-12 * diagnostics.kinetic_energy
    assert abs(diagnostics.energy_drift) > 1e-6       # the torque did change T
    assert quat.norm_error(propagator.state.attitude) <= 4.4e-16


def test_zero_orbit_normal_rejected():
    with pytest.raises(SceneError, match=re.escape(
            "Effect 'gravity_gradient': parameter 'orbit_normal' must be non-zero, "
            "got [0.0, 0.0, 0.0]")):
        effect(orbit_normal=[0.0, 0.0, 0.0])
