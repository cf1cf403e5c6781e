"""Strings from the network made safe to quote: a short prefix, every non-printable escaped.

A ``frame_id`` or ``child_frame_id`` is whatever a peer sent: megabytes long, control
characters, terminal escape sequences. :func:`quoted` is the one way such a string reaches a
log line, a diagnostic value or a printed note: at most :data:`QUOTED_CHARACTERS` characters of
it, in Python's ``repr`` form (quotes added, non-printable characters escaped as ``\\x..``,
``\\u....``), and the length of what was cut.
"""

from __future__ import annotations

__all__ = ['QUOTED_CHARACTERS', 'quoted']

#: Characters of an untrusted string quoted (REP-105 frame names are far shorter).
QUOTED_CHARACTERS = 64


def quoted(text: str, limit: int = QUOTED_CHARACTERS) -> str:
    """``text`` cut to ``limit`` characters, as ``repr`` writes it (``'imu_link'``); a longer
    one ends with how many characters it has (``'aaa…'... (4194304 characters)``)."""
    if len(text) <= limit:
        return repr(text)
    return f'{text[:limit]!r}... ({len(text)} characters)'
