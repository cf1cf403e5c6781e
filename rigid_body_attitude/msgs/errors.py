"""The error of bytes that are not a message of the expected type."""

from __future__ import annotations

from rigid_body_attitude.core.errors import InputError

__all__ = ['MalformedMessage']


class MalformedMessage(InputError):
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
