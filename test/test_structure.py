"""The package stays in small pieces: no module over 600 lines, no class over 250."""

import ast
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
