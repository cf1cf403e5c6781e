"""The sample period of a gyro stream and the samples missed upstream, from its header stamps.

A driver samples at a steady period ``P`` and stamps sample ``k`` at ``t_k = t_0 + k P + e_k``,
``e_k`` the stamp jitter (a driver that stamps on reception on a loaded machine). A sample
lost before the node leaves its index out, so the samples missed between two received ones
are their index difference less one. Counting against the expected index holds while the
jitter stays below half a period; counting from the step between two stamps cannot: at a
jitter of ±40 % of the period a lossless step lies anywhere in [0.2, 1.8] periods and a step
over one lost sample in [1.2, 2.8].

**The coarse period** (:class:`PeriodLearner`): the integrated steps are taken in batches of
:data:`PERIOD_BATCH`. Each batch's median step is the coarse period (robust to drops: fewer
than half the steps are gaps); the period is the mean of the steps below 1.9 medians (stamp
jitter telescopes out of a mean). A batch whose halves disagree on the median by more than
:data:`RATE_CHANGE`, or whose period differs from the last by as much (the driver restarted
at another rate), re-learns the period and drops its own and the last batch's counts: the
period always comes from the latest steps, so it can never stay locked on a wrong value.

**The sample lattice** (:class:`SampleLattice`): the stamps of the first batches are held
(at most :data:`MAX_WINDOW`) until their lattice ``t_0 + k P`` is found: the strongest line
of the stamps' spectrum within :data:`PERIOD_SEARCH` of the coarse period (a histogram of the
stamps, its FFT; a lost sample removes a term but moves no other, so drops do not blur it),
taken when its strength ``|Σ exp(2πi t/P)| / √n`` reaches :data:`LOCK_SCORE` (far above
the ~1 of stamps without a period: at ±40 % jitter about 460 stamps, exact stamps at once),
then refined by least squares of the stamps on their indices. The held stamps are then
counted, and each later batch is counted against the lattice, which follows the stream (an
α-β tracker of its phase and period, :data:`PHASE_GAIN`, :data:`PERIOD_GAIN`). A batch in
which more than one stamp in :data:`COLLISIONS` falls on an index already taken, or whose
mean residual exceeds a quarter period, loses the lattice (a lattice with as many is not
taken): it is found again from the next stamps. Until a lattice is found (and when none is
found within :data:`MAX_WINDOW` stamps: a jitter of half a period or more), each step of
``s`` mean steps of the held stamps counts ``floor(s − 2)`` at once, a lower bound: a burst
shows before the lattice is found, and the held stamps then add what the lattice finds
beyond it. Samples the node received and refused (any rejection of a sample with a stamp)
are subtracted: they were not lost. A full batch's count is confirmed by the next
batch's period. A break in the stamps' time line (a confirmed forward gap, a time jump back,
a reset, a pause) ends the lattice; a forward gap counts ``round(s) − 1`` at once.
Measured in ``test/session/test_missed_samples.py``.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

__all__ = ['BURST_SAMPLES', 'COLLISIONS', 'LOCK_SCORE', 'MAX_WINDOW', 'PERIOD_BATCH',
           'PERIOD_SEARCH', 'PeriodLearner', 'RATE_CHANGE', 'SampleLattice']

#: Integrated steps per batch of :class:`PeriodLearner` (the period and the missed samples
#: are settled once per batch: a sort of 64 integers every 64 samples).
PERIOD_BATCH = 64
#: Relative difference of two medians taken for a change of the sample rate.
RATE_CHANGE = 0.25
#: Gaps of at least this many samples are reported as bursts (a queue or a driver stall).
BURST_SAMPLES = 4
#: Strength of the spectral line ``|Σ exp(2πi t/P)| / √n`` that finds the lattice (stamps
#: without a period give about 1, with a chance of ``exp(−25)`` per line to reach 5).
LOCK_SCORE = 5.0
#: Most stamps held while the lattice is searched for.
MAX_WINDOW = 4096
#: Relative range around the coarse period searched for the lattice's period.
PERIOD_SEARCH = 0.08
#: Histogram bins per coarse period, and the spectrum's oversampling.
_BINS_PER_PERIOD, _OVERSAMPLING = 16, 4
#: Gains of the lattice's phase and period per batch (an α-β tracker, critically damped:
#: β = α² / (2 − α)).
PHASE_GAIN = 0.1
PERIOD_GAIN = PHASE_GAIN ** 2 / (2.0 - PHASE_GAIN)
#: Stamps per stamp on an index already taken beyond which the lattice is refused or lost.
COLLISIONS = 16
#: Factor by which the largest residual seen fades per batch.
JITTER_MEMORY = 0.98

#: (missed samples, gaps, the largest gap).
Counts = tuple[int, int, int]


def _jump_counts(jumps: Sequence[int]) -> Counts:
    """The missed samples, gaps and largest gap of index differences ``jumps``."""
    missed = gaps = largest = 0
    for jump in jumps:
        if jump > 1:
            missed += jump - 1
            gaps += 1
            largest = max(largest, jump - 1)
    return missed, gaps, largest


class SampleLattice:
    """The expected stamps ``t_ref + offset + k·period`` [ns] of a stream's samples, ``k`` the
    sample index counted from the last sample seen (module docstring)."""

    def __init__(self) -> None:
        self.locked = False
        self.period = 0.0
        self.t_ref = 0
        self.offset = 0.0
        #: The largest stamp residual seen, as a fraction of the period (fading per batch).
        self.jitter = 0.0

    def reset(self) -> None:
        """Lost: the next stamps find the lattice again."""
        self.locked = False
        self.jitter = 0.0

    def lock(self, stamps: Sequence[int], coarse_period: float) -> Counts | None:
        """Find the lattice of ``stamps`` (increasing, a lossy stream at about
        ``coarse_period`` [ns]); their counts, or ``None`` when none is found."""
        x = (np.asarray(stamps, dtype=np.int64) - stamps[0]).astype(np.float64)
        period = self._spectral_period(x, coarse_period)
        if period is None:
            return None
        offset = period * float(np.angle(np.exp(2j * np.pi * x / period).sum())) / (2 * np.pi)
        for _ in range(2):  # least squares of the stamps on their indices
            k = np.rint((x - offset) / period)
            k_mean, x_mean = float(k.mean()), float(x.mean())
            spread = float(((k - k_mean) ** 2).sum())
            if spread == 0.0:
                return None
            period = float(((k - k_mean) * (x - x_mean)).sum()) / spread
            offset = x_mean - period * k_mean
        indices = np.rint((x - offset) / period).astype(np.int64)
        jumps = np.diff(indices)
        if int((jumps <= 0).sum()) * COLLISIONS > len(jumps):
            return None
        residuals = np.abs(x - offset - indices * period) / period
        self.locked, self.period, self.jitter = True, period, float(residuals.max())
        self._anchor(stamps[0], offset + float(indices[-1]) * period)
        return _jump_counts(jumps.tolist())

    @staticmethod
    def _spectral_period(x: np.ndarray, coarse_period: float) -> float | None:
        """The period [ns] of the strongest line of the stamps ``x`` (from 0) within
        :data:`PERIOD_SEARCH` of ``coarse_period``, if it reaches :data:`LOCK_SCORE`."""
        bin_ns = coarse_period / _BINS_PER_PERIOD
        bins = (x / bin_ns).astype(np.int64)
        length = 1 << math.ceil(math.log2(_OVERSAMPLING * (int(bins[-1]) + 1)))
        spectrum = np.abs(np.fft.rfft(np.bincount(bins, minlength=length)))
        scale = length * bin_ns  # the period of spectral line j is scale / j
        low = max(1, math.floor(scale / (coarse_period * (1.0 + PERIOD_SEARCH))))
        high = min(len(spectrum) - 1, math.ceil(scale / (coarse_period * (1.0 - PERIOD_SEARCH))))
        if high < low:
            return None
        line = low + int(np.argmax(spectrum[low:high + 1]))
        if spectrum[line] < LOCK_SCORE * math.sqrt(len(x)):
            return None
        return scale / line

    def _anchor(self, base: int, at: float) -> None:
        """Index 0 at ``base + at`` [ns]: ``t_ref`` its whole nanoseconds."""
        whole = math.floor(at)
        self.t_ref, self.offset = base + whole, at - whole

    def count(self, stamps: Sequence[int]) -> Counts | None:
        """Count ``stamps`` (the next ones of the stream) against the lattice and follow it;
        ``None`` when they do not fit it (the lattice is lost)."""
        t_ref, offset, inverse = self.t_ref, self.offset, 1.0 / self.period
        last = taken = collisions = missed = gaps = largest = 0
        residual_sum = index_sum = peak = 0.0
        for stamp in stamps:
            position = (stamp - t_ref - offset) * inverse
            index = round(position)
            jump = index - last
            if jump <= 0:  # an index already taken: a jitter of half a period or more
                collisions += 1
                continue
            residual = position - index
            residual_sum += residual
            index_sum += index
            taken += 1
            if residual > peak or -residual > peak:
                peak = abs(residual)
            if jump > 1:
                missed += jump - 1
                gaps += 1
                largest = max(largest, jump - 1)
            last = index
        mean = residual_sum / taken if taken else 1.0
        if collisions * COLLISIONS > len(stamps) or abs(mean) > 0.25:
            self.reset()
            return None
        self.jitter = max(JITTER_MEMORY * self.jitter, peak)
        self._follow(last, index_sum / taken, mean)
        return missed, gaps, largest

    def _follow(self, last_index: int, index_mean: float, mean: float) -> None:
        """Move the lattice towards a batch whose residuals at the mean index ``index_mean``
        average ``mean`` [periods] (an α-β tracker: the phase by :data:`PHASE_GAIN` of it, the
        period by :data:`PERIOD_GAIN` of it over the indices since the anchor) and anchor it
        at the batch's last index."""
        period = self.period
        correction = mean * period  # [ns] at index_mean
        self.period = period + PERIOD_GAIN * correction / index_mean
        at_mean = self.offset + index_mean * period + PHASE_GAIN * correction
        self._anchor(self.t_ref, at_mean + (last_index - index_mean) * self.period)


class PeriodLearner:
    """The sample period of a stream, learnt in batches of steps; counts the samples missed
    upstream against the sample lattice (module docstring). :meth:`gaps_text` says what the
    gaps look like."""

    def __init__(self) -> None:
        #: The coarse period [ns] (0: not learnt yet).
        self.period_ns = 0.0
        self.missed = 0
        self.steps = [0] * PERIOD_BATCH
        self.stamps = [0] * PERIOD_BATCH
        self.count = 0
        self.lattice = SampleLattice()
        self._window: list[int] = []  # stamps held until the lattice is found
        self._window_credit = 0
        #: Missed samples and gaps of the held stamps counted already (the lower bound).
        self._window_counted = (0, 0)
        self._next_attempt = PERIOD_BATCH
        self._refused_mark = 0
        self._held = [0, 0, 0]  # a full batch's missed samples, gaps, largest gap: unconfirmed
        self._gaps = 0
        self._largest_gap = 0

    def settle(self, refused: int, partial: bool = False) -> None:
        """Count the batch's missed samples (``refused``: samples refused so far by the stream
        and the session); ``partial``: a batch not full yet, counted only when its median
        agrees with the period. A full batch's count is held until the next batch agrees
        with its period (a driver that slowed down late in a batch is not loss)."""
        count, self.count = self.count, 0
        if not count:
            return
        steps, stamps = self.steps[:count], self.stamps[:count]
        median = sorted(steps)[count // 2]
        credit, self._refused_mark = refused - self._refused_mark, refused
        if partial:
            if not (self.period_ns and _close(median, self.period_ns)):
                self.count = count  # not settled: wait for the full batch
                self._refused_mark -= credit
                return
            self._commit()
            self._take(steps, stamps, credit)
            self._commit()
            return
        half = count // 2
        recent = sorted(steps[half:])[(count - half) // 2]
        previous = self.period_ns
        if _close(sorted(steps[:half])[half // 2], recent):
            self._learn(steps, median)
            if not previous or _close(self.period_ns, previous):
                self._commit()
                self._take(steps, stamps, credit)
                return
        else:  # the rate changed within the batch: learn from its second half
            self.period_ns = float(recent)
        self._held = [0, 0, 0]  # a change of rate: neither this batch nor the last is loss
        self._restart()

    def break_line(self, refused: int) -> None:
        """The stamps' time line breaks (a gap, a jump back, a reset, a pause): the batch so
        far is counted (when its median agrees with the period) and the lattice ends."""
        self.settle(refused, partial=True)
        self.count = 0
        self._commit()
        self._restart()

    def gap(self, step_ns: float) -> None:
        """A confirmed forward gap of ``step_ns`` [ns]: its missed samples count at once."""
        period = self.lattice.period if self.lattice.locked else self.period_ns
        lost = round(step_ns / period) - 1 if period else 0
        if lost > 0:
            self._add((lost, 1, lost), 0)
            self._commit()

    def _restart(self) -> None:
        """Forget the lattice and the held stamps: the next stamps find it again."""
        self.lattice.reset()
        self._window, self._window_credit = [], 0
        self._window_counted = (0, 0)
        self._next_attempt = PERIOD_BATCH

    def _take(self, steps: list[int], stamps: list[int], credit: int) -> None:
        """Hold the missed samples of a batch (``stamps`` and their ``steps``) less ``credit``
        refused samples: counted against the lattice; until it is found, a lower bound at once
        and the rest once it is found."""
        if self.lattice.locked:
            counts = self.lattice.count(stamps)
            if counts is not None:
                self._add(counts, credit)
                return
        window = self._window
        if not window:
            window.append(stamps[0] - steps[0])  # the stamp before the batch
        window.extend(stamps)
        self._window_credit += credit
        lower = self._add(self._lower_bound(steps), credit)
        self._window_counted = (self._window_counted[0] + lower[0],
                                self._window_counted[1] + lower[1])
        if len(window) < self._next_attempt or not self.period_ns:
            return
        self._next_attempt = 2 * len(window)
        counts = self.lattice.lock(window, self.period_ns)
        if counts is not None:
            missed, gaps, largest = counts
            counted_missed, counted_gaps = self._window_counted
            self._add((max(0, missed - self._window_credit - counted_missed),
                       max(0, gaps - counted_gaps), largest), 0)
        if counts is not None or len(window) >= MAX_WINDOW:
            self._window, self._window_credit = [], 0
            self._window_counted = (0, 0)
            self._next_attempt = PERIOD_BATCH

    def _lower_bound(self, steps: Sequence[int]) -> Counts:
        """Without a lattice: each step of ``s`` mean steps of the held stamps counts
        ``floor(s − 2)`` (a lossless step stays below 3 periods while the stamps move by less
        than one; a mean step is a period or more)."""
        window = self._window
        period = (window[-1] - window[0]) / (len(window) - 1)
        return _jump_counts([math.floor(step / period) - 1 for step in steps])

    def _add(self, counts: Counts, credit: int) -> Counts:
        """Hold ``counts`` less ``credit`` refused samples; what was held."""
        missed, gaps, largest = counts
        missed -= min(missed, credit)
        if missed <= 0:
            return 0, 0, 0
        held = self._held
        held[0] += missed
        held[1] += gaps
        held[2] = max(held[2], largest)
        return missed, gaps, largest

    def _commit(self) -> None:
        """The held missed samples are confirmed."""
        missed, gaps, largest = self._held
        self.missed += missed
        self._gaps += gaps
        self._largest_gap = max(self._largest_gap, largest)
        self._held = [0, 0, 0]

    def _learn(self, raw: list[int], median: int) -> None:
        """The coarse period [ns]: the mean of the steps below 1.9 medians."""
        limit = 1.9 * median
        kept = [step for step in raw if step < limit]
        self.period_ns = sum(kept) / len(kept)

    def gaps_text(self) -> str:
        """The gaps counted since the last call in words, with their likely cause."""
        gaps, largest = self._gaps, self._largest_gap
        self._gaps = self._largest_gap = 0
        if not gaps:
            return ''
        if largest >= BURST_SAMPLES:
            cause = (f'{gaps} gaps in the header stamps, the largest {largest} samples: bursts '
                     f'lost before the node, as a full input queue drops them while the node '
                     f'is busy (parameter `qos_overrides./imu.subscription.depth`) or a '
                     f'driver stalls')
        else:
            cause = (f'{gaps} gaps of at most {largest} samples in the header stamps: lost by '
                     f'the driver or the transport (a deeper input queue would not help)')
        jitter = self.lattice.jitter
        if jitter >= 0.2:
            cause += (f'; the stamps jitter by up to {100.0 * jitter:.0f} % of the period '
                      f'(counted against the expected sample index)')
        return cause


def _close(a: float, b: float) -> bool:
    """Whether two periods agree within :data:`RATE_CHANGE`."""
    return abs(a - b) <= RATE_CHANGE * max(a, b)
