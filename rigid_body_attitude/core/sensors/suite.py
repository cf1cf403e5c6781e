"""The scene's ``sensors:`` section: which simulated sensors a dynamics scene carries.

Each key names one sensor, read by its own module: ``imu``
(:mod:`~rigid_body_attitude.core.sensors.imu`), ``magnetometer``
(:mod:`~rigid_body_attitude.core.sensors.magnetometer`) and ``star_tracker``
(:mod:`~rigid_body_attitude.core.sensors.star_tracker`). Across them: no two publish on the
same topic, and two that name the same ``frame_id`` have the same mount (one frame, one
transform on ``/tf_static``). What depends on the rest of the scene (the step, gravity, the
magnetic field, the Sun) is checked with the scene.
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass
from typing import Any

from rigid_body_attitude.core.attitude import quaternion
from rigid_body_attitude.core.errors import SceneError
from rigid_body_attitude.core.sensors.imu import ImuSpec, imu_spec
from rigid_body_attitude.core.sensors.magnetometer import MagnetometerSpec, magnetometer_spec
from rigid_body_attitude.core.sensors.section import Quat
from rigid_body_attitude.core.sensors.star_tracker import StarTrackerSpec, star_tracker_spec
from rigid_body_attitude.core.yaml_files import Fields, quote

__all__ = ['SensorSpec', 'SensorSuite', 'sensors_section']

SensorSpec = ImuSpec | MagnetometerSpec | StarTrackerSpec
_FIELDS = Fields(SceneError)
#: Two mounts of one frame agree when their rotations differ by at most this [rad].
_MOUNT_TOLERANCE = 1e-9


@dataclass(frozen=True)
class SensorSuite:
    """The sensors of a scene (``None``: not simulated)."""

    imu: ImuSpec | None = None
    magnetometer: MagnetometerSpec | None = None
    star_tracker: StarTrackerSpec | None = None

    def items(self) -> Iterator[tuple[str, SensorSpec]]:
        """``(key, spec)`` of each sensor present, in section order."""
        for key in ('imu', 'magnetometer', 'star_tracker'):
            spec = getattr(self, key)
            if spec is not None:
                yield key, spec


def sensors_section(data: Any) -> SensorSuite:
    """The scene's ``sensors`` section (``None``: no sensors); one SceneError naming the key
    otherwise."""
    if data is None:
        return SensorSuite()
    data = _FIELDS.mapping(data, 'sensors', {'imu', 'magnetometer', 'star_tracker'})
    suite = SensorSuite(
        imu=imu_spec(data['imu']) if 'imu' in data else None,
        magnetometer=(magnetometer_spec(data['magnetometer']) if 'magnetometer' in data
                      else None),
        star_tracker=(star_tracker_spec(data['star_tracker']) if 'star_tracker' in data
                      else None))
    _check_shared_names(suite)
    return suite


def _check_shared_names(suite: SensorSuite) -> None:
    """Distinct topics; one mount per frame."""
    topics: dict[str, str] = {}
    mounts: dict[str, tuple[str, Quat]] = {}
    for key, spec in suite.items():
        if spec.topic in topics:
            raise SceneError(f'Expected sensors.{key}.topic to differ from sensors.'
                             f'{topics[spec.topic]}.topic, got {quote(spec.topic)} for both')
        topics[spec.topic] = key
        mount = spec.mount()
        if spec.frame_id in mounts:
            other, other_mount = mounts[spec.frame_id]
            if float(quaternion.attitude_error(mount, other_mount)) > _MOUNT_TOLERANCE:
                raise SceneError(f'sensors.{key} and sensors.{other} name the same frame_id '
                                 f'{quote(spec.frame_id)} with different mounts; give each '
                                 f'sensor its own frame_id or the same mount')
        mounts[spec.frame_id] = key, mount
