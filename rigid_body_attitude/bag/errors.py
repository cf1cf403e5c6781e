"""Error types of the rosbag2 layer.

Errors raised by the ``rosbags`` library (``ReaderError``, ``WriterError``, ``SerdeError``,
``FileNotFoundError``) are translated into :class:`BagError` at this package's boundary, so a
caller catches one type (or :class:`~rigid_body_attitude.core.errors.AttitudeError`) for every bad
bag, topic or message. A message whose bytes cannot be decoded raises
:class:`MalformedMessage`, a :class:`BagError` and an
:class:`~rigid_body_attitude.core.errors.InputError` at once: bag readers catch the first, the
node's input handling the second.
"""

from __future__ import annotations

from rigid_body_attitude.core.errors import AttitudeError, InputError

__all__ = ['BagError', 'MalformedMessage']


class BagError(AttitudeError):
    """A bag cannot be opened or written, lacks a topic, or holds a message we cannot decode."""


class MalformedMessage(BagError, InputError):
    """Bytes that are not a CDR-encoded message of the expected type.

    ``reason`` is a short text of bounded length (it never quotes the message's contents),
    e.g. ``'truncated: 20 of 316 bytes'``, ``'bad encapsulation 0x0105'``,
    ``'frame_id length 4294967295 exceeds message (44 bytes)'``; ``msgtype`` the type that
    was expected. ``str(error)`` is ``'malformed <msgtype>: <reason>'``.
    """

    def __init__(self, msgtype: str, reason: str) -> None:
        """Record the expected type and the reason."""
        super().__init__(f'malformed {msgtype}: {reason}')
        self.msgtype = msgtype
        self.reason = reason
