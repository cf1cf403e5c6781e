"""``propagation_node --help``: the node's parameters, printed without starting ROS.

:func:`format_parameter_help` lays out any iterable of :class:`ParameterRow`; the rows of the
node come from :func:`node_parameter_rows`, built from the one parameter table
(:data:`rigid_body_attitude.session.parameters.PARAMETERS`). :func:`wants_help` finds
``-h``/``--help`` among the arguments that are not ROS arguments.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
import textwrap
from typing import Any, NamedTuple

from rigid_body_attitude.session.parameters import PARAMETERS

__all__ = ['ParameterRow', 'format_parameter_help', 'node_parameter_rows', 'usage_text',
           'wants_help']

#: Type names as ``ros2 param describe`` shows them.
_TYPE_NAMES = {bool: 'bool', float: 'double', int: 'integer', str: 'string',
               tuple: 'double array'}

_WIDTH = 96


class ParameterRow(NamedTuple):
    """One parameter as ``--help`` shows it."""

    name: str
    type_name: str
    default: Any
    #: e.g. ``'(0, 1000]'``, or ``''`` when any value of the type is allowed.
    range: str
    description: str
    #: Fixed at start (True) or changeable at run time with ``ros2 param set`` (False).
    read_only: bool


def format_parameter_help(rows: Iterable[ParameterRow | tuple[str, str, Any, str, str, bool]]
                          ) -> str:
    """One block per parameter: name, type, default, range, run-time changeable, then the
    description indented below."""
    blocks = []
    for name, type_name, default, value_range, description, read_only in rows:
        facts = [type_name, f'default {_value_text(default)}']
        if value_range:
            facts.append(f'range {value_range}')
        facts.append('fixed at start' if read_only else 'changeable at run time')
        head = f'  {name}: {", ".join(facts)}'
        body = textwrap.fill(description, _WIDTH, initial_indent=' ' * 6,
                             subsequent_indent=' ' * 6)
        blocks.append(f'{head}\n{body}')
    return '\n'.join(blocks)


def _value_text(value: Any) -> str:
    """A value as written on the command line (``-p name:=value``): ``true``, ``50.0``,
    ``'world'``."""
    if isinstance(value, bool):
        return 'true' if value else 'false'
    if isinstance(value, tuple):
        return f'[{", ".join(map(repr, value))}]'
    return repr(value)


def node_parameter_rows() -> list[ParameterRow]:
    """The node's own parameters in declaration order, then rclpy's ``use_sim_time``."""
    rows = [ParameterRow(p.name, _TYPE_NAMES[p.type], p.default, p.range_text(),
                         p.description + (f' (one of: {", ".join(p.choices)})'
                                          if p.choices else ''), p.read_only)
            for p in PARAMETERS]
    rows.append(ParameterRow('use_sim_time', 'bool', False, '',
                             "rclpy's: the node clock follows /clock (e.g. from a bag)", False))
    return rows


def usage_text(rows: Iterable[ParameterRow | tuple[str, str, Any, str, str, bool]]) -> str:
    """The whole ``--help`` text."""
    return '\n'.join([
        'usage: propagation_node [-h] [--ros-args -p NAME:=VALUE ... '
        '[--params-file FILE] [-r FROM:=TO] ...]',
        '',
        'The attitude_propagator node: propagates a rigid body\'s attitude from gyro',
        'samples (gyro scenes) or Euler\'s equations (dynamics scenes) and publishes it.',
        'Topics, QoS and time rules: README, "The node".',
        '',
        'options:',
        '  -h, --help  print this text and exit (ROS is not started)',
        '',
        'parameters (--ros-args -p NAME:=VALUE; run-time ones also with ros2 param set):',
        format_parameter_help(rows),
        '',
        'QoS of a topic, at start: -p qos_overrides./TOPIC.subscription.depth:=N (inputs;',
        '.publisher. for outputs; also reliability and history).',
    ])


def wants_help(arguments: Sequence[str]) -> bool:
    """Whether ``-h`` or ``--help`` is among ``arguments`` outside ``--ros-args ... --``."""
    in_ros_arguments = False
    for word in arguments:
        if word == '--ros-args':
            in_ros_arguments = True
        elif word == '--' and in_ros_arguments:
            in_ros_arguments = False
        elif not in_ros_arguments and word in ('-h', '--help'):
            return True
    return False
