"""The field checks shared by the package's YAML files: scenes, calibration files, campaign specs.

A :class:`Fields` is bound to the error type of one kind of file (``SceneError``,
``CalibrationError``, ``SpecError``); each check returns the checked value or raises one error
of that type naming the key path (``initial_state``, ``imu0.gyroscopes.M``,
``commands[0].torque``), what was expected and, quoted briefly
(:func:`~rigid_body_attitude.core.yaml_files.quote`), the value found:

* :meth:`Fields.keys`: ``Unknown key 'omega' in initial_state; valid keys: attitude,
  omega_body``, or ``Missing key 'body' in scene; valid keys: ...``;
* :meth:`Fields.mapping`: a mapping (with those keys, if given);
* :meth:`Fields.number`: a finite number (:func:`~rigid_body_attitude.core.yaml_files.real`,
  which explains YAML 1.1's ``1e-3`` read as text) in ``[low, high]`` or ``(low, high]``;
* :meth:`Fields.vector` and :meth:`Fields.matrix`: ``n`` finite numbers (or ``rows × columns``),
  each at most ``bound`` in magnitude.
"""

from __future__ import annotations

from collections.abc import Collection, Mapping
from typing import Any

from rigid_body_attitude.core.yaml_files import MAGNITUDE_LIMIT, quote, real

__all__ = ['Fields']


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
