"""The sensor's mount from ``/tf_static``: the rotation ``body_frame`` -> sensor frame.

When ``mount_rpy`` is not set and the gyro samples' header frame (the sensor frame, REP-145)
differs from ``body_frame``, the mount comes from the static transforms on ``/tf_static``
(``tf2_msgs/msg/TFMessage``, what robot_state_publisher and ``static_transform_publisher``
publish; read with their QoS, :data:`~.qos.TF_STATIC_QOS`, so transforms published before
the node started arrive too). A chain of static transforms (``base_link`` -> ``torso`` ->
``imu_link``, or up and down a tree) is composed. Only rotations matter: the node reports an
attitude.

:class:`MountGate` stands in front of the gyro handler until the mount is known: the first
sample names the sensor frame; while the transform has not arrived, samples are **held** (at
most :data:`HELD_SAMPLES`, the oldest dropped beyond that and counted as ``no_mount``) and
integrated in order once it arrives, so a robot_state_publisher started a moment after the
node costs nothing. After ``tf_timeout`` seconds without it, the held samples and every later
one are dropped and counted as ``no_mount`` (``/diagnostics`` WARN), with an error line
naming the frames and the remedy (throttled), until the transform arrives.
"""

from __future__ import annotations

from collections import deque
from collections.abc import Callable, Iterable
import math
import threading

from rigid_body_attitude.msgs.cdr import header_frame_id
from rigid_body_attitude.msgs.errors import MalformedMessage
from rigid_body_attitude.ros.qos import INPUT_DEPTH
from rigid_body_attitude.session.base import LEVEL_INFO
from rigid_body_attitude.session.gyro import GyroSession

__all__ = ['HELD_SAMPLES', 'MAX_TRANSFORMS', 'MountGate', 'StaticTransforms', 'multiply']

Quaternion = tuple[float, float, float, float]

#: Gyro samples held while the mount is awaited (5 s at 1 kHz).
HELD_SAMPLES = INPUT_DEPTH

#: Static transforms kept (a hostile publisher cannot grow the table without bound).
MAX_TRANSFORMS = 10_000


def multiply(p: Quaternion, q: Quaternion) -> Quaternion:
    """Hamilton product ``p q`` of (w, x, y, z) quaternions."""
    pw, px, py, pz = p
    qw, qx, qy, qz = q
    return (pw * qw - px * qx - py * qy - pz * qz, pw * qx + px * qw + py * qz - pz * qy,
            pw * qy - px * qz + py * qw + pz * qx, pw * qz + px * qy - py * qx + pz * qw)


def _conjugate(q: Quaternion) -> Quaternion:
    return q[0], -q[1], -q[2], -q[3]


class StaticTransforms:
    """The rotations of the static transforms received, as an undirected tree of frames."""

    def __init__(self) -> None:
        """No transforms yet."""
        #: frame -> neighbour frame -> rotation mapping the neighbour's vectors into frame.
        self.edges: dict[str, dict[str, Quaternion]] = {}
        self.count = 0

    def add(self, parent: str, child: str, xyzw: Iterable[float]) -> str:
        """Add ``parent`` -> ``child`` with the message-order rotation ``xyzw``; why it was
        refused, or ``''``."""
        x, y, z, w = xyzw
        norm = math.sqrt(w * w + x * x + y * y + z * z)
        if not parent or not child or parent == child:
            return f'frames {parent[:100]!r} -> {child[:100]!r}'
        if not math.isfinite(norm) or norm < 1e-6:
            return f'rotation {(x, y, z, w)} of {parent[:100]!r} -> {child[:100]!r}'
        if self.count >= MAX_TRANSFORMS and child not in self.edges.get(parent, {}):
            return f'more than {MAX_TRANSFORMS} transforms'
        q = (w / norm, x / norm, y / norm, z / norm)
        if child not in self.edges.get(parent, {}):
            self.count += 1
        self.edges.setdefault(parent, {})[child] = q
        self.edges.setdefault(child, {})[parent] = _conjugate(q)
        return ''

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
                    found[neighbour] = multiply(found[frame], q)
                    frontier.append(neighbour)
        return None


class MountGate:
    """Holds gyro samples until the mount is known, then hands them to the handler.

    :meth:`sample` runs under the node's state lock (the gyro path); :meth:`add_transforms`
    in the executor thread (``/tf_static``), under the gate's own lock.
    """

    def __init__(self, session: GyroSession, timeout_s: float,
                 monotonic: Callable[[], float]) -> None:
        """Gate ``session``'s samples; give up waiting after ``timeout_s`` seconds."""
        self.session, self.timeout_s, self.monotonic = session, timeout_s, monotonic
        #: True once samples go straight to the handler (mount known or not needed).
        self.open = False
        self.transforms = StaticTransforms()
        self.sensor_frame: str | None = None
        self._deadline = math.inf
        self._held: deque[bytes] = deque()
        self._lock = threading.Lock()
        self._refused = 0

    def add_transforms(self, transforms: Iterable[tuple[str, str, Iterable[float]]]) -> None:
        """Static transforms (parent, child, rotation x, y, z, w) from ``/tf_static``."""
        with self._lock:
            for parent, child, xyzw in transforms:
                if self.transforms.add(parent, child, xyzw):
                    self._refused += 1

    def sample(self, data: bytes, handle: Callable[[bytes], None]) -> None:
        """A gyro sample's bytes while the gate is closed (state lock held)."""
        if self.sensor_frame is None:
            try:
                frame = header_frame_id(data)
            except MalformedMessage:
                handle(data)  # the handler counts it
                return
            if not self.session.mount_needed(frame):
                self._open(data, handle)
                return
            self.sensor_frame = frame
            self._deadline = self.monotonic() + self.timeout_s
        with self._lock:
            q = self.transforms.rotation(self.session.body_frame, self.sensor_frame)
        if q is not None:
            self.session.set_mount(q)
            self.session.sink.log(LEVEL_INFO, f'mount {self.session.body_frame!r} -> '
                                              f'{self.sensor_frame!r} from /tf_static: '
                                              f'(w, x, y, z) {_rounded(q)}')
            self._open(data, handle)
            return
        self._held.append(data)
        if self.monotonic() < self._deadline:
            if len(self._held) > HELD_SAMPLES:
                self._held.popleft()
                self._drop(1)
            return
        self._drop(len(self._held))
        self._held.clear()

    def _open(self, data: bytes, handle: Callable[[bytes], None]) -> None:
        self.open = True
        held, self._held = self._held, deque()
        for earlier in held:
            handle(earlier)
        handle(data)

    def _drop(self, count: int) -> None:
        session = self.session
        session.rejections['no_mount'] += count
        session.warn('no_mount', f'no static transform {session.body_frame!r} -> '
                                 f'{self.sensor_frame!r} on /tf_static after tf_timeout '
                                 f'{self.timeout_s:g} s: gyro samples dropped (set the '
                                 f'parameter `mount_rpy`, or publish the transform, e.g. '
                                 f'robot_state_publisher or static_transform_publisher)')


def _rounded(q: Quaternion) -> tuple[float, ...]:
    return tuple(round(value, 6) for value in q)
