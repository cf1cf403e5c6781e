"""The storage files behind an open ``rosbags.rosbag2.Reader``, for the fast read paths."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from rosbags.rosbag2.reader import DirectoryReader

__all__ = ['storage_files']


def storage_files(storage: Any, usable: Callable[[Any], bool]) -> list[Any] | None:
    """The storage files of ``storage`` (a Reader's ``storage`` attribute) if all are usable.

    None when the bag compresses each message on its own, has no files, or a file fails
    ``usable``: the caller then falls back to rosbags' own iterator.
    """
    if isinstance(storage, DirectoryReader):
        if storage.metadata.compression_mode == 'message':
            return None
        files = list(storage.storages)
    else:
        files = [storage]
    if not files or not all(usable(file) for file in files):
        return None
    return files
