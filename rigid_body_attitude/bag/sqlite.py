"""Fast message iteration over sqlite3 bags opened by ``rosbags``.

``rosbags``' sqlite3 reader runs one query over the selected topics and wraps every row in a
generator that maps the topic id to a ``Connection`` (our reader then builds the
``(topic, time, msgtype, data)`` tuple in a second generator): about 1 µs per message. Here the
same query (same tables, join, filter and ``ORDER BY timestamp``, so the same plan and the
same order of equal times) selects the topic name and type itself, so ``apsw`` returns the
finished tuples and no Python code runs per message.

:func:`fast_messages` returns ``None`` for what it does not handle (per-message compression,
another storage plugin); the caller then uses ``rosbags``' own iterator. ``test/bag/test_bag.py``
checks that both give identical sequences, ties included.
"""

from __future__ import annotations

from collections.abc import Collection, Iterator
from itertools import chain
from typing import Any

import apsw
from rosbags.interfaces import Connection
from rosbags.rosbag2 import Reader

from rigid_body_attitude.bag.rosbags_internals import sqlite_files

__all__ = ['fast_messages']

Message = tuple[str, int, str, bytes]

#: ``rosbags``' query (``Sqlite3Reader.messages``) with the name and type selected.
_QUERY = ('SELECT topics.name,messages.timestamp,topics.type,messages.data FROM messages JOIN '
          'topics ON messages.topic_id=topics.id WHERE topics.id IN ({}) ORDER BY timestamp')


def fast_messages(reader: Reader, connections: Collection[Connection]
                  ) -> Iterator[Message] | None:
    """``(topic, time_ns, msgtype, data)`` of ``connections``, or None if not applicable.

    ``reader`` is an open ``rosbags.rosbag2.Reader``.
    """
    files = sqlite_files(reader)
    if files is None:
        return None
    return chain.from_iterable(_file_messages(connection, topics, connections)
                               for connection, topics in files)


def _file_messages(connection: apsw.Connection, topics: list[Connection],
                   connections: Collection[Connection]) -> Iterator[Any]:
    """One file's messages in time order (files follow one another, as in ``rosbags``)."""
    selected = {(c.topic, c.msgtype) for c in connections}
    ids = sorted({c.id for c in topics if (c.topic, c.msgtype) in selected})
    if not ids:
        return iter(())
    return iter(connection.execute(_QUERY.format(','.join('?' * len(ids))), ids))
