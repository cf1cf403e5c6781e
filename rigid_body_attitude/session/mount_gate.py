"""The mount gate: gyro samples held until the IMU's frame and its mount are known.

The sensor's mount is the rotation ``body_frame`` -> sensor frame. When ``mount_rpy`` is not
set and the gyro samples' header frame (the sensor frame, REP-145) differs from
``body_frame``, the mount comes from the static transforms on ``/tf_static``
(``tf2_msgs/msg/TFMessage``, what robot_state_publisher and ``static_transform_publisher``
publish; the node reads them as tf2_ros reads them, so transforms published before the node
started arrive too). A chain of static transforms (``base_link`` -> ``torso`` ->
``imu_link``, or up and down a tree) is composed. Only rotations matter: the
node reports an attitude. The table, its checks and bounds and the chain composition are
:mod:`rigid_body_attitude.session.mount`'s, shared with the replay; the chains from
``body_frame`` are resolved when ``/tf_static`` brings something new, so a gyro sample costs
one look-up however many transforms arrived. Nothing here needs ROS: the node hands the gate
its gyro samples and ``/tf_static`` messages as CDR bytes.

:class:`MountGate` stands in front of the gyro handler until the IMU's frame is known: the
first sample whose frame has a mount (``body_frame`` itself, ``mount_rpy``, or a chain on
``/tf_static``) names the IMU's frame; samples in any other frame are refused from then on
(``foreign_frame``: one IMU per topic). Until then samples are **held** (at most
:data:`HELD_SAMPLES` and :data:`HELD_BYTES`, the oldest dropped beyond that and counted as
``no_mount``) and handed on in order, each to the handler of the topic it came on, as soon as
the mount arrives, so a
robot_state_publisher started a moment after the node costs nothing. Each frame awaiting a
mount waits ``tf_timeout`` seconds from its first sample (at most :data:`PENDING_FRAMES`
frames, the oldest forgotten beyond that); after that its samples are dropped and counted
as ``no_mount`` (``/diagnostics`` WARN), with an error line naming the frames and the remedy
(throttled), until the transform arrives. A sample in a frame without a mount never holds up
those of a frame with one.
"""

from __future__ import annotations

from collections import Counter, deque
from collections.abc import Callable, Iterable
import math
import threading

from rigid_body_attitude.msgs.cdr import header_frame_id
from rigid_body_attitude.msgs.errors import MalformedMessage
from rigid_body_attitude.msgs.tf_message import decode_tf_message, Transform
from rigid_body_attitude.session.gyro import GyroSession
from rigid_body_attitude.session.mount import (
    MAX_FRAME_LENGTH, StaticTransforms, drop_no_mount, set_found_mount, transform_warning)

__all__ = ['HELD_BYTES', 'HELD_SAMPLES', 'Handler', 'MountGate', 'PENDING_FRAMES']

#: Gyro samples held while the mount is awaited (5 s at 1 kHz, as deep as a gyro input queue).
HELD_SAMPLES = 5000
#: Bytes of gyro samples held while the mount is awaited.
HELD_BYTES = 8 * 2**20
#: Frames awaiting a mount tracked at once (their ``tf_timeout`` deadlines).
PENDING_FRAMES = 16

Quaternion = tuple[float, float, float, float]
#: The session's handler of one gyro topic: takes a message's CDR bytes.
Handler = Callable[[bytes], None]

#: Where the remedy of a missing mount is said.
_REMEDY = ('set the parameter `mount_rpy`, or publish the transform, e.g. '
           'robot_state_publisher or static_transform_publisher')


class MountGate:
    """Holds gyro samples until the IMU's frame and its mount are known, then hands them on.

    :meth:`sample`, :meth:`retry` and :meth:`count_refused` run under the node's state lock;
    :meth:`add_transforms` in the executor thread (``/tf_static``), under the gate's own lock.
    """

    def __init__(self, session: GyroSession, timeout_s: float,
                 monotonic: Callable[[], float]) -> None:
        """Gate ``session``'s samples; give up waiting after ``timeout_s`` seconds."""
        self.session, self.timeout_s, self.monotonic = session, timeout_s, monotonic
        #: True once samples go straight to the handler (the IMU's frame known).
        self.open = False
        self.transforms = StaticTransforms()
        #: Frames connected to ``body_frame`` -> (rotation into ``body_frame``, previous frame).
        self._mounts: dict[str, tuple[Quaternion, str]] = {}
        self._deadlines: dict[str, float] = {}  # frame awaiting a mount -> when it times out
        #: Held samples: (frame, bytes, the handler of the topic they came on).
        self._held: deque[tuple[str, bytes, Handler]] = deque()
        self._held_bytes = 0
        self._lock = threading.Lock()

    def add_transforms(self, transforms: Iterable[Transform]) -> Counter[str]:
        """Static transforms from ``/tf_static``; how many were refused, by reason (count
        them with :meth:`count_refused` under the state lock)."""
        with self._lock:
            refused = self.transforms.add_all(transforms)
            self._mounts = self.transforms.resolved(self.session.body_frame)
        return refused

    def mount_of(self, frame: str) -> Quaternion | None:
        """The rotation (w, x, y, z) of ``frame`` into ``body_frame`` from the static
        transforms received so far (None: no chain): another sensor's mount (``imu/mag``)."""
        entry = self._mounts.get(frame)
        return entry[0] if entry is not None else None

    def tf_static(self, data: bytes, lock: threading.Lock) -> None:
        """One ``/tf_static`` message: decoded with the checked decoder (a malformed one
        counted for the topic), its refusals counted, the held samples handed on when their
        mount arrived; the session's changes under ``lock``."""
        try:
            transforms = decode_tf_message(data)
        except MalformedMessage as err:
            with lock:
                self.session.malformed('/tf_static', str(err)[:200])
            return
        refused = self.add_transforms(transforms)
        with lock:
            if refused:
                self.count_refused(refused)
            self.retry()

    def count_refused(self, refused: Counter[str]) -> None:
        """Count the transforms :meth:`add_transforms` refused, warn (throttled)."""
        session = self.session
        for reason, count in refused.items():
            session.rejections[reason] += count
            example = self.transforms.examples.get(reason, ('', ''))
            session.warn(reason, transform_warning(reason, count, example, '/tf_static'))

    def gated(self, handle: Handler) -> Handler:
        """The gyro topic handler ``handle`` behind the gate: straight through once the gate
        is open, else :meth:`sample` (call it under the node's state lock)."""
        def gated_handle(data: bytes) -> None:
            if self.open:
                handle(data)
            else:
                self.sample(data, handle)
        return gated_handle

    def sample(self, data: bytes, handle: Handler) -> None:
        """A gyro sample's bytes, for the handler ``handle`` of its topic, while the gate is
        closed (state lock held)."""
        try:
            frame = header_frame_id(data)
        except MalformedMessage:
            handle(data)  # the handler counts it
            return
        if not self.session.mount_needed(frame):
            self._open(frame, data, handle)
            return
        if frame in self._mounts:
            self._mounted(frame, data, handle)
            return
        self._wait(frame, data, handle)

    def retry(self) -> None:
        """After new transforms (state lock held): the first held sample whose frame has a
        mount names the IMU's frame; the held samples are handed on at once."""
        if self.open:
            return
        for frame, _, _ in self._held:
            if frame in self._mounts:
                self._mounted(frame, None, None)
                return

    def _mounted(self, frame: str, data: bytes | None, handle: Handler | None) -> None:
        """``frame``'s mount is in the table: set it, keep its chain, open."""
        set_found_mount(self.session, frame, self._mounts[frame][0], '/tf_static')
        with self._lock:
            self.transforms.protect(self.session.body_frame, frame)
        self._open(frame, data, handle)

    def _open(self, frame: str, data: bytes | None, handle: Handler | None) -> None:
        """``frame`` is the IMU's: hand on the held samples, each to its own topic's handler
        (which refuses those of other frames), then ``data`` to ``handle``."""
        self.open = True
        self.session.imu_frame = frame
        held, self._held = self._held, deque()
        self._held_bytes = 0
        self._deadlines.clear()
        for _, earlier, handle_earlier in held:
            handle_earlier(earlier)
        if data is not None and handle is not None:
            handle(data)

    def _wait(self, frame: str, data: bytes, handle: Handler) -> None:
        """Hold ``data`` while ``frame``'s mount may still come, else drop it."""
        now = self.monotonic()
        deadline = self._deadlines.get(frame)
        if deadline is None and len(frame) <= MAX_FRAME_LENGTH:
            if len(self._deadlines) >= PENDING_FRAMES:
                del self._deadlines[next(iter(self._deadlines))]
            deadline = self._deadlines[frame] = now + self.timeout_s
        if deadline is None or now >= deadline:
            self._drop(frame, 1)
        else:
            self._held.append((frame, data, handle))
            self._held_bytes += len(data)
        held = self._held
        while held and (len(held) > HELD_SAMPLES or self._held_bytes > HELD_BYTES
                        or now >= self._deadlines.get(held[0][0], -math.inf)):
            earlier, dropped, _ = held.popleft()
            self._held_bytes -= len(dropped)
            self._drop(earlier, 1)

    def _drop(self, frame: str, count: int) -> None:
        drop_no_mount(self.session, count, frame,
                      f'on /tf_static after tf_timeout {self.timeout_s:g} s', _REMEDY)
