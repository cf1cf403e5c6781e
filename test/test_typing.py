"""`mypy --strict` over the package: zero errors (settings in setup.cfg)."""

import subprocess
import sys
from pathlib import Path

REPO_ROOT = Path(__file__).resolve().parents[1]


def test_mypy_strict_passes_on_the_package():
    package = REPO_ROOT / 'rigid_body_attitude'  # the sources the install was built from
    result = subprocess.run(
        [sys.executable, '-m', 'mypy', '--config-file', str(REPO_ROOT / 'setup.cfg'),
         '--cache-dir', '/dev/null', str(package)],
        capture_output=True, text=True, timeout=600, cwd=REPO_ROOT)
    assert result.returncode == 0, result.stdout[-6000:] + result.stderr[-2000:]
    assert 'Success: no issues found' in result.stdout
