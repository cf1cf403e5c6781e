"""Ground truth: reading it from a bag, slerp between its samples, the attitude error of the
outputs against it, and starting the replay from it.

Quaternions are scalar-first ``(w, x, y, z)``, body → world
(:mod:`rigid_body_attitude.core.attitude.quaternion`); stamps are integer nanoseconds.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy.spatial.transform import Rotation, Slerp

from rigid_body_attitude.bag import BagError, BagReader
from rigid_body_attitude.core.attitude import quaternion
from rigid_body_attitude.core.errors import InputError
from rigid_body_attitude.core.propagator import DynamicsPropagator, GyroPropagator
from rigid_body_attitude.msgs import ATTITUDE_DECODERS, header_stamp_ns
from rigid_body_attitude.session.decoding import MALFORMED

__all__ = ['AlignmentError', 'ErrorStatistics', 'GroundTruth', 'GroundTruthStart',
           'attitude_errors', 'interpolate', 'read_ground_truth']

FloatArray = NDArray[np.float64]
StampArray = NDArray[np.int64]


@dataclass(frozen=True)
class GroundTruth:
    """A ground-truth topic: sorted header stamps [ns], unit attitudes (N, 4), and the count
    of malformed records skipped."""

    stamps_ns: StampArray
    attitudes: FloatArray
    malformed: int = 0


def read_ground_truth(reader: BagReader, topic: str) -> GroundTruth:
    """Header stamps (sorted) and unit attitudes of the ground-truth topic.

    Malformed records are skipped (counted); raises :class:`BagError` when no usable record
    is left or one holds a non-finite or zero quaternion.
    """
    decoder = reader.decoder(topic, ATTITUDE_DECODERS)
    stamps, attitudes, malformed = [], [], 0
    for _, _, _, data in reader.messages([topic]):
        try:
            stamp_ns, attitude = header_stamp_ns(data), decoder(data)[1]
        except MALFORMED:
            malformed += 1
            continue
        stamps.append(stamp_ns)
        attitudes.append(attitude)
    if not stamps:
        raise BagError(f'Ground-truth topic {topic!r} has no usable messages ({malformed} '
                       f'malformed)')
    stamp_array = np.array(stamps, dtype=np.int64)
    attitude_array = np.array(attitudes, dtype=np.float64)
    order = np.argsort(stamp_array, kind='stable')
    norms = np.linalg.norm(attitude_array, axis=1)
    if not np.all(np.isfinite(norms)) or np.any(norms == 0.0):
        raise BagError(f'Expected ground-truth topic {topic!r} to hold finite non-zero '
                       f'quaternions, got {int(np.sum(~(np.isfinite(norms) & (norms > 0))))} '
                       f'that are not')
    return GroundTruth(stamp_array[order], (attitude_array / norms[:, None])[order], malformed)


def interpolate(stamps_ns: StampArray, attitudes: FloatArray, at_ns: StampArray) -> FloatArray:
    """Attitudes at ``at_ns`` (within the sorted ``stamps_ns``) by slerp between the
    neighbouring samples (scipy's :class:`~scipy.spatial.transform.Slerp`); at a sample's own
    stamp, that sample unchanged (the first of equal stamps)."""
    sample_ns, first = np.unique(stamps_ns, return_index=True)
    samples = attitudes[first]
    nearest = np.clip(np.searchsorted(sample_ns, at_ns), 0, len(sample_ns) - 1)
    exact = sample_ns[nearest] == at_ns
    if len(sample_ns) == 1:
        return samples[nearest]
    # Only the samples around ``at_ns``: neighbours stay neighbours, and Slerp's set-up costs
    # per sample given.
    used = np.unique(np.concatenate([nearest, np.maximum(nearest - 1, 0)]))
    if len(used) == 1:
        used = np.array([0, 1])
    # Times relative to the first sample: float64 holds integer ns exactly up to 104 days.
    slerp = Slerp((sample_ns[used] - sample_ns[0]).astype(np.float64),
                  Rotation.from_quat(quaternion.to_ros(samples[used])))
    between = quaternion.from_ros(slerp((at_ns - sample_ns[0]).astype(np.float64)).as_quat())
    result: FloatArray = np.where(exact[:, None], samples[nearest], between)
    return result


@dataclass(frozen=True)
class ErrorStatistics:
    """Attitude error against the ground truth (see :func:`attitude_errors`).

    Attributes:
        stamps_ns: stamps compared [ns].
        errors: attitude error at each [rad]
            (:func:`~rigid_body_attitude.core.attitude.quaternion.attitude_error`).
    """

    stamps_ns: StampArray
    errors: FloatArray

    @property
    def count(self) -> int:
        """Ground-truth samples compared."""
        return int(self.errors.size)

    def within(self, start_ns: int, end_ns: int) -> ErrorStatistics:
        """The errors with stamps in ``[start_ns, end_ns]``."""
        mask = (self.stamps_ns >= start_ns) & (self.stamps_ns <= end_ns)
        return ErrorStatistics(self.stamps_ns[mask], self.errors[mask])

    def text(self) -> str:
        """One line: max (and when), mean, RMS and final error in degrees."""
        if not self.count:
            return 'no ground-truth sample within the replayed outputs'
        degrees = np.degrees(self.errors)
        worst = int(np.argmax(degrees))
        return (f'max {degrees[worst]:.4g} deg at stamp {self.stamps_ns[worst] * 1e-9:.3f} s, '
                f'mean {degrees.mean():.4g}, rms {math.sqrt(np.mean(degrees ** 2)):.4g}, '
                f'final {degrees[-1]:.4g} deg ({self.count} samples)')


def attitude_errors(output_stamps_ns: StampArray, output_attitudes: FloatArray,
                    truth_stamps_ns: StampArray, truth_attitudes: FloatArray
                    ) -> ErrorStatistics:
    """Error of the outputs against the ground truth where both are defined.

    Compared at the stamps of the sparser of the two series within their common time span,
    the denser one interpolated there (slerp between its neighbouring samples; an equal stamp
    is used directly), so a 50 Hz output is not blamed for interpolating a 1 kHz truth.
    """
    empty = ErrorStatistics(np.zeros(0, dtype=np.int64), np.zeros(0))
    if output_stamps_ns.size == 0 or truth_stamps_ns.size == 0:
        return empty
    order = np.argsort(output_stamps_ns, kind='stable')
    stamps, attitudes = output_stamps_ns[order], output_attitudes[order]
    start = max(stamps[0], truth_stamps_ns[0])
    end = min(stamps[-1], truth_stamps_ns[-1])
    truth_inside = (truth_stamps_ns >= start) & (truth_stamps_ns <= end)
    outputs_inside = (stamps >= start) & (stamps <= end)
    if not truth_inside.any() or not outputs_inside.any():
        return empty
    if truth_inside.sum() <= outputs_inside.sum():
        at = truth_stamps_ns[truth_inside]
        estimated = interpolate(stamps, attitudes, at)
        truth = truth_attitudes[truth_inside]
    else:
        at = stamps[outputs_inside]
        estimated = attitudes[outputs_inside]
        truth = interpolate(truth_stamps_ns, truth_attitudes, at)
    errors = quaternion.attitude_error(estimated, truth)
    return ErrorStatistics(at, np.atleast_1d(np.asarray(errors, dtype=np.float64)))


class AlignmentError(InputError):
    """The ground truth does not cover the output the attitude was to start from."""


class GroundTruthStart:
    """Sets the attitude from the ground truth at the first output at or after a stamp."""

    def __init__(self, truth: GroundTruth, stamp_ns: int) -> None:
        """Start from ``truth`` at the first output stamped at or after ``stamp_ns``."""
        self.truth = truth
        self.stamp_ns = stamp_ns
        #: The output stamp where the attitude was set [ns], once it was.
        self.aligned_at_ns: int | None = None

    def due(self, output_ns: int) -> bool:
        """Whether the output stamped ``output_ns`` is the one to start from."""
        return self.aligned_at_ns is None and output_ns >= self.stamp_ns

    def apply(self, propagator: DynamicsPropagator | GyroPropagator, output_ns: int) -> None:
        """Set the propagator's attitude to the ground truth at ``output_ns`` (slerp).

        Gyro propagators start a new group (``set_attitude`` resets the method), so methods
        that group samples do not finish their group from the attitude they remembered.
        Raises :class:`AlignmentError` when the ground truth does not cover ``output_ns``.
        """
        stamps = self.truth.stamps_ns
        if not stamps[0] <= output_ns <= stamps[-1]:
            raise AlignmentError(
                f'Expected ground truth at stamp {output_ns * 1e-9:.9f} s to start from, but '
                f'it covers [{stamps[0] * 1e-9:.9f}, {stamps[-1] * 1e-9:.9f}] s')
        attitude = interpolate(stamps, self.truth.attitudes,
                               np.array([output_ns], dtype=np.int64))[0]
        propagator.set_attitude(attitude)
        self.aligned_at_ns = output_ns
