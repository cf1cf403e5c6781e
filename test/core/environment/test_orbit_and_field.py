"""The orbit, the tilted dipole and IGRF-14 (ppigrf) against published values, and the scene
sections that choose them."""

from __future__ import annotations

import math
from datetime import datetime, timezone

import numpy as np
import pytest

from rigid_body_attitude.core.dynamics.scene import scene_from_mapping
from rigid_body_attitude.core.environment.igrf import IgrfField, igrf_earth_fixed
from rigid_body_attitude.core.environment.orbit import (
    CircularOrbit, greenwich_sidereal_angle)
from rigid_body_attitude.core.environment.tilted_dipole import TiltedDipoleField
from rigid_body_attitude.core.errors import SceneError

EPOCH = datetime(2025, 1, 1, tzinfo=timezone.utc)
ORBIT = CircularOrbit(6878137.0, math.radians(97.4), math.radians(30.0), 0.3, EPOCH)

#: IGRF-14 values of IAGA's reference program igrf14syn (year, geocentric radius [km],
#: colatitude [deg], east longitude [deg]; north X, east Y, down Z [nT]), as published in the
#: test file IGRF14_test_geocentric.txt of JuliaSpace's SatelliteToolboxGeomagneticField.jl.
IGRF14_REFERENCE = [
    (2012.2, 6455.32, 4.81, 190.69, 716.25521, 404.85533, 54898.32179),
    (2022.1, 7207.24, 46.47, 114.85, 17343.43338, -1717.75319, 33139.75721),
    (2027.9, 6518.00, 45.06, 138.29, 23401.96250, -4296.86589, 42525.97951),
    (2019.6, 7239.98, 41.70, 23.47, 14510.71642, 1050.50604, 30315.14930),
    (1985.1, 7386.16, 0.05, 0.32, 664.68242, -1268.46751, 37518.62935),
    (2014.9, 6862.91, 48.37, 185.20, 19498.65137, 2350.63958, 29187.72904),
    (2008.1, 7530.46, 66.75, 6.87, 18944.42424, -600.16078, 10833.55729),
    (1990.6, 6412.32, 34.51, 24.06, 16463.66462, 1223.60691, 46293.60423),
]


def decimal_year(year):
    whole = int(year)
    start = datetime(whole, 1, 1, tzinfo=timezone.utc)
    end = datetime(whole + 1, 1, 1, tzinfo=timezone.utc)
    return start + (end - start) * (year - whole)


@pytest.mark.parametrize('year, radius, colatitude, longitude, north, east, down',
                         IGRF14_REFERENCE)
def test_igrf_matches_the_reference_programs_values(year, radius, colatitude, longitude, north,
                                                    east, down):
    theta, phi = math.radians(colatitude), math.radians(longitude)
    position = 1000.0 * radius * np.array([[math.sin(theta) * math.cos(phi),
                                            math.sin(theta) * math.sin(phi), math.cos(theta)]])
    field = igrf_earth_fixed(position, decimal_year(year))[0] * 1e9
    # north = −θ̂, east = φ̂, down = −r̂ (Earth-fixed axes)
    radial = position[0] / np.linalg.norm(position[0])
    south = np.array([math.cos(theta) * math.cos(phi), math.cos(theta) * math.sin(phi),
                      -math.sin(theta)])
    eastward = np.array([-math.sin(phi), math.cos(phi), 0.0])
    # 0.1 nT: the reference interpolates in decimal years, ppigrf in days
    np.testing.assert_allclose([-field @ south, field @ eastward, -field @ radial],
                               [north, east, down], atol=0.1)


def test_the_tilted_dipole_is_igrf_cut_at_degree_one():
    import ppigrf
    for t in (0.0, 700.0, 2900.0):
        position = np.array(ORBIT.position_earth_fixed(t))
        r = np.linalg.norm(position)
        theta, phi = math.acos(position[2] / r), math.atan2(position[1], position[0])
        b_r, b_theta, b_phi = (float(np.ravel(x)[0]) for x in ppigrf.igrf_gc(
            r / 1000.0, math.degrees(theta), math.degrees(phi), datetime(2025, 1, 1),
            max_degree=1))
        dipole = np.array(TiltedDipoleField(ORBIT).field_earth_fixed(tuple(position))) * 1e9
        radial = position / r
        south = np.array([math.cos(theta) * math.cos(phi), math.cos(theta) * math.sin(phi),
                          -math.sin(theta)])
        eastward = np.array([-math.sin(phi), math.cos(phi), 0.0])
        np.testing.assert_allclose([dipole @ radial, dipole @ south, dipole @ eastward],
                                   [b_r, b_theta, b_phi], atol=1e-6)


def test_the_dipole_field_points_down_in_the_north_and_north_on_the_equator():
    polar = CircularOrbit(7e6, math.pi / 2, 0.0, math.pi / 2, EPOCH)  # over the north pole
    field = TiltedDipoleField(polar, (-30000.0, 0.0, 0.0))
    np.testing.assert_allclose(field.field_world(0.0), [0.0, 0.0, -2 * 30000e-9 * (
        6371200.0 / 7e6) ** 3], atol=1e-15)
    equatorial = CircularOrbit(7e6, 0.0, 0.0, 0.0, EPOCH)
    x, y, z = TiltedDipoleField(equatorial, (-30000.0, 0.0, 0.0)).field_world(100.0)
    assert z == pytest.approx(30000e-9 * (6371200.0 / 7e6) ** 3) and abs(x) + abs(y) < 1e-20


def test_igrf_along_the_orbit_is_interpolated_within_a_thousandth_of_a_nanotesla():
    field = IgrfField(ORBIT)
    times = np.linspace(0.0, ORBIT.period, 60) + 3.3
    error = max(np.linalg.norm(np.subtract(field.field_world(t), field.field_direct(t)))
                for t in times)
    assert error < 2e-12  # [T]: 0.002 nT of a 20 000 to 50 000 nT field
    assert 1.8e-5 < np.linalg.norm(field.field_world(0.0)) < 5.5e-5


def test_the_orbit_is_circular_with_its_plane_and_sidereal_time():
    assert ORBIT.period == pytest.approx(5676.98, abs=0.01)
    for t in (0.0, 1000.0):
        assert np.linalg.norm(ORBIT.position(t)) == pytest.approx(6878137.0)
        assert abs(np.dot(ORBIT.radial(t), ORBIT.normal)) < 1e-15
    assert math.degrees(math.acos(ORBIT.normal[2])) == pytest.approx(97.4)
    # GMST at J2000.0 is 280.46062 deg (Vallado 2013, eq. 3-45 at T = 0)
    j2000 = datetime(2000, 1, 1, 12, tzinfo=timezone.utc)
    assert math.degrees(greenwich_sidereal_angle(j2000)) == pytest.approx(280.46062, abs=1e-5)
    # the Earth-fixed position keeps the latitude, turns the longitude back by θ
    assert ORBIT.position_earth_fixed(0.0)[2] == ORBIT.position(0.0)[2]


def spacecraft(**sections):
    return {'rate_source': 'dynamics', 'body': {'inertia': {'moments': [1.0, 2.0, 2.5]}},
            **sections}


def test_scene_sections_choose_the_field_and_feed_gravity_gradient():
    scene = scene_from_mapping(spacecraft(
        orbit={'altitude': 500000.0, 'inclination_deg': 97.4, 'epoch': '2025-01-01T00:00:00Z'},
        magnetic_field={'model': 'tilted_dipole'}, effects=['gravity_gradient']))
    assert isinstance(scene.magnetic_field, TiltedDipoleField)
    gradient = scene.build_effects()[0]
    assert gradient.radial(123.0) == pytest.approx(scene.orbit.radial(123.0))
    local = scene_from_mapping(spacecraft(magnetic_field={
        'model': 'local', 'intensity': 5e-5, 'inclination_deg': 60.0}))
    assert local.magnetic_field.field_world(0.0)[2] == pytest.approx(-5e-5 * math.sin(
        math.radians(60.0)))


@pytest.mark.parametrize('sections, match', [
    ({'orbit': {'inclination_deg': 10.0}}, 'one of altitude or radius'),
    ({'orbit': {'altitude': 5e5, 'radius': 7e6}}, 'one of altitude or radius'),
    ({'orbit': {'radius': 1000.0}}, 'orbit.radius'),
    ({'orbit': {'altitude': 5e5, 'inclination_deg': 200.0}}, 'orbit.inclination_deg'),
    ({'orbit': {'altitude': 5e5, 'epoch': 'yesterday'}}, 'orbit.epoch'),
    ({'orbit': {'altitude': 5e5, 'epoch': '1850-01-01T00:00:00Z'}}, 'orbit.epoch'),
    ({'orbit': {'altitude': 5e5, 'speed': 1}}, "Unknown key 'speed' in orbit"),
    ({'orbit': [1, 2]}, 'Expected orbit to be a mapping'),
    ({'magnetic_field': {'model': 'tilted_dipole'}}, 'needs an orbit: section'),
    ({'magnetic_field': {'model': 'wmm'}}, 'magnetic_field.model'),
    ({'magnetic_field': {'model': 'local', 'intensity': 1.0}}, 'magnetic_field.intensity'),
    ({'orbit': {'altitude': 5e5, 'epoch': '2040-01-01T00:00:00Z'},
      'magnetic_field': {'model': 'igrf'}}, 'within 1900 to 2030'),
    ({'orbit': {'altitude': 5e5}, 'magnetic_field': {'model': 'tilted_dipole',
                                                     'coefficients_nT': [0, 0, 0]}},
     'coefficients_nT'),
    ({'orbit': {'altitude': 5e5}, 'effects': [{'gravity_gradient': {'orbit_radius': 7e6}}]},
     "parameter 'orbit_radius' is given by the scene's orbit"),
    ({'effects': [{'magnetorquers': {'max_dipole': 0.2}}]}, 'magnetic_field: section'),
])
def test_hostile_orbit_and_field_sections_are_one_scene_error(sections, match):
    with pytest.raises(SceneError, match=match) as raised:
        scene_from_mapping(spacecraft(**sections))
    assert '\n' not in str(raised.value) and len(str(raised.value)) < 400
