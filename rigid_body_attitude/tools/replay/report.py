"""What a replay prints and writes besides the output bag: the summary, CSV files, the plot."""

from __future__ import annotations

import csv
from pathlib import Path

import numpy as np

from rigid_body_attitude.session.times import split_ns
from rigid_body_attitude.tools.replay.run import ReplayResult
from rigid_body_attitude.tools.replay.truth import ErrorStatistics

__all__ = ['summary', 'write_csv', 'write_error_csv', 'write_plot']


def _counts_text(counts: dict[str, int]) -> str:
    return ', '.join(f'{name} {count}' for name, count in sorted(counts.items()) if count)


def _rejected_text(result: ReplayResult) -> str:
    """Rejections by reason; malformed messages also by topic."""
    parts = []
    for reason, count in sorted(result.rejected.items()):
        if not count:
            continue
        if reason == 'malformed' and result.malformed:
            parts.append(f'malformed {count} ({_counts_text(dict(result.malformed))})')
        else:
            parts.append(f'{reason} {count}')
    return ', '.join(parts) or 'none'


def _header(result: ReplayResult) -> list[str]:
    scene = result.scene
    step = f', step {scene.step:g} s' if scene.rate_source == 'dynamics' else ''
    lines = [f'replayed {str(result.input_path)!r} -> {str(result.output_path)!r}: scene '
             f'{scene.name!r} ({scene.rate_source}, {scene.integrator}{step})']
    lines += [f'note: {note}' for note in result.notes]
    lines.append(f'read: {_counts_text(result.read) or "nothing"}')
    ticks = f'; clock ticks: {result.ticks}' if scene.rate_source == 'dynamics' else ''
    lines.append(f'used: {result.used}{ticks}; rejected: {_rejected_text(result)}')
    written = ', '.join(f'{topic} {count}' for topic, count in result.written.items())
    lines.append(f'written: {written}')
    warnings, errors = result.logged['warning'], result.logged['error']
    if warnings or errors:
        lines.append(f'logged: {warnings} warnings, {errors} errors (throttled as the node '
                     f'does: one per reason per 5 s of bag time)')
    return lines


def summary(result: ReplayResult) -> str:
    """The printed summary: read, used, rejected, written, final state, drift, error."""
    lines = _header(result)
    if result.final_attitude is not None and result.final_stamp_ns is not None:
        w, x, y, z = result.final_attitude
        lines.append(f'final attitude (w, x, y, z) at stamp {result.final_stamp_ns * 1e-9:.9f} '
                     f's: {w:.12f} {x:.12f} {y:.12f} {z:.12f}')
    lines.append(f'final state: {result.final_state}')
    if result.alignment_stamp_ns is not None:
        lines.append(f'attitude set from the ground truth at stamp '
                     f'{result.alignment_stamp_ns * 1e-9:.9f} s')
    if result.errors is not None:
        lines.append(f'attitude error vs ground truth: {result.errors.text()}')
    if result.elapsed > 0.0 and result.gyro_messages:
        lines.append(f'{result.gyro_messages} gyro messages in {result.elapsed:.3f} s '
                     f'({result.gyro_messages / result.elapsed:,.0f} per second)')
    return '\n'.join(lines)


def _stamp_text(stamp_ns: int) -> str:
    sec, nanosec = split_ns(stamp_ns)
    return f'{sec}.{nanosec:09d}'


def write_csv(result: ReplayResult, path: Path) -> None:
    """One row per attitude output; a dynamics scene's rows also have the energy and momentum
    published at that stamp (a gyro scene simulates no body: no such columns)."""
    stamps, attitudes, positions = result.series.attitude_array()
    body = result.scene.rate_source == 'dynamics'
    invariant_stamps, energies, momenta = result.series.invariant_array()
    invariants = {int(s): (e, m) for s, e, m in zip(invariant_stamps.tolist(),
                                                    energies.tolist(), momenta.tolist())}
    with open(path, 'w', newline='', encoding='utf-8') as stream:
        out = csv.writer(stream)
        out.writerow(['stamp_s', 'qw', 'qx', 'qy', 'qz', 'px', 'py', 'pz']
                     + (['energy_J', 'Hx', 'Hy', 'Hz'] if body else []))
        for stamp, q, p in zip(stamps.tolist(), attitudes.tolist(), positions.tolist()):
            published = invariants.get(stamp)
            extra = ([repr(published[0]), *map(repr, published[1])] if published is not None
                     else ['', '', '', ''])
            out.writerow([_stamp_text(stamp), *map(repr, q), *map(repr, p),
                          *(extra if body else [])])


def write_error_csv(errors: ErrorStatistics, path: Path) -> None:
    """The attitude error at each ground-truth stamp compared."""
    with open(path, 'w', newline='', encoding='utf-8') as stream:
        out = csv.writer(stream)
        out.writerow(['stamp_s', 'attitude_error_rad'])
        for stamp, error in zip(errors.stamps_ns.tolist(), errors.errors.tolist()):
            out.writerow([_stamp_text(stamp), repr(error)])


def write_plot(result: ReplayResult, path: Path) -> None:
    """PNG: attitude error [deg] and (dynamics scenes) kinetic energy [J] against time [s]."""
    import matplotlib
    matplotlib.use('Agg')
    from matplotlib import pyplot
    invariant_stamps, energies, _ = result.series.invariant_array()
    errors = result.errors if result.errors is not None and result.errors.count else None
    origin = int(errors.stamps_ns[0] if errors is not None
                 else (invariant_stamps[0] if invariant_stamps.size else 0))
    body = result.scene.rate_source == 'dynamics'
    figure, axes = pyplot.subplots(2 if body else 1, 1, sharex=True,
                                   figsize=(9, 6 if body else 3.5), squeeze=False)
    error_axes = axes[0][0]
    if errors is not None:
        error_axes.plot((errors.stamps_ns - origin) * 1e-9, np.degrees(errors.errors),
                        linewidth=0.8)
    error_axes.set_ylabel('attitude error [deg]')
    error_axes.set_title(f'{result.input_path.name}: scene {result.scene.name}, '
                         f'{result.scene.integrator}')
    error_axes.grid(True, alpha=0.3)
    if body:
        energy_axes = axes[1][0]
        energy_axes.plot((invariant_stamps - origin) * 1e-9, energies, linewidth=0.8)
        energy_axes.set_ylabel('kinetic energy [J]')
        energy_axes.grid(True, alpha=0.3)
    axes[-1][0].set_xlabel(f'time since stamp {origin * 1e-9:.3f} s [s]')
    figure.tight_layout()
    figure.savefig(path, dpi=120)
    pyplot.close(figure)
