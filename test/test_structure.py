"""The package stays in small pieces: no module over 600 lines, no class over 250."""

import ast
import re
from pathlib import Path
import sys

PACKAGE = Path(__file__).resolve().parents[1] / 'rigid_body_attitude'
MAX_MODULE_LINES = 600
MAX_CLASS_LINES = 250


def test_no_module_over_600_lines_and_no_class_over_250():
    too_long = []
    for path in sorted(PACKAGE.rglob('*.py')):
        text = path.read_text()
        if text.count('\n') > MAX_MODULE_LINES:
            too_long.append(f'{path.relative_to(PACKAGE)}: {text.count(chr(10))} lines')
        for node in ast.walk(ast.parse(text)):
            if isinstance(node, ast.ClassDef):
                lines = node.end_lineno - node.lineno + 1
                if lines > MAX_CLASS_LINES:
                    too_long.append(f'{path.relative_to(PACKAGE)}: class {node.name} {lines}')
    assert too_long == []


def test_rclpy_is_imported_in_the_ros_subpackage_only():
    importers = sorted(
        str(path.relative_to(PACKAGE)) for path in PACKAGE.rglob('*.py')
        if any(isinstance(node, (ast.Import, ast.ImportFrom)) and any(
            (alias.name if isinstance(node, ast.Import) else node.module or '').split('.')[0]
            == 'rclpy' for alias in node.names)
            for node in ast.walk(ast.parse(path.read_text()))))
    assert importers and all(name.startswith('ros/') for name in importers), importers


def imported_modules(path):
    """Names of the modules a file imports (absolute imports), anywhere in it."""
    names = []
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            names += [alias.name for alias in node.names]
        elif isinstance(node, ast.ImportFrom) and not node.level and node.module:
            names.append(node.module)
    return names


def imports_outside(subpackages, allowed):
    """``file: module`` for each import in ``subpackages`` that is neither the standard library
    nor under one of the ``allowed`` prefixes."""
    found = []
    for subpackage in subpackages:
        for path in sorted((PACKAGE / subpackage).rglob('*.py')):
            for name in imported_modules(path):
                if name.split('.')[0] in sys.stdlib_module_names or any(
                        name == prefix or name.startswith(prefix + '.') for prefix in allowed):
                    continue
                found.append(f'{path.relative_to(PACKAGE)}: {name}')
    return found


def test_msgs_imports_the_standard_library_and_the_core_only():
    allowed = ('rigid_body_attitude.msgs', 'rigid_body_attitude.core')
    assert imports_outside(['msgs'], allowed) == []
    assert imports_outside(['bag'], allowed) != []  # the check sees a storage library


def test_the_node_layers_import_no_bag_or_tool_module():
    forbidden = ('rigid_body_attitude.bag', 'rigid_body_attitude.tools', 'rosbags', 'apsw')
    found = [entry for entry in imports_outside(['core', 'msgs', 'session', 'ros'], ())
             if entry.split(': ')[1].startswith(forbidden)]
    assert found == []


def module_name(path, root=PACKAGE):
    """Dotted name of the module at ``path`` (a package's ``__init__.py`` names the package)."""
    parts = path.relative_to(root.parent).with_suffix('').parts
    return '.'.join(parts[:-1] if parts[-1] == '__init__' else parts)


def internal_imports(path, modules, root=PACKAGE):
    """The package's modules that ``path`` imports, anywhere in it (function-level imports
    included): the module imported, and each package on its way that the importer is not
    inside (importing ``a.b.c`` runs ``a/b/__init__.py`` unless ``a.b`` is already loading)."""
    importer = module_name(path, root)
    ancestors = {importer.rsplit('.', n)[0] for n in range(importer.count('.') + 1)}
    package = importer if path.name == '__init__.py' else importer.rpartition('.')[0]
    found = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            targets = [alias.name for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ''
            if node.level:
                base = '.'.join(
                    [*package.split('.')[:len(package.split('.')) - node.level + 1], base]
                ).rstrip('.')
            targets = [f'{base}.{alias.name}' if f'{base}.{alias.name}' in modules else base
                       for alias in node.names]
        else:
            continue
        for target in targets:
            while target and target not in modules:
                target = target.rpartition('.')[0]
            parts = target.split('.')
            found.update(name for name in ('.'.join(parts[:n]) for n in range(1, len(parts) + 1))
                         if name in modules and (name == target or name not in ancestors))
    found.discard(importer)
    return found


def import_cycles(root=PACKAGE):
    """Each cycle of imports among the modules under ``root``, as a list of module names."""
    paths = {module_name(path, root): path for path in sorted(root.rglob('*.py'))}
    graph = {name: sorted(internal_imports(path, paths, root)) for name, path in paths.items()}
    cycles, state = [], {}

    def visit(name, stack):
        state[name] = 'open'
        stack.append(name)
        for target in graph[name]:
            if state.get(target) == 'open':
                cycles.append(stack[stack.index(target):] + [target])
            elif target not in state:
                visit(target, stack)
        stack.pop()
        state[name] = 'done'

    for name in sorted(graph):
        if name not in state:
            visit(name, [])
    return cycles


def test_no_import_cycles_lazy_imports_included():
    assert import_cycles() == []


def test_the_cycle_check_sees_a_cycle_through_a_function_level_import(tmp_path):
    root = tmp_path / 'pkg'
    (root / 'sub').mkdir(parents=True)
    (root / '__init__.py').write_text('')
    (root / 'sub' / '__init__.py').write_text('from pkg.sub.b import B\n')
    (root / 'sub' / 'b.py').write_text('from pkg import a\nB = 1\n')
    (root / 'a.py').write_text('def f():\n    from .sub import B\n    return B\n')
    assert import_cycles(root) == [['pkg.a', 'pkg.sub', 'pkg.sub.b', 'pkg.a']]


#: What each room of core/ may import besides the standard library, NumPy, SciPy, PyYAML and
#: the shared modules (errors, registry, paths, yaml_files): attitude math at the bottom; the
#: environment (world axes, magnetic field, orbit), the IMU's models, sensors and control laws
#: over it; rigid-body dynamics (a scene: the body, its effects, its sensors and controllers)
#: over those; the propagators at the top.
CORE_ROOMS = {
    'attitude': (),
    'environment': ('attitude',),
    'estimation': ('attitude', 'environment'),
    'control': ('attitude',),
    'sensors': ('attitude', 'environment', 'estimation'),
    'dynamics': ('attitude', 'environment', 'estimation', 'control', 'sensors'),
}
CORE_SHARED = ('errors', 'registry', 'paths', 'yaml_files')
THIRD_PARTY_IN_CORE = ('numpy', 'scipy', 'yaml', 'ppigrf')


def test_core_rooms_import_only_the_rooms_below_them():
    assert set(CORE_ROOMS) >= {'attitude', 'estimation', 'dynamics'}
    core = 'rigid_body_attitude.core'
    found = []
    for room, below in CORE_ROOMS.items():
        if not (PACKAGE / 'core' / room).is_dir():
            continue
        allowed = (*THIRD_PARTY_IN_CORE, *(f'{core}.{name}' for name in (room, *below)),
                   *(f'{core}.{name}' for name in CORE_SHARED))
        found += imports_outside([f'core/{room}'], allowed)
    shared = [f'core/{name}.py' for name in CORE_SHARED]
    found += [entry for entry in imports_outside(['core'], ('numpy', 'scipy', 'yaml'))
              if entry.split(':')[0] in shared]
    assert found == []


def test_the_core_imports_no_node_layer():
    allowed = ('numpy', 'scipy', 'yaml', 'ppigrf', 'rigid_body_attitude.core')
    assert imports_outside(['core'], allowed) == []


def listed_in_architecture(relative, text):
    """Whether docs/architecture.md names the module at ``relative`` (a path in the package):
    its file name in the tree drawing (the tree's indentation places it), or its path."""
    return relative.as_posix() in text or re.search(
        rf'(?<![\w/]){re.escape(relative.name)}(?!\w)', text) is not None


def test_architecture_lists_every_module_and_subpackage():
    text = (PACKAGE.parent / 'docs' / 'architecture.md').read_text()
    missing = [str(path.relative_to(PACKAGE)) for path in sorted(PACKAGE.rglob('*.py'))
               if path.name not in ('__init__.py', '__main__.py')
               and not listed_in_architecture(path.relative_to(PACKAGE), text)]
    missing += [f'{path.relative_to(PACKAGE)}/' for path in sorted(PACKAGE.rglob('*'))
                if path.is_dir() and path.name != '__pycache__'
                and f'{path.name}/' not in text]
    assert missing == []
    assert not listed_in_architecture(Path('core/no_such_module.py'), text)


def import_unit(relative):
    """The room or layer of docs/architecture.md's import table that holds the module at
    ``relative`` (a path in the package), or ``None`` for the package's own ``__init__``."""
    parts = relative.parts
    if parts[0] == 'core':
        if len(parts) > 2:
            return f'core/{parts[1]}/'
        return 'core/propagator.py' if parts[1] == 'propagator.py' else 'core/*.py'
    if len(parts) == 1:
        return None if parts[0] == '__init__.py' else parts[0]
    return f'{parts[0]}/'


def actual_imports(root=PACKAGE):
    """Room or layer → (the rooms and layers it imports, the outside packages it imports),
    function-level imports included."""
    modules = {module_name(path, root): path for path in root.rglob('*.py')}
    found = {}
    for path in sorted(root.rglob('*.py')):
        unit = import_unit(path.relative_to(root))
        if unit is None:
            continue
        inside, outside = found.setdefault(unit, (set(), set()))
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.Import):
                targets = [alias.name for alias in node.names]
            elif isinstance(node, ast.ImportFrom) and not node.level and node.module:
                targets = [f'{node.module}.{alias.name}' if f'{node.module}.{alias.name}' in
                           modules else node.module for alias in node.names]
            else:
                continue
            for target in targets:
                top = target.split('.')[0]
                if top != root.name:
                    if top not in sys.stdlib_module_names:
                        outside.add(top)
                    continue
                while target not in modules:
                    target = target.rpartition('.')[0]
                imported = import_unit(modules[target].relative_to(root))
                if imported not in (None, unit):
                    inside.add(imported)
    return found


def documented_imports(text):
    """The import table of docs/architecture.md: room or layer → (rooms and layers, outside
    packages)."""
    table = {}
    for line in text.splitlines():
        match = re.match(r'\| `([^`]+)`[^|]*\| ([^|]*)\| ([^|]*)\|$', line)
        if match:
            inside = set(re.findall(r'`([^`]+)`', match.group(2)))
            outside = {name.strip() for name in match.group(3).split(',') if name.strip()}
            table[match.group(1)] = (inside, outside)
    return table


def test_the_architecture_import_table_is_the_packages_imports():
    """Every room of core/ and every layer (msgs, session, ros, bag, tools, console) imports
    exactly what docs/architecture.md's table says: nothing more, nothing less."""
    text = (PACKAGE.parent / 'docs' / 'architecture.md').read_text()
    documented, actual = documented_imports(text), actual_imports()
    assert {'core/dynamics/', 'msgs/', 'session/', 'ros/', 'bag/', 'tools/'} <= set(actual)
    assert documented == actual


def test_the_import_table_check_sees_an_import_the_table_lacks(tmp_path):
    root = tmp_path / 'pkg'
    (root / 'core' / 'attitude').mkdir(parents=True)
    (root / 'msgs').mkdir()
    for folder in (root, root / 'core', root / 'core' / 'attitude', root / 'msgs'):
        (folder / '__init__.py').write_text('')
    (root / 'core' / 'attitude' / 'q.py').write_text('import numpy\n')
    (root / 'msgs' / 'm.py').write_text('def f():\n    from pkg.core.attitude import q\n')
    assert actual_imports(root) == {'core/*.py': (set(), set()),
                                    'core/attitude/': (set(), {'numpy'}),
                                    'msgs/': ({'core/attitude/'}, set())}
    table = documented_imports('| `msgs/` | `core/*.py` | |\n')
    assert table == {'msgs/': ({'core/*.py'}, set())}
