"""The README's parameter table and config/params.yaml say what the parameter table declares."""

import re
from pathlib import Path

import yaml

from rigid_body_attitude.session.parameters import PARAMETERS

REPO_ROOT = Path(__file__).resolve().parents[2]


def readme_rows() -> dict[str, list[str]]:
    text = (REPO_ROOT / 'README.md').read_text()
    section = text[text.index('### Parameters'):text.index('### Topics and service')]
    rows = {}
    for line in section.splitlines():
        match = re.match(r'\| `(\w+)` \| (.*?) \| (yes|no) \|', line)
        if match:
            rows[match.group(1)] = [match.group(2), match.group(3)]
    return rows


def test_readme_lists_every_parameter_with_its_type_default_bounds_and_mutability():
    rows = readme_rows()
    assert list(rows) == [parameter.name for parameter in PARAMETERS]
    for parameter in PARAMETERS:
        type_default, run_time = rows[parameter.name]
        type_name = {float: 'double', bool: 'bool', str: 'string'}[parameter.type]
        default = str(parameter.default).lower() if parameter.default != '' else "''"
        assert type_default.startswith(f'{type_name}, `{default}`'), parameter.name
        if parameter.range_text():
            assert type_default.endswith(parameter.range_text()), parameter.name
        assert run_time == ('no' if parameter.read_only else 'yes'), parameter.name


def test_params_yaml_holds_every_default():
    document = yaml.safe_load((REPO_ROOT / 'config' / 'params.yaml').read_text())
    values = document['/**/attitude_propagator']['ros__parameters']
    values.pop('use_sim_time')
    assert values == {parameter.name: parameter.default for parameter in PARAMETERS}
