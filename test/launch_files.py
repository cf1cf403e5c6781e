"""The package's launch files read without launch_ros (it has no PyPI wheel), as ROS reads them.

Two front ends give one model (:class:`LaunchFile`): :func:`read_xml` the ``launch_xml``
format (``<arg>``, ``<node>`` with ``<param>`` and ``<remap>``), :func:`read_python` the
subset of Python launch files :data:`PYTHON_CALLS` lists, statically (``ast``: the file is
never run). Either refuses what it does not know (:class:`LaunchFileError`: an unknown tag,
attribute, call, keyword or substitution), so a file outside the checked subset fails rather
than passing unread. Values are evaluated as launch_ros evaluates them:

* ``$(var NAME)`` (Python: ``LaunchConfiguration('NAME')``) is the launch argument's value,
  its default unless given; it must be declared before the action using it;
  ``$(find-pkg-share PKG)`` (``FindPackageShare``) the package's share folder;
* a parameter value written as text is read as YAML after substitution (``1.0`` a double,
  ``1`` an integer, ``true`` a bool, ``[0.0, 1.0]`` a list); launch_ros refuses what YAML
  reads as nothing, a mapping, or an empty or mixed list. A Python literal stays as written;
* ``args`` are split as the shell would, each substitution one argument.

:func:`problems` then checks a file against the package's own tables (module docstring of
``test/test_launch_files.py``), and :func:`command_line` renders a node as the command
launch_ros would run.
"""

from __future__ import annotations

import ast
from dataclasses import dataclass, field
from pathlib import Path
import re
import shlex
from typing import Any
import xml.etree.ElementTree as ElementTree

import yaml

__all__ = ['Argument', 'LaunchFile', 'LaunchFileError', 'LaunchedNode', 'PYTHON_CALLS',
           'Resolver', 'TransitionRequest', 'read_launch_file', 'read_python', 'read_xml']


class LaunchFileError(Exception):
    """A construct the reader does not know, or a file launch itself would refuse."""


@dataclass
class Argument:
    """A declared launch argument."""

    name: str
    default: str | None
    description: str


@dataclass
class LaunchedNode:
    """A ``<node>`` (``Node``) or ``LifecycleNode`` with its values evaluated.

    ``parameters``: the explicit ones, as launch_ros passes them (later ones win);
    ``parameter_files``: the ``<param from=...>`` files, applied before them;
    ``problems``: values launch_ros itself refuses.
    """

    package: str
    executable: str
    name: str | None
    namespace: str
    lifecycle: bool = False
    parameters: dict[str, Any] = field(default_factory=dict)
    parameter_files: list[str] = field(default_factory=list)
    remaps: list[tuple[str, str]] = field(default_factory=list)
    arguments: list[str] = field(default_factory=list)
    problems: list[str] = field(default_factory=list)


@dataclass
class TransitionRequest:
    """A lifecycle transition a Python launch file requests: at start (``after`` None) or
    when its node goes ``after`` = (start state, goal state); ``condition``: the value of the
    launch argument of its ``IfCondition`` (None: unconditional)."""

    node: LaunchedNode
    transition: str
    after: tuple[str | None, str | None] | None
    condition: str | None


@dataclass
class LaunchFile:
    """What a launch file declares and starts."""

    path: Path
    top_comment: str
    arguments: dict[str, Argument] = field(default_factory=dict)
    nodes: list[LaunchedNode] = field(default_factory=list)
    transitions: list[TransitionRequest] = field(default_factory=list)
    used_arguments: set[str] = field(default_factory=set)
    problems: list[str] = field(default_factory=list)


class Resolver:
    """Substitutions of one launch file: launch arguments (their defaults, or ``given``
    values) and package share folders (``share_dirs``: package → folder)."""

    #: ``$(kind argument)`` of launch's substitution grammar, one level deep.
    SUBSTITUTION = re.compile(r'\$\(([a-z-]+)((?:\s+[^()\s]+)*)\s*\)')

    def __init__(self, launch: LaunchFile, share_dirs: dict[str, Path],
                 given: dict[str, str]) -> None:
        self.launch = launch
        self.share_dirs = share_dirs
        self.given = dict(given)

    def declare(self, argument: Argument) -> None:
        """An ``<arg>`` / ``DeclareLaunchArgument`` (names are declared once)."""
        if argument.name in self.launch.arguments:
            raise LaunchFileError(f'launch argument {argument.name!r} declared twice')
        self.launch.arguments[argument.name] = argument

    def var(self, name: str) -> str:
        """The value of launch argument ``name`` (a problem when it is not declared yet)."""
        self.launch.used_arguments.add(name)
        argument = self.launch.arguments.get(name)
        if argument is None:
            self.launch.problems.append(f'launch argument {name!r} used before it is declared')
            return ''
        if name in self.given:
            return self.given[name]
        if argument.default is None:
            self.launch.problems.append(f'launch argument {name!r} has no default')
            return ''
        return argument.default

    def find_pkg_share(self, package: str) -> str:
        """The share folder of ``package``."""
        if package not in self.share_dirs:
            raise LaunchFileError(f'no share folder known for package {package!r}')
        return str(self.share_dirs[package])

    def segments(self, text: str) -> list[tuple[bool, str]]:
        """``text`` as (is a substitution, its text or value) pieces."""
        pieces: list[tuple[bool, str]] = []
        position = 0
        for match in self.SUBSTITUTION.finditer(text):
            pieces.append((False, text[position:match.start()]))
            pieces.append((True, self._substitute(match.group(1), match.group(2).split())))
            position = match.end()
        pieces.append((False, text[position:]))
        if any('$(' in piece for is_value, piece in pieces if not is_value):
            raise LaunchFileError(f'unsupported substitution in {text!r}')
        return [(is_value, piece) for is_value, piece in pieces if is_value or piece]

    def text(self, text: str) -> str:
        """``text`` with its substitutions performed."""
        return ''.join(piece for _, piece in self.segments(text))

    def arguments(self, text: str) -> list[str]:
        """An ``args`` attribute as launch splits it: text as the shell would, each
        substitution one argument."""
        found: list[str] = []
        for is_value, piece in self.segments(text):
            found.extend([piece] if is_value else shlex.split(piece))
        return found

    def _substitute(self, kind: str, words: list[str]) -> str:
        if kind == 'var' and len(words) == 1:
            return self.var(words[0])
        if kind == 'find-pkg-share' and len(words) == 1:
            return self.find_pkg_share(words[0])
        raise LaunchFileError(f'unsupported substitution $({kind} {" ".join(words)})')


def parameter_value(value: Any, name: str, node: LaunchedNode) -> Any:
    """A parameter value as launch_ros passes it: text read as YAML, lists as tuples; a value
    launch_ros refuses is a problem of ``node``."""
    if isinstance(value, str):
        try:
            value = yaml.safe_load(value)
        except yaml.YAMLError as err:
            node.problems.append(f'parameter {name!r}: not YAML ({err})')
            return None
    if isinstance(value, (bool, int, float, str)):
        return value
    if isinstance(value, (list, tuple)) and value and isinstance(
            value[0], (bool, int, float, str)) and all(
            type(item) is type(value[0]) for item in value):
        return tuple(value)
    node.problems.append(f'parameter {name!r}: launch_ros refuses {value!r} (a value of type '
                         f'bool, int, float, str, or a non-empty list of one of them)')
    return None


# -- XML ---------------------------------------------------------------------------------------

#: The tags and attributes read, with the attributes each tag may have.
XML_ATTRIBUTES = {
    'launch': set(),
    'arg': {'name', 'default', 'description'},
    'node': {'pkg', 'exec', 'name', 'namespace', 'output', 'args'},
    'param': {'name', 'value', 'from'},
    'remap': {'from', 'to'},
}
#: The children each tag may have.
XML_CHILDREN = {'launch': {'arg', 'node'}, 'node': {'param', 'remap'}}


def _checked(element: ElementTree.Element) -> ElementTree.Element:
    """``element`` after checking its tag, attributes and children."""
    allowed = XML_ATTRIBUTES.get(element.tag)
    if allowed is None:
        raise LaunchFileError(f'unsupported tag <{element.tag}>')
    unknown = set(element.attrib) - allowed
    if unknown:
        raise LaunchFileError(f'<{element.tag}> has unsupported attributes {sorted(unknown)}')
    for child in element:
        if child.tag not in XML_CHILDREN.get(element.tag, set()):
            raise LaunchFileError(f'<{child.tag}> is not read inside <{element.tag}>')
    if (element.text or '').strip():
        raise LaunchFileError(f'<{element.tag}> holds text')
    return element


def _required(element: ElementTree.Element, name: str) -> str:
    value = element.get(name)
    if value is None:
        raise LaunchFileError(f'<{element.tag}> lacks attribute {name!r}')
    return value


def read_xml(path: Path, share_dirs: dict[str, Path],
             given: dict[str, str] | None = None) -> LaunchFile:
    """A ``launch_xml`` file, its arguments ``given`` (name → value) or at their defaults."""
    text = path.read_text(encoding='utf-8')
    comment = re.match(r'\s*(?:<\?xml[^>]*\?>\s*)?<!--(.*?)-->', text, flags=re.S)
    launch = LaunchFile(path, comment.group(1) if comment else '')
    resolver = Resolver(launch, share_dirs, given or {})
    root = _checked(ElementTree.fromstring(text))
    if root.tag != 'launch':
        raise LaunchFileError(f'the root is <{root.tag}>, not <launch>')
    for element in root:
        _checked(element)
        if element.tag == 'arg':
            default = element.get('default')
            resolver.declare(Argument(_required(element, 'name'),
                                      None if default is None else resolver.text(default),
                                      element.get('description', '')))
        else:
            launch.nodes.append(_xml_node(element, resolver))
    _check_given(launch, given)
    return launch


def _xml_node(element: ElementTree.Element, resolver: Resolver) -> LaunchedNode:
    name = element.get('name')
    node = LaunchedNode(
        resolver.text(_required(element, 'pkg')), resolver.text(_required(element, 'exec')),
        None if name is None else resolver.text(name),
        resolver.text(element.get('namespace', '')),
        arguments=resolver.arguments(element.get('args', '')))
    for child in element:
        _checked(child)
        if child.tag == 'remap':
            node.remaps.append((resolver.text(_required(child, 'from')),
                                resolver.text(_required(child, 'to'))))
        elif 'from' in child.attrib:
            if set(child.attrib) != {'from'}:
                raise LaunchFileError('<param from=...> takes no other attribute')
            node.parameter_files.append(resolver.text(child.attrib['from']))
        else:
            parameter = _required(child, 'name')
            node.parameters[parameter] = parameter_value(
                resolver.text(_required(child, 'value')), parameter, node)
    return node


def _check_given(launch: LaunchFile, given: dict[str, str] | None) -> None:
    unknown = set(given or {}) - set(launch.arguments)
    if unknown:
        raise LaunchFileError(f'no launch arguments {sorted(unknown)} to give')


# -- Python ------------------------------------------------------------------------------------

_NODE_KEYWORDS = frozenset({'package', 'executable', 'name', 'namespace', 'output',
                            'parameters', 'remappings', 'arguments'})

#: The calls a Python launch file may make: qualified name → (positional arguments, keywords,
#: required keywords), as launch and launch_ros (Jazzy) define them.
PYTHON_CALLS: dict[str, tuple[int, frozenset[str], frozenset[str]]] = {
    'launch.LaunchDescription': (1, frozenset(), frozenset()),
    'launch.actions.DeclareLaunchArgument': (
        1, frozenset({'default_value', 'description'}), frozenset({'description'})),
    'launch.actions.EmitEvent': (0, frozenset({'event', 'condition'}), frozenset({'event'})),
    'launch.actions.RegisterEventHandler': (1, frozenset({'condition'}), frozenset()),
    'launch.conditions.IfCondition': (1, frozenset(), frozenset()),
    'launch.events.matches_action': (1, frozenset(), frozenset()),
    'launch.substitutions.LaunchConfiguration': (1, frozenset(), frozenset()),
    'launch.substitutions.PathJoinSubstitution': (1, frozenset(), frozenset()),
    'launch_ros.actions.LifecycleNode': (
        0, _NODE_KEYWORDS, frozenset({'package', 'executable', 'name', 'namespace'})),
    'launch_ros.actions.Node': (0, _NODE_KEYWORDS, frozenset({'package', 'executable'})),
    'launch_ros.event_handlers.OnStateTransition': (
        0, frozenset({'target_lifecycle_node', 'start_state', 'goal_state', 'entities'}),
        frozenset({'target_lifecycle_node', 'entities'})),
    'launch_ros.events.lifecycle.ChangeState': (
        0, frozenset({'lifecycle_node_matcher', 'transition_id'}),
        frozenset({'lifecycle_node_matcher', 'transition_id'})),
    'launch_ros.substitutions.FindPackageShare': (1, frozenset(), frozenset()),
}
#: Classes whose constants a Python launch file may name (``Transition.TRANSITION_...``).
PYTHON_CONSTANT_OWNERS = frozenset({'lifecycle_msgs.msg.Transition'})


@dataclass(frozen=True, eq=False)
class Call:
    """A call of :data:`PYTHON_CALLS`, its arguments evaluated (identity matters: the node a
    handler targets is the node object)."""

    name: str
    args: tuple[Any, ...]
    kwargs: dict[str, Any]


@dataclass(frozen=True)
class Constant:
    """A constant of :data:`PYTHON_CONSTANT_OWNERS`: owner and attribute."""

    owner: str
    attribute: str


class _PythonEvaluator:
    """Expressions of ``generate_launch_description`` → values, :class:`Call` and
    :class:`Constant`."""

    def __init__(self, imports: dict[str, str]) -> None:
        self.imports = imports
        self.names: dict[str, Any] = {}

    def value(self, node: ast.expr) -> Any:
        if isinstance(node, ast.Constant):
            return node.value
        if isinstance(node, (ast.List, ast.Tuple)):
            items = [self.value(item) for item in node.elts]
            return items if isinstance(node, ast.List) else tuple(items)
        if isinstance(node, ast.Dict):
            return self._dict(node)
        if isinstance(node, ast.Name) and node.id in self.names:
            return self.names[node.id]
        if isinstance(node, ast.Attribute) and isinstance(node.value, ast.Name):
            owner = self.imports.get(node.value.id, '')
            if owner in PYTHON_CONSTANT_OWNERS:
                return Constant(owner, node.attr)
        if isinstance(node, ast.Call):
            return self._call(node)
        raise LaunchFileError(f'line {node.lineno}: unsupported expression {ast.unparse(node)}')

    def _dict(self, node: ast.Dict) -> dict[str, Any]:
        keys = [self.value(key) if key is not None else None for key in node.keys]
        if not all(isinstance(key, str) for key in keys):
            raise LaunchFileError(f'line {node.lineno}: dictionary keys must be strings')
        return dict(zip(keys, (self.value(value) for value in node.values)))

    def _call(self, node: ast.Call) -> Call:
        name = self.imports.get(node.func.id, '') if isinstance(node.func, ast.Name) else ''
        if name not in PYTHON_CALLS:
            raise LaunchFileError(f'line {node.lineno}: unsupported call {ast.unparse(node.func)}')
        positional, keywords, required = PYTHON_CALLS[name]
        given = {keyword.arg for keyword in node.keywords}
        if len(node.args) != positional or None in given or not given <= keywords or (
                not required <= given):
            raise LaunchFileError(
                f'line {node.lineno}: {name} takes {positional} positional arguments and the '
                f'keywords {sorted(keywords)} (required: {sorted(required)})')
        return Call(name, tuple(self.value(arg) for arg in node.args),
                    {str(keyword.arg): self.value(keyword.value) for keyword in node.keywords})


def _python_imports(module: ast.Module) -> dict[str, str]:
    """``from X import A`` → {A: X.A}; any other module-level statement but the function,
    the docstring and these imports is refused."""
    imports: dict[str, str] = {}
    for statement in module.body:
        if isinstance(statement, ast.ImportFrom) and statement.module and not statement.level:
            for alias in statement.names:
                imports[alias.asname or alias.name] = f'{statement.module}.{alias.name}'
        elif not isinstance(statement, ast.FunctionDef) and not (
                isinstance(statement, ast.Expr) and isinstance(statement.value, ast.Constant)):
            raise LaunchFileError(f'line {statement.lineno}: unsupported module statement')
    return imports


def _launch_description(module: ast.Module, evaluator: _PythonEvaluator) -> list[Any]:
    """The actions ``generate_launch_description()`` returns, in order."""
    functions = [s for s in module.body if isinstance(s, ast.FunctionDef)]
    if [f.name for f in functions] != ['generate_launch_description'] or (
            functions[0].args.args or functions[0].args.kwonlyargs):
        raise LaunchFileError('expected one function, generate_launch_description()')
    body = functions[0].body
    if body and isinstance(body[0], ast.Expr) and isinstance(body[0].value, ast.Constant):
        body = body[1:]
    for statement in body[:-1]:
        if not (isinstance(statement, ast.Assign) and len(statement.targets) == 1
                and isinstance(statement.targets[0], ast.Name)):
            raise LaunchFileError(f'line {statement.lineno}: expected `name = expression`')
        evaluator.names[statement.targets[0].id] = evaluator.value(statement.value)
    last = body[-1] if body else None
    result = evaluator.value(last.value) if isinstance(last, ast.Return) and last.value else None
    if not (isinstance(result, Call) and result.name == 'launch.LaunchDescription'
            and isinstance(result.args[0], list)):
        raise LaunchFileError('expected `return LaunchDescription([...])` last')
    return list(result.args[0])


def read_python(path: Path, share_dirs: dict[str, Path],
                given: dict[str, str] | None = None) -> LaunchFile:
    """A Python launch file of the :data:`PYTHON_CALLS` subset, read statically."""
    module = ast.parse(path.read_text(encoding='utf-8'))
    launch = LaunchFile(path, ast.get_docstring(module) or '')
    evaluator = _PythonEvaluator(_python_imports(module))
    actions = _launch_description(module, evaluator)
    reader = _PythonActions(launch, Resolver(launch, share_dirs, given or {}))
    for action in actions:
        reader.action(action)
    reader.end()
    _check_given(launch, given)
    return launch


class _PythonActions:
    """The actions of a Python launch description, into the model."""

    def __init__(self, launch: LaunchFile, resolver: Resolver) -> None:
        self.launch = launch
        self.resolver = resolver
        #: id of a node's call → the node (handlers may be registered before their node).
        self.nodes: dict[int, LaunchedNode] = {}
        #: (id of the target's call, transition, after, condition), resolved by :meth:`end`.
        self.pending: list[tuple[int, str, tuple[str | None, str | None] | None,
                                 str | None]] = []

    def end(self) -> None:
        """Every requested transition to its node (launched by this file)."""
        for target, transition, after, condition in self.pending:
            if target not in self.nodes:
                raise LaunchFileError('ChangeState and OnStateTransition must name a node this '
                                      'file launches')
            self.launch.transitions.append(TransitionRequest(
                self.nodes[target], transition, after, condition))

    def action(self, action: Any) -> None:
        name = action.name if isinstance(action, Call) else repr(action)
        if name == 'launch.actions.DeclareLaunchArgument':
            default = action.kwargs.get('default_value')
            self.resolver.declare(Argument(
                self._literal(action.args[0]),
                None if default is None else self.text(default),
                self._literal(action.kwargs['description'])))
        elif name in ('launch_ros.actions.Node', 'launch_ros.actions.LifecycleNode'):
            self.nodes[id(action)] = self._node(action)
            self.launch.nodes.append(self.nodes[id(action)])
        elif name == 'launch.actions.EmitEvent':
            self._transition(action.kwargs['event'], None, action.kwargs.get('condition'))
        elif name == 'launch.actions.RegisterEventHandler':
            self._handler(action.args[0], action.kwargs.get('condition'))
        else:
            raise LaunchFileError(f'unsupported action {name}')

    def text(self, value: Any) -> str:
        """A substitution (or a plain string) as text."""
        if isinstance(value, str):
            return value
        if isinstance(value, Call) and value.name == 'launch.substitutions.LaunchConfiguration':
            return self.resolver.var(self._literal(value.args[0]))
        if isinstance(value, Call) and value.name == 'launch_ros.substitutions.FindPackageShare':
            return self.resolver.find_pkg_share(self._literal(value.args[0]))
        if isinstance(value, Call) and value.name == 'launch.substitutions.PathJoinSubstitution':
            return '/'.join(self.text(part) for part in value.args[0])
        raise LaunchFileError(f'not a substitution: {value!r}')

    def _literal(self, value: Any) -> str:
        if not isinstance(value, str):
            raise LaunchFileError(f'expected a string literal, got {value!r}')
        return value

    def _node(self, call: Call) -> LaunchedNode:
        kwargs = call.kwargs
        node = LaunchedNode(
            self.text(kwargs['package']), self.text(kwargs['executable']),
            self.text(kwargs['name']) if 'name' in kwargs else None,
            self.text(kwargs.get('namespace', '')),
            lifecycle=call.name == 'launch_ros.actions.LifecycleNode',
            arguments=[self.text(item) for item in kwargs.get('arguments', [])],
            remaps=[(self.text(a), self.text(b)) for a, b in kwargs.get('remappings', [])])
        for entry in kwargs.get('parameters', []):
            if isinstance(entry, dict):
                for name, value in entry.items():
                    node.parameters[name] = parameter_value(self._raw(value), name, node)
            else:
                node.parameter_files.append(self.text(entry))
        return node

    def _raw(self, value: Any) -> Any:
        """A parameter value before launch_ros evaluates it: numbers and bools as written,
        strings and substitutions as text (read as YAML), lists item by item."""
        if isinstance(value, (bool, int, float)):
            return value
        if isinstance(value, list):
            items = [self._raw(item) for item in value]
            return [yaml.safe_load(item) if isinstance(item, str) else item for item in items]
        return self.text(value)

    def _condition(self, condition: Any) -> str | None:
        if condition is None:
            return None
        if isinstance(condition, Call) and condition.name == 'launch.conditions.IfCondition':
            return self.text(condition.args[0])
        raise LaunchFileError(f'unsupported condition {condition!r}')

    def _transition(self, event: Any, after: tuple[str | None, str | None] | None,
                    condition: Any) -> None:
        if not (isinstance(event, Call)
                and event.name == 'launch_ros.events.lifecycle.ChangeState'):
            raise LaunchFileError(f'unsupported event {event!r}')
        matcher = event.kwargs['lifecycle_node_matcher']
        transition = event.kwargs['transition_id']
        if not (isinstance(matcher, Call) and matcher.name == 'launch.events.matches_action'):
            raise LaunchFileError('ChangeState must match its node with matches_action')
        if not isinstance(transition, Constant):
            raise LaunchFileError(f'transition_id {transition!r}: name a Transition constant')
        self.pending.append((id(matcher.args[0]), transition.attribute, after,
                             self._condition(condition)))

    def _handler(self, handler: Any, condition: Any) -> None:
        if not (isinstance(handler, Call)
                and handler.name == 'launch_ros.event_handlers.OnStateTransition'):
            raise LaunchFileError(f'unsupported event handler {handler!r}')
        target = handler.kwargs['target_lifecycle_node']
        after = (handler.kwargs.get('start_state'), handler.kwargs.get('goal_state'))
        for entity in handler.kwargs['entities']:
            if not (isinstance(entity, Call) and entity.name == 'launch.actions.EmitEvent'):
                raise LaunchFileError(f'unsupported handler entity {entity!r}')
            self._transition(entity.kwargs['event'], after, condition)
            event = entity.kwargs['event']
            if event.kwargs['lifecycle_node_matcher'].args[0] is not target:
                raise LaunchFileError('a handler changes the state of the node it watches only')


def read_launch_file(path: Path, share_dirs: dict[str, Path],
                     given: dict[str, str] | None = None) -> LaunchFile:
    """An XML (``*.launch.xml``) or Python (``*.launch.py``) launch file."""
    if path.name.endswith('.launch.xml'):
        return read_xml(path, share_dirs, given)
    if path.name.endswith('.launch.py'):
        return read_python(path, share_dirs, given)
    raise LaunchFileError(f'{path.name}: not a .launch.xml or .launch.py file')
