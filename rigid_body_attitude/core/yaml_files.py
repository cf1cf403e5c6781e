"""Checked reading of the package's YAML files: scenes, calibration files, campaign specs.

Every file is hostile until checked. :func:`read_yaml` refuses, with one error of the caller's
type whose text starts with the caller's ``where`` (``Scene file '<path>'``):

* a file that cannot be read, or one larger than :data:`MAX_FILE_BYTES` (64 KiB);
* bytes that are not UTF-8 (line, column and byte named);
* YAML syntax errors (line and column named), aliases (``*name``: an alias bomb of a few
  hundred bytes expands to gigabytes; anchors alone are harmless) and nesting deeper than
  :data:`MAX_DEPTH` levels;
* an integer too large for a float (a 400-digit mass is refused, not overflowed).

Error texts quote at most :data:`QUOTE_LIMIT` characters of a bad value (:func:`quote`) and
are at most :data:`MAX_ERROR_CHARS` long, on one line (:func:`bounded`).

The checks of the fields, shared by the three kinds of file, are those of :class:`Fields`,
bound to the error type of one kind (``SceneError``, ``CalibrationError``, ``SpecError``);
each returns the checked value or raises one error naming the key path (``initial_state``,
``imu0.gyroscopes.M``, ``commands[0].torque``), what was expected and the value found:

* :meth:`Fields.keys`: ``Unknown key 'omega' in initial_state; valid keys: attitude,
  omega_body``, or ``Missing key 'body' in scene; valid keys: ...``;
* :meth:`Fields.mapping`: a mapping (with those keys, if given);
* :meth:`Fields.number`: a finite number (:func:`real`, which explains YAML 1.1's ``1e-3``
  read as text) in ``[low, high]`` or ``(low, high]``;
* :meth:`Fields.vector` and :meth:`Fields.matrix`: ``n`` finite numbers (or ``rows ×
  columns``), each at most ``bound`` in magnitude.
"""

from __future__ import annotations

import math
import reprlib
from collections.abc import Collection, Iterator, Mapping
from pathlib import Path
from typing import Any

import yaml

__all__ = ['Fields', 'MAGNITUDE_LIMIT', 'MAX_DEPTH', 'MAX_ERROR_CHARS', 'MAX_FILE_BYTES',
           'QUOTE_LIMIT', 'bounded', 'quote', 'read_yaml', 'real']

#: Largest file read [bytes] (the shipped files are a few KiB at most; the limit is small
#: because the pure-Python YAML parser that the alias and depth checks need is slow).
MAX_FILE_BYTES = 64 * 1024
#: Deepest nesting of YAML collections.
MAX_DEPTH = 32
#: Most characters of a bad value quoted in an error; a whole error text is at most
#: :data:`MAX_ERROR_CHARS`.
QUOTE_LIMIT = 100
MAX_ERROR_CHARS = 600
_FLOAT_MAX = 1.7976931348623157e308
_QUOTE = reprlib.Repr()
_QUOTE.maxstring = _QUOTE.maxother = _QUOTE.maxlong = QUOTE_LIMIT
_QUOTE.maxlist = _QUOTE.maxtuple = _QUOTE.maxdict = _QUOTE.maxset = 6
_QUOTE.maxlevel = 3


def quote(value: Any) -> str:
    """``repr(value)`` of at most about :data:`QUOTE_LIMIT` characters (for error texts)."""
    text = _QUOTE.repr(value)
    return text if len(text) <= QUOTE_LIMIT else text[:QUOTE_LIMIT - 3] + '...'


def bounded(text: str, limit: int = MAX_ERROR_CHARS) -> str:
    """``text`` on one line, at most ``limit`` characters."""
    text = ' '.join(text[:limit + 1].splitlines())
    return text if len(text) <= limit else text[:limit - 3] + '...'


def read_yaml(path: Path, where: str, error: type[Exception], kind: str,
              skip_directive: bool = False) -> Any:
    """The parsed content of the YAML file ``path``, checked (module docstring).

    ``where`` starts every error text, ``error`` is the type raised, ``kind`` names the files
    in texts (``'scene files'``). ``skip_directive``: a first line ``%YAML...`` (OpenCV's
    ``%YAML:1.0``) is read as empty, keeping the line numbers.
    """
    try:
        text = _read_text(path, where, error)
        if skip_directive and text.startswith('%YAML'):
            text = '\n' + text.split('\n', 1)[1] if '\n' in text else ''
        return _parse_yaml(text, where, error, kind)
    except error as err:
        raise error(bounded(str(err))) from None


def _read_text(path: Path, where: str, error: type[Exception]) -> str:
    """The file's text: at most :data:`MAX_FILE_BYTES`, UTF-8."""
    try:
        with path.open('rb') as file:
            raw = file.read(MAX_FILE_BYTES + 1)
    except OSError as err:
        raise error(f'{where} cannot be read: {quote(err.strerror)}') from None
    if len(raw) > MAX_FILE_BYTES:
        raise error(f'{where} is larger than the limit of {MAX_FILE_BYTES} bytes')
    try:
        return raw.decode('utf-8')
    except UnicodeDecodeError as err:
        line = raw.count(b'\n', 0, err.start) + 1
        column = err.start - raw.rfind(b'\n', 0, err.start)
        raise error(f'{where}, line {line}, column {column}: not UTF-8 (byte '
                    f'0x{raw[err.start]:02x})') from None


class _CheckedLoader(yaml.SafeLoader):
    """PyYAML's safe loader without aliases and with a nesting limit."""

    kind = 'these files'

    def __init__(self, stream: str) -> None:
        super().__init__(stream)
        self.depth = 0

    def compose_node(self, parent: yaml.Node | None, index: Any) -> yaml.Node | None:
        """Refuse an alias, or a collection nested deeper than :data:`MAX_DEPTH`."""
        event = self.peek_event()  # type: ignore[no-untyped-call]
        mark = event.start_mark
        if isinstance(event, yaml.AliasEvent):
            raise yaml.composer.ComposerError(
                None, None, f'aliases (*name) are not allowed in {self.kind}', mark)
        if self.depth >= MAX_DEPTH:
            raise yaml.composer.ComposerError(
                None, None, f'nesting deeper than {MAX_DEPTH} levels', mark)
        self.depth += 1
        try:
            return super().compose_node(parent, index)
        finally:
            self.depth -= 1


def _parse_yaml(text: str, where: str, error: type[Exception], kind: str) -> Any:
    loader = None
    try:
        loader = _CheckedLoader(text)
        loader.kind = kind
        data = loader.get_single_data()
    except yaml.MarkedYAMLError as err:
        mark = err.problem_mark or err.context_mark
        position = f', line {mark.line + 1}, column {mark.column + 1}' if mark else ''
        raise error(f'{where}{position}: not valid YAML: '
                    f'{bounded(err.problem or err.context or "", QUOTE_LIMIT)}') from None
    except (yaml.YAMLError, ValueError, TypeError, OverflowError) as err:
        raise error(f'{where}: not valid YAML: {bounded(str(err), QUOTE_LIMIT)}') from None
    finally:
        if loader is not None:
            loader.dispose()
    for key_path, value in _integers(data, ''):
        if abs(value) > _FLOAT_MAX:
            raise error(f'{where}: {key_path or "file"}: an integer of '
                        f'{len(str(abs(value)))} digits is too large for a float')
    return data


def _integers(data: Any, key_path: str) -> Iterator[tuple[str, int]]:
    """``(key path, integer)`` of every integer in the parsed file (nesting is bounded)."""
    if isinstance(data, bool):
        return
    if isinstance(data, int):
        yield key_path, data
    elif isinstance(data, Mapping):
        for key, value in data.items():
            yield from _integers(key, key_path)
            name = key if isinstance(key, str) else quote(key)
            yield from _integers(value, f'{key_path}.{name}' if key_path else name)
    elif isinstance(data, list):
        for index, value in enumerate(data):
            yield from _integers(value, f'{key_path}[{index}]')


#: Largest magnitude of a number in a file (scene, effect parameter, calibration): the scene's
#: bound (:data:`rigid_body_attitude.core.dynamics.scene.SCALE_LIMIT`), so that products of a
#: few such numbers (torques, momenta, energies) stay finite; far beyond any physical parameter
#: (the Sun's gravitational parameter is 1.3e20 m³/s²).
MAGNITUDE_LIMIT = 1e75


def real(value: Any) -> float:
    """A finite real number of magnitude at most :data:`MAGNITUDE_LIMIT` (booleans and strings
    are refused)."""
    if isinstance(value, str) and _looks_numeric(value):
        raise TypeError(f'a number (YAML 1.1 reads {value} as text: write it with a sign in '
                        f'the exponent and a dot, e.g. 7.0e+6)')
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise TypeError('a number')
    try:
        number = float(value)
    except OverflowError as err:  # an integer too large for a float
        raise ValueError('a number of magnitude at most 1e75') from err
    if not math.isfinite(number):
        raise ValueError('a finite number')
    if abs(number) > MAGNITUDE_LIMIT:
        raise ValueError('a number of magnitude at most 1e75')
    return number


def _looks_numeric(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


class Fields:
    """The field checks of one kind of file, raising ``error`` (module docstring)."""

    def __init__(self, error: type[Exception]) -> None:
        self.error = error

    def keys(self, data: Mapping[Any, Any], valid: Collection[str], where: str = '',
             required: Collection[str] = ()) -> None:
        """Refuse a key of ``data`` not in ``valid`` or a ``required`` key missing; ``where``
        names the section (``''``: the file's top level, not named)."""
        section = f' in {where}' if where else ''
        listed = ', '.join(sorted(valid))
        for key in data:
            if key not in valid:
                raise self.error(f'Unknown key {quote(key)}{section}; valid keys: {listed}')
        for key in required:
            if key not in data:
                raise self.error(f'Missing key {key!r}{section}; valid keys: {listed}')

    def mapping(self, value: Any, where: str, valid: Collection[str] | None = None,
                required: Collection[str] = (), none_is_empty: bool = False
                ) -> Mapping[Any, Any]:
        """``value`` if it is a mapping (with keys among ``valid``, if given, and the
        ``required`` ones); ``None`` is read as empty if ``none_is_empty``."""
        if value is None and none_is_empty:
            value = {}
        if not isinstance(value, Mapping):
            keys = f' with keys {", ".join(sorted(valid))}' if valid else ''
            raise self.error(f'Expected {where} to be a mapping{keys}, got {quote(value)}')
        if valid is not None:
            self.keys(value, valid, where, required)
        return value

    def number(self, value: Any, key: str, low: float = -MAGNITUDE_LIMIT,
               high: float = MAGNITUDE_LIMIT, low_open: bool = False) -> float:
        """A finite number in ``[low, high]`` (``(low, high]`` if ``low_open``)."""
        try:
            number = real(value)
        except (TypeError, ValueError) as err:
            raise self.error(f'Expected {key} to be {err}, got {quote(value)}') from None
        if not (low < number if low_open else low <= number) or number > high:
            interval = f'{"(" if low_open else "["}{low:g}, {high:g}]'
            raise self.error(f'Expected {key} to be in {interval}, got {number!r}')
        return number

    def vector(self, value: Any, key: str, size: int = 3,
               bound: float = MAGNITUDE_LIMIT) -> tuple[float, ...]:
        """``size`` finite numbers (a list), each at most ``bound`` in magnitude."""
        if not _sequence(value, size):
            raise self.error(f'Expected {key} to be {size} numbers, got {quote(value)}')
        return tuple(self._entry(item, key, bound) for item in value)

    def matrix(self, value: Any, key: str, rows: int = 3, columns: int = 3,
               bound: float = MAGNITUDE_LIMIT) -> tuple[tuple[float, ...], ...]:
        """A ``rows × columns`` matrix (a list of rows), each entry at most ``bound`` in
        magnitude."""
        if not _sequence(value, rows) or not all(_sequence(row, columns) for row in value):
            raise self.error(f'Expected {key} to be a {rows}x{columns} matrix (a list of {rows} '
                             f'rows of {columns} numbers), got {quote(value)}')
        return tuple(tuple(self._entry(item, key, bound) for item in row) for row in value)

    def _entry(self, value: Any, key: str, bound: float) -> float:
        try:
            number = real(value)
        except (TypeError, ValueError) as err:
            raise self.error(f'Expected every entry of {key} to be {err}, got '
                             f'{quote(value)}') from None
        if abs(number) > bound:
            raise self.error(f'Expected every entry of {key} to be at most {bound:g} in '
                             f'magnitude, got {number!r}')
        return number


def _sequence(value: Any, size: int) -> bool:
    return isinstance(value, (list, tuple)) and len(value) == size
