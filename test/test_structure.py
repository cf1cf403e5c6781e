"""The package stays in small pieces: no module over 600 lines, no class over 250."""

import ast
from pathlib import Path

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
