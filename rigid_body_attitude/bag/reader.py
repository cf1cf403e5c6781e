"""Reading rosbag2 bags (sqlite3 or mcap) as raw CDR messages, with clear errors.

Messages come out as plain tuples ``(topic, bag_time_ns, msgtype, data)`` in bag-time order
(the recorder's receive time; ties keep their write order). ``data`` is the CDR bytes: decode
the per-sample fields with :mod:`rigid_body_attitude.msgs.cdr` (fast) or a full message object
with :func:`rigid_body_attitude.bag.serde.deserialize` (slow). Indexed MCAP files are
walked by :mod:`rigid_body_attitude.bag.mcap`, sqlite3 files queried by
:mod:`rigid_body_attitude.bag.sqlite` (same output as ``rosbags``' iterator, faster).
"""

from __future__ import annotations

from collections.abc import Collection, Iterable, Iterator, Mapping
from pathlib import Path
from types import TracebackType
from typing import NamedTuple, TypeVar

import numpy as np
from numpy.typing import NDArray
from rosbags.interfaces import Connection
from rosbags.rosbag2 import Reader

from rigid_body_attitude.bag import mcap, sqlite
from rigid_body_attitude.bag.errors import BagError
from rigid_body_attitude.bag.rosbags_internals import custom_data
from rigid_body_attitude.msgs.cdr import (
    Decoder,
    float64_value,
    imu_rates,
    pose_orientation,
    quaternion_stamped,
    twist_angular,
    vector3_stamped,
    wrench_torque,
)
from rigid_body_attitude.msgs.errors import MalformedMessage
from rigid_body_attitude.msgs.types import (
    FLOAT64,
    IMU,
    POSE_STAMPED,
    QUATERNION_STAMPED,
    TWIST_STAMPED,
    VECTOR3_STAMPED,
    WRENCH_STAMPED,
)

__all__ = ['SERIES_DECODERS', 'BagMessage', 'BagReader', 'Series', 'read_messages',
           'read_series']

#: A decoder of any signature, as a table by message type holds them.
AnyDecoder = TypeVar('AnyDecoder')
#: ``(topic, bag_time_ns, msgtype, cdr_bytes)``; plain tuples are yielded for speed.
BagMessage = tuple[str, int, str, bytes]
#: A topic selection: names, or names mapped to the message types the caller can use.
TopicSelection = Iterable[str] | Mapping[str, Collection[str]]

#: Default field read by :func:`read_series` for each message type.
SERIES_DECODERS: dict[str, Decoder] = {
    IMU: imu_rates,
    VECTOR3_STAMPED: vector3_stamped,
    WRENCH_STAMPED: wrench_torque,
    TWIST_STAMPED: twist_angular,
    QUATERNION_STAMPED: quaternion_stamped,
    POSE_STAMPED: pose_orientation,
}


class BagReader:
    """An open rosbag2 bag: its topics, custom metadata and messages.

    Use as a context manager. Raises :class:`BagError` for a missing path, a directory
    without ``metadata.yaml``, an unknown storage plugin or a corrupt file.
    """

    def __init__(self, path: str | Path) -> None:
        """Open the bag directory (or bare ``.db3`` / ``.mcap`` file) at ``path``."""
        self.path = Path(path)
        if not self.path.exists():
            raise BagError(f'Expected a rosbag2 bag (a directory with metadata.yaml, or a .db3 '
                           f'or .mcap file) at {str(self.path)!r}; it does not exist')
        try:
            self._reader = Reader(self.path)
            self._reader.open()
        # rosbags, apsw and the mcap parser raise many types for unreadable bags; translate all.
        except Exception as err:
            raise BagError(f'Cannot read bag {str(self.path)!r}: {err}') from err

    @property
    def topics(self) -> dict[str, str]:
        """Topic name → message type (types joined by ``|`` if a topic has several)."""
        types: dict[str, list[str]] = {}
        for connection in self._reader.connections:
            names = types.setdefault(connection.topic, [])
            if connection.msgtype not in names:
                names.append(connection.msgtype)
        return {topic: '|'.join(names) for topic, names in sorted(types.items())}

    @property
    def message_counts(self) -> dict[str, int]:
        """Topic name → number of messages."""
        counts: dict[str, int] = {}
        for connection in self._reader.connections:
            counts[connection.topic] = counts.get(connection.topic, 0) + connection.msgcount
        return counts

    @property
    def custom_data(self) -> dict[str, str]:
        """The bag's ``custom_data`` metadata (rosbag2 ≥ 6), empty if there is none."""
        return custom_data(self._reader)

    def _describe(self) -> str:
        topics = self.topics
        if not topics:
            return 'it has no topics'
        return 'it has: ' + ', '.join(f'{name} ({msgtype})' for name, msgtype in topics.items())

    def connections(self, topics: TopicSelection) -> list[Connection]:
        """The connections of ``topics``; checks that each exists and has a usable type.

        ``topics`` is a sequence of names, or a mapping from name to the accepted types.
        """
        names = [topics] if isinstance(topics, str) else list(topics)
        if not names:
            raise BagError(f'Expected at least one topic to read from {str(self.path)!r}; '
                           f'{self._describe()}')
        selected = []
        for name in names:
            found = [c for c in self._reader.connections if c.topic == name]
            if not found:
                raise BagError(f'Topic {name!r} is not in bag {str(self.path)!r}; '
                               f'{self._describe()}')
            if isinstance(topics, Mapping):
                accepted = topics[name]
                for connection in found:
                    if connection.msgtype not in accepted:
                        raise BagError(
                            f'Topic {name!r} in bag {str(self.path)!r} has type '
                            f'{connection.msgtype!r}; expected one of {sorted(accepted)}')
            selected.extend(found)
        return selected

    def decoder(self, topic: str, decoders: Mapping[str, AnyDecoder]) -> AnyDecoder:
        """The decoder in ``decoders`` (msgtype → decoder) for ``topic``'s type, or BagError.

        Use with :data:`~rigid_body_attitude.msgs.decoders.RATE_DECODERS` (integer stamps),
        :data:`SERIES_DECODERS`, :data:`~rigid_body_attitude.msgs.cdr.TORQUE_DECODERS` or
        :data:`~rigid_body_attitude.msgs.cdr.ATTITUDE_DECODERS` (float stamps).
        """
        (connection, *others) = self.connections({topic: decoders.keys()})
        if any(other.msgtype != connection.msgtype for other in others):
            raise BagError(f'Expected topic {topic!r} to carry one message type, got '
                           f'{self.topics[topic]!r}')
        return decoders[connection.msgtype]

    def messages(self, topics: TopicSelection) -> Iterator[BagMessage]:
        """``(topic, bag_time_ns, msgtype, cdr_bytes)`` of ``topics`` in bag-time order.

        The topics are checked before this returns (errors are not deferred to iteration).
        """
        return self._iterate(self.connections(topics))

    def _iterate(self, connections: list[Connection]) -> Iterator[BagMessage]:
        try:
            fast = mcap.fast_messages(self._reader, connections)
            if fast is None:
                fast = sqlite.fast_messages(self._reader, connections)
            if fast is not None:
                yield from fast
                return
            for connection, bag_time_ns, data in self._reader.messages(connections):
                yield connection.topic, bag_time_ns, connection.msgtype, data
        # A truncated or corrupt storage file surfaces only while reading.
        except Exception as err:
            raise BagError(f'Cannot read messages of bag {str(self.path)!r}: {err}') from err

    def close(self) -> None:
        """Close the bag (idempotent)."""
        if self._reader.is_open:
            self._reader.close()

    def __enter__(self) -> BagReader:
        """Return the open reader."""
        return self

    def __exit__(self, exc_type: type[BaseException] | None, exc: BaseException | None,
                 traceback: TracebackType | None) -> None:
        """Close the bag."""
        self.close()


def read_messages(path: str | Path, topics: TopicSelection) -> Iterator[BagMessage]:
    """``(topic, bag_time_ns, msgtype, cdr_bytes)`` of ``topics`` in the bag at ``path``.

    Opens the bag and checks the topics immediately (``BagError`` with the bag's topics and
    types if one is missing or, with a mapping ``topic → accepted types``, has another type);
    the bag is closed when the iterator is exhausted or closed.
    """
    reader = BagReader(path)
    try:
        iterator = reader.messages(topics)
    except BaseException:
        reader.close()
        raise
    return _closing(reader, iterator)


def _closing(reader: BagReader, iterator: Iterator[BagMessage]) -> Iterator[BagMessage]:
    with reader:
        yield from iterator


FloatArray = NDArray[np.float64]


class Series(NamedTuple):
    """One topic as arrays: header stamps (s), values ``(N, k)``, bag times (ns)."""

    stamps: FloatArray
    values: FloatArray
    bag_times_ns: NDArray[np.int64]


def read_series(path: str | Path, topic: str, decoder: Decoder | None = None) -> Series:
    """Read all of ``topic`` into arrays with ``decoder`` (default: by type, SERIES_DECODERS).

    Defaults: Imu → angular velocity, WrenchStamped → torque, TwistStamped → angular,
    QuaternionStamped/PoseStamped → ``(w, x, y, z)``. ``std_msgs/msg/Float64`` has no header:
    its stamps are the bag times. A message that cannot be decoded is a :class:`BagError`.
    """
    with BagReader(path) as reader:
        try:
            if decoder is None and reader.topics.get(topic) == FLOAT64:
                return _float64_series(reader, topic)
            if decoder is None:
                decoder = reader.decoder(topic, SERIES_DECODERS)
            stamps, values, times = [], [], []
            for _, bag_time_ns, _, data in reader.messages([topic]):
                stamp, value = decoder(data)
                stamps.append(stamp)
                values.append(value)
                times.append(bag_time_ns)
        except MalformedMessage as err:
            raise BagError(f'Cannot read topic {topic!r} of bag {str(path)!r}: {err}') from err
    width = len(values[0]) if values else 0
    return Series(np.array(stamps, dtype=np.float64),
                  np.array(values, dtype=np.float64).reshape(len(values), width),
                  np.array(times, dtype=np.int64))


def _float64_series(reader: BagReader, topic: str) -> Series:
    values, times = [], []
    for _, bag_time_ns, _, data in reader.messages([topic]):
        values.append(float64_value(data))
        times.append(bag_time_ns)
    bag_times = np.array(times, dtype=np.int64)
    stamps = np.asarray(bag_times * 1e-9, dtype=np.float64)
    return Series(stamps, np.array(values, dtype=np.float64).reshape(-1, 1), bag_times)
