"""Every use of ``rosbags``' unexported API, in one module.

``rosbags`` (pinned in ``requirements.txt``) exports ``Reader``, ``Writer`` and a few enums from
``rosbags.rosbag2``; the fast bag paths of this package need more, and all of it is here:

* writing: :class:`Sqlite3Storage` and :class:`McapStorage` subclass the unexported storage
  writers ``storage_sqlite3.Sqlite3Writer`` (its ``SQLITE_SCHEMA``, attributes ``path``,
  ``conn``, ``cursor``) and ``storage_mcap.McapWriter`` (attributes ``bio``, ``chunk``
  (a ``PendingChunk``), ``chunks``, ``channel_stats``, ``compressor``, ``compression``,
  ``message_start_time``, ``message_end_time``; ``close_chunk`` is rewritten; ``close`` calls
  it while ``chunk.bio`` holds data). :class:`Rosbag2Writer` sets ``Writer.STORAGE_PLUGINS`` and
  keeps ``Writer``'s ``counts``, ``storage``, ``min_timestamp``, ``max_timestamp`` for batches.
* reading: ``Reader.storage`` (not a documented attribute), its ``metadata`` (``custom``,
  ``compression_mode``), ``reader.DirectoryReader.storages``, ``storage_sqlite3.Sqlite3Reader``
  (``dbconn``, ``connections``), ``storage_mcap.McapReader`` (``bio``, ``chunks`` of
  ``ChunkInfo``, ``connections``) and ``storage_mcap.decompress``: :func:`custom_data`,
  :func:`sqlite_files`, :func:`mcap_files` turn them into this module's own types.
* typing: ``typesys.store.Typestore``, the type of ``get_typestore()``'s result.

Public and used elsewhere: ``rosbags.rosbag2`` (``Reader``, ``Writer``, ``StoragePlugin``,
``CompressionMode``, ``WriterError``), ``rosbags.typesys`` (``Stores``, ``get_typestore``),
``rosbags.serde.SerdeError`` and ``rosbags.interfaces.Connection``.

:func:`incompatibilities` lists what of this the installed ``rosbags`` lacks;
``test/bag/test_rosbags_internals.py`` fails with that list (naming each missing name, and the
installed and pinned versions) when the library changes. The byte-equality tests of
``test/bag/test_bag.py`` (MCAP files identical to ``rosbags``' own, same messages as its
readers) catch a change of behaviour behind unchanged names.
"""

from __future__ import annotations

import struct
from bisect import bisect_right
from collections import defaultdict
from collections.abc import Mapping, Sequence
from importlib.metadata import version
from io import BytesIO
from itertools import accumulate, chain, repeat
from operator import add
from pathlib import Path
from typing import Any, BinaryIO, NamedTuple, cast

import apsw
import numpy as np
from rosbags.interfaces import Connection
from rosbags.rosbag2 import CompressionMode, Reader, StoragePlugin, Writer, WriterError
from rosbags.typesys import Stores, get_typestore

try:
    from rosbags.rosbag2.reader import DirectoryReader
    from rosbags.rosbag2.storage_mcap import McapReader, McapWriter, PendingChunk, decompress
    from rosbags.rosbag2.storage_sqlite3 import Sqlite3Reader, Sqlite3Writer
    from rosbags.typesys.store import Typestore
except ImportError as err:  # pragma: no cover - only with another rosbags
    raise ImportError(f'rigid_body_attitude.bag needs the rosbags internals listed in '
                      f'{__name__} (rosbags {version("rosbags")} installed): {err}') from err

__all__ = ['McapChunk', 'McapFile', 'McapStorage', 'Record', 'Rosbag2Writer',
           'SQLITE_PAGE_SIZE', 'Sqlite3Storage', 'Typestore', 'custom_data', 'decompress',
           'incompatibilities', 'mcap_files', 'sqlite_files']

#: One record for a batch write: ``(connection.id, bag_time_ns, cdr_bytes)``.
Record = tuple[int, int, bytes]
#: Page size of the sqlite3 files written [bytes]. SQLite's default (4096) makes an insert of
#: the replay's three outputs cost 3.2 µs; 32 KiB pages (fewer page splits and b-tree levels)
#: 2.6 µs; 64 KiB gains no more. Any SQLite reader opens any page size.
SQLITE_PAGE_SIZE = 32768
_INSERT_MESSAGE = 'INSERT INTO messages (topic_id, timestamp, data) VALUES(?, ?, ?)'
#: Rows per multi-row insert: 512 rows (1536 parameters) insert three outputs per message in
#: 1.7 µs against 2.5 µs one row per statement; 1024 gains no more.
_SQLITE_ROWS_PER_INSERT = 512
_INSERT_MESSAGES = ('INSERT INTO messages (topic_id, timestamp, data) VALUES '
                    + ','.join(['(?, ?, ?)'] * _SQLITE_ROWS_PER_INSERT))
#: MCAP message record: opcode, record length, channel id, sequence, log time, publish time.
_MCAP_MESSAGE = struct.Struct('<BQHIQQ')
_MCAP_MESSAGE_OPCODE = 0x05
_MCAP_CHUNK_OPCODE = 0x06
_MCAP_MESSAGE_INDEX_OPCODE = 0x07
_MCAP_RECORD = struct.Struct('<BQ')
_MCAP_MESSAGE_FIELDS = _MCAP_MESSAGE.size - 9  # the record length counts what follows it
#: ``rosbags``' McapWriter closes a chunk once it holds more than this many bytes.
_MCAP_CHUNK_BYTES = 2 ** 20


class Sqlite3Storage(Sqlite3Writer):
    """``rosbags``' sqlite3 storage (schema, topics, rows) on an ``apsw`` connection.

    One transaction from creation to :meth:`close`, as ``rosbags``' own (the standard module
    opens it implicitly at the first insert and commits on close); pages of
    :data:`SQLITE_PAGE_SIZE` bytes.
    """

    def __init__(self, path: Path, compression: CompressionMode) -> None:
        if compression == CompressionMode.STORAGE:
            raise WriterError('SQLITE3 writer does not support storage-side compression.')
        self.path = path / f'{path.name}.db3'
        self.database = apsw.Connection(str(self.path))
        # rosbags annotates ``conn`` as sqlite3's; its methods used here (add_msgtype,
        # add_connection) only call ``cursor.execute``, which apsw's cursor provides.
        self.conn = self.database  # type: ignore[assignment]
        self.cursor = self.database.cursor()  # type: ignore[assignment]
        self.cursor.execute(f'PRAGMA page_size={SQLITE_PAGE_SIZE}')
        self.cursor.execute(self.SQLITE_SCHEMA)
        self.cursor.execute('BEGIN')

    def write_many(self, records: Sequence[Record]) -> None:
        """Insert ``(topic_id, timestamp, data)`` rows in order.

        :data:`_SQLITE_ROWS_PER_INSERT` rows per statement (a multi-row ``VALUES``), the rest
        one per statement: SQLite's cost per statement run is then shared by the rows.
        """
        rows = _SQLITE_ROWS_PER_INSERT
        full = len(records) - len(records) % rows
        if full:
            self.cursor.executemany(_INSERT_MESSAGES, [
                tuple(chain.from_iterable(records[begin:begin + rows]))
                for begin in range(0, full, rows)])
        if full < len(records):
            self.cursor.executemany(_INSERT_MESSAGE, records[full:])

    def close(self, version: int, metadata: str) -> None:
        """Store the metadata row, commit and close."""
        self.cursor.execute('INSERT INTO metadata(metadata_version, metadata) VALUES(?, ?)',
                            (version, metadata))
        self.cursor.execute('COMMIT')
        self.cursor.execute('PRAGMA optimize')
        self.database.close()

    def abort(self) -> None:
        """Roll back and close."""
        try:
            if not self.database.getautocommit():
                self.cursor.execute('ROLLBACK')
        finally:
            self.database.close()


class McapStorage(McapWriter):
    """``rosbags``' MCAP storage writing batches of message records (the same bytes).

    The pending chunk's message index is kept as three flat lists (channel ids, log times,
    record offsets) instead of ``rosbags``' per-channel lists of pairs, so that a batch is
    laid out by C-level ``map``/``accumulate`` calls and the index packed by NumPy per chunk.
    Chunks close after the record that takes them past 1 MiB, as in ``rosbags``.
    """

    def __init__(self, path: Path, compression: CompressionMode) -> None:
        super().__init__(path, compression)
        self.index_channels: list[int] = []
        self.index_times: list[int] = []
        self.index_offsets: list[int] = []

    def write(self, connection: Connection, timestamp: int, data: bytes | memoryview) -> None:
        """One message record (:meth:`write_many` of one, without the batch set-up)."""
        chunk = self.chunk
        self.index_channels.append(connection.id)
        self.index_times.append(timestamp)
        self.index_offsets.append(chunk.bio.tell())
        chunk.bio.write(_MCAP_MESSAGE.pack(_MCAP_MESSAGE_OPCODE, _MCAP_MESSAGE_FIELDS + len(data),
                                           connection.id, 0, timestamp, timestamp))
        chunk.bio.write(data)
        chunk.message_start_time = min(chunk.message_start_time, timestamp)
        chunk.message_end_time = max(chunk.message_end_time, timestamp)
        self.message_start_time = min(self.message_start_time, timestamp)
        self.message_end_time = max(self.message_end_time, timestamp)
        self.channel_stats[connection.id] += 1
        if chunk.bio.tell() > _MCAP_CHUNK_BYTES:
            self.close_chunk()

    def write_many(self, channel_ids: Sequence[int], times: Sequence[int],
                   datas: Sequence[bytes], counts: Mapping[int, int]) -> None:
        """Append message records, as :meth:`McapWriter.write` of each in turn would.

        ``channel_ids``, ``times`` and ``datas`` are the records' columns; ``counts`` the
        records per channel id.
        """
        sizes = list(map(len, datas))
        headers = list(map(_MCAP_MESSAGE.pack, repeat(_MCAP_MESSAGE_OPCODE),
                           map(add, sizes, repeat(_MCAP_MESSAGE_FIELDS)), channel_ids, repeat(0),
                           times, times))
        # starts[i]: where record i starts if the whole batch went into the pending chunk.
        starts = list(accumulate(map(add, sizes, repeat(_MCAP_MESSAGE.size)),
                                 initial=self.chunk.bio.tell()))
        count, begin = len(sizes), 0
        while begin < count:
            chunk = self.chunk
            shift = chunk.bio.tell() - starts[begin]
            # The chunk closes after the first record ending beyond the limit.
            end = min(bisect_right(starts, _MCAP_CHUNK_BYTES - shift, begin + 1), count)
            chunk.bio.writelines(chain.from_iterable(zip(headers[begin:end], datas[begin:end])))
            self.index_channels.extend(channel_ids[begin:end])
            self.index_times.extend(times[begin:end])
            self.index_offsets.extend(map(add, starts[begin:end], repeat(shift)))
            chunk.message_start_time = min(chunk.message_start_time, min(times[begin:end]))
            chunk.message_end_time = max(chunk.message_end_time, max(times[begin:end]))
            if chunk.bio.tell() > _MCAP_CHUNK_BYTES:
                self.close_chunk()
            begin = end
        self.message_start_time = min(self.message_start_time, min(times))
        self.message_end_time = max(self.message_end_time, max(times))
        for channel_id, records in counts.items():
            self.channel_stats[channel_id] += records

    def close_chunk(self) -> None:
        """Write the pending chunk, its message indexes and keep its chunk index record.

        :meth:`McapWriter.close_chunk` record for record; each channel's message index
        (``(log time, offset)`` pairs in write order) is packed by NumPy.
        """
        chunk, bio = self.chunk, self.bio
        uncompressed_size = chunk.bio.tell()
        compressed = self.compressor(cast(bytes, chunk.bio.getbuffer()))  # any buffer will do
        compression = self.compression.encode()
        compression_field = struct.pack('<I', len(compression)) + compression
        times = struct.pack('<QQ', chunk.message_start_time, chunk.message_end_time)
        header = b''.join((times, struct.pack('<QI', uncompressed_size, 0), compression_field,
                           struct.pack('<Q', len(compressed))))
        chunk_start = bio.tell()
        compressed_size = len(compressed)
        bio.write(_MCAP_RECORD.pack(_MCAP_CHUNK_OPCODE, len(header) + compressed_size))
        bio.write(header)
        bio.write(compressed)
        del compressed  # a view of the chunk's buffer
        chunk_end = bio.tell()
        channels = np.array(self.index_channels, dtype=np.int64)
        pairs = np.empty((channels.size, 2), dtype='<u8')
        pairs[:, 0] = self.index_times
        pairs[:, 1] = self.index_offsets
        offsets = []
        for channel_id in dict.fromkeys(self.index_channels):  # in order of first message
            offsets.append(struct.pack('<HQ', channel_id, bio.tell()))
            entries = pairs[channels == channel_id].tobytes()
            bio.write(_MCAP_RECORD.pack(_MCAP_MESSAGE_INDEX_OPCODE, 6 + len(entries)))
            bio.write(struct.pack('<HI', channel_id, len(entries)))
            bio.write(entries)
        index = BytesIO()
        index.write(b''.join((
            times, struct.pack('<QQI', chunk_start, chunk_end - chunk_start, 10 * len(offsets)),
            *offsets, struct.pack('<Q', bio.tell() - chunk_end), compression_field,
            struct.pack('<QQ', compressed_size, uncompressed_size))))
        self.chunks.append(index)
        self.chunk = PendingChunk(2 ** 63 - 1, 0, BytesIO(), defaultdict(list))
        self.index_channels, self.index_times, self.index_offsets = [], [], []


class Rosbag2Writer(Writer):
    """``rosbags``' writer with the storages above and a batch write."""

    STORAGE_PLUGINS = {StoragePlugin.SQLITE3: Sqlite3Storage, StoragePlugin.MCAP: McapStorage}

    def registered(self) -> set[int]:
        """Connection ids registered (``Writer.counts``' keys)."""
        return set(self.counts)

    def is_open(self) -> bool:
        """True between :meth:`open` and :meth:`close` / :meth:`abort`."""
        return self.storage is not None

    def write_records(self, records: Sequence[Record], channel_ids: list[int], times: list[int],
                      datas: list[bytes], counts: Mapping[int, int]) -> None:
        """Append checked records and keep ``Writer``'s counts and time range, as ``write``.

        ``channel_ids``, ``times``, ``datas`` are the records' columns, ``counts`` the records
        per connection id; the caller has checked ids, times and types.
        """
        storage = self.storage
        if isinstance(storage, McapStorage):
            storage.write_many(channel_ids, times, datas, counts)
        elif isinstance(storage, Sqlite3Storage):
            storage.write_many(records)
        else:
            raise WriterError('Bag is not open.')
        for connection_id, count in counts.items():
            self.counts[connection_id] += count
        self.min_timestamp = min(min(times), self.min_timestamp)
        self.max_timestamp = max(max(times), self.max_timestamp)


class McapChunk(NamedTuple):
    """One chunk of an indexed MCAP file (from ``rosbags``' ``ChunkInfo``)."""

    start_offset: int
    message_start_time: int
    message_end_time: int
    compression: str
    compressed_size: int
    uncompressed_size: int
    channel_ids: frozenset[int]


class McapFile(NamedTuple):
    """An open, indexed MCAP file: its stream, chunk index and connections."""

    stream: BinaryIO
    chunks: list[McapChunk]
    connections: list[Connection]


def _storages(reader: Reader) -> list[Any] | None:
    """The storage files behind an open ``Reader``; None if messages are compressed one by one.
    """
    storage = reader.storage
    if isinstance(storage, DirectoryReader):
        if storage.metadata.compression_mode == 'message':
            return None
        return list(storage.storages)
    return [storage]


def custom_data(reader: Reader) -> dict[str, str]:
    """The bag's ``custom_data`` metadata (rosbag2 ≥ 6), empty if there is none."""
    return dict(reader.storage.metadata.custom or {})


def sqlite_files(reader: Reader) -> list[tuple[apsw.Connection, list[Connection]]] | None:
    """``(connection, topics)`` of every sqlite3 file of ``reader``, or None if any is not one.
    """
    files = _storages(reader)
    if not files or not all(isinstance(f, Sqlite3Reader) and f.dbconn for f in files):
        return None
    return [(f.dbconn, list(f.connections)) for f in files]


def mcap_files(reader: Reader) -> list[McapFile] | None:
    """Every indexed MCAP file of ``reader``, or None if any is not one (or not indexed)."""
    files = _storages(reader)
    if not files or not all(isinstance(f, McapReader) and f.chunks and f.bio for f in files):
        return None
    return [McapFile(f.bio, [McapChunk(chunk.chunk_start_offset, chunk.message_start_time,
                                       chunk.message_end_time, chunk.compression,
                                       chunk.compressed_size, chunk.uncompressed_size,
                                       frozenset(k for k, n in chunk.channel_count.items() if n))
                             for chunk in f.chunks], list(f.connections))
            for f in files]


#: What the code above uses of each unexported class (attributes read on instances are checked
#: by :func:`incompatibilities` on a bag it writes and reads).
_CLASS_ATTRIBUTES: dict[Any, tuple[str, ...]] = {
    Sqlite3Writer: ('SQLITE_SCHEMA', '__init__', 'add_msgtype', 'add_connection', 'close'),
    McapWriter: ('__init__', 'close_chunk', 'close', 'add_connection', 'add_msgtype'),
    Writer: ('STORAGE_PLUGINS', 'open', 'close', 'abort', 'add_connection', 'write',
             'set_custom_data'),
    PendingChunk: ('__init__',),
    Typestore: ('serialize_cdr', 'deserialize_cdr'),
}
_INSTANCE_ATTRIBUTES = {
    'Writer': ('counts', 'storage', 'min_timestamp', 'max_timestamp'),
    'McapWriter': ('bio', 'chunk', 'chunks', 'channel_stats', 'compressor', 'compression',
                   'message_start_time', 'message_end_time'),
    'PendingChunk': ('message_start_time', 'message_end_time', 'bio', 'msgs'),
    'Reader': ('storage',),
    'Reader.storage.metadata': ('custom', 'compression_mode'),
    'DirectoryReader': ('storages', 'metadata'),
    'Sqlite3Reader': ('dbconn', 'connections'),
    'McapReader': ('bio', 'chunks', 'connections'),
    'Typestore': ('fielddefs', 'types'),
    'ChunkInfo': ('chunk_start_offset', 'message_start_time', 'message_end_time',
                  'compression', 'compressed_size', 'uncompressed_size', 'channel_count'),
}


def _missing(where: str, instance: object, names: Sequence[str]) -> list[str]:
    return [f'{where}.{name}' for name in names if not hasattr(instance, name)]


def incompatibilities(folder: Path) -> list[str]:
    """What this module relies on and the installed ``rosbags`` lacks (empty if nothing).

    Writes and reads a small bag of each storage (one directory bag, one bare file) in
    ``folder`` to look at the instances' attributes. Each entry names the missing attribute.
    """
    found = [f'{cls.__name__}.{name}' for cls, names in _CLASS_ATTRIBUTES.items()
             for name in names if not hasattr(cls, name)]
    if found:
        return found
    typestore = get_typestore(Stores.ROS2_JAZZY)
    found += _missing('Typestore', typestore, _INSTANCE_ATTRIBUTES['Typestore'])
    for storage in (StoragePlugin.SQLITE3, StoragePlugin.MCAP):
        path = folder / f'probe_{storage.name.lower()}'
        writer = Rosbag2Writer(path, version=9, storage_plugin=storage)
        writer.open()
        connection = writer.add_connection('probe', 'std_msgs/msg/Float64', typestore=typestore)
        found += _missing('Writer', writer, _INSTANCE_ATTRIBUTES['Writer'])
        if isinstance(writer.storage, McapStorage):
            found += _missing('McapWriter', writer.storage, _INSTANCE_ATTRIBUTES['McapWriter'])
            found += _missing('PendingChunk', getattr(writer.storage, 'chunk', None),
                              _INSTANCE_ATTRIBUTES['PendingChunk'])
        writer.write(connection, 1, b'\x00\x01\x00\x00' + bytes(8))
        writer.close()
        found += _reader_incompatibilities(path)
    return sorted(set(found))


def _reader_incompatibilities(path: Path) -> list[str]:
    found: list[str] = []
    with Reader(path) as reader:
        found += _missing('Reader', reader, _INSTANCE_ATTRIBUTES['Reader'])
        storage = getattr(reader, 'storage', None)
        found += _missing('Reader.storage.metadata', getattr(storage, 'metadata', None),
                          _INSTANCE_ATTRIBUTES['Reader.storage.metadata'])
        if not isinstance(storage, DirectoryReader):
            return found + [f'Reader.storage is a {type(storage).__name__}, not the '
                            f'DirectoryReader expected for a bag directory']
        found += _missing('DirectoryReader', storage, _INSTANCE_ATTRIBUTES['DirectoryReader'])
        for file in getattr(storage, 'storages', []):
            name = type(file).__name__
            if name not in ('Sqlite3Reader', 'McapReader'):
                found.append(f'DirectoryReader.storages holds a {name}')
                continue
            found += _missing(name, file, _INSTANCE_ATTRIBUTES[name])
            for chunk in getattr(file, 'chunks', []) if name == 'McapReader' else []:
                found += _missing('ChunkInfo', chunk, _INSTANCE_ATTRIBUTES['ChunkInfo'])
    return found
