"""The project's documentation rules as tests, read from the source with ``ast``.

* Every module, and every public class, function and method of the package, has a docstring
  (the role of ament's pep257 test). Public means the name does not start with ``_``; magic
  methods, ``@overload`` stubs and property setters/deleters are exempt.
* Public functions and methods of the core (everything but the rclpy shells, which stay lightly
  typed like the ROS examples) annotate every parameter and the return type (``__init__`` needs
  no return annotation).
* No work-in-progress markers in the package, benchmarks, studies, scripts or tests.
"""

import ast
from pathlib import Path
import re

import pytest

REPO_ROOT = Path(__file__).resolve().parents[1]
PACKAGE_DIR = REPO_ROOT / 'rigid_body_attitude'
SHELL_MODULES = {'node.py', 'replay.py'}  # rclpy shells: docstrings yes, full typing no

PACKAGE_FILES = sorted(PACKAGE_DIR.rglob('*.py'))
MARKER_FILES = sorted(
    path for folder in ('rigid_body_attitude', 'bench', 'studies', 'scripts', 'test')
    for path in (REPO_ROOT / folder).rglob('*')
    if path.is_file() and (path.suffix == '.py' or path.parent.name in ('scripts', 'launchers'))
    and '__pycache__' not in path.parts)
# Spelled in pieces so that this file does not match itself.
WORK_IN_PROGRESS = re.compile(
    r'\b(' + '|'.join(['TO' + 'DO', 'FIX' + 'ME', 'NotImplemented' + 'Error']) + r')\b')

FUNCTION_TYPES = (ast.FunctionDef, ast.AsyncFunctionDef)
FunctionNode = ast.FunctionDef | ast.AsyncFunctionDef


def relative(path: Path) -> str:
    """Return ``path`` relative to the repository, for test ids and messages."""
    return str(path.relative_to(REPO_ROOT))


def decorator_names(function: FunctionNode) -> set[str]:
    """Return the decorators of ``function`` as dotted names (``overload``, ``name.setter``)."""
    return {ast.unparse(decorator) for decorator in function.decorator_list}


def is_exempt_from_docstring(function: FunctionNode) -> bool:
    """Tell whether a function needs no docstring: magic methods, overloads, setters."""
    decorators = decorator_names(function)
    return (
        (function.name.startswith('__') and function.name.endswith('__'))
        or bool(decorators & {'overload', 'typing.overload'})
        or any(d.endswith(('.setter', '.deleter')) for d in decorators))


def public_definitions(tree: ast.Module) -> list[tuple[str, ast.AST]]:
    """Return ``(qualified name, node)`` of public top-level definitions and their methods."""
    definitions = []
    for node in tree.body:
        if not isinstance(node, (ast.ClassDef, *FUNCTION_TYPES)):
            continue
        if node.name.startswith('_'):
            continue
        definitions.append((node.name, node))
        if isinstance(node, ast.ClassDef):
            definitions.extend(
                (f'{node.name}.{member.name}', member) for member in node.body
                if isinstance(member, FUNCTION_TYPES)
                and (not member.name.startswith('_') or member.name.startswith('__')))
    return definitions


def missing_annotations(function: FunctionNode, is_method: bool) -> list[str]:
    """Return the parameters (and ``return``) of ``function`` that have no annotation."""
    arguments = function.args
    parameters = [*arguments.posonlyargs, *arguments.args, *arguments.kwonlyargs]
    if is_method and parameters and 'staticmethod' not in decorator_names(function):
        parameters = parameters[1:]  # self or cls
    parameters += [a for a in (arguments.vararg, arguments.kwarg) if a is not None]
    missing = [parameter.arg for parameter in parameters if parameter.annotation is None]
    if function.returns is None and function.name != '__init__':
        missing.append('return')
    return missing


def parse(path: Path) -> ast.Module:
    """Return the syntax tree of a source file."""
    return ast.parse(path.read_text(encoding='utf-8'), filename=str(path))


@pytest.mark.parametrize('path', PACKAGE_FILES, ids=relative)
def test_public_names_have_docstrings(path):
    tree = parse(path)
    undocumented = [] if ast.get_docstring(tree) else ['<module>']
    undocumented += [
        name for name, node in public_definitions(tree)
        if not ast.get_docstring(node)
        and not (isinstance(node, FUNCTION_TYPES) and is_exempt_from_docstring(node))]
    assert undocumented == [], f'{relative(path)}: no docstring on {undocumented}'


@pytest.mark.parametrize(
    'path', [p for p in PACKAGE_FILES if p.name not in SHELL_MODULES], ids=relative)
def test_core_public_functions_are_annotated(path):
    unannotated = {}
    for name, node in public_definitions(parse(path)):
        if isinstance(node, FUNCTION_TYPES) and 'overload' not in decorator_names(node):
            missing = missing_annotations(node, is_method='.' in name)
            if missing:
                unannotated[name] = missing
    assert unannotated == {}, f'{relative(path)}: missing annotations {unannotated}'


@pytest.mark.parametrize('path', MARKER_FILES, ids=relative)
def test_no_work_in_progress_markers(path):
    found = [
        f'{relative(path)}:{number}: {line.strip()}'
        for number, line in enumerate(path.read_text(encoding='utf-8').splitlines(), start=1)
        if WORK_IN_PROGRESS.search(line)]
    assert found == []


def test_rules_reject_what_they_should():
    # The checks above pass only if they can fail: run them on a bad example.
    tree = ast.parse(
        'def shown(x, *args):\n    return x\n\n\n'
        'class Shape:\n    """Doc."""\n\n    def area(self, scale: float):\n        return 1\n\n'
        '    @property\n    def size(self) -> int:\n        """Doc."""\n        return 1\n\n'
        '    @size.setter\n    def size(self, value: int) -> None:\n        pass\n')
    definitions = dict(public_definitions(tree))
    assert ast.get_docstring(tree) is None
    assert set(definitions) == {'shown', 'Shape', 'Shape.area', 'Shape.size'}
    assert not ast.get_docstring(definitions['shown'])
    assert missing_annotations(definitions['shown'], is_method=False) == ['x', 'args', 'return']
    assert missing_annotations(definitions['Shape.area'], is_method=True) == ['return']
    setter = tree.body[1].body[-1]
    assert is_exempt_from_docstring(setter)
    assert WORK_IN_PROGRESS.search('raise ' + 'NotImplemented' + 'Error')
    assert not WORK_IN_PROGRESS.search('todos = 3  # counts of things')
