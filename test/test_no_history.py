"""The shipped files speak to users: no account of the project's own development history.

Scanned: ``README.md``, everything under ``docs/``, ``config/`` and ``launch/``, ``package.xml``,
``setup.py``, ``setup.cfg``, and the comments and strings (docstrings included) of the
package's and the benchmarks' Python files. Refused: numbered stages of the project's work
("session 9", "issue 13", "item 5", "sweep 3"), references to the investigation notes, and
phrases that tell how something was before ("used to", "as of", "now", "formerly", "before
this change", ...). A hit fails the test naming ``file:line``.
"""

import io
from pathlib import Path
import re
import tokenize

import pytest

REPO_ROOT = Path(__file__).resolve().parents[1]

#: What a user's document must not say, each with why it is refused.
PATTERNS = {
    'numbered stage of the project': re.compile(
        r'\b(sessions?|issues?|items?|sweeps?|milestones?)\s+\d+', re.IGNORECASE),
    'the issue that asked for it': re.compile(r"\b(the|this|that) issue\b(?!s)", re.IGNORECASE),
    'the investigation notes': re.compile(r'\bNOTES\b|\bNOTES\.md\b|\blab notebook\b'),
    'how it was before': re.compile(
        r"\bused to\b|\bas of\b|(?<![.\w`])now(?![\w(`]|\.\w)|\bformer(ly)?\b|"
        r"\bpreviously\b|\bbefore (this|the|that) (change|session|issue|fix|rewrite)\b|"
        r"\bthe old (code|settings|default|version)\b|\bwas changed\b|\bchanged from\b",
        re.IGNORECASE),
}

TEXT_SUFFIXES = {'.md', '.yaml', '.yml', '.xml', '.txt', '.cfg', '.csv', '.rst', ''}


def shipped_files() -> list[Path]:
    """Every shipped text file this test scans, sorted."""
    files = [REPO_ROOT / name for name in ('README.md', 'package.xml', 'setup.py', 'setup.cfg')]
    for folder in ('docs', 'config', 'launch'):
        files += [path for path in (REPO_ROOT / folder).rglob('*')
                  if path.is_file() and path.suffix in TEXT_SUFFIXES]
    for folder in ('rigid_body_attitude', 'bench', 'studies', 'launch'):
        files += (REPO_ROOT / folder).rglob('*.py')
    return sorted(path for path in files if path.is_file())


def prose_lines(path: Path) -> list[tuple[int, str]]:
    """(line number, text) of what a reader reads: all of a text file; the comments and
    strings of a Python file (names in code, such as a variable ``now``, are not prose)."""
    text = path.read_text(encoding='utf-8')
    if path.suffix != '.py':
        return list(enumerate(text.splitlines(), start=1))
    lines = []
    for token in tokenize.generate_tokens(io.StringIO(text).readline):
        if token.type in (tokenize.COMMENT, tokenize.STRING) or (
                token.type == getattr(tokenize, 'FSTRING_MIDDLE', -1)):
            for offset, line in enumerate(token.string.splitlines()):
                lines.append((token.start[0] + offset, line))
    return lines


def history_hits(path: Path) -> list[str]:
    """``file:line: reason: text`` for every refused phrase in ``path``."""
    hits = []
    for number, line in prose_lines(path):
        for reason, pattern in PATTERNS.items():
            match = pattern.search(line)
            if match:
                hits.append(f'{path.relative_to(REPO_ROOT)}:{number}: {reason}: '
                            f'{match.group(0)!r} in {line.strip()[:100]!r}')
    return hits


def test_named_benchmarks_exist():
    """A shipped file that names a benchmark or a study names one that is there."""
    missing = []
    for path in shipped_files():
        for number, line in enumerate(path.read_text(encoding='utf-8').splitlines(), start=1):
            for folder, name in re.findall(r'\b(bench|studies)/([\w.]+\.(?:py|xml|md))', line):
                if not (REPO_ROOT / folder / name).is_file():
                    missing.append(f'{path.relative_to(REPO_ROOT)}:{number}: {folder}/{name}')
    assert missing == [], 'names a benchmark that does not exist:\n' + '\n'.join(missing)


def test_scanned_set_holds_the_shipped_files():
    names = {path.relative_to(REPO_ROOT).as_posix() for path in shipped_files()}
    assert {'README.md', 'package.xml', 'setup.py', 'config/fastdds.xml',
            'rigid_body_attitude/__init__.py', 'bench/node_throughput.py',
            'studies/broad_strapdown.py', 'launch/imu.launch.xml', 'launch/managed.launch.py'
            } <= names
    assert any(name.startswith('docs/') for name in names)


@pytest.mark.parametrize('path', shipped_files(),
                         ids=lambda path: path.relative_to(REPO_ROOT).as_posix())
def test_no_development_history(path):
    hits = history_hits(path)
    assert hits == [], 'development history in a shipped file:\n' + '\n'.join(hits)


@pytest.mark.parametrize('text', [
    'Measured in session 9 (issue 13, item 5).', 'See bench/NOTES.md, section 3.',
    'The node now ships a profile.', 'It used to publish twice.', 'as of this release',
    'the former sensor-data default', 'Sweep 3 met it.', 'as the issue asks'])
def test_patterns_catch_history(text, tmp_path):
    path = tmp_path / 'page.md'
    path.write_text(f'A fine line.\n{text}\n')
    assert [hit.split(':')[1] for hit in _hits_outside_repo(path)] == ['2']


@pytest.mark.parametrize('text', [
    'The session layer is the node without ROS.', 'clock.now() gives the time',
    'A known issue of Fast DDS 2.14.', 'Returns the items.', 'rclpy issue #968',
    'Integrate up to ``now``.', 'stage 7 of the Runge-Kutta step'])
def test_patterns_pass_ordinary_prose(text, tmp_path):
    path = tmp_path / 'page.md'
    path.write_text(text + '\n')
    assert _hits_outside_repo(path) == []


def test_python_names_are_not_prose(tmp_path):
    path = tmp_path / 'module.py'
    path.write_text('"""A module."""\n\nnow = 1.0  # the time\nprint(now)\n')
    assert _hits_outside_repo(path) == []
    path.write_text('"""A module."""\n\nx = 1.0  # now faster\n')
    assert [hit.split(':')[1] for hit in _hits_outside_repo(path)] == ['3']


def _hits_outside_repo(path: Path) -> list[str]:
    """:func:`history_hits` for a file outside the repository (named by its file name)."""
    hits = []
    for number, line in prose_lines(path):
        hits += [f'{path.name}:{number}: {reason}' for reason, pattern in PATTERNS.items()
                 if pattern.search(line)]
    return hits
