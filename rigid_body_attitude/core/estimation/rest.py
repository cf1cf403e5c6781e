"""Rest detection from gyro and accelerometer samples, and gyro bias refinement at rest.

:class:`RestDetector` is fed one sample at a time (sensor/body frame: rates [rad/s], specific
force [m/s²], sample interval ``dt`` [s]) and keeps a sliding window of ``window_seconds``
with running sums, so each sample costs a constant number of float operations. The body is
at rest when, over the full window,

* the gyro's total standard deviation ``√(σx² + σy² + σz²)`` is at most ``noise_factor``
  times the gyro noise floor, and likewise the accelerometer's;
* the mean rate, less the current bias estimate (:meth:`RestDetector.set_gyro_bias`), is at
  most ``max_rest_rate`` (a slow steady turn has a quiet gyro but a non-zero mean);
* ``|mean specific force|`` is within ``gravity_tolerance`` of ``gravity``.

The noise floors are measured: the smallest windowed standard deviation seen so far (the
quietest window), kept within ``[min_*_noise, max_*_noise]`` so that a quantised sensor
(zero spread) or a body that never rests does not set an absurd threshold; a known noise
(``gyro_noise`` from a calibration file's density × √rate) replaces the measured floor. A tap
(an accelerometer spike of a few samples) raises the window's accelerometer spread far
above its floor for a whole window, so neither the tap nor the window after it is rest.

:class:`RestBiasEstimator` refines a gyro bias estimate from the samples the detector
confirms: it is fed :attr:`RestDetector.delayed_gyro`, the oldest sample of a quiet window
(quiet samples on both sides of it), so the first samples of a motion never enter the
estimate even though the detector notices the motion a few samples late.

Bounded arithmetic: :meth:`RestDetector.update` takes a sample only when its rate is at most
:data:`RATE_LIMIT` and its specific force at most :data:`SPECIFIC_FORCE_LIMIT` in magnitude
(finite, so); any other is not added to the windowed sums and counts in
:attr:`RestDetector.refused`. The sums of squares of a window then stay below ``n × 10¹²``
and a sample dropped from the window leaves a round-off below ``10⁻⁴`` (rad/s)² or (m/s²)² in
them, far below the noise floors the thresholds come from. Sessions refuse such samples before
(counted by reason); the detector's own check keeps any other caller's sums finite.
"""

from __future__ import annotations

import math
from collections import deque

from rigid_body_attitude.core.errors import InputError

__all__ = ['DEFAULT_BIAS_TIME_CONSTANT', 'RATE_LIMIT', 'REFINE_BIAS_AT_REST',
           'RestBiasEstimator', 'RestDetector', 'SPECIFIC_FORCE_LIMIT', 'STANDARD_GRAVITY']

Vec = tuple[float, float, float]
#: [m/s²]
STANDARD_GRAVITY = 9.80665
#: Whether a session refines the gyro bias at rest by default. Measured on the four BROAD
#: trials against the optical truth (test/tools/test_rest_study.py, docs/imu.md): on the
#: trial with breaks refinement lowers the mean error over the motion phase from 2.120 to
#: 2.022 deg, but over the four trials the mean errors add up to 9.39 deg against 8.87 deg
#: with the alignment window's bias, so it is off by default.
REFINE_BIAS_AT_REST = False
#: Largest specific-force magnitude of a sample [m/s²], about 1020 g: far above the full scale
#: of any IMU accelerometer (MEMS parts end at ±16 g to ±400 g, e.g. the ADXL375's ±200 g),
#: far below values whose square could lose the rest of a window's sums.
SPECIFIC_FORCE_LIMIT = 1.0e4
#: Largest rate magnitude the rest detector takes [rad/s] (the upper bound of the
#: ``max_angular_rate`` parameter).
RATE_LIMIT = 1.0e6
#: Time constant of :class:`RestBiasEstimator` [s].
DEFAULT_BIAS_TIME_CONSTANT = 60.0
#: Samples between two recomputations of the running sums from the window (round-off).
_RESUM_INTERVAL = 4096
_RATE_LIMIT_SQUARED = RATE_LIMIT * RATE_LIMIT
_SPECIFIC_FORCE_LIMIT_SQUARED = SPECIFIC_FORCE_LIMIT * SPECIFIC_FORCE_LIMIT


def _positive(name: str, value: float) -> float:
    if not (math.isfinite(value) and value > 0.0):
        raise InputError(f'Expected {name} to be a positive finite number, got {value!r}')
    return float(value)


class RestDetector:
    """Sliding-window rest detector with thresholds from the measured noise (module docstring).

    Args:
        window_seconds: window length [s].
        noise_factor: rest if each windowed spread is at most this many times its floor.
        max_rest_rate: largest |mean rate − bias estimate| at rest [rad/s].
        gravity: [m/s²].
        gravity_tolerance: largest ``||mean a| − gravity|`` at rest [m/s²].
        gyro_noise: known gyro noise per sample [rad/s] (total over the axes is √3 times it),
            or 0 to measure it.
        min_gyro_noise, max_gyro_noise: bounds of the gyro floor (per axis) [rad/s].
        min_accel_noise, max_accel_noise: bounds of the accelerometer floor (per axis) [m/s²].
    """

    def __init__(self, window_seconds: float = 0.25, noise_factor: float = 2.0,
                 max_rest_rate: float = 0.05, gravity: float = STANDARD_GRAVITY,
                 gravity_tolerance: float = 0.5, gyro_noise: float = 0.0,
                 min_gyro_noise: float = 2e-4, max_gyro_noise: float = 0.02,
                 min_accel_noise: float = 2e-3, max_accel_noise: float = 0.2) -> None:
        self.window_seconds = _positive('window_seconds', window_seconds)
        self.noise_factor = _positive('noise_factor', noise_factor)
        self.max_rest_rate = _positive('max_rest_rate', max_rest_rate)
        self.gravity = _positive('gravity', gravity)
        self.gravity_tolerance = _positive('gravity_tolerance', gravity_tolerance)
        self.gyro_noise = 0.0 if gyro_noise == 0.0 else _positive('gyro_noise', gyro_noise)
        self._gyro_bounds = (math.sqrt(3.0) * _positive('min_gyro_noise', min_gyro_noise),
                             math.sqrt(3.0) * _positive('max_gyro_noise', max_gyro_noise))
        self._accel_bounds = (math.sqrt(3.0) * _positive('min_accel_noise', min_accel_noise),
                              math.sqrt(3.0) * _positive('max_accel_noise', max_accel_noise))
        self._bias: Vec = (0.0, 0.0, 0.0)
        #: Samples not taken: non-finite or beyond :data:`RATE_LIMIT` /
        #: :data:`SPECIFIC_FORCE_LIMIT` (module docstring).
        self.refused = 0
        self.reset()

    def reset(self) -> None:
        """Forget the window and the measured noise floors (the bias estimate stays)."""
        self._window: deque[tuple[float, float, float, float, float, float, float]] = deque()
        self._sums = [0.0] * 12  # Σx and Σx² of the six channels
        self._duration = 0.0
        self._since_resum = 0
        self._gyro_floor = math.inf
        self._accel_floor = math.inf
        self.at_rest = False
        #: Windowed total spreads and means of the last sample (plain floats).
        self.gyro_spread = math.inf
        self.accel_spread = math.inf
        self.mean_gyro: Vec = (0.0, 0.0, 0.0)
        self.mean_accel: Vec = (0.0, 0.0, 0.0)
        self.gyro_threshold = self.accel_threshold = 0.0
        self._set_thresholds()

    def set_gyro_bias(self, bias: Vec) -> None:
        """The bias estimate [rad/s] subtracted from the mean rate in the rest test."""
        self._bias = (float(bias[0]), float(bias[1]), float(bias[2]))

    @property
    def window_full(self) -> bool:
        """Whether the window spans ``window_seconds``."""
        return self._duration >= self.window_seconds

    @property
    def delayed_gyro(self) -> Vec:
        """The oldest rate sample in the window [rad/s] (the one to refine a bias with)."""
        oldest = self._window[0]
        return oldest[0], oldest[1], oldest[2]

    def _set_thresholds(self) -> None:
        """Thresholds from the floors: :attr:`gyro_threshold` [rad/s], :attr:`accel_threshold`
        [m/s²] (largest total windowed spreads counted as rest)."""
        low, high = self._gyro_bounds
        gyro_floor = (math.sqrt(3.0) * self.gyro_noise if self.gyro_noise > 0.0
                      else min(max(self._gyro_floor, low), high))
        low, high = self._accel_bounds
        self.gyro_threshold = self.noise_factor * gyro_floor
        self.accel_threshold = self.noise_factor * min(max(self._accel_floor, low), high)

    def update(self, wx: float, wy: float, wz: float, ax: float, ay: float, az: float,
               dt: float) -> bool:
        """Add one sample (rates [rad/s], specific force [m/s²], its interval [s]); returns
        :attr:`at_rest` (unchanged for a refused sample, see :attr:`refused`)."""
        if not (wx * wx + wy * wy + wz * wz <= _RATE_LIMIT_SQUARED
                and ax * ax + ay * ay + az * az <= _SPECIFIC_FORCE_LIMIT_SQUARED
                and 0.0 <= dt < math.inf):  # NaN and Inf fail too
            self.refused += 1
            return self.at_rest
        window, s = self._window, self._sums
        window.append((wx, wy, wz, ax, ay, az, dt))
        self._duration += dt
        s[0] += wx
        s[1] += wy
        s[2] += wz
        s[3] += ax
        s[4] += ay
        s[5] += az
        s[6] += wx * wx
        s[7] += wy * wy
        s[8] += wz * wz
        s[9] += ax * ax
        s[10] += ay * ay
        s[11] += az * az
        while len(window) > 2 and self._duration - window[0][6] >= self.window_seconds:
            self._drop(window.popleft())
        self._since_resum += 1
        if self._since_resum >= _RESUM_INTERVAL:
            self._resum()
        if self._duration < self.window_seconds:
            self.at_rest = False
            return False
        self._statistics()
        self.at_rest = self._quiet()
        return self.at_rest

    def _drop(self, sample: tuple[float, ...]) -> None:
        s = self._sums
        wx, wy, wz, ax, ay, az, dt = sample
        self._duration -= dt
        s[0] -= wx
        s[1] -= wy
        s[2] -= wz
        s[3] -= ax
        s[4] -= ay
        s[5] -= az
        s[6] -= wx * wx
        s[7] -= wy * wy
        s[8] -= wz * wz
        s[9] -= ax * ax
        s[10] -= ay * ay
        s[11] -= az * az

    def _resum(self) -> None:
        self._since_resum = 0
        self._sums = [sum(sample[index] for sample in self._window) for index in range(6)] + [
            sum(sample[index] ** 2 for sample in self._window) for index in range(6)]
        self._duration = sum(sample[6] for sample in self._window)

    def _statistics(self) -> None:
        s = self._sums
        scale = 1.0 / len(self._window)
        gx, gy, gz = s[0] * scale, s[1] * scale, s[2] * scale
        fx, fy, fz = s[3] * scale, s[4] * scale, s[5] * scale
        self.mean_gyro = (gx, gy, gz)
        self.mean_accel = (fx, fy, fz)
        # Variances Σx²/n − mean², summed over the axes; round-off can make a sum negative.
        gyro = (s[6] + s[7] + s[8]) * scale - (gx * gx + gy * gy + gz * gz)
        accel = (s[9] + s[10] + s[11]) * scale - (fx * fx + fy * fy + fz * fz)
        self.gyro_spread = math.sqrt(gyro) if gyro > 0.0 else 0.0
        self.accel_spread = math.sqrt(accel) if accel > 0.0 else 0.0
        if self.gyro_spread < self._gyro_floor or self.accel_spread < self._accel_floor:
            self._gyro_floor = min(self._gyro_floor, self.gyro_spread)
            self._accel_floor = min(self._accel_floor, self.accel_spread)
            self._set_thresholds()

    def _quiet(self) -> bool:
        if self.gyro_spread > self.gyro_threshold or self.accel_spread > self.accel_threshold:
            return False
        return (self.mean_rate() <= self.max_rest_rate
                and abs(self.mean_specific_force() - self.gravity) <= self.gravity_tolerance)

    def mean_rate(self) -> float:
        """``|windowed mean rate − bias estimate|`` [rad/s]."""
        bias = self._bias
        return math.sqrt((self.mean_gyro[0] - bias[0]) ** 2 + (self.mean_gyro[1] - bias[1]) ** 2
                         + (self.mean_gyro[2] - bias[2]) ** 2)

    def mean_specific_force(self) -> float:
        """``|windowed mean specific force|`` [m/s²]."""
        return math.sqrt(self.mean_accel[0] ** 2 + self.mean_accel[1] ** 2
                         + self.mean_accel[2] ** 2)

    def reason(self) -> str:
        """Why the body is not at rest (empty when it is), in words with the numbers."""
        if self.at_rest:
            return ''
        if not self.window_full:
            return (f'collecting {self._duration:.2f}/{self.window_seconds:g} s of samples')
        if self.gyro_spread > self.gyro_threshold:
            return (f'gyro spread {self.gyro_spread:.3g} rad/s above threshold '
                    f'{self.gyro_threshold:.3g}')
        if self.accel_spread > self.accel_threshold:
            return (f'accelerometer spread {self.accel_spread:.3g} m/s² above threshold '
                    f'{self.accel_threshold:.3g}')
        if self.mean_rate() > self.max_rest_rate:
            return (f'gyro {self.mean_rate():.3g} rad/s above threshold '
                    f'{self.max_rest_rate:g}')
        return (f'specific force {self.mean_specific_force():.3g} m/s² is not gravity '
                f'({self.gravity:g} ± {self.gravity_tolerance:g})')


class RestBiasEstimator:
    """Gyro bias refined at rest: a running mean that turns into an exponential average.

    While at rest, ``b ← b + (dt / τ_eff)(ω − b)`` with ``τ_eff = min(time_constant,
    rest time so far)``, the initial estimate counting as ``initial_seconds`` of rest: the
    estimate is the plain mean of all rest samples until ``time_constant`` seconds of rest
    have been seen, then an exponentially weighted mean with that time constant (a bias that
    drifts with temperature is followed). Feed it :attr:`RestDetector.delayed_gyro`.

    Args:
        initial_bias: starting estimate [rad/s] (the alignment window's mean rate).
        initial_seconds: how much rest the starting estimate stands for [s].
        time_constant: [s].
    """

    def __init__(self, initial_bias: Vec = (0.0, 0.0, 0.0), initial_seconds: float = 1.0,
                 time_constant: float = DEFAULT_BIAS_TIME_CONSTANT) -> None:
        self.time_constant = _positive('time_constant', time_constant)
        self.reset(initial_bias, initial_seconds)

    def reset(self, initial_bias: Vec, initial_seconds: float) -> None:
        """Start again from ``initial_bias`` [rad/s] standing for ``initial_seconds`` [s]."""
        self.bias: Vec = (float(initial_bias[0]), float(initial_bias[1]),
                          float(initial_bias[2]))
        self.rest_seconds = max(float(initial_seconds), 0.0)

    def update(self, at_rest: bool, gyro: Vec, dt: float) -> Vec:
        """Refine with one rate sample [rad/s] of interval ``dt`` [s] if ``at_rest``; returns
        the bias estimate [rad/s]."""
        if not at_rest or dt <= 0.0:
            return self.bias
        self.rest_seconds += dt
        gain = dt / min(self.time_constant, self.rest_seconds)
        b = self.bias
        self.bias = (b[0] + gain * (gyro[0] - b[0]), b[1] + gain * (gyro[1] - b[1]),
                     b[2] + gain * (gyro[2] - b[2]))
        return self.bias
