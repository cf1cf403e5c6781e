"""What every simulated sensor's section and model share: the checks of its keys, its mount,
its noise drawn in blocks, its saturation and quantisation.

A sensor's section (``sensors.<name>``) is read by :class:`SensorSection`: every fault is one
:class:`~rigid_body_attitude.core.errors.SceneError` that names the key (``sensors.imu.rate``)
and the bound it breaks. A sensor frame sits in the body frame at ``mount_rpy`` (roll, pitch,
yaw of the sensor frame in the body frame, tf2's ``setRPY``): :func:`mount_quaternion`.
:class:`NormalRows` hands out rows of unit normals drawn in blocks from a seeded generator; a
block of ``n`` rows of width ``w`` holds the generator's next ``n w`` normals in order, so the
rows are the same whatever the block size.
"""

from __future__ import annotations

import math
import re
import struct
from collections.abc import Callable, Iterable, Mapping
from dataclasses import fields
from typing import Any

import numpy as np

from rigid_body_attitude.core.attitude import quaternion
from rigid_body_attitude.core.errors import SceneError
from rigid_body_attitude.core.yaml_files import Fields, quote

__all__ = ['ANGLE_LIMIT', 'MAX_RATE', 'Matrix', 'NOISE_BLOCK', 'NormalRows', 'SampledSensorSpec',
           'Quat', 'SensorSection', 'Vector', 'body_to_sensor_matrix', 'check_section_keys',
           'limited', 'mount_quaternion', 'unit_vector']

Vector = tuple[float, float, float]
Quat = tuple[float, float, float, float]
Matrix = tuple[Vector, Vector, Vector]

#: Highest sample rate [Hz] of any simulated sensor (real IMUs: 100 Hz to a few kHz).
MAX_RATE = 10_000.0
#: Rows of unit normals drawn at a time.
NOISE_BLOCK = 1024
#: Largest |mount angle| [rad].
ANGLE_LIMIT = 10.0
_NAME = re.compile(r'[A-Za-z_][A-Za-z0-9_]*(/[A-Za-z_][A-Za-z0-9_]*)*')
_FRAME = re.compile(r'[A-Za-z0-9_./-]{1,256}')
_FIELDS = Fields(SceneError)


class SensorSection:
    """The key checks of one sensor's section, ``sensors.<name>``."""

    def __init__(self, name: str) -> None:
        """Checks whose errors name ``sensors.<name>.<key>``."""
        self.where = f'sensors.{name}'

    def mapping(self, data: Any, valid: set[str], required: tuple[str, ...]) -> Mapping[Any, Any]:
        """The section itself: a mapping of known keys with the required ones."""
        return _FIELDS.mapping(data, self.where, valid, required)

    def number(self, key: str, value: Any, low: float, high: float,
               low_open: bool = False) -> float:
        """A finite number in ``[low, high]`` (``(low, high]`` if ``low_open``)."""
        return _FIELDS.number(value, f'{self.where}.{key}', low, high, low_open=low_open)

    def numbers(self, data: Mapping[Any, Any], bounds: Mapping[str, tuple[float, float, float]],
                positive: tuple[str, ...] = ('rate',)) -> dict[str, float]:
        """Each key of ``bounds`` that ``data`` has, checked against its ``(default, lowest,
        highest)``; the ``positive`` keys exclude their lowest."""
        return {key: self.number(key, data[key], low, high, low_open=key in positive)
                for key, (_, low, high) in bounds.items() if key in data}

    def triple(self, key: str, value: Any, limit: float) -> Vector:
        """Three finite numbers, each at most ``limit`` in magnitude."""
        a, b, c = _FIELDS.vector(value, f'{self.where}.{key}', 3, limit)
        return a, b, c

    def matrix(self, key: str, value: Any, limit: float) -> Matrix:
        """A 3×3 matrix (a list of three rows), each entry at most ``limit`` in magnitude."""
        rows = _FIELDS.matrix(value, f'{self.where}.{key}', 3, 3, limit)
        (a, b, c), (d, e, f), (g, h, i) = rows
        return (a, b, c), (d, e, f), (g, h, i)

    def frame_id(self, value: Any) -> str:
        """A frame name (letters, digits, ``_ . / -``)."""
        return self._matching('frame_id', value, _FRAME)

    def topic(self, value: Any) -> str:
        """A relative ROS topic name (the node or the replay refuses one of the node's own
        when it loads the scene: ``session.interface.check_scene_topics``)."""
        return self._matching('topic', value, _NAME)

    def placement(self, data: dict[str, Any]) -> dict[str, Any]:
        """The checked values of the keys every sensor has, those ``data`` gives:
        ``frame_id``, ``topic``, ``mount_rpy`` (|angle| at most :data:`ANGLE_LIMIT`),
        ``seed``."""
        checks: dict[str, Callable[[Any], Any]] = {
            'frame_id': self.frame_id, 'topic': self.topic, 'seed': self.seed,
            'mount_rpy': lambda value: self.triple('mount_rpy', value, ANGLE_LIMIT)}
        return {key: check(data[key]) for key, check in checks.items() if key in data}

    def seed(self, value: Any) -> int:
        """An integer in ``[0, 2^63)``."""
        if isinstance(value, bool) or not isinstance(value, int) or not 0 <= value < 2**63:
            raise SceneError(f'Expected {self.where}.seed to be an integer in [0, 2^63), got '
                             f'{quote(value)}')
        return value

    def choice(self, key: str, value: Any, choices: tuple[str, ...]) -> str:
        """One of ``choices``."""
        if not isinstance(value, str) or value not in choices:
            raise SceneError(f'Expected {self.where}.{key} to be one of {", ".join(choices)}, '
                             f'got {quote(value)}')
        return value

    def _matching(self, key: str, value: Any, pattern: re.Pattern[str]) -> str:
        if not isinstance(value, str) or len(value) > 256 or not pattern.fullmatch(value):
            raise SceneError(f'Expected {self.where}.{key} to be a ROS name (letters, digits, '
                             f'underscores{", dots, dashes" if key == "frame_id" else ""} and '
                             f'slashes, at most 256 characters), got {quote(value)}')
        return value


class SampledSensorSpec:
    """What every sensor spec has: its ``rate`` [Hz] and the mount ``mount_rpy`` [rad] of its
    frame in the body frame (a mixin of the specs' dataclasses)."""

    rate: float
    mount_rpy: Vector

    @property
    def period_ns(self) -> int:
        """Sample period [ns]: samples are taken at the clock times that are its multiples."""
        return round(1e9 / self.rate)

    @property
    def period(self) -> float:
        """Sample period Δt [s]."""
        return self.period_ns * 1e-9

    def mount(self) -> Quat:
        """Rotation (w, x, y, z) of the sensor frame in the body frame: ``Rz(yaw) Ry(pitch)
        Rx(roll)`` (tf2's ``setRPY``, static_transform_publisher's angles)."""
        return mount_quaternion(self.mount_rpy)


def mount_quaternion(mount_rpy: Vector) -> Quat:
    """Rotation (w, x, y, z) of the sensor frame in the body frame: ``Rz(yaw) Ry(pitch)
    Rx(roll)`` (tf2's ``setRPY``, static_transform_publisher's angles)."""
    w, x, y, z = quaternion.from_rpy(mount_rpy).tolist()
    return w, x, y, z


def body_to_sensor_matrix(mount: Quat) -> list[list[float]]:
    """``C``: body components → sensor components, for the mount ``mount``."""
    matrix: list[list[float]] = quaternion.to_matrix(mount).T.tolist()
    return matrix


class NormalRows:
    """Rows of ``width`` unit normals from a generator, drawn ``block`` rows at a time."""

    def __init__(self, rng: np.random.Generator, width: int, block: int = NOISE_BLOCK) -> None:
        """Rows from ``rng`` (its next normals, in order)."""
        self._rng = rng
        self._width = width
        self._block = block
        self._row = struct.Struct(f'={width}d')
        self._data = b''
        self._offset = 0

    def next(self) -> tuple[float, ...]:
        """The next row."""
        offset = self._offset
        if offset == len(self._data):
            # unpacked row by row: no list of all the block's floats
            self._data = self._rng.standard_normal((self._block, self._width)).tobytes()
            offset = 0
        self._offset = offset + self._row.size
        row: tuple[float, ...] = self._row.unpack_from(self._data, offset)
        return row


def limited(x: float, y: float, z: float, full_scale: float, resolution: float) -> Vector:
    """Clipped to ``±full_scale`` and rounded to a multiple of ``resolution`` (0: not)."""
    if full_scale > 0.0:
        low = -full_scale
        x = full_scale if x > full_scale else low if x < low else x
        y = full_scale if y > full_scale else low if y < low else y
        z = full_scale if z > full_scale else low if z < low else z
    if resolution > 0.0:
        x, y, z = (resolution * round(x / resolution), resolution * round(y / resolution),
                   resolution * round(z / resolution))
    return x, y, z


def unit_vector(where: str, value: Vector) -> Vector:
    """``value / |value|``; a SceneError naming ``where`` for a zero vector."""
    norm = math.sqrt(value[0] ** 2 + value[1] ** 2 + value[2] ** 2)
    if not norm > 0.0:
        raise SceneError(f'Expected {where} to be a non-zero direction, got {list(value)!r}')
    return value[0] / norm, value[1] / norm, value[2] / norm


def check_section_keys(section: str, spec: type[Any], keys: Iterable[str]) -> None:
    """Raise ImportError unless every key of ``sensors.<section>`` is a field of the dataclass
    ``spec`` (called once at import by each sensor's module)."""
    if not set(keys) <= {f.name for f in fields(spec)}:
        raise ImportError(f'sensors.{section} keys and {spec.__name__} fields differ')
