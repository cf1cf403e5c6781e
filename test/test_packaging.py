"""The installed layout: what colcon would produce for an ament_python package, in the venv.

``make test`` installs the package (not editable) into the virtual env that runs the tests, so
these tests check the install itself: the ament index marker, package.xml, config/ and launch/
under ``share/``, executables under ``lib/rigid_body_attitude/`` found the way ``ros2 run`` finds
them, and a core that never imports rclpy.
"""

import ast
import configparser
import filecmp
import importlib.metadata
import json
import os
from pathlib import Path
import re
import shutil
import subprocess
import sys
import sysconfig
import xml.etree.ElementTree as ElementTree

from ament_index_python.packages import get_package_prefix, get_package_share_directory
import pytest

import rigid_body_attitude

PACKAGE = 'rigid_body_attitude'
PREFIX = Path(sys.prefix).resolve()
SHARE_DIR = PREFIX / 'share' / PACKAGE
LIBEXEC_DIR = PREFIX / 'lib' / PACKAGE
REPO_ROOT = Path(__file__).resolve().parents[1]

# What `ros2 run rigid_body_attitude <name>` starts, and the function it runs.
EXECUTABLES = {
    'propagation_node': 'rigid_body_attitude.ros.serve:main',
    'managed_propagation_node': 'rigid_body_attitude.ros.managed_node:main',
    'replay': 'rigid_body_attitude.tools.replay:main',
    'accuracy_study': 'rigid_body_attitude.tools.study:main',
    'imu_noise': 'rigid_body_attitude.tools.allan:main',
    'campaign': 'rigid_body_attitude.tools.campaign:main',
    'attitude_controller': 'rigid_body_attitude.ros.controller:main',
}

# rclpy is imported in one subpackage only: every other module must import without rclpy.
SHELL_MODULES: set[str] = set()
SHELL_PACKAGES = {'ros'}

REQUIRED_EXEC_DEPENDS = {
    'rclpy', 'rcl_interfaces', 'geometry_msgs', 'sensor_msgs', 'std_msgs', 'diagnostic_msgs',
    'std_srvs', 'python3-numpy', 'python3-yaml', 'python3-scipy', 'python3-matplotlib',
    'python3-tqdm', 'python3-rosbags-pip',
}
#: Third-party modules → the rosdep key that provides them (a ROS package: its own name).
ROSDEP_KEYS = {'numpy': 'python3-numpy', 'scipy': 'python3-scipy', 'yaml': 'python3-yaml',
               'matplotlib': 'python3-matplotlib', 'tqdm': 'python3-tqdm',
               'rosbags': 'python3-rosbags-pip'}
#: Modules that rosdistro's rosdep/python.yaml has no key for → their pip distribution: pinned
#: in requirements.txt, named in a comment of package.xml and in docs/setup.md's pip line.
WITHOUT_ROSDEP_KEY = {'apsw': 'apsw', 'dask': 'dask',
                      'distributed': 'distributed', 'pyarrow': 'pyarrow',
                      'allantools': 'allantools', 'ppigrf': 'ppigrf'}
REQUIRED_TEST_DEPENDS = {'python3-pytest'}

# Run in a fresh interpreter: refuses rclpy through a meta path finder (so an import anywhere,
# however indirect or guarded by try/except, is recorded), imports each module named in argv[1]
# and prints what failed, what asked for rclpy and which rclpy modules got loaded.
RCLPY_BLOCKER = r'''
import importlib, json, sys, traceback

attempts = []


class RclpyBlocker:
    def find_spec(self, name, path=None, target=None):
        if name == 'rclpy' or name.startswith('rclpy.'):
            attempts.append(''.join(traceback.format_stack(limit=12)))
            raise ImportError(f'{name} is blocked: the core must not import rclpy')
        return None


sys.meta_path.insert(0, RclpyBlocker())
failures = {}
for module_name in json.loads(sys.argv[1]):
    try:
        importlib.import_module(module_name)
    except BaseException:
        failures[module_name] = traceback.format_exc()
rclpy_modules = sorted(m for m in sys.modules if m == 'rclpy' or m.startswith('rclpy.'))
print(json.dumps({'failures': failures, 'attempts': attempts, 'rclpy_modules': rclpy_modules}))
'''


def core_module_names() -> list[str]:
    """Return every module of the installed package except the rclpy shells, by file."""
    package_dir = Path(rigid_body_attitude.__file__).parent
    names = []
    for path in sorted(package_dir.rglob('*.py')):
        parts = path.relative_to(package_dir.parent).with_suffix('').parts
        if parts[-1] == '__init__':
            parts = parts[:-1]
        name = '.'.join(parts)
        if parts[-1] == '__main__' or name in SHELL_MODULES or SHELL_PACKAGES & set(parts):
            continue
        names.append(name)
    return names


def import_with_rclpy_blocked(module_names: list[str], extra_path: str = '') -> dict:
    """Import ``module_names`` in a fresh interpreter with rclpy blocked; return its report."""
    env = dict(os.environ)
    if extra_path:
        env['PYTHONPATH'] = os.pathsep.join(filter(None, [extra_path, env.get('PYTHONPATH')]))
    result = subprocess.run(
        [sys.executable, '-P', '-c', RCLPY_BLOCKER, json.dumps(module_names)],
        capture_output=True, text=True, env=env, timeout=120, check=True)
    return json.loads(result.stdout.splitlines()[-1])


def run_launcher(launcher: Path, args: list[str], first_on_path: Path,
                 cwd: Path) -> subprocess.CompletedProcess:
    """Run a launcher with ``first_on_path`` before the system folders on PATH."""
    env = dict(os.environ, PATH=os.pathsep.join([str(first_on_path), '/usr/bin', '/bin']))
    return subprocess.run(
        [str(launcher), *args], capture_output=True, text=True, env=env, cwd=cwd, timeout=60)


def write_executable(path: Path, text: str) -> Path:
    """Write an executable file (making its folders); return its path."""
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(text)
    path.chmod(0o755)
    return path


def test_package_imported_from_install_prefix():
    installed = Path(sysconfig.get_path('purelib')).resolve() / PACKAGE / '__init__.py'
    assert Path(rigid_body_attitude.__file__).resolve() == installed


def test_get_package_prefix_resolves_to_install_prefix():
    assert Path(get_package_prefix(PACKAGE)).resolve() == PREFIX
    assert Path(get_package_share_directory(PACKAGE)).resolve() == SHARE_DIR


def test_ament_index_marker_installed():
    marker = PREFIX / 'share' / 'ament_index' / 'resource_index' / 'packages' / PACKAGE
    assert marker.is_file()
    assert marker.read_bytes() == (REPO_ROOT / 'resource' / PACKAGE).read_bytes()


def test_package_xml_installed_as_in_source():
    assert filecmp.cmp(SHARE_DIR / 'package.xml', REPO_ROOT / 'package.xml', shallow=False)


def test_config_installed_recursively():
    source_config = REPO_ROOT / 'config'
    installed_config = SHARE_DIR / 'config'
    source_files = {p.relative_to(source_config) for p in source_config.rglob('*')
                    if p.is_file() and not p.name.startswith('.')}
    installed_files = {p.relative_to(installed_config) for p in installed_config.rglob('*')
                       if p.is_file()}
    assert installed_files == source_files
    for relative in source_files:
        assert filecmp.cmp(source_config / relative, installed_config / relative, shallow=False)
    assert sorted((installed_config / 'scenes').glob('*.yaml')), 'no scene installed'
    assert sorted((installed_config / 'campaigns').glob('*.yaml')), 'no campaign installed'


def test_launch_files_installed_where_ros2_launch_looks():
    source_files = {p.name for p in (REPO_ROOT / 'launch').iterdir() if p.is_file()}
    installed_launch = SHARE_DIR / 'launch'
    # (pip byte-compiles managed.launch.py into __pycache__, as ros2 launch does when it loads it)
    assert {p.name for p in installed_launch.iterdir() if p.is_file()} == source_files
    assert {'imu.launch.xml', 'managed.launch.py'} <= source_files
    for name in source_files:
        assert filecmp.cmp(REPO_ROOT / 'launch' / name, installed_launch / name, shallow=False)


@pytest.mark.parametrize('name', sorted(EXECUTABLES))
def test_executable_installed_where_ros2_run_looks(name):
    path = Path(get_package_prefix(PACKAGE)) / 'lib' / PACKAGE / name
    assert path.is_file()
    # Executable by everyone, as colcon installs scripts: the bits survived the wheel.
    assert path.stat().st_mode & 0o111 == 0o111


@pytest.mark.parametrize('name', sorted(EXECUTABLES))
def test_launcher_runs_the_console_script_entry_point(name):
    console_scripts = {
        entry_point.name: entry_point.value
        for entry_point in importlib.metadata.distribution(PACKAGE).entry_points
        if entry_point.group == 'console_scripts'}
    module, function = EXECUTABLES[name].split(':')
    assert console_scripts[name] == EXECUTABLES[name]
    assert f'\nfrom {module} import {function}\n' in (LIBEXEC_DIR / name).read_text()
    assert (PREFIX / 'bin' / name).is_file()


def test_launcher_prefers_python_of_its_own_prefix(tmp_path):
    prefix = tmp_path / 'prefix'
    launcher = prefix / 'lib' / PACKAGE / 'propagation_node'
    write_executable(launcher, (LIBEXEC_DIR / 'propagation_node').read_text())
    report_args = '#!/bin/sh\necho {}\nfor arg in "$@"; do echo "[$arg]"; done\n'
    write_executable(prefix / 'bin' / 'python', report_args.format('prefix-python'))
    write_executable(tmp_path / 'path' / 'python3', report_args.format('path-python3'))

    result = run_launcher(launcher, ['--ros-args', '-p', 'scene:=a b'], tmp_path / 'path',
                          tmp_path)

    lines = result.stdout.splitlines()
    assert result.returncode == 0, result.stderr
    assert lines[0] == 'prefix-python'
    assert lines[1] == '[-c]'
    assert 'from rigid_body_attitude.ros.serve import main' in result.stdout
    assert lines[-4:] == [f'[{launcher}]', '[--ros-args]', '[-p]', '[scene:=a b]']


def test_launcher_falls_back_to_python3_on_path(tmp_path):
    launcher = tmp_path / 'prefix' / 'lib' / PACKAGE / 'replay'
    write_executable(launcher, (LIBEXEC_DIR / 'replay').read_text())
    write_executable(tmp_path / 'path' / 'python3', '#!/bin/sh\necho path-python3 "$1"\n')

    result = run_launcher(launcher, [], tmp_path / 'path', tmp_path)

    assert result.returncode == 0, result.stderr
    assert result.stdout.startswith('path-python3 -c')


def test_launcher_code_passes_argv_and_exit_code_and_skips_cwd(tmp_path):
    # The launcher's own Python code, with the entry point swapped for one that reports what it
    # sees: argv as a console script gets it, the exit code passed on, the cwd not importable.
    text = (LIBEXEC_DIR / 'accuracy_study').read_text()
    import_line = 'from rigid_body_attitude.tools.study import main\n'
    assert import_line in text
    reporter = ('import json, os\n'
                'def main():\n'
                '    print(json.dumps([sys.argv, os.path.realpath(sys.path[0]), sys.prefix]))\n'
                '    return 3\n')
    launcher = write_executable(tmp_path / 'lib' / PACKAGE / 'accuracy_study',
                                text.replace(import_line, reporter))
    write_executable(tmp_path / 'bin' / 'python', f'#!/bin/sh\nexec {sys.executable} "$@"\n')

    result = run_launcher(launcher, ['--runs', 'two words'], tmp_path / 'path', tmp_path)

    assert result.returncode == 3, result.stderr
    argv, first_path, prefix = json.loads(result.stdout)
    assert argv == [str(launcher), '--runs', 'two words']
    assert first_path != str(tmp_path.resolve())
    assert Path(prefix).resolve() == PREFIX


def test_setup_cfg_sends_scripts_to_lib_package():
    config = configparser.ConfigParser()
    config.read(REPO_ROOT / 'setup.cfg')
    assert config['develop']['script_dir'] == '$base/lib/rigid_body_attitude'
    assert config['install']['install_scripts'] == '$base/lib/rigid_body_attitude'


def test_package_xml_format_3_with_dependencies():
    root = ElementTree.parse(SHARE_DIR / 'package.xml').getroot()
    assert root.tag == 'package'
    assert root.get('format') == '3'
    assert root.findtext('name') == PACKAGE
    assert root.findtext('license') == 'Apache-2.0'
    assert root.findtext('export/build_type') == 'ament_python'
    assert {e.text for e in root.findall('exec_depend')} >= REQUIRED_EXEC_DEPENDS
    assert {e.text for e in root.findall('test_depend')} >= REQUIRED_TEST_DEPENDS
    version = root.findtext('version')
    assert version == rigid_body_attitude.__version__
    assert version == importlib.metadata.version(PACKAGE)


def third_party_imports(package_dir: Path) -> dict[str, set[str]]:
    """Top-level modules outside the standard library that the package imports anywhere
    (module level or inside functions) → the files importing them."""
    found: dict[str, set[str]] = {}
    for path in sorted(package_dir.rglob('*.py')):
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.Import):
                names = [alias.name for alias in node.names]
            elif isinstance(node, ast.ImportFrom) and not node.level and node.module:
                names = [node.module]
            else:
                continue
            for name in names:
                top = name.split('.')[0]
                if top not in sys.stdlib_module_names and top != PACKAGE:
                    found.setdefault(top, set()).add(str(path.relative_to(package_dir)))
    return found


def undeclared_imports(imports: dict[str, set[str]], package_xml: str, requirements: str,
                       is_ros_package) -> list[str]:
    """The imports that package.xml (and for modules without a rosdep key, requirements.txt)
    does not declare."""
    root = ElementTree.fromstring(package_xml)
    declared = {element.text for tag in ('exec_depend', 'depend')  # depend: build and exec
                for element in root.findall(tag)}
    comments = ' '.join(re.findall(r'<!--(.*?)-->', package_xml, flags=re.S))
    pinned = {line.split('==')[0].strip().lower() for line in requirements.splitlines()
              if '==' in line and not line.lstrip().startswith('#')}
    missing = []
    for module, files in sorted(imports.items()):
        if module in WITHOUT_ROSDEP_KEY:
            distribution = WITHOUT_ROSDEP_KEY[module]
            if distribution not in pinned or distribution not in comments:
                missing.append(f'{module} (no rosdep key: pin {distribution} in requirements.txt '
                               f'and name it in a package.xml comment), imported by '
                               f'{sorted(files)}')
            continue
        key = ROSDEP_KEYS.get(module) or (module if is_ros_package(module) else None)
        if key not in declared:
            missing.append(f'{module} (rosdep key {key}), imported by {sorted(files)}')
    return missing


def installed_ros_package(name: str) -> bool:
    """Whether ``name`` is a ROS package of the install prefix (its ament index marker)."""
    return (PREFIX / 'share' / 'ament_index' / 'resource_index' / 'packages' / name).is_file()


def test_every_import_of_the_package_is_a_declared_dependency():
    imports = third_party_imports(Path(rigid_body_attitude.__file__).parent)
    assert {'numpy', 'rclpy', 'rosbags'} <= set(imports)
    missing = undeclared_imports(imports, (SHARE_DIR / 'package.xml').read_text(),
                                 (REPO_ROOT / 'requirements.txt').read_text(),
                                 installed_ros_package)
    assert missing == []


def test_the_ros_install_pip_line_pins_every_module_without_a_rosdep_key():
    """docs/setup.md's one pip line, after ``rosdep install``, installs the rest, at the
    versions requirements.txt pins."""
    setup_md = (REPO_ROOT / 'docs' / 'setup.md').read_text()
    lines = [line for line in setup_md.splitlines() if 'pip install' in line and '==' in line]
    assert len(lines) == 1, lines
    named = dict(word.split('==') for word in lines[0].split() if '==' in word)
    pinned = dict(line.split('==') for line in
                  (REPO_ROOT / 'requirements.txt').read_text().splitlines()
                  if '==' in line and not line.startswith('#'))
    assert set(named) == set(WITHOUT_ROSDEP_KEY.values())
    assert all(named[name] == pinned[name] for name in named)


def test_an_undeclared_import_is_reported():
    package_xml = ('<package><exec_depend>python3-numpy</exec_depend>'
                   '<exec_depend>rclpy</exec_depend><!-- apsw: pip --></package>')
    imports = {'numpy': {'a.py'}, 'rclpy': {'b.py'}, 'rosbags': {'c.py'}, 'apsw': {'c.py'},
               'dask': {'f.py'}, 'pandas': {'d.py'}, 'std_srvs': {'e.py'}}
    missing = undeclared_imports(imports, package_xml, 'apsw==2.0\ndask==1.0\n',
                                 lambda name: name in {'rclpy', 'std_srvs'})
    assert [entry.split(' ')[0] for entry in missing] == ['dask', 'pandas', 'rosbags', 'std_srvs']


def test_core_module_discovery_finds_the_core_and_leaves_out_shells():
    names = core_module_names()
    assert {'rigid_body_attitude', 'rigid_body_attitude.core.attitude.quaternion',
            'rigid_body_attitude.core.errors'} <= set(names)
    assert not SHELL_MODULES & set(names)


def test_core_modules_import_without_rclpy():
    report = import_with_rclpy_blocked(core_module_names())
    assert report['failures'] == {}
    assert report['attempts'] == []
    assert report['rclpy_modules'] == []


def test_rclpy_blocker_catches_an_indirect_guarded_import(tmp_path):
    # A module that hides the import behind try/except must still be reported.
    (tmp_path / 'sneaky.py').write_text(
        'try:\n    import rclpy.node\nexcept ImportError:\n    pass\n')
    report = import_with_rclpy_blocked(['sneaky'], extra_path=str(tmp_path))
    assert report['failures'] == {}
    assert len(report['attempts']) == 1
    assert 'sneaky.py' in report['attempts'][0]


def make_prefix_with_package(prefix: Path, package: str, executable_text: str) -> None:
    """Lay out a minimal ament prefix holding ``package`` with one executable, ``hello``."""
    marker = prefix / 'share' / 'ament_index' / 'resource_index' / 'packages' / package
    marker.parent.mkdir(parents=True)
    marker.touch()
    write_executable(prefix / 'lib' / package / 'hello', executable_text)


def run_ros2run(args: list[str], ament_prefix_path: str) -> subprocess.CompletedProcess:
    """Run scripts/ros2run with the given AMENT_PREFIX_PATH; return the finished process."""
    env = dict(os.environ, AMENT_PREFIX_PATH=ament_prefix_path)
    return subprocess.run(
        [sys.executable, str(REPO_ROOT / 'scripts' / 'ros2run'), *args],
        capture_output=True, text=True, env=env, timeout=60)


def test_ros2run_execs_the_executable_of_the_first_prefix_holding_the_package(tmp_path):
    make_prefix_with_package(tmp_path / 'first', 'demo_pkg',
                             '#!/bin/sh\necho "first:$1|$2"\nexit 7\n')
    make_prefix_with_package(tmp_path / 'second', 'demo_pkg', '#!/bin/sh\necho second\n')

    result = run_ros2run(['demo_pkg', 'hello', 'a', 'b c'],
                         f'{tmp_path / "first"}{os.pathsep}{tmp_path / "second"}')

    assert result.returncode == 7, result.stderr
    assert result.stdout == 'first:a|b c\n'


def test_ros2run_lists_executables_for_an_unknown_one():
    result = run_ros2run([PACKAGE, 'no_such_executable'], str(PREFIX))
    assert result.returncode == 2
    assert "No executable 'no_such_executable'" in result.stderr
    for name in EXECUTABLES:
        assert repr(name) in result.stderr


def test_ros2run_reports_an_unknown_package(tmp_path):
    result = run_ros2run(['no_such_package', 'hello'], str(tmp_path))
    assert result.returncode == 2
    assert "Package 'no_such_package' not found" in result.stderr


def test_colcon_style_install_puts_executables_in_lib_package(tmp_path):
    # What `colcon build` runs for an ament_python package (setup.py install with setup.cfg),
    # on a copy of the sources. setuptools installs the console scripts last, into
    # lib/rigid_body_attitude (setup.cfg), in place of the launchers: see setup.py.
    source = tmp_path / 'src'
    source.mkdir()
    for name in ('setup.py', 'setup.cfg', 'package.xml', 'LICENSE'):
        shutil.copy2(REPO_ROOT / name, source / name)
    for name in ('resource', 'config', 'launch', 'scripts', PACKAGE):
        shutil.copytree(REPO_ROOT / name, source / name,
                        ignore=shutil.ignore_patterns('__pycache__'))
    prefix = tmp_path / 'install'
    build = tmp_path / 'build'
    build.mkdir()
    subprocess.run(
        [sys.executable, 'setup.py', '-q', 'egg_info', '--egg-base', str(build),
         'build', '--build-base', str(build / 'build'),
         'install', '--prefix', str(prefix), '--record', str(build / 'install.log'),
         '--single-version-externally-managed'],
        cwd=source, capture_output=True, text=True, timeout=300, check=True)

    for name in EXECUTABLES:
        executable = prefix / 'lib' / PACKAGE / name
        assert executable.stat().st_mode & 0o111 == 0o111
        text = executable.read_text()
        assert text.startswith(f'#!{sys.executable}\n')
        assert f"'console_scripts', '{name}'" in text
    assert (prefix / 'share' / PACKAGE / 'package.xml').is_file()
    assert (prefix / 'share' / 'ament_index' / 'resource_index' / 'packages' / PACKAGE).is_file()
    assert sorted((prefix / 'share' / PACKAGE / 'config' / 'scenes').glob('*.yaml'))
    assert {p.name for p in (prefix / 'share' / PACKAGE / 'launch').iterdir()} == {
        p.name for p in (REPO_ROOT / 'launch').iterdir() if p.is_file()}
    assert not (prefix / 'bin').exists()
