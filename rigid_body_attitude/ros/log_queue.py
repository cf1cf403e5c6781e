"""Log lines handed to rclpy's logger by a thread of their own, never by the gyro path.

rcutils writes each console line synchronously to stderr (stdout with
``RCUTILS_LOGGING_USE_STDOUT=1``). When that is a pipe read slowly (a launcher or supervisor
that falls behind), the write blocks until the reader makes room; a node logging from its
gyro path, under its state lock, would stop integrating meanwhile. The node hands its lines to
a :class:`LogQueue` instead: :meth:`LogQueue.put` never blocks (a full queue drops the line and
counts it), and the queue's thread hands them to the logger (each severity from a call site
of its own: rclpy refuses a call site whose severity changes), each only once the stream has
room for a line (it waits with ``select``, which releases the GIL: the rest of the process
runs on), and says how many were dropped.
"""

from __future__ import annotations

import os
import queue
import select
import sys
import threading
from typing import Any

__all__ = ['ERROR', 'INFO', 'LOG_QUEUE_SIZE', 'LogQueue', 'WARN']

#: Lines waiting to be written; more are dropped and counted.
LOG_QUEUE_SIZE = 1000

#: A line is written only when the stream has room for this many bytes (a pipe with at least
#: PIPE_BUF = 4 096 free bytes takes a write of that size without blocking).
_LINE_ROOM = 4096

#: Severities of :meth:`LogQueue.put`.
INFO, WARN, ERROR = 0, 1, 2


def _console_fd() -> int | None:
    """The file descriptor rcutils writes console lines to, or None if there is none."""
    stream = sys.stdout if os.environ.get('RCUTILS_LOGGING_USE_STDOUT') == '1' else sys.stderr
    try:
        return stream.fileno() if stream is not None else None
    except (AttributeError, OSError, ValueError):
        return None


class LogQueue:
    """A bounded queue of ``(severity, text)`` drained into ``logger`` by a daemon thread
    (:meth:`start`)."""

    def __init__(self, logger: Any, size: int = LOG_QUEUE_SIZE) -> None:
        """An empty queue of ``size`` lines for ``logger`` (an rclpy logger); not started."""
        self.logger = logger
        self._queue: queue.Queue[tuple[int, str] | None] = queue.Queue(size)
        self._fd = _console_fd()
        self._dropped = 0
        self._lock = threading.Lock()
        self._thread = threading.Thread(target=self._drain, name='log', daemon=True)
        #: Lines dropped so far because the queue was full.
        self.dropped_total = 0

    def start(self) -> None:
        """Start the thread that writes the lines."""
        self._thread.start()

    def put(self, severity: int, text: str) -> None:
        """Queue ``text`` at ``severity`` (:data:`INFO`, :data:`WARN`, :data:`ERROR`); never
        blocks (a full queue drops and counts the line)."""
        try:
            self._queue.put_nowait((severity, text))
        except queue.Full:
            with self._lock:
                self._dropped += 1
                self.dropped_total += 1

    def stop(self, timeout_s: float = 1.0) -> None:
        """Write what is queued (for at most ``timeout_s`` seconds) and end the thread."""
        if self._thread.ident is None:
            return
        try:
            self._queue.put(None, timeout=timeout_s)
        except queue.Full:
            return
        self._thread.join(timeout_s)

    def _drain(self) -> None:
        """Thread body: write each line once the stream has room for it."""
        while True:
            item = self._queue.get()
            if item is None:
                return
            severity, text = item
            self._wait_for_room()
            with self._lock:
                dropped, self._dropped = self._dropped, 0
            if dropped:
                self.logger.warning(f'{dropped} log lines dropped: the log output is read too '
                                    f'slowly')
                self._wait_for_room()
            if severity >= ERROR:
                self.logger.error(text)
            elif severity == WARN:
                self.logger.warning(text)
            else:
                self.logger.info(text)

    def _wait_for_room(self) -> None:
        """Wait until the console stream takes a line without blocking (pipes; a file or a
        terminal always takes it)."""
        if self._fd is None:
            return
        try:
            while not select.select([], [self._fd], [], 1.0)[1]:
                pass
        except (OSError, ValueError):
            self._fd = None
