"""rosbag2 input/output (through the pure-Python ``rosbags`` library; no ROS install needed).

* :mod:`~rigid_body_attitude.bag.reader`: :class:`BagReader`, :func:`read_messages` (raw CDR
  tuples in bag-time order) and :func:`read_series` (a topic as arrays); indexed MCAP files
  are walked by :mod:`~rigid_body_attitude.bag.mcap`.
* :mod:`~rigid_body_attitude.bag.writer`: :class:`BagWriter` for output bags (one record or
  a batch of :data:`Record` per call) and :func:`write_bag` for arrays of samples.
* :mod:`~rigid_body_attitude.bag.serde`: the Jazzy type store and the generic (slow)
  serialisation of any message type.

The records' bytes are read and written with the codecs of :mod:`rigid_body_attitude.msgs`.
"""

from rigid_body_attitude.bag.errors import BagError
from rigid_body_attitude.bag.reader import (
    SERIES_DECODERS,
    BagMessage,
    BagReader,
    Series,
    read_messages,
    read_series,
)
from rigid_body_attitude.bag.serde import deserialize, serialize, typestore
from rigid_body_attitude.bag.writer import (
    GROUND_TRUTH_TYPES,
    STORAGES,
    BagWriter,
    Record,
    write_bag,
)

__all__ = [
    'GROUND_TRUTH_TYPES',
    'SERIES_DECODERS',
    'STORAGES',
    'BagError',
    'BagMessage',
    'BagReader',
    'BagWriter',
    'Record',
    'Series',
    'deserialize',
    'read_messages',
    'read_series',
    'serialize',
    'typestore',
    'write_bag',
]
