"""The Sun's direction (core/environment/sun.py) and the scene's ``sun`` section."""

import math

import pytest

from rigid_body_attitude.core.environment.sun import ConstantSunDirection, sun_section
from rigid_body_attitude.core.errors import InputError, SceneError


def test_a_constant_direction_is_normalised_and_the_same_at_every_time():
    sun = ConstantSunDirection((3.0, 0.0, -4.0))
    assert sun.sun_direction_world(0.0) == pytest.approx((0.6, 0.0, -0.8), abs=1e-16)
    assert sun.sun_direction_world(1e6) == sun.sun_direction_world(0.0)


@pytest.mark.parametrize('direction', [(0.0, 0.0, 0.0), (math.nan, 1.0, 0.0),
                                       (math.inf, 0.0, 0.0)])
def test_a_direction_that_is_no_direction_is_refused(direction):
    with pytest.raises(InputError, match='direction'):
        ConstantSunDirection(direction)


def test_the_section_is_read_and_none_is_no_sun():
    assert sun_section(None) is None
    assert sun_section({'direction': [0, 0, 2]}).direction == (0.0, 0.0, 1.0)


@pytest.mark.parametrize('section, words', [
    ({'direction': [0, 0, 0]}, 'sun.direction to be a non-zero direction'),
    ({'direction': [1, 0]}, 'sun.direction to be 3 numbers'),
    ({'direction': [1e7, 0, 0]}, 'every entry of sun.direction to be at most 1e+06'),
    ({'direction': ['x', 0, 0]}, 'sun.direction'),
    ({}, "Missing key 'direction' in sun"),
    ({'direction': [1, 0, 0], 'ephemeris': 'de440'}, "Unknown key 'ephemeris' in sun"),
    ([1, 0, 0], 'Expected sun to be a mapping'),
])
def test_a_bad_section_is_one_error_naming_the_key(section, words):
    with pytest.raises(SceneError) as raised:
        sun_section(section)
    assert words in str(raised.value) and '\n' not in str(raised.value)
