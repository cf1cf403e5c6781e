"""The error type of the rosbag2 layer.

Errors raised by the ``rosbags`` library (``ReaderError``, ``WriterError``, ``SerdeError``,
``FileNotFoundError``) are translated into :class:`BagError` at this package's boundary, so a
caller catches one type (or :class:`~rigid_body_attitude.core.errors.AttitudeError`) for every bad
bag, topic or message. A message whose bytes cannot be decoded raises
:class:`~rigid_body_attitude.msgs.errors.MalformedMessage` from the codecs; :func:`read_series`
turns it into a :class:`BagError` naming the bag and topic.
"""

from __future__ import annotations

from rigid_body_attitude.core.errors import AttitudeError

__all__ = ['BagError']


class BagError(AttitudeError):
    """A bag cannot be opened or written, lacks a topic, or holds a message we cannot decode."""
