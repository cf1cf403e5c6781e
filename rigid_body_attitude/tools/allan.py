"""``imu_noise INPUT [--topic T] [--output imu.yaml] [--plot allan.png]``: IMU noise by Allan
deviation.

Reads a static recording: a rosbag2 bag with a ``sensor_msgs/msg/Imu`` topic (the only one, or
``--topic``), or a BROAD trial archive (``.npz``; its initial rest phase). Computes the
overlapping Allan deviation of each axis with ``allantools`` and fits, on the mean over axes:

* ``N`` (white noise, angle/velocity random walk): the slope −½ line through the point whose
  local log-log slope is closest to −½, read at τ = 1 s;
* ``K`` (bias random walk): the slope +½ line through the point whose local slope is closest to
  +½, read at τ = 3 s. When no part of the curve rises (slope below +¼ everywhere, the
  recording too short to show the walk), ``K`` is the upper bound ``min σ(τ) √(3/τ)`` and the
  output says so;
* ``B`` (bias instability): the curve's minimum over ``√(2 ln 2/π) ≈ 0.664``.

Only τ up to a tenth of the recording enter a fit (at least ten independent averages).
Writes a kalibr-style ``imu.yaml`` (``rostopic``, ``update_rate``, ``gyroscope_noise_density``,
``gyroscope_random_walk`` and the ``accelerometer_`` pair when the input has acceleration;
bias instability and bounds as comments) and the Allan plot with the fitted lines (PNG).
Returns 0, or 2 with one ``error:`` line for bad input.
"""

from __future__ import annotations

import argparse
import math
import sys
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from rigid_body_attitude.console import closed_pipe_safe
from rigid_body_attitude.bag import BagReader
from rigid_body_attitude.msgs import IMU, imu_acceleration, imu_rates
from rigid_body_attitude.core.errors import AttitudeError, InputError

__all__ = ['AllanCurve', 'NoiseFit', 'Recording', 'allan_curve', 'check_static', 'checked_yaml',
           'fit_noise', 'kalibr_yaml', 'main', 'read_recording', 'write_plot']

FloatArray = NDArray[np.float64]

#: Shortest recording accepted [s]; a reliable K needs hours, N a few minutes.
MIN_SECONDS = 10.0
#: Points per decade of τ.
POINTS_PER_DECADE = 12
#: Flicker floor factor: σ_min = √(2 ln 2/π) B.
FLICKER_FACTOR = math.sqrt(2.0 * math.log(2.0) / math.pi)
_RISING = 0.25
#: Most robust standard deviations (1.4826 × the median absolute deviation) a sample of a
#: static recording may lie from the median; Gaussian noise stays within 7 in 10^11 samples.
OUTLIER_SPREADS = 1000.0
#: Largest share of an axis's samples at its largest or smallest value (further than three
#: robust standard deviations from the median): more is a saturated sensor.
SATURATED_FRACTION = 0.01


@dataclass(frozen=True)
class Recording:
    """A static recording: sample rate [Hz], gyro (n, 3) [rad/s], accelerometer (n, 3)
    [m/s²] or ``None``, and the Imu topic it came from (``''`` for a BROAD archive)."""

    rate: float
    gyro: FloatArray
    acc: FloatArray | None
    topic: str


@dataclass(frozen=True)
class AllanCurve:
    """Overlapping Allan deviation: τ [s] (m,), per axis (m, 3) and its mean over axes (m,)."""

    taus: FloatArray
    axes: FloatArray
    mean: FloatArray


@dataclass(frozen=True)
class NoiseFit:
    """Fitted figures: white-noise density N, random walk K (``k_is_bound``: an upper bound),
    bias instability B, and the τ of the points the N and K lines pass through."""

    white: float
    random_walk: float
    k_is_bound: bool
    instability: float
    white_tau: float
    walk_tau: float


def read_recording(path: str | Path, topic: str | None = None) -> Recording:
    """Load a BROAD ``.npz`` (initial rest phase) or the Imu topic of a bag; checked."""
    path = Path(path)
    if path.suffix == '.npz':
        from rigid_body_attitude.tools.broad import load_trial
        trial = load_trial(path)
        rest = trial.first_motion_index
        recording = Recording(trial.sampling_rate, np.array(trial.gyro[:rest]),
                              np.array(trial.acc[:rest]), '')
    else:
        recording = _read_bag(path, topic)
    duration = recording.gyro.shape[0] / recording.rate
    if not duration >= MIN_SECONDS:
        raise InputError(f'Expected at least {MIN_SECONDS:g} s of static data in '
                         f'{str(path)!r}, got {duration:.3g} s')
    check_static(recording.gyro, 'gyroscope', f'{str(path)!r}')
    if recording.acc is not None:
        check_static(recording.acc, 'accelerometer', f'{str(path)!r}')
    return recording


def check_static(samples: FloatArray, sensor: str, where: str) -> None:
    """Refuse (InputError saying why) samples no Allan deviation can be estimated from:
    non-finite; an axis constant, or more than half its samples at one value (a stuck
    sensor, or quantisation coarser than the noise); a sample more than
    :data:`OUTLIER_SPREADS` robust spreads off the median (a glitch or a bump: not static);
    or more than :data:`SATURATED_FRACTION` of the samples at the axis's extreme value (a
    saturated sensor)."""
    if not np.all(np.isfinite(samples)):
        raise InputError(f'Expected finite {sensor} samples in {where}; '
                         f'{int(np.sum(~np.isfinite(samples)))} are NaN or Inf')
    for axis, name in enumerate('xyz'):
        column = samples[:, axis]
        median = float(np.median(column))
        spread = 1.4826 * float(np.median(np.abs(column - median)))  # σ of Gaussian noise
        if not spread > 0.0:
            share = float(np.mean(column == median))
            raise InputError(f'Expected the {sensor} {name} axis in {where} to vary: '
                             f'{100 * share:.0f} % of its samples equal {median:.6g} (a stuck or '
                             f'saturated sensor, or quantisation coarser than the noise)')
        off = float(np.max(np.abs(column - median))) / spread
        if off > OUTLIER_SPREADS:
            raise InputError(f'Expected a static recording in {where}: a {sensor} {name} '
                             f'sample lies {off:.3g} robust standard deviations from the '
                             f'median (at most {OUTLIER_SPREADS:g}: a glitch or a bump)')
        for extreme in (float(column.max()), float(column.min())):
            share = float(np.mean(column == extreme))
            if share > SATURATED_FRACTION and abs(extreme - median) > 3.0 * spread:
                raise InputError(f'Expected an unsaturated {sensor} in {where}: '
                                 f'{100 * share:.2g} % of the {name} samples sit at '
                                 f'{extreme:.6g} (at most {100 * SATURATED_FRACTION:g} %)')


def _read_bag(path: Path, topic: str | None) -> Recording:
    with BagReader(path) as reader:
        imu_topics = [name for name, kind in reader.topics.items() if kind == IMU]
        if topic is None:
            if len(imu_topics) != 1:
                raise InputError(f'Expected exactly one {IMU} topic in {str(path)!r} (or '
                                 f'--topic), got {imu_topics or "none"}; topics: '
                                 f'{reader.topics}')
            topic = imu_topics[0]
        elif topic not in imu_topics:
            raise InputError(f'Expected topic {topic!r} of type {IMU} in {str(path)!r}; '
                             f'topics: {reader.topics}')
        stamps, gyro, acc = [], [], []
        for _, _, _, data in reader.messages([topic]):
            stamp, rate = imu_rates(data)
            stamps.append(stamp)
            gyro.append(rate)
            acc.append(imu_acceleration(data)[1])
    return _checked_recording(path, topic, np.array(stamps), np.array(gyro), np.array(acc))


def _checked_recording(path: Path, topic: str, stamps: FloatArray, gyro: FloatArray,
                       acc: FloatArray) -> Recording:
    if stamps.size < 2 or not np.all(np.diff(stamps) > 0.0):
        raise InputError(f'Expected increasing header stamps on {topic!r} in {str(path)!r} '
                         f'({stamps.size} messages)')
    rate = (stamps.size - 1) / float(stamps[-1] - stamps[0])
    has_acc = bool(np.any(acc != 0.0))
    return Recording(rate, gyro.reshape(-1, 3), acc.reshape(-1, 3) if has_acc else None, topic)


def allan_curve(samples: FloatArray, rate: float) -> AllanCurve:
    """Overlapping Allan deviation of each column of ``samples`` (rates at ``rate`` Hz)."""
    import allantools
    duration = samples.shape[0] / rate
    decades = math.log10(duration / 2.0 / (1.0 / rate))
    taus = np.logspace(math.log10(1.0 / rate), math.log10(duration / 2.0),
                       max(int(decades * POINTS_PER_DECADE), 2))
    columns = []
    for axis in range(samples.shape[1]):
        computed, deviation, _, _ = allantools.oadev(samples[:, axis], rate=rate,
                                                     data_type='freq', taus=taus)
        columns.append((np.asarray(computed, dtype=np.float64),
                        np.asarray(deviation, dtype=np.float64)))
    common = columns[0][0]
    axes = np.stack([deviation for _, deviation in columns], axis=1)
    return AllanCurve(common, axes, axes.mean(axis=1))


def fit_noise(curve: AllanCurve, duration: float) -> NoiseFit:
    """The N, K, B fits of the module docstring on ``curve.mean``."""
    usable = curve.taus <= duration / 10.0
    taus, sigma = curve.taus[usable], curve.mean[usable]
    if taus.size < 3:
        raise InputError(f'Expected a recording long enough for an Allan fit, got '
                         f'{duration:.3g} s')
    slopes = np.gradient(np.log(sigma), np.log(taus))
    white = int(np.argmin(np.abs(slopes + 0.5)))
    walk = int(np.argmin(np.abs(slopes - 0.5)))
    rising = bool(slopes[walk] >= _RISING)
    if rising:
        k_value, walk_tau = float(sigma[walk] * math.sqrt(3.0 / taus[walk])), float(taus[walk])
    else:
        bound = sigma * np.sqrt(3.0 / taus)
        walk = int(np.argmin(bound))
        k_value, walk_tau = float(bound[walk]), float(taus[walk])
    return NoiseFit(white=float(sigma[white] * math.sqrt(taus[white])), random_walk=k_value,
                    k_is_bound=not rising, instability=float(sigma.min() / FLICKER_FACTOR),
                    white_tau=float(taus[white]), walk_tau=walk_tau)


def kalibr_yaml(recording: Recording, gyro: NoiseFit, acc: NoiseFit | None,
                rostopic: str) -> str:
    """The ``imu.yaml`` text (kalibr keys; B and bounds as comments)."""
    lines = ['# IMU noise from the overlapping Allan deviation of a static recording '
             f'({recording.gyro.shape[0]} samples, {recording.gyro.shape[0] / recording.rate:.1f}'
             ' s).']
    figures = [('gyroscope', 'rad/s/sqrt(Hz)', 'rad/s^2/sqrt(Hz)', 'rad/s', gyro)]
    if acc is not None:
        figures.append(('accelerometer', 'm/s^2/sqrt(Hz)', 'm/s^3/sqrt(Hz)', 'm/s^2', acc))
    for name, _, _, unit, fit in figures:
        bound = ' (upper bound: no random-walk slope seen)' if fit.k_is_bound else ''
        lines.append(f'# {name}: bias instability {fit.instability:.6g} {unit}; random walk '
                     f'read at tau = {fit.walk_tau:.3g} s{bound}.')
    lines += [f'rostopic: {rostopic}', f'update_rate: {recording.rate:.6g}']
    for name, white_unit, walk_unit, _, fit in figures:
        lines.append(f'{name}_noise_density: {fit.white:.6e}  # {white_unit}')
        lines.append(f'{name}_random_walk: {fit.random_walk:.6e}  # {walk_unit}')
    return '\n'.join(lines) + '\n'


def checked_yaml(text: str) -> None:
    """Refuse (InputError) an ``imu.yaml`` text the node would refuse as a calibration file:
    read back and checked by the node's own checker
    (:func:`~rigid_body_attitude.core.estimation.calibration.calibration_from_mapping`)."""
    import yaml
    from rigid_body_attitude.core.estimation.calibration import calibration_from_mapping
    from rigid_body_attitude.core.errors import CalibrationError
    try:
        calibration_from_mapping(yaml.safe_load(text))
    except CalibrationError as err:
        raise InputError(f'The estimate gives an imu.yaml the node would refuse ({err}); '
                         f'nothing written') from None


def _plot_title(recording: Recording, source: str) -> str:
    count = recording.gyro.shape[0]
    return (f'Allan deviation of {Path(source).name}: {count} samples, '
            f'{count / recording.rate:.1f} s at {recording.rate:.6g} Hz')


_UNITS = {'gyroscope': ('rad/s', 'rad/s/sqrt(Hz)', 'rad/s^2/sqrt(Hz)'),
          'accelerometer': ('m/s^2', 'm/s^2/sqrt(Hz)', 'm/s^3/sqrt(Hz)')}


def write_plot(curves: dict[str, tuple[AllanCurve, NoiseFit]], path: Path,
               title: str = 'Allan deviation') -> None:
    """PNG, one panel per sensor: the Allan deviation of each axis, the fitted −½ and +½ slope
    lines, and the points read off (N at τ = 1 s, K at τ = 3 s) marked and labelled."""
    import matplotlib
    matplotlib.use('Agg')
    from matplotlib import pyplot
    figure, panels = pyplot.subplots(1, len(curves), figsize=(7.0 * len(curves), 5.5),
                                     squeeze=False)
    for axes, (name, (curve, fit)) in zip(panels[0], curves.items()):
        _panel(axes, name, curve, fit)
    figure.suptitle(title)
    figure.tight_layout()
    figure.savefig(path, dpi=110)
    pyplot.close(figure)


def _panel(axes: Any, name: str, curve: AllanCurve, fit: NoiseFit) -> None:
    """One sensor's Allan deviation, fitted lines and read-off points."""
    unit, white_unit, walk_unit = _UNITS.get(name, ('', '', ''))
    for axis, label in enumerate('xyz'):
        axes.loglog(curve.taus, curve.axes[:, axis], linewidth=1.0, label=f'{label} axis')
    taus = np.logspace(math.log10(min(curve.taus[0], 1.0)),
                       math.log10(max(curve.taus[-1], 3.0)), 50)
    bound = 'K <= ' if fit.k_is_bound else 'K = '
    axes.loglog(taus, fit.white / np.sqrt(taus), 'k--', linewidth=0.9,
                label='white noise, slope -1/2: N / sqrt(tau)')
    axes.loglog(taus, fit.random_walk * np.sqrt(taus / 3.0), 'k:', linewidth=1.2,
                label='rate random walk, slope +1/2: K sqrt(tau / 3)')
    for tau, value, text, offset in (
            (1.0, fit.white, f'N = {fit.white:.3g} {white_unit}\n(read at tau = 1 s)', -30),
            (3.0, fit.random_walk,
             f'{bound}{fit.random_walk:.3g} {walk_unit}\n(read at tau = 3 s)', 10)):
        axes.plot([tau], [value], 'o', color='crimson', markersize=6, zorder=5)
        axes.annotate(text, (tau, value), xytext=(8, offset), textcoords='offset points',
                      fontsize=8, color='crimson',
                      bbox={'boxstyle': 'round', 'facecolor': 'white', 'alpha': 0.8})
    axes.set_title(f'{name}: N {fit.white:.3g} {white_unit}, {bound}{fit.random_walk:.3g} '
                   f'{walk_unit}', fontsize=9)
    axes.set_xlabel('averaging time tau [s]')
    axes.set_ylabel(f'{name} Allan deviation sigma(tau) [{unit}]')
    axes.grid(True, which='both', alpha=0.3)
    axes.legend(fontsize=8, loc='lower left')


class _Parser(argparse.ArgumentParser):
    def error(self, message: str) -> None:  # type: ignore[override]
        """One ``error:`` line and exit code 2 (no usage block)."""
        print(f'error: {message}', file=sys.stderr)
        raise SystemExit(2)


def _parse(argv: Sequence[str] | None) -> argparse.Namespace:
    parser = _Parser(prog='imu_noise', description='IMU noise densities and random walks by '
                     'Allan deviation from a static recording; writes a kalibr-style imu.yaml '
                     'and the Allan plot.')
    parser.add_argument('input', help='rosbag2 bag (Imu topic) or BROAD trial (.npz)')
    parser.add_argument('--topic', help='Imu topic in the bag (default: the only one)')
    parser.add_argument('--output', default='imu.yaml', help='imu.yaml to write')
    parser.add_argument('--plot', default='allan.png', help='Allan plot (PNG) to write')
    parser.add_argument('--rostopic', help="'rostopic' in imu.yaml (default: the bag's topic)")
    return parser.parse_args(argv)


@closed_pipe_safe
def main(argv: Sequence[str] | None = None) -> int:
    """Console entry point; returns 0, or 2 with one ``error:`` line."""
    try:
        args = _parse(argv)
    except SystemExit as exit_request:
        return int(exit_request.code or 0)
    try:
        recording = read_recording(args.input, args.topic)
        duration = recording.gyro.shape[0] / recording.rate
        curves = {'gyroscope': _fitted(recording.gyro, recording.rate, duration)}
        if recording.acc is not None:
            curves['accelerometer'] = _fitted(recording.acc, recording.rate, duration)
        rostopic = args.rostopic or '/' + (recording.topic or 'imu').lstrip('/')
        text = kalibr_yaml(recording, curves['gyroscope'][1],
                           curves['accelerometer'][1] if recording.acc is not None else None,
                           rostopic)
        checked_yaml(text)
        Path(args.output).write_text(text, encoding='utf-8')
        write_plot(curves, Path(args.plot), _plot_title(recording, args.input))
    except (AttitudeError, OSError) as err:
        print(f'error: {err}', file=sys.stderr)
        return 2
    gyro = curves['gyroscope'][1]
    print(f'{args.output}: gyroscope_noise_density {gyro.white:.4g} rad/s/sqrt(Hz), '
          f'gyroscope_random_walk {"<= " if gyro.k_is_bound else ""}{gyro.random_walk:.4g} '
          f'rad/s^2/sqrt(Hz) ({duration:.1f} s at {recording.rate:.6g} Hz); plot {args.plot}')
    return 0


def _fitted(samples: FloatArray, rate: float, duration: float) -> tuple[AllanCurve, NoiseFit]:
    curve = allan_curve(samples, rate)
    return curve, fit_noise(curve, duration)


if __name__ == '__main__':
    sys.exit(main())
