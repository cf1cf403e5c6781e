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
naming the frames and the remedy (throttled), until the transform arrives. The table and the
chain composition are :mod:`rigid_body_attitude.session.mount`'s, shared with the replay.
"""

from __future__ import annotations

from collections import deque
from collections.abc import Callable, Iterable
import math
import threading

from rigid_body_attitude.msgs.cdr import header_frame_id
from rigid_body_attitude.msgs.errors import MalformedMessage
from rigid_body_attitude.ros.qos import INPUT_DEPTH
from rigid_body_attitude.session.gyro import GyroSession
from rigid_body_attitude.session.mount import StaticTransforms, drop_no_mount, set_found_mount

__all__ = ['HELD_SAMPLES', 'MountGate']

#: Gyro samples held while the mount is awaited (5 s at 1 kHz).
HELD_SAMPLES = INPUT_DEPTH

#: Where the remedy of a missing mount is said.
_REMEDY = ('set the parameter `mount_rpy`, or publish the transform, e.g. '
           'robot_state_publisher or static_transform_publisher')


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
        """Static transforms (parent, child, rotation w, x, y, z) from ``/tf_static``."""
        with self._lock:
            self._refused += self.transforms.add_all(transforms)

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
            set_found_mount(self.session, self.sensor_frame, q, '/tf_static')
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
        drop_no_mount(self.session, count, str(self.sensor_frame),
                      f'on /tf_static after tf_timeout {self.timeout_s:g} s', _REMEDY)
