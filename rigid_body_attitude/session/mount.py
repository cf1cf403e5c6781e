"""The sensor's mount from static transforms: the rotation ``body_frame`` -> sensor frame.

What the node (:mod:`rigid_body_attitude.ros.tf_lookup`, ``/tf_static`` received) and the
replay (:mod:`rigid_body_attitude.tools.replay.mount`, a bag's ``/tf_static``) share: the
table of static transforms (:class:`StaticTransforms`, rotations only: the node reports an
attitude), the composition of a chain between two frames (``base_link`` -> ``torso`` ->
``imu_link``, or up and down a tree), the line saying where the mount came from, and the
dropping of gyro samples while no mount is known (counted ``no_mount``).
"""

from __future__ import annotations

from collections import deque
from collections.abc import Iterable
import math

from rigid_body_attitude.core.attitude.quaternion import multiply_floats
from rigid_body_attitude.session.base import LEVEL_INFO
from rigid_body_attitude.session.gyro import GyroSession

__all__ = ['MAX_TRANSFORMS', 'StaticTransforms', 'drop_no_mount', 'set_found_mount']

Quaternion = tuple[float, float, float, float]

#: Static transforms kept (a hostile publisher or bag cannot grow the table without bound).
MAX_TRANSFORMS = 10_000


def _conjugate(q: Quaternion) -> Quaternion:
    return q[0], -q[1], -q[2], -q[3]


class StaticTransforms:
    """The rotations of the static transforms received, as an undirected tree of frames."""

    def __init__(self) -> None:
        """No transforms yet."""
        #: frame -> neighbour frame -> rotation mapping the neighbour's vectors into frame.
        self.edges: dict[str, dict[str, Quaternion]] = {}
        self.count = 0

    def add(self, parent: str, child: str, wxyz: Iterable[float]) -> str:
        """Add ``parent`` -> ``child`` with the rotation ``wxyz`` (mapping ``child``-frame
        vectors into ``parent``'s); why it was refused, or ``''``."""
        w, x, y, z = wxyz
        norm = math.sqrt(w * w + x * x + y * y + z * z)
        if not parent or not child or parent == child:
            return f'frames {parent[:100]!r} -> {child[:100]!r}'
        if not math.isfinite(norm) or norm < 1e-6:
            return f'rotation {(w, x, y, z)} of {parent[:100]!r} -> {child[:100]!r}'
        if self.count >= MAX_TRANSFORMS and child not in self.edges.get(parent, {}):
            return f'more than {MAX_TRANSFORMS} transforms'
        q = (w / norm, x / norm, y / norm, z / norm)
        if child not in self.edges.get(parent, {}):
            self.count += 1
        self.edges.setdefault(parent, {})[child] = q
        self.edges.setdefault(child, {})[parent] = _conjugate(q)
        return ''

    def add_all(self, transforms: Iterable[tuple[str, str, Iterable[float]]]) -> int:
        """Add each (parent, child, rotation w, x, y, z); returns how many were refused."""
        return sum(bool(self.add(parent, child, wxyz)) for parent, child, wxyz in transforms)

    def rotation(self, parent: str, child: str) -> Quaternion | None:
        """The rotation mapping ``child``-frame vectors into ``parent``'s (the chain between
        them composed), or None when they are not connected."""
        found: dict[str, Quaternion] = {parent: (1.0, 0.0, 0.0, 0.0)}
        frontier = deque([parent])
        while frontier:
            frame = frontier.popleft()
            if frame == child:
                return found[frame]
            for neighbour, q in self.edges.get(frame, {}).items():
                if neighbour not in found:
                    found[neighbour] = multiply_floats(found[frame], q)
                    frontier.append(neighbour)
        return None


def set_found_mount(session: GyroSession, sensor_frame: str, q_body_sensor: Quaternion,
                    source: str) -> None:
    """Give ``session`` the mount found in ``source`` (``/tf_static``, the bag's) and say so."""
    session.set_mount(q_body_sensor)
    rounded = tuple(round(value, 6) for value in q_body_sensor)
    session.sink.log(LEVEL_INFO, f'mount {session.body_frame!r} -> {sensor_frame!r} from '
                                 f'{source}: (w, x, y, z) {rounded}')


def drop_no_mount(session: GyroSession, count: int, sensor_frame: str, where: str,
                  remedy: str) -> None:
    """``count`` gyro samples dropped for want of the transform ``body_frame`` ->
    ``sensor_frame`` (counted ``no_mount``; a throttled warning naming ``where`` it was looked
    for and the ``remedy``)."""
    session.rejections['no_mount'] += count
    session.warn('no_mount', f'no static transform {session.body_frame!r} -> '
                             f'{sensor_frame!r} {where}: gyro samples dropped ({remedy})')
