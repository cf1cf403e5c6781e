"""The README's parameter tables and config/params.yaml say what the parameter table declares;
docs/closed-loop.md's table what the controller's declares."""

import re
from pathlib import Path

import yaml

from rigid_body_attitude.session.parameters import PARAMETERS

REPO_ROOT = Path(__file__).resolve().parents[2]


#: Declared by the parameter table but not documented as node parameters: the thread-scheduling
#: parameters that the ros/session change removes. Empty this set once they are gone.
DOCUMENTED = list(PARAMETERS)


def readme_rows(heading: str) -> dict[str, list[str]]:
    """Name -> [type and default, run time] of each row of the README table under ``heading``."""
    text = (REPO_ROOT / 'README.md').read_text()
    start = text.index(f'\n### {heading}\n')
    section = text[start:text.index('\n#', start + 1)]
    rows = {}
    for line in section.splitlines():
        match = re.match(r'\| `(\w+)` \| (.*?) \| (yes|no) \| .+ \|$', line)
        if match:
            rows[match.group(1)] = [match.group(2), match.group(3)]
    return rows


def test_readme_lists_every_parameter_once_standard_then_advanced():
    standard, advanced = readme_rows('Standard parameters'), readme_rows('Advanced parameters')
    assert standard and advanced
    assert not set(standard) & set(advanced)
    assert sorted([*standard, *advanced]) == sorted(p.name for p in DOCUMENTED)


def test_readme_rows_are_one_line_each():
    text = (REPO_ROOT / 'README.md').read_text()
    for parameter in DOCUMENTED:
        lines = [line for line in text.splitlines() if line.startswith(f'| `{parameter.name}` |')]
        assert len(lines) == 1, parameter.name
        assert len(lines[0]) <= 200, parameter.name


def test_readme_gives_every_parameter_its_type_default_bounds_and_mutability():
    rows = readme_rows('Standard parameters') | readme_rows('Advanced parameters')
    for parameter in DOCUMENTED:
        assert_row_says(parameter, *rows[parameter.name])


def assert_row_says(parameter, type_default: str, run_time: str) -> None:
    """A table row's type, default, bounds and mutability are the parameter's."""
    type_name = {float: 'double', bool: 'bool', str: 'string',
                 tuple: 'double array'}[parameter.type]
    default = str(parameter.default).lower() if parameter.default != '' else "''"
    if parameter.type is tuple:
        default = str(list(parameter.default))
    assert type_default.startswith(f'{type_name}, `{default}`'), parameter.name
    if parameter.range_text():
        assert type_default.endswith(parameter.range_text()), parameter.name
    assert run_time == ('no' if parameter.read_only else 'yes'), parameter.name


def test_params_yaml_holds_every_default():
    document = yaml.safe_load((REPO_ROOT / 'config' / 'params.yaml').read_text())
    values = document['/**/attitude_propagator']['ros__parameters']
    values.pop('use_sim_time')
    assert values == {parameter.name: list(parameter.default) if parameter.type is tuple
                      else parameter.default for parameter in DOCUMENTED}


def test_the_controller_table_gives_every_controller_parameter_once():
    from rigid_body_attitude.session.controller_parameters import CONTROLLER_PARAMETERS
    text = (REPO_ROOT / 'docs' / 'closed-loop.md').read_text()
    start = text.index('\n## The reference controller\n')
    section = text[start:text.index('\n## ', start + 1)]
    rows = {}
    for line in section.splitlines():
        match = re.match(r'\| `(\w+)` \| (.*?) \| (yes|no) \| .+ \|$', line)
        if match:
            assert match.group(1) not in rows, match.group(1)
            rows[match.group(1)] = [match.group(2), match.group(3)]
    assert sorted(rows) == sorted(p.name for p in CONTROLLER_PARAMETERS)
    for parameter in CONTROLLER_PARAMETERS:
        assert_row_says(parameter, *rows[parameter.name])
