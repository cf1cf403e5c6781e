"""A parameter table (:class:`~rigid_body_attitude.session.parameters.Parameter` rows) on an
rclpy node: declared with its descriptors, read back as the table takes the values.

Used by both nodes and the controller: the propagator's table
(:data:`rigid_body_attitude.session.parameters.PARAMETERS`) and the controller's
(:data:`rigid_body_attitude.session.controller_parameters.CONTROLLER_PARAMETERS`).
"""

from __future__ import annotations

import array
from collections.abc import Callable, Mapping, Sequence
from typing import Any

from rclpy.exceptions import (
    InvalidParameterTypeException, ParameterException, ParameterUninitializedException)
from rclpy.node import Node
from rclpy.parameter import Parameter as RosParameter
from rcl_interfaces.msg import FloatingPointRange, ParameterDescriptor

from rigid_body_attitude.core.errors import InputError
from rigid_body_attitude.session.parameters import Parameter, PARAMETERS

__all__ = ['declare_retired_parameters', 'declare_table_parameter', 'parameter_descriptor',
           'parameter_values', 'ros_value']


def parameter_descriptor(parameter: Parameter) -> ParameterDescriptor:
    """The ROS descriptor of a parameter of the table."""
    limits = []
    if parameter.type is float:
        low = parameter.low if parameter.low is not None else -float('inf')
        high = parameter.high if parameter.high is not None else float('inf')
        limits = [FloatingPointRange(from_value=low, to_value=high)]
    return ParameterDescriptor(
        name=parameter.name, description=parameter.description,
        read_only=parameter.read_only, floating_point_range=limits)


def ros_value(parameter: Parameter, value: Any) -> Any:
    """A parameter's value as the table takes it: a double array (rclpy gives a list or an
    ``array.array``, ``None`` when not set) as a tuple; other values as they are."""
    if parameter.type is not tuple:
        return value
    if value is None:
        return parameter.default
    return tuple(value) if isinstance(value, (list, tuple, array.array)) else value


def parameter_values(node: Node, table: Sequence[Parameter] = PARAMETERS) -> dict[str, Any]:
    """Current values of ``node``'s parameters of ``table`` by name (``None``: a double
    array not set)."""
    values = {}
    for parameter in table:
        try:
            value = node.get_parameter(parameter.name).value
        except ParameterUninitializedException:  # a double array not set
            value = None
        values[parameter.name] = ros_value(parameter, value)
    return values


def declare_table_parameter(node: Node, parameter: Parameter, ignore_override: bool = False
                            ) -> Any:
    """Declare ``parameter`` of a table on ``node`` (with the value given at start unless
    ``ignore_override``); its value, or :class:`InputError` naming it."""
    # A double array without a value ([]: not set) is declared by its type (an empty list
    # would make it a byte array); unset, it reads as the table's default.
    default = (RosParameter.Type.DOUBLE_ARRAY if parameter.type is tuple
               else parameter.default)
    try:
        return ros_value(parameter, node.declare_parameter(
            parameter.name, default, parameter_descriptor(parameter),
            ignore_override=ignore_override).value)
    except InvalidParameterTypeException as err:
        raise InputError(f'Expected parameter `{parameter.name}` to be a '
                         f'{parameter.type_text}: {str(err)[:200]}') from err
    except ParameterException as err:
        raise InputError(f'Bad parameter `{parameter.name}`: {str(err)[:200]}') from err


def declare_retired_parameters(node: Node, retired: Mapping[str, str],
                               problem: Callable[[str], str]) -> None:
    """Declare the ``retired`` names of renamed parameters (any type, no value), so a value
    given for one at start is not silently ignored: :class:`InputError` with ``problem(name)``.
    (Set at run time, the node's parameters callback refuses them.)"""
    for name, present in retired.items():
        value = node.declare_parameter(name, None, ParameterDescriptor(
            name=name, dynamic_typing=True,
            description=f'retired name of `{present}`: set that one')).value
        if value is not None:
            raise InputError(problem(name))
