"""``propagation_node --help``: the formatter, the rows of the node and the argument scan."""

from __future__ import annotations

import pytest

from rigid_body_attitude.ros.cli_help import (
    format_parameter_help, node_parameter_rows, ParameterRow, wants_help)
from rigid_body_attitude.session.parameters import PARAMETERS


def test_formatter_takes_plain_tuples_and_wraps_the_description():
    text = format_parameter_help([
        ('gain', 'double', 2.5, '[0, 10]', 'how much ' * 20, True),
        ('verbose', 'bool', False, '', 'say more', False),
    ])
    lines = text.splitlines()
    assert lines[0] == '  gain: double, default 2.5, range [0, 10], fixed at start'
    body = lines[1:-2]
    assert len(body) >= 2
    assert all(len(line) <= 96 and line.startswith(' ' * 6) for line in body)
    assert ' '.join(line.strip() for line in body) == ('how much ' * 20).strip()
    assert lines[-2] == '  verbose: bool, default false, changeable at run time'
    assert lines[-1] == '      say more'


def test_node_rows_cover_every_parameter_with_its_default_and_range():
    rows = {row.name: row for row in node_parameter_rows()}
    assert set(rows) == {p.name for p in PARAMETERS} | {'use_sim_time'}
    for parameter in PARAMETERS:
        row = rows[parameter.name]
        assert row.default == parameter.default and row.read_only == parameter.read_only
        assert row.description.startswith(parameter.description)
        assert bool(row.range) == (parameter.type is float)
    assert rows['publish_rate'] == ParameterRow(
        'publish_rate', 'double', 50.0, '(0, 1000]',
        next(p for p in PARAMETERS if p.name == 'publish_rate').description, True)
    assert rows['constant_dt'].range == '[0, 10]'
    assert rows['time_jump_threshold'].range == '(0, 1e6]'
    assert rows['scene'].type_name == 'string' and rows['use_header_stamps'].type_name == 'bool'


@pytest.mark.parametrize('arguments, expected', [
    (['--help'], True),
    (['-h', '--ros-args', '-p', 'scene:=strapdown'], True),
    (['--ros-args', '-p', 'scene:=strapdown', '--', '--help'], True),
    (['--ros-args', '-h'], False),
    (['--ros-args', '-p', 'scene:=--help'], False),
    ([], False),
])
def test_help_counts_only_outside_the_ros_arguments(arguments, expected):
    assert wants_help(arguments) is expected
