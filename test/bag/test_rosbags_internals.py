"""rosbags' unexported API is used in one module only, and the installed rosbags still has it.

When ``rosbags`` changes, these tests fail naming what changed: the version against the pin
in requirements.txt, each unexported class, attribute or function that is gone, or a module of
the package that imports rosbags internals outside ``bag/rosbags_internals.py``.
"""

from __future__ import annotations

import ast
from importlib.metadata import version
from pathlib import Path
import re

import pytest
from rosbags.rosbag2.storage_mcap import McapWriter

import rigid_body_attitude
from rigid_body_attitude.bag import rosbags_internals

#: rosbags' modules and names this package may use outside rosbags_internals (its public API).
PUBLIC = {
    'rosbags.rosbag2': {'CompressionFormat', 'CompressionMode', 'Reader', 'ReaderError',
                        'StoragePlugin', 'Writer', 'WriterError'},
    'rosbags.typesys': {'Stores', 'TypesysError', 'get_types_from_idl', 'get_types_from_msg',
                        'get_typestore'},
    'rosbags.serde': {'SerdeError'},
    'rosbags.interfaces': {'Connection', 'ConnectionExtRosbag2', 'Nodetype'},
}


def test_installed_rosbags_is_the_pinned_one(repo_root):
    pins = re.findall(r'^rosbags==(\S+)', (repo_root / 'requirements.txt').read_text(), re.M)
    installed = version('rosbags')
    assert pins == [installed], (
        f'rosbags {installed} is installed but requirements.txt pins {pins}: check every name '
        f'listed in rigid_body_attitude/bag/rosbags_internals.py against the new version, then '
        f'update the pin')


def test_installed_rosbags_has_every_internal_used(tmp_path):
    missing = rosbags_internals.incompatibilities(tmp_path)
    assert missing == [], (f'rosbags {version("rosbags")} lacks what '
                           f'bag/rosbags_internals.py uses: {", ".join(missing)}')


def test_a_missing_internal_is_named(tmp_path, monkeypatch):
    monkeypatch.setitem(rosbags_internals._CLASS_ATTRIBUTES, McapWriter,
                        ('close_chunk', 'flush_pending_chunk'))
    assert rosbags_internals.incompatibilities(tmp_path) == ['McapWriter.flush_pending_chunk']
    monkeypatch.setitem(rosbags_internals._INSTANCE_ATTRIBUTES, 'ChunkInfo',
                        ('chunk_start_offset', 'crc'))
    monkeypatch.delitem(rosbags_internals._CLASS_ATTRIBUTES, McapWriter)
    assert rosbags_internals.incompatibilities(tmp_path / 'second') == ['ChunkInfo.crc']


def _rosbags_imports(path: Path) -> list[tuple[str, str]]:
    """``(module, name)`` of every import from rosbags in the file at ``path``."""
    found = []
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.ImportFrom) and (node.module or '').startswith('rosbags'):
            found += [(node.module, alias.name) for alias in node.names]
        elif isinstance(node, ast.Import):
            found += [(alias.name, '') for alias in node.names
                      if alias.name.startswith('rosbags')]
    return found


def test_no_other_module_uses_rosbags_internals():
    package = Path(rigid_body_attitude.__file__).parent
    adapter = Path(rosbags_internals.__file__).resolve()
    modules = [path for path in package.rglob('*.py') if path.resolve() != adapter]
    assert len(modules) > 20
    private = [f'{path.relative_to(package)}: {module}.{name}'
               for path in modules for module, name in _rosbags_imports(path)
               if name not in PUBLIC.get(module, set())]
    assert private == [], f'rosbags internals used outside bag/rosbags_internals.py: {private}'


@pytest.mark.parametrize('module, names', sorted(PUBLIC.items()))
def test_the_public_names_are_exported(module, names):
    imported = __import__(module, fromlist=['_'])
    exported = set(getattr(imported, '__all__', dir(imported)))
    assert names <= exported, f'{module} no longer exports {sorted(names - exported)}'
