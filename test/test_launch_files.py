"""The launch files in launch/, read as launch_ros reads them and checked against the package.

launch_ros has no PyPI wheel, so ``ros2 launch`` cannot run here: ``launch_files`` reads each
file (XML, or the Python subset, statically) into nodes with their parameters, remaps and
arguments, and ``launch_checks`` checks them against the package's own tables (the executables
of setup.py, the parameter tables, the interface, tf2_ros's command line, lifecycle_msgs).
Each check is shown to refuse a file that breaks it. The files are also checked against what
they promise: the closed loop is the README's quick start value for value, every ``ros2
launch`` command the documentation shows passes, and package.xml declares what they use.
test/ros/test_launch_files_run.py runs the nodes of each file as launch_ros would start them.
"""

from __future__ import annotations

import ast
from pathlib import Path
import re
import shlex
from typing import Any
import xml.etree.ElementTree as ElementTree

from ament_index_python.packages import get_package_share_directory
from launch_checks import NODE_KINDS, package_node, problems, RCLPY_PARAMETERS
from launch_files import LaunchFile, LaunchFileError, read_launch_file
import pytest
import yaml

REPO_ROOT = Path(__file__).resolve().parents[1]
LAUNCH_DIR = REPO_ROOT / 'launch'
SHARE_DIRS = {'rigid_body_attitude': Path(get_package_share_directory('rigid_body_attitude'))}
LAUNCH_FILES = sorted(path.name for path in LAUNCH_DIR.glob('*.launch.*'))
#: The documents whose ``ros2 launch`` commands are run through the checks.
DOCUMENTS = [REPO_ROOT / 'README.md', *sorted((REPO_ROOT / 'docs').glob('*.md'))]


def read(name: str, given: dict[str, str] | None = None,
         folder: Path = LAUNCH_DIR) -> LaunchFile:
    """The launch file ``name`` of ``folder``, its arguments ``given`` or at their defaults."""
    return read_launch_file(folder / name, SHARE_DIRS, given)


def node_of(launch: LaunchFile, executable: str) -> Any:
    """The one node of ``launch`` running ``executable``."""
    nodes = [node for node in launch.nodes if node.executable == executable]
    assert len(nodes) == 1, [node.executable for node in launch.nodes]
    return nodes[0]


def values_of(launch: LaunchFile, executable: str) -> dict[str, Any]:
    """The parameter values ``executable`` starts with (defaults, files, the launch file's)."""
    report, found = package_node(node_of(launch, executable))
    assert found == [] and report is not None, found
    return report.values


def test_the_package_ships_eight_launch_files():
    assert LAUNCH_FILES == ['bdot_loop.launch.xml', 'closed_loop.launch.xml',
                            'dynamics.launch.xml', 'gnc_loop.launch.xml', 'imu.launch.xml',
                            'imu_filter.launch.xml', 'managed.launch.py',
                            'spacecraft_loop.launch.xml']


def test_bdot_loop_is_the_measured_bdot_example():
    """The values of test/ros/test_magnetic_loop.py's B-dot run (docs/closed-loop.md)."""
    launch = read('bdot_loop.launch.xml')
    assert problems(launch) == []
    plant, controller = (values_of(launch, name) for name in (
        'propagation_node', 'attitude_controller'))
    assert plant['scene'] == controller['scene'] == 'bdot_detumbling_commanded'
    assert (plant['lockstep'], plant['publish_rate']) == (True, 1.0)
    assert (controller['actuator'], controller['bdot_gain'], controller['control_period']) == (
        'magnetorquers', 4e5, 1.0)


def test_spacecraft_loop_gives_both_nodes_the_scene_and_drives_the_wheels():
    launch = read('spacecraft_loop.launch.xml', {'scene': 'wheel_slew_commanded'})
    assert problems(launch) == []
    plant, controller = (values_of(launch, name) for name in (
        'propagation_node', 'attitude_controller'))
    assert plant['scene'] == controller['scene'] == 'wheel_slew_commanded'
    assert (plant['lockstep'], controller['actuator']) == (True, 'reaction_wheels')
    assert controller['target_rpy'] == (0.0, 0.0, 0.6981317)


@pytest.mark.parametrize('name', LAUNCH_FILES)
def test_every_launch_file_passes_every_check(name):
    launch = read(name)
    assert launch.nodes
    assert problems(launch) == []


def test_imu_starts_the_strapdown_node_and_the_mount_on_the_imu_topic():
    launch = read('imu.launch.xml', {'imu_topic': '/camera/imu', 'body_frame': 'chassis',
                                     'imu_frame': 'camera_imu', 'mount_roll': '3.14159',
                                     'mount_z': '0.2'})
    assert problems(launch) == []
    node = node_of(launch, 'propagation_node')
    assert node.remaps == [('imu', '/camera/imu')]
    values = values_of(launch, 'propagation_node')
    assert (values['scene'], values['body_frame'], values['publish_tf']) == (
        'strapdown', 'chassis', True)
    mount = node_of(launch, 'static_transform_publisher')
    assert (mount.package, mount.arguments) == ('tf2_ros', [
        '--x', '0.0', '--y', '0.0', '--z', '0.2', '--roll', '3.14159', '--pitch', '0.0',
        '--yaw', '0.0', '--frame-id', 'chassis', '--child-frame-id', 'camera_imu'])


def test_imu_filter_starts_the_filter_on_madgwicks_topics():
    launch = read('imu_filter.launch.xml', {'magnetic_declination': '0.07'})
    assert problems(launch) == []
    node = node_of(launch, 'propagation_node')
    assert node.remaps == [('imu', 'imu/data_raw'), ('imu/mag', 'imu/mag')]
    values = values_of(launch, 'propagation_node')
    assert (values['scene'], values['magnetic_declination']) == ('imu_filter', 0.07)


def test_dynamics_starts_the_scene_given():
    launch = read('dynamics.launch.xml', {'scene': 'gyrostat', 'publish_rate': '100.0'})
    assert problems(launch) == []
    values = values_of(launch, 'propagation_node')
    assert (values['scene'], values['publish_rate'], values['lockstep']) == (
        'gyrostat', 100.0, False)


def test_managed_configures_then_activates_once_inactive_unless_told_not_to():
    launch = read('managed.launch.py')
    node = node_of(launch, 'managed_propagation_node')
    assert node.lifecycle and node.name == 'attitude_propagator'
    assert [(r.transition, r.after, r.condition) for r in launch.transitions] == [
        ('TRANSITION_ACTIVATE', ('configuring', 'inactive'), 'true'),
        ('TRANSITION_CONFIGURE', None, 'true')]
    assert {r.condition for r in read('managed.launch.py', {'autostart': 'false'}).transitions
            } == {'false'}


# -- what the files promise ------------------------------------------------------------------

def readme_block(document: Path, heading: str) -> str:
    """The first ``sh`` code block after ``heading``, continuation lines joined."""
    text = document.read_text(encoding='utf-8')
    found = re.search(re.escape(heading) + r'\n.*?```sh\n(.*?)```', text, flags=re.S)
    assert found, f'{document.name}: no code block after {heading!r}'
    return found.group(1).replace('\\\n', ' ')


def command_values(line: str) -> tuple[str, dict[str, Any]]:
    """``ros2 run rigid_body_attitude EXEC --ros-args -p NAME:=VALUE ...`` → executable and
    the values it starts with (defaults, then the ``-p`` values read as YAML)."""
    words = shlex.split(line)
    assert words[:3] == ['ros2', 'run', 'rigid_body_attitude'] and '--ros-args' in words, line
    kind = NODE_KINDS[words[3]]
    values: dict[str, Any] = {p.name: p.default for p in kind.table}
    values.update(use_sim_time=False)
    for flag, setting in zip(words, words[1:]):
        if flag == '-p':
            name, _, text = setting.partition(':=')
            value = yaml.safe_load(text)
            values[name] = tuple(value) if isinstance(value, list) else value
    return words[3], values


@pytest.mark.parametrize('document', ['README.md', 'docs/closed-loop.md'])
def test_closed_loop_starts_the_quick_start_value_for_value(document):
    block = readme_block(REPO_ROOT / document, 'controller in the loop')
    commands = dict(command_values(line) for line in block.splitlines() if line.strip())
    launch = read('closed_loop.launch.xml')
    assert sorted(commands) == sorted(node.executable for node in launch.nodes)
    for executable, expected in commands.items():
        values = {'use_sim_time': False, **values_of(launch, executable)}
        assert values == expected, executable


def launch_commands() -> list[tuple[str, str, dict[str, str]]]:
    """Every ``ros2 launch rigid_body_attitude FILE NAME:=VALUE ...`` of the documentation and
    of the launch files' own comments: (where, file, arguments)."""
    found = []
    for path in [*DOCUMENTS, *(LAUNCH_DIR / name for name in LAUNCH_FILES)]:
        for line in path.read_text(encoding='utf-8').splitlines():
            command = re.search(r'ros2 launch rigid_body_attitude (\S+)((?: \w+:=\S+)*)', line)
            if command:
                given = dict(word.strip('`').split(':=', 1) for word in command.group(2).split())
                found.append((path.name, command.group(1).strip('`'), given))
    return found


def test_the_readme_shows_every_launch_file():
    shown = {name for where, name, _ in launch_commands() if where == 'README.md'}
    assert shown == set(LAUNCH_FILES)


@pytest.mark.parametrize('where, name, given', launch_commands())
def test_every_launch_command_shown_passes_the_checks(where, name, given):
    assert name in LAUNCH_FILES, where
    assert problems(read(name, given)) == [], where


def test_package_xml_declares_what_the_launch_files_use():
    manifest = ElementTree.parse(REPO_ROOT / 'package.xml').getroot()
    declared = {element.text for tag in ('exec_depend', 'depend')
                for element in manifest.findall(tag)}
    used = {'ros2launch'}
    for name in LAUNCH_FILES:
        used |= {node.package for node in read(name).nodes} - {'rigid_body_attitude'}
        if name.endswith('.xml'):
            used.add('launch_xml')
        else:
            module = ast.parse((LAUNCH_DIR / name).read_text())
            used |= {statement.module.split('.')[0] for statement in module.body
                     if isinstance(statement, ast.ImportFrom) and statement.module}
    assert used >= {'launch', 'launch_ros', 'launch_xml', 'lifecycle_msgs', 'tf2_ros'}
    assert used <= declared, used - declared


def test_rclpy_parameters_are_no_parameter_of_the_tables():
    for kind in NODE_KINDS.values():
        assert not set(RCLPY_PARAMETERS) & {parameter.name for parameter in kind.table}


# -- the checks refuse what breaks them ------------------------------------------------------

def mutated(tmp_path: Path, name: str, old: str, new: str) -> Path:
    """A copy of launch file ``name`` in ``tmp_path`` with ``old`` (present) made ``new``."""
    text = (LAUNCH_DIR / name).read_text(encoding='utf-8')
    assert old in text, old
    (tmp_path / name).write_text(text.replace(old, new, 1), encoding='utf-8')
    return tmp_path


IMU, DYNAMICS = 'imu.launch.xml', 'dynamics.launch.xml'
LOOP, MANAGED = 'closed_loop.launch.xml', 'managed.launch.py'

#: (file, text, replacement, a problem expected): edits each check must refuse.
BROKEN_FILES = [
    (DYNAMICS, '<param name="publish_tf"', '<param name="publish_tff"',
     'Unknown parameter `publish_tff`'),
    (DYNAMICS, 'exec="propagation_node"', 'exec="propagation_nod"',
     "no console script 'propagation_nod'"),
    (DYNAMICS, 'exec="propagation_node"', 'exec="replay"', "'replay' is a tool"),
    (DYNAMICS, '<param name="scene" value="$(var scene)"/>',
     '<param name="scene" value="$(var scenes)"/>', "'scenes' used before it is declared"),
    (DYNAMICS, '<launch>', '<launch>\n  <arg name="spare" default="1" description="unused"/>',
     "'spare' is never used"),
    (DYNAMICS, 'description="Hz: ticks (outputs per second)"', '',
     "'publish_rate' has no description"),
    (DYNAMICS, 'ros2 launch rigid_body_attitude dynamics.launch.xml', 'ros2 launch',
     'the top comment does not show'),
    (IMU, '<remap from="imu"', '<remap from="imu_raw"', "remap 'imu_raw': not a topic"),
    (IMU, '--frame-id $(var body_frame)', '--frame-id base',
     "parent 'base' is not body_frame 'base_link'"),
    (IMU, '--roll $(var mount_roll)', '--rol $(var mount_roll)',
     "'--rol': not a flag of static_transform_publisher"),
    (IMU, '--yaw $(var mount_yaw)', '--yaw $(var mount_yaw) --qw 1.0',
     'both a quaternion and roll, pitch, yaw'),
    (IMU, '--child-frame-id $(var imu_frame)', '', '--child-frame-id missing or empty'),
    (IMU, '--x $(var mount_x)', '--x metres', "--x 'metres': not a number"),
    (LOOP, '<param name="control_period" value="0.1"/>\n    <param name="world_frame" '
     'value="$(var world_frame)"/>',
     '<param name="control_period" value="0.1"/>\n    <param name="world_frame" value="map"/>',
     "the controller's world_frame 'map' is not the propagator's 'world'"),
    (LOOP, '<param name="kp" value="10.0"/>', '<param name="kp" value="10"/>',
     'Expected parameter `kp` to be a double'),
    (LOOP, '<param name="lockstep" value="true"/>', '<param name="lockstep" value="yes please"/>',
     'Expected parameter `lockstep` to be a boolean'),
    (MANAGED, "transition_id=Transition.TRANSITION_ACTIVATE",
     "transition_id=Transition.TRANSITION_ACTIVATED", 'TRANSITION_ACTIVATED: not one of'),
    (MANAGED, "goal_state='inactive'", "goal_state='idle'", "state 'idle': not one of"),
    (MANAGED, "DeclareLaunchArgument('autostart', default_value='true'",
     "DeclareLaunchArgument('autostart', default_value='yes'", "condition 'yes': not one of"),
    (MANAGED, "executable='managed_propagation_node'", "executable='propagation_node'",
     'propagation_node is not a lifecycle node'),
    (MANAGED, "'use_sim_time': LaunchConfiguration('use_sim_time')", "'use_sim_time': 1",
     'Expected parameter `use_sim_time` to be a bool'),
]


@pytest.mark.parametrize('name, old, new, expected', BROKEN_FILES)
def test_a_broken_file_is_refused(tmp_path, name, old, new, expected):
    found = problems(read(name, folder=mutated(tmp_path, name, old, new)))
    assert any(expected in problem for problem in found), found


#: (file, arguments given, a problem expected): values the nodes would refuse at start.
BAD_ARGUMENTS = [
    (DYNAMICS, {'publish_rate': '100'}, 'Expected parameter `publish_rate` to be a double'),
    (DYNAMICS, {'publish_rate': '0.0'}, 'to be a finite number in (0, 1000]'),
    (DYNAMICS, {'scene': ''}, "parameter 'scene': launch_ros refuses None"),
    (DYNAMICS, {'scene': 'no_such_scene'}, "scene 'no_such_scene':"),
    (DYNAMICS, {'world_frame': 'base_link'}, 'Expected `world_frame` and `body_frame` to differ'),
    (IMU, {'scene': 'torque_free_box'}, "remap 'imu': scene 'torque_free_box' has no such topic"),
    (IMU, {'mount_pitch': 'level'}, "--pitch 'level': not a number"),
    (LOOP, {'scene': 'strapdown'}, 'Expected a dynamics scene with `publish_clock` or `lockstep`'),
    (LOOP, {'scene': 'torque_free_box'}, 'Expected a scene with commanded inputs'),
    (MANAGED, {'use_sim_time': 'maybe'}, 'Expected parameter `use_sim_time` to be a bool'),
]


@pytest.mark.parametrize('name, given, expected', BAD_ARGUMENTS)
def test_bad_launch_arguments_are_refused(name, given, expected):
    found = problems(read(name, given))
    assert any(expected in problem for problem in found), found


def test_a_controller_beside_a_scene_without_commands_is_refused(tmp_path):
    folder = mutated(tmp_path, LOOP, '<param name="lockstep" value="true"/>', '')
    found = problems(read(LOOP, {'scene': 'torque_free_box'}, folder))
    assert any("scene 'torque_free_box' takes no torque command" in p for p in found), found


@pytest.mark.parametrize('contents, expected', [
    ('other_node:\n  ros__parameters:\n    scene: strapdown\n',
     'has no entry for /attitude_propagator'),
    ('/**:\n  ros__parameters:\n    publish_rate: 100\n',
     'parameters file params.yaml: Expected parameter `publish_rate` to be a double'),
    ('/**:\n  ros__parameters:\n    no_such_parameter: 1.0\n', 'Unknown parameter'),
])
def test_a_bad_parameters_file_is_refused(tmp_path, contents, expected):
    path = tmp_path / 'params.yaml'
    path.write_text(contents)
    found = problems(read(DYNAMICS, {'params_file': str(path)}))
    assert any(expected in problem for problem in found), found


@pytest.mark.parametrize('name, old, new, expected', [
    (DYNAMICS, '$(var scene)', '$(env SCENE)', 'unsupported substitution'),
    (DYNAMICS, '<node pkg', '<group/>\n  <node pkg', '<group> is not read inside <launch>'),
    (DYNAMICS, 'output="screen"', 'output="screen" respawn="true"', 'unsupported attributes'),
    (DYNAMICS, '<param from="$(var params_file)"/>', '<parm from="$(var params_file)"/>',
     '<parm> is not read inside <node>'),
    (MANAGED, "'scene': LaunchConfiguration('scene')", "'scene': str('strapdown')",
     'unsupported call str'),
    (MANAGED, 'import LaunchDescription', 'import LaunchDescription  # noqa\nimport os',
     'unsupported module statement'),
    (MANAGED, 'namespace=LaunchConfiguration', 'ns=LaunchConfiguration',
     'launch_ros.actions.LifecycleNode takes'),
])
def test_what_the_reader_does_not_know_is_refused(tmp_path, name, old, new, expected):
    with pytest.raises(LaunchFileError, match=re.escape(expected)):
        read(name, folder=mutated(tmp_path, name, old, new))


def test_an_unknown_launch_argument_given_is_refused():
    with pytest.raises(LaunchFileError, match='imu_topics'):
        read(IMU, {'imu_topics': '/camera/imu'})
