"""The parameter table: every check derived from one declaration per parameter."""

import math

import pytest

from rigid_body_attitude.session.parameters import (
    check_values, defaults, Parameter, PARAMETERS)


def test_defaults_pass_their_own_checks():
    assert check_values(defaults()) == ''
    assert all(parameter.problem(parameter.default) == '' for parameter in PARAMETERS)


def test_names_are_unique_and_no_parameter_schedules_threads():
    names = [parameter.name for parameter in PARAMETERS]
    assert len(names) == len(set(names))
    assert not [name for name in names if 'cpu' in name or 'sched' in name or '_hz' in name]


def test_a_string_with_choices_names_them():
    parameter = Parameter('mode', str, 'a', 'a mode', choices=('a', 'b'))
    assert parameter.problem('c') == "Expected parameter `mode` to be one of 'a', 'b', got 'c'"
    assert parameter.problem('b') == ''


@pytest.mark.parametrize('name, value, expected', [
    ('max_dt', 0.0, 'Expected parameter `max_dt` to be a finite number in (0, 3600], got 0.0'),
    ('publish_rate', math.nan, '`publish_rate` to be a finite number in (0, 1000], got nan'),
    ('publish_rate', 50, '`publish_rate` to be a double (written with a decimal point'),
    ('time_jump_threshold', -1.0, '`time_jump_threshold` to be a finite number in (0, 1e6]'),
    ('constant_dt', -0.001, '`constant_dt` to be a finite number in [0, 10], got -0.001'),
    ('step', math.inf, '`step` to be a finite number in [0, 10], got inf'),
    ('max_angular_rate', 0.0, '`max_angular_rate` to be a finite number in (0, 1e6]'),
    ('scene', ' ', '`scene` to be a non-empty name'),
    ('scene', 'x' * 5000, '`scene` to be at most 4096 characters, got 5000'),
    ('use_header_stamps', 1.0, '`use_header_stamps` to be a boolean (true or false), got 1.0'),
    ('body_frame', 'world', '`world_frame` and `body_frame` to differ, both are \'world\''),
])
def test_check_values_names_the_parameter_and_the_bad_value(name, value, expected):
    values = defaults()
    values[name] = value
    assert expected in check_values(values)


def test_a_huge_bad_value_is_quoted_short():
    values = defaults()
    values['publish_rate'] = 'x' * 10**6
    problem = check_values(values)
    assert problem.startswith('Expected parameter `publish_rate` to be a double')
    assert len(problem) < 250


def test_unknown_parameter_is_named():
    assert check_values({'no_such': 1.0}).startswith('Unknown parameter `no_such`')


def test_the_steps_of_one_tick_are_bounded():
    values = defaults()
    values['time_jump_threshold'] = 2e4
    assert check_values(values) == ''  # gyro scenes: no integration over clock jumps
    assert check_values(values, 0.002, 10_000_000) == ''  # 1e7 steps
    assert check_values(values, 0.001, 10_000_000) == (
        'Expected parameter `time_jump_threshold` to be at most 10000 s (10000000 steps of '
        '0.001 s in one tick), got 20000.0')


def test_untrusted_strings_are_quoted_short_in_every_parameter_error():
    """A frame name of 4 000 characters (within the length bound), with terminal escapes,
    is quoted as the network's strings are: 64 characters, escaped, its length named."""
    frame = '\x1b[31m' + 'w' * 3995
    values = defaults()
    values['world_frame'] = values['body_frame'] = frame
    problem = check_values(values)
    assert problem.startswith('Expected `world_frame` and `body_frame` to differ, both are ')
    assert problem.endswith('... (4000 characters)') and len(problem) < 200, problem
    assert '\x1b' not in problem and '\\x1b[31m' in problem
    values = defaults()
    values['scene'] = ' ' * 4000
    problem = check_values(values)
    assert '`scene` to be a non-empty name' in problem and problem.endswith('(4000 characters)')
    unknown = check_values({'\x1b' + 'n' * 5000: 1.0})
    assert unknown.startswith("Unknown parameter '\\x1bnnn") and '(5001 characters)' in unknown
    assert len(unknown.split(';')[0]) < 120 and '\x1b' not in unknown
