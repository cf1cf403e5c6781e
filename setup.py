"""Packaging of rigid_body_attitude as an ament_python package.

Whatever installs it, a prefix ends up with the layout ROS 2 expects::

    <prefix>/lib/python3.X/site-packages/rigid_body_attitude/   the Python package
    <prefix>/share/ament_index/resource_index/packages/rigid_body_attitude   (empty marker)
    <prefix>/share/rigid_body_attitude/package.xml
    <prefix>/share/rigid_body_attitude/config/...                  scenes and parameter files
    <prefix>/share/rigid_body_attitude/launch/...                  what `ros2 launch` starts
    <prefix>/lib/rigid_body_attitude/<executable>                  what `ros2 run` starts

``ros2 run rigid_body_attitude propagation_node`` finds the package prefix through the ament
index (AMENT_PREFIX_PATH) and runs ``<prefix>/lib/rigid_body_attitude/propagation_node``.

How each installer gets there:

* **pip** (``make``: a non-editable ``pip install`` into ``.venv``) builds a wheel. A wheel
  ignores setup.cfg's ``[install] install_scripts``, so the console scripts land in
  ``<prefix>/bin`` (handy on PATH, not where ``ros2 run`` looks). The small launchers in
  ``scripts/launchers/`` are therefore shipped as data files to ``lib/rigid_body_attitude``
  (pip keeps their executable bit); each runs its entry point with ``<prefix>/bin/python``
  found relative to itself, so it needs no activated virtual env.
* **colcon build** on a ROS install runs ``setup.py egg_info build install
  --single-version-externally-managed``. setup.cfg sends the console scripts to
  ``lib/rigid_body_attitude``. setuptools runs ``install_scripts`` last (its entry-point scripts
  need the egg-info), after ``install_data`` has copied the launchers there, so the console
  scripts of the same names replace them: the files any ament_python package gets, with the
  building interpreter in their shebang. test/test_packaging.py runs this command.
* **colcon build --symlink-install** runs ``setup.py develop ... install_data``. setup.cfg's
  ``[develop] script_dir`` puts the console scripts in ``lib/rigid_body_attitude`` first;
  ``install_data`` does not overwrite a file newer than its source, so they normally stay (a
  launcher edited later is copied over its script). Either file starts the same ``main()``; a
  launcher finds no ``<prefix>/bin/python`` in colcon's install space and runs ``python3`` from
  PATH, the interpreter of the sourced ROS install.
"""

from pathlib import Path
import xml.etree.ElementTree as ElementTree

from setuptools import find_packages, setup

PACKAGE_NAME = 'rigid_body_attitude'
SOURCE_DIR = Path(__file__).resolve().parent

# Executable name -> entry point. Each name has a launcher in scripts/launchers/ and a console
# script; ``make test`` (test/test_packaging.py) checks that the two agree.
EXECUTABLES = {
    'propagation_node': 'rigid_body_attitude.ros.serve:main',
    'managed_propagation_node': 'rigid_body_attitude.ros.managed_node:main',
    'replay': 'rigid_body_attitude.tools.replay:main',
    'accuracy_study': 'rigid_body_attitude.tools.study:main',
    'imu_noise': 'rigid_body_attitude.tools.allan:main',
    'campaign': 'rigid_body_attitude.tools.campaign:main',
    'attitude_controller': 'rigid_body_attitude.ros.controller:main',
}

# Names that say what they belong to, for <prefix>/bin on a shared PATH.
ALIASES = {
    'rigid-body-attitude-node': 'rigid_body_attitude.ros.serve:main',
    'rigid-body-attitude-replay': 'rigid_body_attitude.tools.replay:main',
    'rigid-body-attitude-study': 'rigid_body_attitude.tools.study:main',
    'rigid-body-attitude-imu-noise': 'rigid_body_attitude.tools.allan:main',
    'rigid-body-attitude-campaign': 'rigid_body_attitude.tools.campaign:main',
    'rigid-body-attitude-controller': 'rigid_body_attitude.ros.controller:main',
}


def package_version() -> str:
    """Return the version in package.xml, the one place it is written."""
    root = ElementTree.parse(SOURCE_DIR / 'package.xml').getroot()
    return root.findtext('version').strip()


def shared_data_files(folder: str) -> list[tuple[str, list[str]]]:
    """Return data_files entries shipping ``folder`` (config/, launch/) recursively to
    share/<package>/<folder>."""
    entries = []
    top = SOURCE_DIR / folder
    for directory in sorted(p for p in [top, *top.rglob('*')] if p.is_dir()):
        files = sorted(
            str(p.relative_to(SOURCE_DIR)) for p in directory.iterdir()
            if p.is_file() and not p.name.startswith('.') and p.suffix != '.pyc')
        if files:
            target = Path('share', PACKAGE_NAME, directory.relative_to(SOURCE_DIR))
            entries.append((str(target), files))
    return entries


setup(
    name=PACKAGE_NAME,
    version=package_version(),
    packages=find_packages(include=[PACKAGE_NAME, PACKAGE_NAME + '.*']),
    package_data={PACKAGE_NAME: ['py.typed']},
    data_files=[
        ('share/ament_index/resource_index/packages', ['resource/' + PACKAGE_NAME]),
        ('share/' + PACKAGE_NAME, ['package.xml']),
        ('lib/' + PACKAGE_NAME, ['scripts/launchers/' + name for name in EXECUTABLES]),
        *shared_data_files('config'),
        *shared_data_files('launch'),
    ],
    install_requires=['numpy', 'PyYAML', 'scipy', 'rosbags', 'apsw', 'matplotlib', 'tqdm',
                      'allantools', 'dask[distributed]', 'pyarrow', 'ppigrf'],
    python_requires='>=3.11, <3.13',
    zip_safe=True,
    maintainer='rigid_body_attitude developers',
    maintainer_email='dev@rigid-body-attitude.invalid',
    description='Rigid-body attitude propagation: a NumPy core and ROS 2 shells over it.',
    license='Apache-2.0',
    entry_points={
        'console_scripts': [
            f'{name} = {target}' for name, target in {**EXECUTABLES, **ALIASES}.items()
        ],
    },
)
