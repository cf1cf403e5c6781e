"""flake8 as a test: the sources are clean at 99 columns (setup.cfg [flake8], as ament_flake8)."""

from pathlib import Path
import subprocess
import sys

REPO_ROOT = Path(__file__).resolve().parents[1]

# The package, its tests, benchmarks, studies and launch files, and the packaging and helper
# scripts (Python).
CHECKED_PATHS = ['rigid_body_attitude', 'test', 'bench', 'studies', 'launch', 'setup.py',
                 'scripts/ros2run']


def test_flake8_clean():
    paths = [path for path in CHECKED_PATHS if (REPO_ROOT / path).exists()]
    result = subprocess.run(
        [sys.executable, '-m', 'flake8', *paths],
        cwd=REPO_ROOT, capture_output=True, text=True, timeout=300)
    report = result.stdout + result.stderr
    assert result.returncode == 0, f'flake8 found {len(report.splitlines())} problems:\n{report}'


def test_flake8_reads_the_99_column_limit(tmp_path):
    # The check above means something only if flake8 applies setup.cfg: a 100-column line fails.
    long_line = tmp_path / 'long_line.py'
    long_line.write_text('NAME = ' + repr('x' * 91) + '\n')
    assert len(long_line.read_text().rstrip('\n')) == 100
    result = subprocess.run(
        [sys.executable, '-m', 'flake8', str(long_line)],
        cwd=REPO_ROOT, capture_output=True, text=True, timeout=60)
    assert 'E501 line too long (100 > 99 characters)' in result.stdout
