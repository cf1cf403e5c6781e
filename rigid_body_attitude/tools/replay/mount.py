"""The sensor's mount in a replay: from ``mount_rpy``, or from the bag's ``/tf_static``.

As the node does (:mod:`rigid_body_attitude.session.mount_gate`): the IMU's frame (the sensor
frame, REP-145) is the first decodable gyro record's frame with a known mount: any frame when
``mount_rpy`` is given, else ``body_frame`` itself, an empty frame, or a frame the static
transforms connect to ``body_frame`` (a chain composed if need be:
:class:`~rigid_body_attitude.session.mount.StaticTransforms`, the node's table), here from
every ``tf2_msgs/msg/TFMessage`` recorded on ``/tf_static`` (the node receives them whenever
they were published: transient local). Records in any other frame are refused
(``foreign_frame``), before and after it, as the node refuses the samples it held. Malformed
records and refused transforms are counted and said in a note. When no frame has a mount the
replay behaves as the node after ``tf_timeout``: every gyro sample from the first decodable
one on is dropped and counted ``no_mount`` (:class:`NoMountGate`), with a warning and a note
naming the first record's frame and ``body_frame``.
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass

from rigid_body_attitude.bag import BagReader
from rigid_body_attitude.msgs.cdr import header_frame_id
from rigid_body_attitude.msgs.errors import MalformedMessage
from rigid_body_attitude.msgs.tf_message import TF_MESSAGE, decode_tf_message
from rigid_body_attitude.msgs.untrusted import quoted
from rigid_body_attitude.session.decoding import Handler
from rigid_body_attitude.session.interface import NODE_INTERFACE
from rigid_body_attitude.session.filtered_gyro import FilteredGyroSession
from rigid_body_attitude.session.gyro import GyroSession
from rigid_body_attitude.session.mount import StaticTransforms, drop_no_mount, set_found_mount

__all__ = ['BagMount', 'NoMountGate', 'TF_STATIC', 'read_bag_mount']

#: The topic of static transforms (REP-105; robot_state_publisher, static_transform_publisher).
#: The node's ``/tf_static`` input (the interface's).
TF_STATIC = NODE_INTERFACE.endpoint('/tf_static').name
_WHERE = "in the bag's /tf_static"
_REMEDY = 'give --mount-rpy, or record /tf_static with the bag'


@dataclass
class BagMount:
    """The bag's sensor frame and static transforms, and how the replay's samples are mounted.

    Attributes:
        sensor_frame: the first decodable gyro record's frame with a known mount, else the
            first decodable one's (``''``: none).
        transforms: the bag's ``/tf_static`` transforms.
        notes: remarks for the user (malformed or refused ``/tf_static`` records, a
            missing transform).
        missing_frame: set by :meth:`apply`: the sensor frame whose transform the bag lacks
            (``''``: none lacking).
    """

    sensor_frame: str
    transforms: StaticTransforms
    notes: list[str]
    missing_frame: str = ''

    def apply(self, session: GyroSession) -> None:
        """Set ``session``'s mount from the transforms when the node would wait for it, and
        its IMU frame (``imu_frame``: records in another frame are refused); the other
        sensors' mounts (``imu/mag``) from the same transforms."""
        if isinstance(session, FilteredGyroSession):
            transforms, body_frame = self.transforms, session.body_frame
            session.frame_mount = lambda frame: transforms.rotation(body_frame, frame)
        frame = self.sensor_frame
        if not session.mount_needed(frame):
            if frame:  # records in other frames are refused, as the node refuses them
                session.imu_frame = frame
            return
        q = self.transforms.rotation(session.body_frame, frame)
        if q is None:
            self.missing_frame = frame
            self.notes.append(f'no static transform {quoted(session.body_frame)} -> '
                              f'{quoted(frame)} '
                              f'{_WHERE}: gyro samples dropped, counted no_mount ({_REMEDY})')
            return
        set_found_mount(session, frame, q, "the bag's /tf_static")
        session.imu_frame = frame

    def gate(self, session: GyroSession, handle: Handler) -> Handler:
        """The gyro handler: ``handle``, or a :class:`NoMountGate` when the mount is missing."""
        return NoMountGate(session, handle, self.missing_frame) if self.missing_frame else handle


def read_bag_mount(reader: BagReader, gyro_topic: str, body_frame: str,
                   mount_given: bool) -> BagMount:
    """The sensor frame of ``gyro_topic`` (:attr:`BagMount.sensor_frame`) and the bag's
    static transforms; ``mount_given``: ``mount_rpy`` is set (every frame has a mount)."""
    if not gyro_topic:
        return BagMount('', StaticTransforms(), [])
    transforms, notes = _static_transforms(reader)
    mounted = transforms.resolved(body_frame)  # body_frame itself included
    first: str | None = None
    for frame in _frames(reader, gyro_topic):
        if mount_given or not frame or frame in mounted:
            return BagMount(frame, transforms, notes)
        if first is None:
            first = frame
    if first is None:
        return BagMount('', StaticTransforms(), [])
    return BagMount(first, transforms, notes)


def _frames(reader: BagReader, gyro_topic: str) -> Iterator[str]:
    """The header frames of the gyro records that have a decodable one, in order."""
    for _, _, _, data in reader.messages([gyro_topic]):
        try:
            yield header_frame_id(data)
        except MalformedMessage:
            continue


def _static_transforms(reader: BagReader) -> tuple[StaticTransforms, list[str]]:
    """The bag's static transforms and notes on what was refused."""
    transforms = StaticTransforms()
    msgtype = reader.topics.get(TF_STATIC)
    if msgtype is None:
        return transforms, []
    if msgtype != TF_MESSAGE:
        return transforms, [f'topic {TF_STATIC} ignored: type {msgtype!r}, not {TF_MESSAGE!r}']
    malformed = refused = 0
    for _, _, _, data in reader.messages([TF_STATIC]):
        try:
            decoded = decode_tf_message(data)
        except MalformedMessage:
            malformed += 1
            continue
        refused += sum(transforms.add_all(decoded).values())
    notes = [f'{malformed} malformed {TF_STATIC} records ignored'] if malformed else []
    if refused:
        notes.append(f'{refused} {TF_STATIC} transforms refused or dropped (empty, equal or '
                     f'overlong frames, a non-finite or non-unit rotation, or the oldest beyond '
                     f'the table size)')
    return transforms, notes


class NoMountGate:
    """The gyro handler of a replay whose bag lacks the mount: samples dropped (``no_mount``),
    as the node drops them after ``tf_timeout``; those before the first with a decodable
    header go to the handler (counted malformed there)."""

    def __init__(self, session: GyroSession, handle: Handler, sensor_frame: str) -> None:
        """Drop ``session``'s samples of ``sensor_frame``; ``handle``: the gyro handler."""
        self.session, self.handle, self.sensor_frame = session, handle, sensor_frame
        self.seen = False

    def __call__(self, data: bytes) -> None:
        """One gyro record's bytes."""
        if not self.seen:
            try:
                header_frame_id(data)
            except MalformedMessage:
                self.handle(data)
                return
            self.seen = True
        drop_no_mount(self.session, 1, self.sensor_frame, _WHERE, _REMEDY)
