"""Hostile and broken scene files: each is refused at load with one bounded SceneError.

One test per attack class (issue 11 item 3), including the exact cases of the issue: a
non-UTF-8 file, a 400-digit integer for a mass and for a moment, YAML nested 500 levels,
``omega_body: [1e308, ...]``, ``moments: [1e308, ...]``, a 500-byte alias bomb and its variant
that printed an 800 MB error line. Every error names the file and the key path (or the line and
column of a YAML fault), is one line, is at most ``MAX_ERROR_CHARS`` long, and comes without
any warning. The replay tool prints it as one ``error:`` line and exits 1.
"""

from __future__ import annotations

from pathlib import Path
import re
import subprocess
import sys
import warnings

import numpy as np
import pytest

from rigid_body_attitude.bag import write_bag
from rigid_body_attitude.core.errors import SceneError
from rigid_body_attitude.core.dynamics.scene import load_scene, scene_from_mapping
from rigid_body_attitude.core.yaml_files import MAX_DEPTH, MAX_ERROR_CHARS, MAX_FILE_BYTES

BODY = 'body: {mass: 2.0, inertia: {moments: [1.0, 2.0, 2.5]}}'
GOOD = f'rate_source: dynamics\n{BODY}\n'


def _refused(tmp_path: Path, content: str | bytes, pattern: str) -> str:
    """Load ``content`` as a scene file; assert one bounded SceneError matching ``pattern``."""
    path = tmp_path / 'hostile.yaml'
    if isinstance(content, str):
        content = content.encode()
    path.write_bytes(content)
    with warnings.catch_warnings():
        warnings.simplefilter('error')  # no RuntimeWarning (overflow) besides the one error
        with pytest.raises(SceneError) as caught:
            load_scene(str(path))
    message = str(caught.value)
    assert message.startswith(f'Scene file {str(path)!r}'), message
    assert re.search(pattern, message), message
    assert len(message) <= MAX_ERROR_CHARS and '\n' not in message, message
    return message


def _alias_bomb(leaf_key: str) -> str:
    """A 'billion laughs' file: nine levels of nine aliases each (9⁹ leaves)."""
    lines = ['a0: &a0 [lol, lol, lol, lol, lol, lol, lol, lol, lol]']
    for level in range(1, 9):
        aliases = ', '.join([f'*a{level - 1}'] * 9)
        lines.append(f'a{level}: &a{level} [{aliases}]')
    lines.append(f'{leaf_key}: *a8')
    return '\n'.join(lines) + '\n'


def test_the_good_scene_loads(tmp_path):
    path = tmp_path / 'good.yaml'
    path.write_text(GOOD)
    assert load_scene(str(path)).mass == 2.0


def test_non_utf8_file(tmp_path):
    _refused(tmp_path, b'name: caf\xe9\n' + GOOD.encode(),
             r'line 1, column 10: not UTF-8 \(byte 0xe9\)$')


def test_file_over_the_size_limit(tmp_path):
    padding = '#' * 79 + '\n'
    _refused(tmp_path, GOOD + padding * (MAX_FILE_BYTES // 80 + 1),
             f'is larger than the limit of {MAX_FILE_BYTES} bytes')


def test_400_digit_integer_for_a_mass(tmp_path):
    huge = '9' * 400
    _refused(tmp_path, f'rate_source: dynamics\nbody: {{mass: {huge}, inertia: {{moments: '
                       f'[1, 2, 2.5]}}}}\n',
             r': body\.mass: an integer of 400 digits is too large for a float$')


def test_400_digit_integer_for_a_moment(tmp_path):
    _refused(tmp_path, f'rate_source: dynamics\nbody: {{inertia: {{moments: [1, {"7" * 400}, '
                       f'2]}}}}\n',
             r': body\.inertia\.moments\[1\]: an integer of 400 digits')


def test_integer_beyond_python_string_conversion_limit(tmp_path):
    _refused(tmp_path, f'rate_source: dynamics\nstep: {"1" * 5000}\n{BODY}\n',
             r'not valid YAML: Exceeds the limit \(4300 digits\)')


def test_400_digit_integer_in_an_effect_parameter(tmp_path):
    _refused(tmp_path, GOOD + f'effects: [viscous_damping: {{coefficient: {"3" * 400}}}]\n',
             r': effects\[0\]\.viscous_damping\.coefficient: an integer of 400 digits')


@pytest.mark.parametrize('style', ['flow', 'block'])
def test_yaml_nested_500_levels(tmp_path, style):
    if style == 'flow':
        nested = '[' * 500 + ']' * 500
    else:
        nested = '\n  ' + '- ' * 500 + '1'  # block sequences, one inside the other
    _refused(tmp_path, GOOD + f'description: {nested}\n',
             rf'line \d+, column \d+: not valid YAML: nesting deeper than {MAX_DEPTH} levels')


def test_nesting_up_to_the_limit_is_read(tmp_path):
    # The scene's mapping is the first level; MAX_DEPTH - 1 lists inside it are read.
    nested = '[' * (MAX_DEPTH - 1) + ']' * (MAX_DEPTH - 1)
    _refused(tmp_path, GOOD + f'description: {nested}\n',
             r"Expected 'description' to be a string, got \[\[\[")
    nested = '[' * MAX_DEPTH + ']' * MAX_DEPTH
    _refused(tmp_path, GOOD + f'description: {nested}\n',
             rf'line 3, column {13 + MAX_DEPTH}: not valid YAML: nesting deeper than')


def test_alias_bomb_of_500_bytes(tmp_path):
    bomb = GOOD + _alias_bomb('name')
    assert len(bomb) <= 600
    _refused(tmp_path, bomb, r'line 4, column 10: not valid YAML: aliases \(\*name\) are not '
                             r'allowed in scene files$')


def test_alias_bomb_in_a_key_that_is_quoted_in_the_error(tmp_path):
    # The variant that printed an 800 MB error line: the expansion as an unknown rate_source.
    _refused(tmp_path, f'{BODY}\n' + _alias_bomb('rate_source'), r'not valid YAML: aliases')


def test_omega_body_1e308(tmp_path):
    _refused(tmp_path, GOOD + 'initial_state: {omega_body: [1.0e+308, 1.0e+308, 1.0e+308]}\n',
             r'\|initial_state\.omega_body\| \[rad/s\] to be at most 1e\+75 so that the physics '
             r'stays finite, got 1\.73205e\+308')


def test_moments_1e308(tmp_path):
    _refused(tmp_path, 'rate_source: dynamics\nbody: {inertia: {moments: [1.0e+308, 1.0e+308, '
                       '1.0e+308]}}\n',
             r'body\.inertia\.moments \(principal moment\) to be \[1e-75, 1e\+75\]')


def test_energy_and_momentum_that_overflow_from_moderate_values(tmp_path):
    # Each value is within the scale limit; their products are not.
    _refused(tmp_path, 'rate_source: dynamics\nbody: {inertia: {moments: [1.0e+70, 1.0e+70, '
                       '1.0e+70]}}\ninitial_state: {omega_body: [1.0e+10, 0, 0]}\n',
             r'initial angular momentum \|J omega_body\| \[kg m²/s\] to be at most 1e\+75')
    _refused(tmp_path, 'rate_source: dynamics\nbody: {inertia: {moments: [1.0e+40, 1.0e+40, '
                       '1.0e+40]}}\ninitial_state: {omega_body: [1.0e+35, 0, 0]}\n',
             r'initial kinetic energy \[J\] to be at most 1e\+75')


def test_moments_too_small_to_invert_safely(tmp_path):
    _refused(tmp_path, 'rate_source: dynamics\nbody: {inertia: {moments: [1.0e-80, 1.0e-80, '
                       '1.0e-80]}}\n', r'body\.inertia\.moments \(principal moment\)')


def test_mass_beyond_the_scale_limit(tmp_path):
    _refused(tmp_path, 'rate_source: dynamics\nbody: {mass: 1.0e+200, inertia: {moments: '
                       '[1, 1, 1]}}\n', r'body\.mass to be \[1e-75, 1e\+75\]')


@pytest.mark.parametrize('component', ['1.0e+200', '1.0e-200'])
def test_attitude_that_overflows_or_underflows_when_normalised(tmp_path, component):
    _refused(tmp_path, GOOD + f'initial_state: {{attitude: [{component}, {component}, '
                              f'{component}, {component}]}}\n',
             r'initial_state\.attitude \(largest component\) to be \[1e-75, 1e\+75\]')


def test_zero_attitude_names_the_key(tmp_path):
    _refused(tmp_path, GOOD + 'initial_state: {attitude: [0, 0, 0, 0]}\n',
             r'initial_state\.attitude to be a non-zero quaternion \(w, x, y, z\), got '
             r'\[0\.0, 0\.0, 0\.0, 0\.0\]$')


def test_absurd_name_and_description(tmp_path):
    _refused(tmp_path, GOOD + f'name: {"x" * 300}\n',
             r"Expected 'name' to be at most 256 characters, got 300: 'xxx")
    _refused(tmp_path, GOOD + f'description: {"y" * 5000}\n',
             r"Expected 'description' to be at most 1024 characters, got 5000")


def test_a_huge_value_is_quoted_briefly(tmp_path):
    items = ', '.join(['dynamics'] * 5000)
    message = _refused(tmp_path, f'{BODY}\nrate_source: [{items}]\n', r'Unknown rate_source ')
    assert len(message) < 250


def test_keys_that_are_not_text(tmp_path):
    _refused(tmp_path, GOOD + '1: 2\n', r'Unknown key 1 in scene')
    _refused(tmp_path, GOOD + '[a, b]: 2\n', r'not valid YAML: found unhashable key')


def test_yaml_tags_and_control_characters(tmp_path):
    _refused(tmp_path, GOOD + 'name: !!python/object:os.system [ls]\n',
             r"line 3, column 7: not valid YAML: could not determine a constructor")
    _refused(tmp_path, GOOD + 'name: a\x00b\n', r'not valid YAML: unacceptable character #x0000')


def test_empty_file_and_non_mapping(tmp_path):
    _refused(tmp_path, '', r'Expected a scene to be a mapping .* got None')
    _refused(tmp_path, '- 1\n' * 3000, r'Expected a scene to be a mapping .* got \[1, 1, 1, 1, '
                                       r'1, 1, \.\.\.\]$')


def test_scene_from_mapping_applies_the_same_physics_limits():
    with pytest.raises(SceneError, match=r'\|initial_state\.omega_body\|'):
        scene_from_mapping({'rate_source': 'gyro', 'body': {'inertia': {'moments': [1, 1, 1]}},
                            'initial_state': {'omega_body': [1e300, 0, 0]}})
    with pytest.raises(SceneError, match=r"'body\.mass' to be a number within the float range"):
        scene_from_mapping({'rate_source': 'gyro', 'body': {
            'mass': 10 ** 400, 'inertia': {'moments': [1, 1, 1]}}})


def test_replay_prints_one_error_line_and_exits_1(tmp_path):
    bag = tmp_path / 'input'
    stamps = 0.01 * np.arange(20)
    write_bag(bag, stamps=stamps, rates=np.zeros((20, 3)))
    scene = tmp_path / 'bomb.yaml'
    scene.write_text('rate_source: gyro\n' + BODY + '\n' + _alias_bomb('name'))
    replay = Path(sys.prefix) / 'lib' / 'rigid_body_attitude' / 'replay'
    result = subprocess.run([str(replay), str(bag), '--scene', str(scene)],
                            capture_output=True, text=True, timeout=60, check=False)
    assert result.returncode == 1, result.stderr
    lines = result.stderr.splitlines()
    assert len(lines) == 1 and lines[0].startswith(f'error: Scene file {str(scene)!r}, line '), (
        result.stderr)
    assert 'aliases (*name) are not allowed' in lines[0]
