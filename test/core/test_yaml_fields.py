"""The field checks shared by scene, calibration and campaign files (yaml_files.Fields)."""

from __future__ import annotations

import math

import pytest

from rigid_body_attitude.core.errors import CalibrationError, SceneError
from rigid_body_attitude.core.yaml_files import Fields

FIELDS = Fields(CalibrationError)


def _message(call, *args, **kwargs) -> str:
    with pytest.raises(CalibrationError) as raised:
        call(*args, **kwargs)
    return str(raised.value)


def test_an_unknown_key_is_named_with_the_valid_ones():
    assert _message(FIELDS.keys, {'a': 1, 'colour': 2}, {'a', 'b'}, 'body') == (
        "Unknown key 'colour' in body; valid keys: a, b")
    assert _message(FIELDS.keys, {'x': 1}, {'a'}) == "Unknown key 'x'; valid keys: a"
    assert _message(FIELDS.keys, {'a': 1}, {'a', 'b'}, 'scene', ('b',)) == (
        "Missing key 'b' in scene; valid keys: a, b")
    FIELDS.keys({'a': 1}, {'a', 'b'}, 'scene', ('a',))


def test_the_error_type_is_the_files_own():
    with pytest.raises(SceneError, match="Unknown key 'x' in sensors"):
        Fields(SceneError).keys({'x': 1}, {'imu'}, 'sensors')


def test_a_number_names_the_key_and_the_bound():
    assert FIELDS.number(2.0, 'rate', 1.0, 10.0) == 2.0
    assert _message(FIELDS.number, 0.0, 'density', 0.0, 1.0, low_open=True) == (
        'Expected density to be in (0, 1], got 0.0')
    assert _message(FIELDS.number, 11, 'rate', 1.0, 10.0) == (
        'Expected rate to be in [1, 10], got 11.0')
    assert 'YAML 1.1' in _message(FIELDS.number, '1e-3', 'step')
    assert _message(FIELDS.number, math.nan, 'mass') == (
        'Expected mass to be a finite number, got nan')
    assert _message(FIELDS.number, True, 'mass') == 'Expected mass to be a number, got True'


def test_a_vector_is_n_finite_bounded_numbers():
    assert FIELDS.vector([1, 2.5, 3], 'bias', 3, 10.0) == (1.0, 2.5, 3.0)
    assert _message(FIELDS.vector, [1, 2], 'bias') == 'Expected bias to be 3 numbers, got [1, 2]'
    assert _message(FIELDS.vector, 'abc', 'bias') == "Expected bias to be 3 numbers, got 'abc'"
    assert _message(FIELDS.vector, [1, math.inf, 0], 'bias') == (
        'Expected every entry of bias to be a finite number, got inf')
    assert _message(FIELDS.vector, [0, 0, 150], 'bias', 3, 100.0) == (
        'Expected every entry of bias to be at most 100 in magnitude, got 150.0')


def test_a_matrix_is_rows_of_numbers():
    assert FIELDS.matrix([[1, 0], [0, 1]], 'M', 2, 2) == ((1.0, 0.0), (0.0, 1.0))
    assert 'to be a 3x3 matrix' in _message(FIELDS.matrix, [[1, 0, 0], [0, 1]], 'M')


def test_a_mapping_with_its_keys():
    assert FIELDS.mapping(None, 'statistics', none_is_empty=True) == {}
    assert _message(FIELDS.mapping, [1], 'body', {'mass', 'inertia'}) == (
        'Expected body to be a mapping with keys inertia, mass, got [1]')
    assert _message(FIELDS.mapping, {'M': 1, 'Q': 2}, 'imu0.gyroscopes', {'M'}) == (
        "Unknown key 'Q' in imu0.gyroscopes; valid keys: M")
