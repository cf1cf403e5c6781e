"""A launch file (:mod:`launch_files`' model) checked against the package's own tables.

:func:`problems` lists what is wrong, each a line naming the file and the node:

* **arguments**: each declared once with a description, used, and declared before an action
  uses it; the top comment shows ``ros2 launch rigid_body_attitude <file>``;
* **this package's nodes**: the executable is a console script installed where ``ros2 launch``
  finds it (``lib/rigid_body_attitude``); every parameter, given in the file or in its
  parameters files, is one of the node's table (:data:`NODE_KINDS`) or rclpy's
  ``use_sim_time``, of the table's type, within its checks; the values together pass the
  checks the node makes at start (the propagator: ``check_values``, the scene loaded, the
  sim clock's rules; the controller: ``check_controller_values``); a parameters file has an
  entry for the node; every remapped name is an endpoint of the node's interface, and, for the
  propagator, one present with this scene and these values;
* **tf2_ros's static_transform_publisher**: the flags of its Jazzy command line
  (:data:`STATIC_TRANSFORM_FLAGS`), each with its value, both frames, not both rotations;
* **nodes together**: a static transform's parent frame is the propagator's ``body_frame``; a
  controller shares the propagator's namespace and frames and commands an input the scene
  takes;
* **lifecycle transitions** (Python files): transitions and states of ``lifecycle_msgs``, on a
  lifecycle node of a lifecycle executable, conditions on a boolean argument.

:func:`command_line` renders a node as the command launch_ros runs.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass
import importlib.metadata
import math
from pathlib import Path
import re
from typing import Any

from launch_files import LaunchedNode, LaunchFile
from lifecycle_msgs.msg import State, Transition
import yaml

from rigid_body_attitude.core.errors import AttitudeError
from rigid_body_attitude.core.propagator import (
    DynamicsPropagator, GyroPropagator, MAX_STEPS_PER_CALL)
from rigid_body_attitude.ros.controller import CONTROLLER_NODE_NAME
from rigid_body_attitude.session.controller_parameters import (
    check_controller_values, CONTROLLER_PARAMETERS)
from rigid_body_attitude.session.interface import (
    CONTROLLER_INTERFACE, Interface, NODE_INTERFACE, Situation)
from rigid_body_attitude.session.parameters import check_values, Parameter, PARAMETERS
from rigid_body_attitude.session.settings import load_node_scene, NODE_NAME
from rigid_body_attitude.session.sim_clock import sim_clock_problem

PACKAGE = 'rigid_body_attitude'


@dataclass(frozen=True)
class NodeKind:
    """What a launch file may give one of the package's executables."""

    table: tuple[Parameter, ...]
    check: Callable[[Mapping[str, Any]], str]
    node_name: str
    interface: Interface
    propagator: bool
    lifecycle: bool


#: The package's executables that are nodes: their parameter table, checks, node name and
#: interface (the other executables are tools, not for a launch file).
NODE_KINDS = {
    'propagation_node': NodeKind(PARAMETERS, check_values, NODE_NAME, NODE_INTERFACE,
                                 propagator=True, lifecycle=False),
    'managed_propagation_node': NodeKind(PARAMETERS, check_values, NODE_NAME, NODE_INTERFACE,
                                         propagator=True, lifecycle=True),
    'attitude_controller': NodeKind(CONTROLLER_PARAMETERS, check_controller_values,
                                    CONTROLLER_NODE_NAME, CONTROLLER_INTERFACE,
                                    propagator=False, lifecycle=False),
}
#: Parameters every rclpy node declares, with their type.
RCLPY_PARAMETERS = {'use_sim_time': bool}

#: tf2_ros static_transform_publisher's flags (ros2/geometry2, Jazzy,
#: tf2_ros/src/static_transform_broadcaster_program.cpp): each takes one value; the numbers
#: are parsed with std::stod; both frames are required and not empty; rotation flags are
#: either quaternion or roll-pitch-yaw; positional arguments are the deprecated old form.
STATIC_TRANSFORM_FLAGS = {
    '--x': float, '--y': float, '--z': float, '--qx': float, '--qy': float, '--qz': float,
    '--qw': float, '--roll': float, '--pitch': float, '--yaw': float,
    '--frame-id': str, '--child-frame-id': str,
}
#: External executables a launch file may start, with the check of their arguments.
EXTERNAL = {('tf2_ros', 'static_transform_publisher')}

#: Transitions ``ChangeState`` can request (the others are the state machine's own).
REQUESTABLE_TRANSITIONS = frozenset(
    name for name in dir(Transition) if name.startswith('TRANSITION_') and not any(
        part in name for part in ('_ON_', 'CALLBACK', 'CREATE', 'DESTROY')))
#: Lifecycle state labels (``configuring``, ``inactive``, ...), as transition events name them.
STATE_LABELS = frozenset(
    name.split('_STATE_')[1].lower() for name in dir(State)
    if '_STATE_' in name and not name.endswith('UNKNOWN'))
#: Values launch's IfCondition takes.
CONDITION_VALUES = ('true', 'false', '1', '0')


@dataclass
class NodeReport:
    """One of the package's nodes with its values at start (defaults, files, the file's)."""

    node: LaunchedNode
    kind: NodeKind
    values: dict[str, Any]
    situation: Situation | None = None


def problems(launch: LaunchFile) -> list[str]:
    """Everything wrong with ``launch`` (module docstring); empty when it is fine."""
    found = list(launch.problems) + argument_problems(launch)
    reports: list[NodeReport] = []
    static_transforms: list[dict[str, Any]] = []
    for node in launch.nodes:
        where = f'{node.package}/{node.executable}'
        found += [f'{where}: {problem}' for problem in node.problems]
        if node.package == PACKAGE:
            report, node_problems = package_node(node)
            found += [f'{where}: {problem}' for problem in node_problems]
            if report is not None:
                reports.append(report)
        elif (node.package, node.executable) in EXTERNAL:
            parsed, flag_problems = static_transform(node.arguments)
            found += [f'{where}: {problem}' for problem in flag_problems]
            static_transforms.append(parsed)
        else:
            found.append(f'{where}: not an executable the check knows')
    found += together(reports, static_transforms) + transition_problems(launch)
    return [f'{launch.path.name}: {problem}' for problem in found]


def argument_problems(launch: LaunchFile) -> list[str]:
    """Arguments without a description or never used, and a top comment without usage."""
    found = [f'launch argument {name!r} has no description'
             for name, argument in launch.arguments.items() if not argument.description.strip()]
    found += [f'launch argument {name!r} is never used'
              for name in launch.arguments if name not in launch.used_arguments]
    usage = f'ros2 launch {PACKAGE} {launch.path.name}'
    if usage not in launch.top_comment:
        found.append(f'the top comment does not show {usage!r}')
    return found


def package_node(node: LaunchedNode) -> tuple[NodeReport | None, list[str]]:
    """One of the package's nodes: executable, parameters, start checks, remaps."""
    installed = {entry.name for entry in importlib.metadata.distribution(PACKAGE).entry_points
                 if entry.group == 'console_scripts'}
    if node.executable not in installed:
        return None, [f'no console script {node.executable!r}']
    kind = NODE_KINDS.get(node.executable)
    if kind is None:
        return None, [f'{node.executable!r} is a tool, not a node of {sorted(NODE_KINDS)}']
    found = []
    if node.lifecycle and not kind.lifecycle:
        found.append(f'{node.executable} is not a lifecycle node')
    values = dict(zip((p.name for p in kind.table), (p.default for p in kind.table)))
    for path in node.parameter_files:
        found += merge(values, parameters_file(Path(path), full_name(node, kind), found), kind,
                       f'parameters file {Path(path).name}: ')
    found += merge(values, node.parameters, kind, '')
    report = NodeReport(node, kind, values)
    if not found:
        found += start_problems(report)
    found += remap_problems(report)
    return report, found


def full_name(node: LaunchedNode, kind: NodeKind) -> str:
    """The node's fully qualified name (``/namespace/name``)."""
    namespace = node.namespace.strip('/')
    return ('/' + namespace if namespace else '') + '/' + (node.name or kind.node_name)


def parameters_file(path: Path, node_name: str, found: list[str]) -> dict[str, Any]:
    """The parameters a ROS parameters file gives the node ``node_name``: every entry whose
    key matches it (rcl's wildcards ``*`` and ``**``), nested names joined with dots."""
    try:
        document = yaml.safe_load(path.read_text(encoding='utf-8'))
    except (OSError, yaml.YAMLError) as err:
        found.append(f'parameters file {path}: {err}')
        return {}
    values: dict[str, Any] = {}
    matched = False
    for key, section in (document or {}).items():
        if re.fullmatch(_key_pattern(str(key)), node_name):
            matched = True
            values.update(_flattened(section.get('ros__parameters', {})))
    if not matched:
        found.append(f'parameters file {path.name} has no entry for {node_name}')
    return values


def _key_pattern(key: str) -> str:
    tokens = key.strip('/').split('/')
    return ''.join('(?:/[^/]+)*' if token == '**' else '/[^/]+' if token == '*'
                   else '/' + re.escape(token) for token in tokens)


def _flattened(section: Mapping[str, Any], prefix: str = '') -> dict[str, Any]:
    values: dict[str, Any] = {}
    for name, value in section.items():
        if isinstance(value, dict):
            values.update(_flattened(value, f'{prefix}{name}.'))
        else:
            values[prefix + name] = tuple(value) if isinstance(value, list) else value
    return values


def merge(values: dict[str, Any], given: Mapping[str, Any], kind: NodeKind,
          source: str) -> list[str]:
    """``given`` checked one by one (name, type, the table's checks) into ``values``."""
    found = []
    table = {parameter.name: parameter for parameter in kind.table}
    for name, value in given.items():
        if name in RCLPY_PARAMETERS:
            problem = '' if type(value) is RCLPY_PARAMETERS[name] else (
                f'Expected parameter `{name}` to be a {RCLPY_PARAMETERS[name].__name__}, '
                f'got {value!r}')
        elif name.startswith('qos_overrides.'):
            problem = ''  # rclpy's, read at start
        elif name in table:
            problem = table[name].problem(value)
        else:
            problem = f'Unknown parameter `{name}` of {kind.node_name}'
        if problem:
            found.append(source + problem)
        else:
            values[name] = value
    return found


def start_problems(report: NodeReport) -> list[str]:
    """What the node refuses at start with these values: its table's checks and, for the
    propagator, the scene and the rules that need it (as its ``build`` checks them)."""
    kind = report.kind
    values = {p.name: report.values[p.name] for p in kind.table}  # no rclpy parameters
    problem = kind.check(values)
    if problem or not kind.propagator:
        return [problem] if problem else []
    if kind.lifecycle and (values['publish_clock'] or values['lockstep']):
        return ['publish_clock and lockstep need propagation_node']
    try:
        scene = load_node_scene(values['scene'], values['integrator'], values['step'],
                                values['torque_timeout'])
    except (AttitudeError, OSError) as err:
        return [f'scene {values["scene"]!r}: {err}']
    propagator = (DynamicsPropagator if scene.rate_source == 'dynamics' else GyroPropagator)(
        scene)
    inputs = propagator.input_names
    if scene.rate_source == 'dynamics':
        problem = check_values(values, scene.step, MAX_STEPS_PER_CALL)
    problem = problem or sim_clock_problem(values, scene, tuple(sorted(inputs)))
    report.situation = Situation(scene, values, inputs)
    return [problem] if problem else []


def remap_problems(report: NodeReport) -> list[str]:
    """Remapped names that are no endpoint of the node (or none present here)."""
    found = []
    for source, _ in report.node.remaps:
        endpoints = [e for e in report.kind.interface if e.name == source]
        if not endpoints:
            found.append(f'remap {source!r}: not a topic or service of {report.kind.node_name} '
                         f'({", ".join(report.kind.interface.names("in"))} in)')
        elif report.situation is not None and not any(
                endpoint.present(report.situation) for endpoint in endpoints):
            found.append(f'remap {source!r}: scene {report.values["scene"]!r} has no such '
                         f'topic with these parameters')
    return found


def static_transform(arguments: list[str]) -> tuple[dict[str, Any], list[str]]:
    """static_transform_publisher's command line: (flag → value, problems)."""
    parsed: dict[str, Any] = {}
    found: list[str] = []
    words = iter(arguments)
    for word in words:
        kind = STATIC_TRANSFORM_FLAGS.get(word)
        value = next(words, None)
        if kind is None:
            found.append(f'{word!r}: not a flag of static_transform_publisher (Jazzy: '
                         f'{", ".join(STATIC_TRANSFORM_FLAGS)})')
        elif value is None:
            found.append(f'{word} has no value')
        elif kind is float and not _number(value):
            found.append(f'{word} {value!r}: not a number')
        else:
            parsed[word] = float(value) if kind is float else value
    for flag in ('--frame-id', '--child-frame-id'):
        if not parsed.get(flag):
            found.append(f'{flag} missing or empty')
    if {'--qx', '--qy', '--qz', '--qw'} & set(parsed) and {
            '--roll', '--pitch', '--yaw'} & set(parsed):
        found.append('both a quaternion and roll, pitch, yaw')
    return parsed, found


def _number(text: str) -> bool:
    try:
        return math.isfinite(float(text))
    except ValueError:
        return False


def together(reports: list[NodeReport], transforms: list[dict[str, Any]]) -> list[str]:
    """The rules between the nodes of one file."""
    found = []
    propagators = [r for r in reports if r.kind.propagator]
    for transform in transforms:
        for report in propagators:
            if transform.get('--frame-id') != report.values['body_frame']:
                found.append(f'the static transform\'s parent {transform.get("--frame-id")!r} '
                             f'is not body_frame {report.values["body_frame"]!r}')
    plants = [r for r in propagators
              if r.situation is None or r.situation.scene.rate_source == 'dynamics']
    for controller in (r for r in reports if not r.kind.propagator):
        for report in plants:
            found += _controller_with(controller, report)
        found += _state_source(controller, propagators)
    return found


def _resolved(namespace: str, topic: str) -> str:
    """A topic name resolved in ``namespace`` (an absolute one as it is)."""
    if topic.startswith('/'):
        return topic
    return '/' + '/'.join(part for part in (namespace.strip('/'), topic) if part)


def _state_source(controller: NodeReport, propagators: list[NodeReport]) -> list[str]:
    """The controller's ``odom`` (remapped or not) is a propagator's of the file: the
    plant's truth or an estimator's (a filter scene)."""
    if controller.values.get('state_input', 'odom') != 'odom' or not propagators:
        return []
    source = dict(controller.node.remaps).get('odom', 'odom')
    wanted = _resolved(controller.node.namespace, source)
    published = {_resolved(report.node.namespace, 'odom') for report in propagators
                 if report.situation is None or any(
                     endpoint.name == 'odom' and endpoint.direction == 'out'
                     for endpoint in NODE_INTERFACE.present(report.situation))}
    if wanted in published:
        return []
    return [f'the controller reads odom on {wanted}, which no propagator of the file '
            f'publishes ({", ".join(sorted(published)) or "none"})']


def _controller_with(controller: NodeReport, plant: NodeReport) -> list[str]:
    found = []
    if controller.node.namespace != plant.node.namespace:
        found.append('the controller and the propagator are in different namespaces')
    for frame in ('world_frame', 'body_frame'):
        if controller.values[frame] != plant.values[frame]:
            found.append(f'the controller\'s {frame} {controller.values[frame]!r} is not the '
                         f'propagator\'s {plant.values[frame]!r}')
    # the controller's command: the body torque, the wheels' (actuator reaction_wheels) or
    # the rods' dipole (actuator magnetorquers)
    commands = [CONTROLLER_INTERFACE.endpoint(
        {'reaction_wheels': 'wheels/command', 'magnetorquers': 'dipole'}.get(
            controller.values.get('actuator', 'body'), 'torque'), 'out')]
    if plant.situation is not None and not all(any(
            endpoint.name == command.name and endpoint.present(plant.situation)
            for endpoint in NODE_INTERFACE.inputs(plant.situation)) for command in commands):
        found.append(f'scene {plant.values["scene"]!r} takes no '
                     f'{", ".join(c.name for c in commands)} command')
    return found


def transition_problems(launch: LaunchFile) -> list[str]:
    """Lifecycle transitions of unknown names or states, on nodes that are no lifecycle
    nodes, under conditions that are no boolean."""
    found = []
    for request in launch.transitions:
        if request.transition not in REQUESTABLE_TRANSITIONS:
            found.append(f'{request.transition}: not one of {sorted(REQUESTABLE_TRANSITIONS)}')
        states = [state for state in request.after or () if state is not None]
        found += [f'state {state!r}: not one of {sorted(STATE_LABELS)}'
                  for state in states if state not in STATE_LABELS]
        if not request.node.lifecycle:
            found.append(f'{request.transition} on {request.node.executable}, not a '
                         f'LifecycleNode')
        if request.condition is not None and request.condition.lower() not in CONDITION_VALUES:
            found.append(f'condition {request.condition!r}: not one of {CONDITION_VALUES}')
    return found


def command_line(node: LaunchedNode, executable: Path, parameters_path: Path) -> list[str]:
    """The command launch_ros runs for ``node``: the executable, its arguments, then the ROS
    arguments (name, namespace, each parameters file, the file's own parameters written to
    ``parameters_path`` as launch_ros writes them, the remaps)."""
    ros_arguments = []
    if node.name is not None:
        ros_arguments += ['-r', f'__node:={node.name}']
    ros_arguments += ['-r', f'__ns:=/{node.namespace.strip("/")}']
    files = list(node.parameter_files)
    if node.parameters:
        parameters = {name: list(value) if isinstance(value, tuple) else value
                      for name, value in node.parameters.items()}
        parameters_path.write_text(yaml.safe_dump({'/**': {'ros__parameters': parameters}}))
        files.append(str(parameters_path))
    for path in files:
        ros_arguments += ['--params-file', path]
    for source, target in node.remaps:
        ros_arguments += ['-r', f'{source}:={target}']
    return [str(executable), *node.arguments, '--ros-args', *ros_arguments]
