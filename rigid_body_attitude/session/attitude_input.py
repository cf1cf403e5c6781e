"""A filtered gyro session's ``attitude_measurement`` input: checked, fused in stamp order.

An attitude measurement (a star tracker, motion capture: ``PoseWithCovarianceStamped`` in
``world_frame``) stamped ``s`` is fused at the gyro state of the last sample stamped at or
before ``s``:

* at once when the state is stamped ``s`` (or later: the gyro ran ahead of it, which is
  counted as ``attitude_late`` in the filter's updates, and the measurement is paired with
  the newer state);
* otherwise held until the next gyro sample stamped after ``s`` arrives, and fused just
  before that sample is integrated.

Either way a measurement changes no output stamped at or before its own stamp, and the
outputs stamped after it carry it, whatever the order in which a measurement and a gyro
sample of the same stamp arrive: the estimate a lockstep controller reads for tick ``t_k``
holds the measurements stamped before ``t_k`` (the one stamped ``t_k`` reaches the estimate
of the next sample), so two runs of a loop fuse the same measurements into the same outputs.
The measurement is paired with the propagated attitude at its stamp when its stamp is a gyro
sample's (the world-axis error ``log(q_true ⊗ q_est*)`` does not change over a step both
attitudes take with the same rate); between two samples it is paired with the earlier one.

With ``estimation: {start: attitude_measurement}`` the filter starts at the first accepted
measurement: its attitude and its covariance (the attitude block; the gyro states keep their
prior) at its stamp, which is the gyro stream's first instant (:meth:`GyroStream.start_at
<rigid_body_attitude.session.stream.GyroStream.start_at>`), and the start is published at
that stamp with a zero body rate (no gyro sample yet). Gyro samples before it are refused
(``awaiting_attitude``).

Refusals (counted ``attitude_measurement_<reason>``): ``stale_stamp`` (a stamp not newer than
the last accepted measurement's: a lockstep plant repeating its first tick resends its
samples), ``stale_measurement`` (further than ``max_dt`` from the latest gyro sample),
``queue_full`` (more than :data:`MEASUREMENT_QUEUE` held for a stalled gyro: the oldest is
dropped), besides the message checks of the session.
"""

from __future__ import annotations

from collections import deque
from rigid_body_attitude.session.levelling import FROM_SCENE, AlignmentResult

__all__ = ['ATTITUDE_START_STATUS', 'AttitudeMeasurements', 'MEASUREMENT_QUEUE', 'start_result']

Quat = tuple[float, float, float, float]
#: Measurements held for a gyro that has not reached their stamps.
MEASUREMENT_QUEUE = 64
#: The alignment status of a filter started from an attitude measurement.
ATTITUDE_START_STATUS = 'started from the first attitude_measurement'


class AttitudeMeasurements:
    """The held measurements and the last accepted stamp of one session (module docstring).
    """

    def __init__(self) -> None:
        """None held, none accepted."""
        self.held: deque[tuple[int, Quat, tuple[float, ...]]] = deque()
        self.last_ns: int | None = None

    def restart(self) -> None:
        """Forget the held measurements and the last stamp (reset, a jump back)."""
        self.held.clear()
        self.last_ns = None

    def accept(self, stamp_ns: int) -> str:
        """``''`` when a measurement stamped ``stamp_ns`` is newer than the last accepted
        (it becomes the last), else ``'stale_stamp'``."""
        if self.last_ns is not None and stamp_ns <= self.last_ns:
            return 'stale_stamp'
        self.last_ns = stamp_ns
        return ''

    def hold(self, stamp_ns: int, q: Quat, block: tuple[float, ...]) -> bool:
        """Hold a measurement until the gyro passes its stamp; True when the queue was full
        (the oldest dropped)."""
        held = self.held
        held.append((stamp_ns, q, block))
        if len(held) > MEASUREMENT_QUEUE:
            held.popleft()
            return True
        return False

    def due(self, sample_ns: int) -> list[tuple[Quat, tuple[float, ...]]]:
        """The held measurements stamped before a gyro sample stamped ``sample_ns``, oldest
        first (removed from the queue)."""
        held = self.held
        due = []
        while held and held[0][0] < sample_ns:
            _, q, block = held.popleft()
            due.append((q, block))
        return due


def start_result(q: Quat) -> AlignmentResult:
    """The start of a filter from an attitude measurement ``q`` (w, x, y, z)."""
    return AlignmentResult(attitude=q, gyro_bias=(0.0, 0.0, 0.0), window_seconds=0.0,
                           at_rest=False, source=FROM_SCENE, status=ATTITUDE_START_STATUS)
