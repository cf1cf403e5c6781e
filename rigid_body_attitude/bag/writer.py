"""Writing rosbag2 bags: a writer for output bags and :func:`write_bag` for sample arrays.

:class:`BagWriter` registers each topic's connection once and then writes CDR bytes made by
the fast encoders of :mod:`rigid_body_attitude.msgs.cdr` (or any message object through the
``rosbags`` type store), one record at a time (:meth:`BagWriter.write`) or many per call
(:meth:`BagWriter.write_many`). :func:`write_bag` turns arrays of samples into a bag of
standard messages, for test fixtures and for users converting their own logs.

Batched writing. ``rosbags``' writer costs about 3.7 µs per record (a membership scan of its
connections, one ``sqlite3`` statement or a ``BytesIO`` record per message); the replay tool
writes three records per gyro message and needs ≥ 10⁵ messages/s. The storages used are
``rosbags``' own with a ``write_many`` added (in
:mod:`~rigid_body_attitude.bag.rosbags_internals`, with every other use of ``rosbags``'
unexported API). The sqlite3 storage keeps ``rosbags``' schema and statements but runs on an
``apsw`` connection (the SQLite binding ``rosbags`` reads with), 512 rows per statement, in one
transaction, with 32 KiB pages. The MCAP storage lays
out a batch of message records with C-level ``map`` calls and closes chunks at the same 1 MiB
boundary as ``rosbags``, so the file is byte for byte the one ``rosbags`` writes. Metadata
(message counts, start, duration) is kept by ``rosbags``' ``Writer`` as for single writes.
"""

from __future__ import annotations

import struct
from collections.abc import Callable, Mapping, Sequence
from operator import itemgetter
from pathlib import Path
from types import TracebackType

import numpy as np
from numpy.typing import ArrayLike, NDArray
from rosbags.interfaces import Connection
from rosbags.rosbag2 import StoragePlugin, WriterError

from rigid_body_attitude.bag.errors import BagError
from rigid_body_attitude.bag.rosbags_internals import Record, Rosbag2Writer
from rigid_body_attitude.bag.serde import typestore
from rigid_body_attitude.core.errors import InputError
from rigid_body_attitude.msgs.cdr import (
    encode_imu,
    encode_magnetic_field,
    encode_pose_stamped,
    encode_quaternion_stamped,
    encode_vector3_stamped,
    encode_wrench_stamped,
    stamp_to_ns,
)
from rigid_body_attitude.msgs.types import (
    IMU,
    MAGNETIC_FIELD,
    POSE_STAMPED,
    QUATERNION_STAMPED,
    VECTOR3_STAMPED,
    WRENCH_STAMPED,
)

__all__ = ['GROUND_TRUTH_TYPES', 'STORAGES', 'BagWriter', 'Record', 'write_bag']

FloatArray = NDArray[np.float64]

#: Storage plugin names accepted by :class:`BagWriter` and :func:`write_bag`.
STORAGES = {'sqlite3': StoragePlugin.SQLITE3, 'mcap': StoragePlugin.MCAP}
#: ``ground_truth_type`` names accepted by :func:`write_bag`.
GROUND_TRUTH_TYPES = {'QuaternionStamped': QUATERNION_STAMPED, 'PoseStamped': POSE_STAMPED}
#: Largest deviation of ``|q|`` from 1 accepted in ground truth (float32 sources give ~1e−7).
UNIT_NORM_TOLERANCE = 1e-6


_FIRST, _SECOND, _THIRD = itemgetter(0), itemgetter(1), itemgetter(2)
#: Records :func:`write_bag` hands to :meth:`BagWriter.write_many` at a time.
_WRITE_BAG_BATCH = 16384
_TIME_LIMIT = 2 ** 63
#: Types accepted as message data (``bytes`` from the encoders; views of read messages).
_DATA_TYPES = {bytes, bytearray, memoryview}


def _storage_plugin(storage: str) -> StoragePlugin:
    if not isinstance(storage, str) or storage not in STORAGES:
        raise InputError(f'Expected `storage` to be one of {sorted(STORAGES)}, got {storage!r}')
    return STORAGES[storage]


class BagWriter:
    """A new rosbag2 bag (format version 9) open for writing; use as a context manager.

    Register each topic once with :meth:`add_topic`, then :meth:`write` CDR bytes with the
    returned connection, or :meth:`write_many` records in one call. On leaving the ``with``
    block the bag is closed (metadata written), or aborted if an exception is propagating.
    ``custom_data`` (str → str) is stored in the bag's metadata (``metadata.yaml`` and, for
    mcap, the file's own metadata record).
    """

    def __init__(self, path: str | Path, *, storage: str = 'sqlite3',
                 custom_data: Mapping[str, str] | None = None) -> None:
        """Create the bag directory ``path`` (which must not exist) with ``storage``."""
        plugin = _storage_plugin(storage)
        custom = dict(custom_data or {})
        for key, value in custom.items():
            if not isinstance(key, str) or not isinstance(value, str):
                raise InputError(f'Expected `custom_data` to map str to str, got '
                                 f'{key!r}: {value!r}')
        self.path = Path(path)
        try:
            self._writer = Rosbag2Writer(self.path, version=9, storage_plugin=plugin)
            for key, value in custom.items():
                self._writer.set_custom_data(key, value)
            self._writer.open()
        except WriterError as err:
            raise BagError(f'Cannot create bag {str(self.path)!r}: {err}') from err
        self._connections: dict[str, Connection] = {}

    def add_topic(self, topic: str, msgtype: str) -> Connection:
        """Register ``topic`` with Jazzy type ``msgtype`` (once) and return its connection."""
        if not isinstance(topic, str) or not topic:
            raise InputError(f'Expected `topic` to be a non-empty string, got {topic!r}')
        if topic in self._connections:
            raise BagError(f'Topic {topic!r} is already registered in bag {str(self.path)!r} '
                           f'with type {self._connections[topic].msgtype!r}')
        if msgtype not in typestore().fielddefs:
            raise BagError(f'Expected a ROS 2 Jazzy message type for topic {topic!r}, '
                           f'got {msgtype!r}')
        connection = self._writer.add_connection(topic, msgtype, typestore=typestore())
        self._connections[topic] = connection
        return connection

    def add_topics(self, topics: Mapping[str, str]) -> dict[str, Connection]:
        """Register several ``topic → msgtype`` at once; returns ``topic → connection``."""
        return {topic: self.add_topic(topic, msgtype) for topic, msgtype in topics.items()}

    def write(self, connection: Connection, bag_time_ns: int, data: bytes) -> None:
        """Append CDR bytes ``data`` on ``connection`` at bag (receive) time ``bag_time_ns``."""
        try:
            self._writer.write(connection, bag_time_ns, data)
        except (WriterError, struct.error, OverflowError, TypeError) as err:
            raise BagError(f'Cannot write to bag {str(self.path)!r} at bag_time_ns='
                           f'{bag_time_ns!r} (expected a registered connection and an '
                           f'integer time in [0, 2**63) ns): {err}') from err

    def write_many(self, records: Sequence[Record]) -> None:
        """Append ``(connection.id, bag_time_ns, cdr_bytes)`` records in order, in one call.

        The same bag as :meth:`write` of each record in turn, about ten times faster. Raises
        :class:`BagError` for a connection id not registered here or a time that is not an
        integer in ``[0, 2**63)`` ns; nothing of the batch is written then.
        """
        if not records:
            return
        writer = self._writer
        try:
            if set(map(len, records)) != {3}:
                raise ValueError(f'records of lengths {sorted(set(map(len, records)))}')
            channel_ids = list(map(_FIRST, records))
            times = list(map(_SECOND, records))
            datas = list(map(_THIRD, records))
            if not set(map(type, times)) <= {int}:
                raise TypeError(f'times of types {sorted(set(map(type, times)), key=str)}')
            first, last = min(times), max(times)
        except (TypeError, ValueError) as err:
            raise BagError(f'Cannot write to bag {str(self.path)!r}: expected records '
                           f'(connection id, integer bag time in [0, 2**63) ns, bytes), got '
                           f'{err}') from err
        registered = writer.registered()
        counts = {connection_id: channel_ids.count(connection_id) for connection_id in registered}
        if (first < 0 or last >= _TIME_LIMIT or sum(counts.values()) != len(channel_ids)
                or not writer.is_open() or not set(map(type, datas)) <= _DATA_TYPES):
            unknown = sorted(set(channel_ids) - registered)
            types = sorted({type(data).__name__ for data in datas})
            raise BagError(f'Cannot write to bag {str(self.path)!r}: expected an open bag, '
                           f'connection ids of its topics {sorted(registered)}, bag times '
                           f'in [0, 2**63) ns and bytes, got ids {unknown} not registered, '
                           f'times [{first}, {last}], data of types {types}')
        writer.write_records(records, channel_ids, times, datas, counts)

    def close(self) -> None:
        """Finish the bag: flush storage and write ``metadata.yaml``."""
        self._writer.close()

    def abort(self) -> None:
        """Stop without writing metadata (the directory is left incomplete)."""
        self._writer.abort()

    def __enter__(self) -> BagWriter:
        """Return the open writer."""
        return self

    def __exit__(self, exc_type: type[BaseException] | None, exc: BaseException | None,
                 traceback: TracebackType | None) -> None:
        """Close the bag, or abort it if an exception is propagating."""
        if exc_type is None:
            self.close()
        else:
            self.abort()


def _column(value: ArrayLike, name: str, finite: bool = True) -> FloatArray:
    try:
        array = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError) as err:
        raise InputError(f'Expected `{name}` to be numeric with shape (N,), '
                         f'got {value!r}') from err
    if array.ndim != 1 or array.size == 0:
        raise InputError(f'Expected `{name}` to have shape (N,) with N ≥ 1, got {array.shape}')
    if finite and not np.all(np.isfinite(array)):
        raise InputError(f'Expected `{name}` to be finite, got non-finite values at indices '
                         f'{np.flatnonzero(~np.isfinite(array))[:10].tolist()}')
    return array


def _rows(value: ArrayLike, name: str, count: int, width: int, finite: bool) -> FloatArray:
    try:
        array = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError) as err:
        raise InputError(f'Expected `{name}` to be numeric with shape ({count}, {width}), '
                         f'got {value!r}') from err
    if array.shape != (count, width):
        raise InputError(f'Expected `{name}` to have shape ({count}, {width}) (one row per '
                         f'stamp), got {array.shape}')
    if finite and not np.all(np.isfinite(array)):
        bad = np.flatnonzero(~np.all(np.isfinite(array), axis=1))
        raise InputError(f'Expected `{name}` to be finite, got non-finite rows '
                         f'{bad[:10].tolist()}: {array[bad[:3]].tolist()}')
    return array


def _ground_truth_rows(value: ArrayLike, count: int, validate: bool) -> tuple[FloatArray,
                                                                              NDArray[np.bool_]]:
    """Ground truth and the mask of rows to write (all-NaN rows are lost samples)."""
    array = _rows(value, 'ground_truth', count, 4, finite=False)
    present = ~np.all(np.isnan(array), axis=1)
    if validate:
        rows = array[present]
        bad = np.flatnonzero(present)[~np.all(np.isfinite(rows), axis=1)]
        if bad.size:
            raise InputError(f'Expected `ground_truth` rows to be finite or all NaN (lost), got '
                             f'rows {bad[:10].tolist()}: {array[bad[:3]].tolist()}')
        norm_error = np.abs(np.linalg.norm(rows, axis=1) - 1.0)
        bad = np.flatnonzero(present)[norm_error > UNIT_NORM_TOLERANCE]
        if bad.size:
            raise InputError(f'Expected `ground_truth` to be unit quaternions (w, x, y, z) '
                             f'within {UNIT_NORM_TOLERANCE}, got rows {bad[:10].tolist()}: '
                             f'{array[bad[:3]].tolist()}')
    return array, present


def _stamps_ns(stamps: FloatArray, name: str) -> list[int]:
    seconds = np.floor(stamps)
    if np.any(seconds < -2 ** 31) or np.any(seconds >= 2 ** 31):
        raise InputError(f'Expected `{name}` within the int32 seconds range of '
                         f'builtin_interfaces/Time, got range [{stamps.min()}, {stamps.max()}]')
    return [stamp_to_ns(t) for t in stamps.tolist()]


def _check_topics(topics: dict[str, str | None]) -> None:
    used: dict[str, str] = {}
    for argument, topic in topics.items():
        if topic is None:
            continue
        if not isinstance(topic, str) or not topic:
            raise InputError(f'Expected `{argument}` to be a non-empty string, got {topic!r}')
        if topic in used:
            raise InputError(f'Expected distinct topics, got `{argument}` = `{used[topic]}` = '
                             f'{topic!r}')
        used[topic] = argument


def _bag_times(receive_times: ArrayLike | None, stamps: FloatArray) -> list[int]:
    times = stamps if receive_times is None else _column(receive_times, 'receive_times')
    if times.shape != stamps.shape:
        raise InputError(f'Expected `receive_times` to have shape {stamps.shape} like `stamps`, '
                         f'got {times.shape}')
    if np.any(times < 0.0):
        raise InputError(f'Expected `receive_times` (default: `stamps`) to be ≥ 0 s, got '
                         f'minimum {times.min()}; pass non-negative `receive_times` to record '
                         f'negative header stamps')
    return _stamps_ns(times, 'receive_times')


Stream = tuple[str, str, Callable[[int], bytes]]


def write_bag(path: str | Path, *, stamps: ArrayLike, rates: ArrayLike | None = None,
              torques: ArrayLike | None = None, forces: ArrayLike | None = None,
              ground_truth: ArrayLike | None = None, accelerations: ArrayLike | None = None,
              receive_times: ArrayLike | None = None, imu_topic: str | None = 'imu',
              angular_velocity_topic: str | None = None, torque_topic: str | None = 'torque',
              ground_truth_topic: str | None = 'ground_truth',
              ground_truth_type: str = 'QuaternionStamped', frame_id: str = 'base_link',
              world_frame: str = 'world', storage: str = 'sqlite3',
              custom_data: Mapping[str, str] | None = None,
              validate: bool = True, magnetic_fields: ArrayLike | None = None,
              magnetic_field_topic: str = 'imu/mag') -> dict[str, int]:
    """Write sample arrays as a rosbag2 bag; returns the message count per topic.

    Row ``i`` of every array belongs to header stamp ``stamps[i]`` (s) and is recorded at bag
    time ``receive_times[i]`` (s, default ``stamps``, must be ≥ 0). Readers return messages in
    bag-time order, so header stamps that go backwards or jump are kept as given only if
    ``receive_times`` orders the rows.

    * ``rates`` (N, 3) rad/s, body frame: ``sensor_msgs/msg/Imu`` on ``imu_topic`` (with
      ``accelerations`` (N, 3) m/s² if given; REP-145 ``covariance[0] = −1`` for the fields not
      provided) and/or ``geometry_msgs/msg/Vector3Stamped`` on ``angular_velocity_topic``.
    * ``magnetic_fields`` (N, 3) T, body frame: ``sensor_msgs/msg/MagneticField`` on
      ``magnetic_field_topic`` (covariance unknown), each row written before the Imu of the
      same row.
    * ``torques`` / ``forces`` (N, 3), body frame: ``geometry_msgs/msg/WrenchStamped`` on
      ``torque_topic`` (the missing one is zero).
    * ``ground_truth`` (N, 4) scalar-first ``(w, x, y, z)``, body → world: ``QuaternionStamped``
      or ``PoseStamped`` (``ground_truth_type``, position zero) on ``ground_truth_topic`` with
      ``frame_id = world_frame``; all-NaN rows (lost samples) are skipped.

    Body-frame messages carry ``frame_id``. With ``validate=False`` non-finite values and
    non-unit quaternions are written verbatim (fault-injection bags); shapes, stamps and topics
    are always checked, and nothing is created on disk unless every check passes.
    """
    streams = _plan(stamps=stamps, rates=rates, torques=torques, forces=forces,
                    ground_truth=ground_truth, accelerations=accelerations,
                    imu_topic=imu_topic, angular_velocity_topic=angular_velocity_topic,
                    torque_topic=torque_topic, ground_truth_topic=ground_truth_topic,
                    ground_truth_type=ground_truth_type, frame_id=frame_id,
                    world_frame=world_frame, validate=validate)
    if magnetic_fields is not None:
        stamp_ns = _stamps_ns(_column(stamps, 'stamps'), 'stamps')
        field_rows = _rows(magnetic_fields, 'magnetic_fields', len(stamp_ns), 3,
                           validate).tolist()
        _check_topics({'magnetic_field_topic': magnetic_field_topic})
        streams.insert(0, (magnetic_field_topic, MAGNETIC_FIELD, lambda i: encode_magnetic_field(
            stamp_ns[i], frame_id, field_rows[i])))
    bag_times = _bag_times(receive_times, _column(stamps, 'stamps'))
    counts = {topic: 0 for topic, _, _ in streams}
    with BagWriter(path, storage=storage, custom_data=custom_data) as writer:
        connections = [(writer.add_topic(topic, msgtype).id, encode, topic)
                       for topic, msgtype, encode in streams]
        records: list[Record] = []
        for index, bag_time_ns in enumerate(bag_times):
            for connection_id, encode, topic in connections:
                data = encode(index)
                if data:
                    records.append((connection_id, bag_time_ns, data))
                    counts[topic] += 1
            if len(records) >= _WRITE_BAG_BATCH:
                writer.write_many(records)
                records.clear()
        writer.write_many(records)
    return counts


def _plan(*, stamps: ArrayLike, rates: ArrayLike | None, torques: ArrayLike | None,
          forces: ArrayLike | None, ground_truth: ArrayLike | None,
          accelerations: ArrayLike | None, imu_topic: str | None,
          angular_velocity_topic: str | None, torque_topic: str | None,
          ground_truth_topic: str | None, ground_truth_type: str, frame_id: str,
          world_frame: str, validate: bool) -> list[Stream]:
    """Validate every argument of :func:`write_bag`; return ``(topic, msgtype, encode(i))``."""
    stamp_ns = _stamps_ns(_column(stamps, 'stamps'), 'stamps')
    for name, value in (('frame_id', frame_id), ('world_frame', world_frame)):
        if not isinstance(value, str) or '\x00' in value:
            raise InputError(f'Expected `{name}` to be a string without NUL, got {value!r}')
    if ground_truth_type not in GROUND_TRUTH_TYPES:
        raise InputError(f'Expected `ground_truth_type` to be one of '
                         f'{sorted(GROUND_TRUTH_TYPES)}, got {ground_truth_type!r}')
    if all(value is None for value in (rates, torques, forces, ground_truth)):
        raise InputError('Expected at least one of `rates`, `torques`, `forces`, `ground_truth`, '
                         'got none')
    needs = {'imu_topic': imu_topic if rates is not None else None,
             'angular_velocity_topic': angular_velocity_topic if rates is not None else None,
             'torque_topic': torque_topic if torques is not None or forces is not None else None,
             'ground_truth_topic': ground_truth_topic if ground_truth is not None else None}
    _check_topics(needs)
    streams: list[Stream] = []
    if rates is not None:
        streams += _rate_streams(stamp_ns, rates, accelerations, imu_topic,
                                 angular_velocity_topic, frame_id, validate)
    elif accelerations is not None:
        raise InputError('Expected `rates` with `accelerations` (an Imu carries both), got '
                         'rates=None')
    if torques is not None or forces is not None:
        streams.append(_wrench_stream(stamp_ns, torques, forces, torque_topic, frame_id,
                                      validate))
    if ground_truth is not None:
        streams.append(_ground_truth_stream(stamp_ns, ground_truth, ground_truth_topic,
                                            ground_truth_type, world_frame, validate))
    return streams


def _rate_streams(stamp_ns: list[int], rates: ArrayLike, accelerations: ArrayLike | None,
                  imu_topic: str | None, angular_velocity_topic: str | None, frame_id: str,
                  validate: bool) -> list[Stream]:
    count = len(stamp_ns)
    rate_rows = _rows(rates, 'rates', count, 3, validate).tolist()
    if imu_topic is None and angular_velocity_topic is None:
        raise InputError('Expected `imu_topic` or `angular_velocity_topic` for `rates`, got '
                         'both None')
    if accelerations is not None and imu_topic is None:
        raise InputError('Expected `imu_topic` for `accelerations`, got None')
    acceleration_rows = (None if accelerations is None
                         else _rows(accelerations, 'accelerations', count, 3, validate).tolist())
    streams: list[Stream] = []
    if imu_topic is not None:
        def encode_imu_row(i: int) -> bytes:
            return encode_imu(stamp_ns[i], frame_id, rate_rows[i],
                              None if acceleration_rows is None else acceleration_rows[i])
        streams.append((imu_topic, IMU, encode_imu_row))
    if angular_velocity_topic is not None:
        streams.append((angular_velocity_topic, VECTOR3_STAMPED,
                        lambda i: encode_vector3_stamped(stamp_ns[i], frame_id, rate_rows[i])))
    return streams


def _wrench_stream(stamp_ns: list[int], torques: ArrayLike | None, forces: ArrayLike | None,
                   torque_topic: str | None, frame_id: str, validate: bool) -> Stream:
    count = len(stamp_ns)
    if torque_topic is None:
        raise InputError('Expected `torque_topic` for `torques`/`forces`, got None')
    zeros = np.zeros((count, 3))
    torque_rows = (zeros if torques is None
                   else _rows(torques, 'torques', count, 3, validate)).tolist()
    force_rows = (zeros if forces is None
                  else _rows(forces, 'forces', count, 3, validate)).tolist()
    return (torque_topic, WRENCH_STAMPED,
            lambda i: encode_wrench_stamped(stamp_ns[i], frame_id, force_rows[i], torque_rows[i]))


def _ground_truth_stream(stamp_ns: list[int], ground_truth: ArrayLike,
                         ground_truth_topic: str | None, ground_truth_type: str,
                         world_frame: str, validate: bool) -> Stream:
    if ground_truth_topic is None:
        raise InputError('Expected `ground_truth_topic` for `ground_truth`, got None')
    array, present = _ground_truth_rows(ground_truth, len(stamp_ns), validate)
    rows = array.tolist()
    written = present.tolist()
    msgtype = GROUND_TRUTH_TYPES[ground_truth_type]
    origin = (0.0, 0.0, 0.0)

    def encode_row(i: int) -> bytes:
        if not written[i]:
            return b''
        if msgtype == POSE_STAMPED:
            return encode_pose_stamped(stamp_ns[i], world_frame, origin, rows[i])
        return encode_quaternion_stamped(stamp_ns[i], world_frame, rows[i])
    return ground_truth_topic, msgtype, encode_row
