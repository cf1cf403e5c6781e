"""What every command-line entry point shares: a reader that closes the pipe early.

``propagation_node --help | head`` closes standard output after a few lines; the next write
raises :class:`BrokenPipeError`, and Python would print a traceback (and again, at exit, while
flushing). :func:`closed_pipe_safe` wraps a ``main`` so that the command ends quietly with the
status of a process stopped by ``SIGPIPE``, as ``yes | head`` does.
"""

from __future__ import annotations

from collections.abc import Callable
import functools
import os
import sys
from typing import ParamSpec

__all__ = ['CLOSED_PIPE_STATUS', 'closed_pipe_safe']

#: 128 + SIGPIPE: the status a shell reports for a writer whose reader went away.
CLOSED_PIPE_STATUS = 141

_P = ParamSpec('_P')


def closed_pipe_safe(main: Callable[_P, int]) -> Callable[_P, int]:
    """``main`` that returns :data:`CLOSED_PIPE_STATUS` when its output pipe is closed."""
    @functools.wraps(main)
    def guarded(*args: _P.args, **kwargs: _P.kwargs) -> int:
        try:
            return main(*args, **kwargs)
        except BrokenPipeError:
            # Nothing more can reach the reader; point stdout at /dev/null so that the flush
            # at interpreter exit does not raise again.
            devnull = os.open(os.devnull, os.O_WRONLY)
            os.dup2(devnull, sys.stdout.fileno())
            os.close(devnull)
            return CLOSED_PIPE_STATUS
    return guarded
