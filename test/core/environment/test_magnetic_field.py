"""The local magnetic field in ENU, NED and NWU world axes."""

import math

import numpy as np
import pytest

from rigid_body_attitude.core.environment.magnetic_field import (
    LocalMagneticField, field_world_vector)
from rigid_body_attitude.core.errors import InputError


def test_field_world_vector_enu_points_north_and_down():
    field = field_world_vector(5e-5, math.radians(60.0), 0.0, 'enu')
    np.testing.assert_allclose(field, [0.0, 2.5e-5, -5e-5 * math.sin(math.radians(60.0))],
                               atol=1e-18)


def test_field_world_vector_declination_turns_the_horizontal_east():
    east, north, _ = field_world_vector(5e-5, 0.0, math.radians(90.0), 'enu')
    assert east == pytest.approx(5e-5)
    assert north == pytest.approx(0.0, abs=1e-18)


@pytest.mark.parametrize('axes', ['ned', 'nwu'])
def test_field_world_vector_same_field_in_other_axes(axes):
    enu = np.array(field_world_vector(4.9e-5, 1.1, 0.07, 'enu'))
    other = np.array(field_world_vector(4.9e-5, 1.1, 0.07, axes))
    north, east, up = enu[1], enu[0], enu[2]
    expected = {'ned': [north, east, -up], 'nwu': [north, -east, up]}[axes]
    np.testing.assert_allclose(other, expected, atol=1e-18)
    assert np.linalg.norm(other) == pytest.approx(4.9e-5)


@pytest.mark.parametrize('args, match', [
    ((-1.0, 0.0, 0.0, 'enu'), 'intensity'),
    ((5e-5, 2.0, 0.0, 'enu'), 'inclination'),
    ((5e-5, 0.0, math.nan, 'enu'), 'declination'),
    ((5e-5, 0.0, 0.0, 'xyz'), 'world_axes'),
])
def test_field_world_vector_refuses_bad_values(args, match):
    with pytest.raises(InputError, match=match):
        field_world_vector(*args)


def test_local_magnetic_field_is_constant_and_checked():
    field = LocalMagneticField(5e-5, 1.2, -0.05, 'ned')
    assert field.field_world(0.0) == field.field_world(1e6)
    with pytest.raises(InputError, match='inclination'):
        LocalMagneticField(5e-5, 3.0)
