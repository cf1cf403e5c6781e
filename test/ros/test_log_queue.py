"""The log queue: lines reach the logger in order from its thread; a full queue drops and
counts instead of blocking."""

from __future__ import annotations

import threading

from rigid_body_attitude.ros.log_queue import ERROR, INFO, LogQueue, WARN


class Recorder:
    """A logger that records (severity, text, thread) and can be held up."""

    def __init__(self) -> None:
        """Nothing recorded; not held."""
        self.lines: list[tuple[str, str, str]] = []
        self.release = threading.Event()
        self.release.set()

    def _record(self, severity: str, text: str) -> None:
        self.release.wait(10.0)
        self.lines.append((severity, text, threading.current_thread().name))

    def info(self, text: str) -> None:
        self._record('info', text)

    def warning(self, text: str) -> None:
        self._record('warning', text)

    def error(self, text: str) -> None:
        self._record('error', text)


def test_lines_reach_the_logger_in_order_from_the_log_thread():
    logger = Recorder()
    log = LogQueue(logger)
    log.start()
    for severity, text in ((INFO, 'a'), (WARN, 'b'), (ERROR, 'c')):
        log.put(severity, text)
    log.stop()
    assert logger.lines == [('info', 'a', 'log'), ('warning', 'b', 'log'),
                            ('error', 'c', 'log')]


def test_a_full_queue_drops_and_counts_and_never_blocks():
    """A logger stuck (a console nobody reads): put() returns at once; beyond the queue's
    size lines are dropped, counted, and the count is logged once the logger moves again."""
    logger = Recorder()
    logger.release.clear()
    log = LogQueue(logger, size=10)
    log.start()
    for k in range(100):
        log.put(INFO, str(k))
    assert 89 <= log.dropped_total <= 90  # the thread may have taken one line already
    logger.release.set()
    log.stop(5.0)
    dropped = [text for _, text, _ in logger.lines if 'log lines dropped' in text]
    assert dropped == [f'{log.dropped_total} log lines dropped: the log output is read too '
                       f'slowly']
    assert len(logger.lines) == 100 - log.dropped_total + 1
