"""Fast message iteration over indexed MCAP files opened by ``rosbags``.

``rosbags``' MCAP reader builds a ``BytesIO`` and a named tuple per message and merges chunks
through ``heapq`` (about 4 µs per message); Jazzy records MCAP by default, and the replay tool
needs ≥ 10⁵ messages/s end to end. This module reuses what ``rosbags`` already parsed when it
opened the file (channels and the chunk index from the summary section) and its chunk
``decompress`` (none, zstd, lz4; CRC checked), and walks the decompressed message records with
``struct.unpack_from``.

Same output as ``rosbags``: messages in log-time order, ties in file order, only the chunks of
the index. Chunks that overlap in time are merged by a stable sort. :func:`fast_messages`
returns ``None`` for what it does not handle (an unindexed file, per-message compression,
another storage plugin); the caller then uses ``rosbags``' own iterator. ``test/bag/test_bag.py``
checks that both give identical sequences, with and without overlapping chunks.

MCAP record framing (https://mcap.dev/spec): ``opcode u8, length u64, content``. Chunk (0x06):
``start u64, end u64, uncompressed_size u64, crc u32, compression (u32 length + bytes),
compressed_size u64, records``. Message (0x05): ``channel_id u16, sequence u32,
log_time u64, publish_time u64, data``.
"""

from __future__ import annotations

import struct
from collections.abc import Collection, Iterator
from itertools import chain, repeat
from operator import itemgetter

from rosbags.interfaces import Connection
from rosbags.rosbag2 import Reader

from rigid_body_attitude.bag.rosbags_internals import McapChunk, McapFile, decompress, mcap_files

__all__ = ['fast_messages']

_RECORD = struct.Struct('<BQ')
_MESSAGE = struct.Struct('<H4xQ')
_CHUNK_CRC_AT = 9 + 24          # opcode + length, then start, end, uncompressed size
_CHUNK_COMPRESSION_AT = 9 + 28  # ... then the crc
_MESSAGE_OPCODE = 0x05
_MESSAGE_HEADER = 22            # channel, sequence, log time, publish time

Message = tuple[str, int, str, bytes]


def fast_messages(reader: Reader, connections: Collection[Connection]
                  ) -> Iterator[Message] | None:
    """``(topic, log_time_ns, msgtype, data)`` of ``connections``, or None if not applicable.

    ``reader`` is an open ``rosbags.rosbag2.Reader``.
    """
    files = mcap_files(reader)
    if files is None:
        return None
    return _iterate(files, connections)


def _iterate(files: list[McapFile], connections: Collection[Connection]) -> Iterator[Message]:
    """Files one after the other (as rosbags does), each in log-time order.

    Messages come from per-chunk lists chained at C level (no Python code per message).
    """
    return chain.from_iterable(_group_messages(file, group, wanted)
                               for file, wanted, groups in map(_plan, files, repeat(connections))
                               for group in groups)


def _plan(file: McapFile, connections: Collection[Connection]
          ) -> tuple[McapFile, dict[int, tuple[str, str]], list[list[McapChunk]]]:
    """The file's wanted channels and its chunks holding them, grouped disjoint in time."""
    wanted = {channel.id: (selected.topic, selected.msgtype)
              for channel in file.connections for selected in connections
              if channel.topic == selected.topic and channel.msgtype == selected.msgtype}
    chunks = [chunk for chunk in file.chunks if not chunk.channel_ids.isdisjoint(wanted)]
    return file, wanted, _time_groups(chunks)


def _group_messages(file: McapFile, group: list[McapChunk],
                    wanted: dict[int, tuple[str, str]]) -> list[Message]:
    """The messages of chunks overlapping in time, merged by a stable sort."""
    if len(group) == 1:
        return _chunk_messages(file, group[0], wanted)
    merged: list[Message] = []
    for chunk in sorted(group, key=lambda chunk: chunk.start_offset):
        merged.extend(_chunk_messages(file, chunk, wanted))
    merged.sort(key=itemgetter(1))  # stable: ties in file order, as rosbags' merge
    return merged


def _time_groups(chunks: list[McapChunk]) -> list[list[McapChunk]]:
    """Chunks grouped so that groups are disjoint in time (touching chunks share a group)."""
    groups: list[list[McapChunk]] = []
    group_end = -1
    for chunk in sorted(chunks, key=lambda chunk: (chunk.message_start_time,
                                                   chunk.start_offset)):
        if groups and chunk.message_start_time <= group_end:
            groups[-1].append(chunk)
            group_end = max(group_end, chunk.message_end_time)
        else:
            groups.append([chunk])
            group_end = chunk.message_end_time
    return groups


def _chunk_messages(file: McapFile, chunk: McapChunk,
                    wanted: dict[int, tuple[str, str]]) -> list[Message]:
    raw = _chunk_records(file, chunk)
    messages = []
    unpack_record = _RECORD.unpack_from
    unpack_message = _MESSAGE.unpack_from
    position, end, previous, ordered = 0, len(raw), -1, True
    while position < end:
        opcode, length = unpack_record(raw, position)
        body = position + 9
        if opcode == _MESSAGE_OPCODE:
            channel_id, log_time = unpack_message(raw, body)
            names = wanted.get(channel_id)
            if names is not None:
                messages.append((names[0], log_time, names[1],
                                 raw[body + _MESSAGE_HEADER:body + length]))
                ordered = ordered and log_time >= previous
                previous = log_time
        position = body + length
    if not ordered:
        messages.sort(key=itemgetter(1))  # stable: ties keep file order, as rosbags does
    return messages


def _chunk_records(file: McapFile, chunk: McapChunk) -> bytes:
    """The decompressed, CRC-checked records of one chunk."""
    stream = file.stream
    stream.seek(chunk.start_offset + _CHUNK_CRC_AT)
    (crc,) = struct.unpack('<I', stream.read(4))
    stream.seek(chunk.start_offset + _CHUNK_COMPRESSION_AT + 4 + len(chunk.compression) + 8)
    compressed = stream.read(chunk.compressed_size)
    return decompress(compressed, chunk.compression, chunk.uncompressed_size, crc)
