"""``replay``: run a rosbag2 bag through the propagation node's session, offline, into a new bag.

``replay BAG [-o OUT] [--scene NAME|FILE] [--ground-truth TOPIC] [--csv FILE] ...`` reads a
bag (sqlite3 or MCAP, through :mod:`rigid_body_attitude.bag`; no ROS install needed), decodes
its gyro, command and ``set_pose`` messages with the node's decoders and feeds them to the
node's own session (:mod:`rigid_body_attitude.session`: time rules, counting, fault handling,
outputs), on the bag's time axis; the session's outputs are written to an output bag with the
node's topics, types and stamps. A replayed bag and the live node give the same numbers by
construction: only where messages come from and where outputs go differ. It prints what it
read, used and rejected, the final attitude and the drift of energy and momentum; with
``--ground-truth`` also the attitude error (statistics and a PNG).

Modules: :mod:`~.options` (options, derived from the node's parameter table), :mod:`~.plan`
(topics), :mod:`~.sink` (the session's output sink: records in the bag), :mod:`~.loop` (the
event loop: ticks, diagnostics, messages on bag time), :mod:`~.run` (:func:`replay_bag`),
:mod:`~.truth` (ground truth, slerp, error statistics), :mod:`~.report` (summary, CSV, plot),
:mod:`~.cli` (the command line). The output bag keeps the input bag's ``custom_data`` (e.g. a
dataset's citation and licence) and adds the replay settings.
"""

from rigid_body_attitude.tools.replay.cli import main
from rigid_body_attitude.tools.replay.options import ReplayOptions
from rigid_body_attitude.tools.replay.report import (
    summary, write_csv, write_error_csv, write_plot)
from rigid_body_attitude.tools.replay.run import ReplayResult, replay_bag
from rigid_body_attitude.tools.replay.sink import OutputSeries
from rigid_body_attitude.tools.replay.truth import ErrorStatistics, attitude_errors

__all__ = ['ErrorStatistics', 'OutputSeries', 'ReplayOptions', 'ReplayResult',
           'attitude_errors', 'main', 'replay_bag', 'summary', 'write_csv', 'write_error_csv',
           'write_plot']
