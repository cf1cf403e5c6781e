"""Explain the slow spells of kept benchmark windows from their poses and thread samples.

Reads the ``NAME.poses.bin`` and ``NAME.threads.npz`` that ``node_throughput.py
--keep-traces DIR --sample-threads MS`` keeps for each window. A *spell* is a run of poses
slower than ``--over`` ms whose stamps lie at most ``--join`` ms apart. For each window with
a spell it prints the spells with the most slow poses, each with:

* its start (s after the first thread sample), length, slow poses and worst latency;
* the publisher's largest gap between two consecutive stamps in it, minus the window's median
  gap (the bench publisher was that late: it stamps at publish time);
* the sampler's largest lateness in it (``_thread_sampler.py``): another process of the
  bench, so a late sampler beside a late publisher is the whole machine stalled;
* for every thread that ran at least 1 % of a core in the window: its run time and its
  run-queue wait in % of a core over the spell, beside the same over the window (first
  sample to last publish; poses stamped before the sampler started are left out). A
  thread that waits far more than usual did not get a CPU; one that runs far more spins;
* when the samples have them (``cpu_ns``), the CPUs' idle time in % of a core (both CPUs
  together; from cpuidle's µs counters when sampled, else from ``/proc/stat``'s 10 ms ticks,
  too coarse for spells under about 50 ms), the busy time no sampled thread was charged for
  (the CPUs' busy time minus every sampled thread's run time: other processes, the kernel's
  threads, interrupts) and the steal time in ms over the spell, the first two also over the
  window: time stolen by the hypervisor is time the guest's threads could not run, whatever
  their priorities.

``--table`` prints one row per spell instead (:func:`table_row`).

Example::

    python bench/episodes.py /tmp/traces --over 1 --windows 'node_15000*'
    python bench/episodes.py /tmp/traces --table --min-slow 20 --windows 'node_*'
"""

from __future__ import annotations

import argparse
from fnmatch import fnmatch
from pathlib import Path
import sys
from typing import Dict, List, NamedTuple, Optional, Tuple

import numpy as np


def spells(stamps: np.ndarray, latency_ms: np.ndarray, over_ms: float,
           join_ms: float) -> List[Tuple[int, int]]:
    """Index ranges [first, last] into the stamp-sorted poses of the spells slower than
    ``over_ms``, joined when their slow poses lie at most ``join_ms`` apart."""
    slow = np.flatnonzero(latency_ms > over_ms)
    if slow.size == 0:
        return []
    breaks = np.flatnonzero(np.diff(stamps[slow]) > join_ms * 1e6)
    firsts = np.concatenate([[slow[0]], slow[breaks + 1]])
    lasts = np.concatenate([slow[breaks], [slow[-1]]])
    return list(zip(firsts.tolist(), lasts.tolist()))


#: A window's ``threads.npz`` (``bench/_thread_sampler.py``), every array read once.
Samples = Dict[str, np.ndarray]


def load_samples(path: Path) -> Samples:
    """The arrays of ``path`` (an ``NpzFile`` decompresses an array on every access)."""
    with np.load(path) as archive:
        return {key: archive[key] for key in archive.files}


def bracket(times_ns: np.ndarray, start_ns: int, end_ns: int) -> Tuple[int, int]:
    """Indices of the samples bracketing ``start_ns`` .. ``end_ns`` (at least one apart when
    there are two samples)."""
    first = max(0, int(np.searchsorted(times_ns, start_ns, side='right')) - 1)
    last = min(times_ns.size - 1, int(np.searchsorted(times_ns, end_ns, side='left')))
    if last <= first:
        last = min(times_ns.size - 1, first + 1)
    return first, last


def percent_between(times_ns: np.ndarray, cumulative_ns: np.ndarray, start_ns: int,
                    end_ns: int) -> np.ndarray:
    """% of one core each column of ``cumulative_ns`` grew by between the samples
    bracketing ``start_ns`` .. ``end_ns``."""
    first, last = bracket(times_ns, start_ns, end_ns)
    span = max(1, int(times_ns[last] - times_ns[first]))
    return 100.0 * (cumulative_ns[last] - cumulative_ns[first]) / span


class SpellFigures(NamedTuple):
    """What one spell measured (:func:`measure_spell`); thread figures in % of a core per
    sampled thread, over the spell and over the window."""

    start_ns: int
    last_stamp_ns: int
    end_ns: int  # the last slow pose's arrival
    poses: int
    slow: int
    worst_ms: float
    publisher_late_ms: float
    sampler_late_ms: Optional[float]
    run_spell: Optional[np.ndarray]
    wait_spell: Optional[np.ndarray]
    run_window: Optional[np.ndarray]
    wait_window: Optional[np.ndarray]
    cpu_spell: Optional[Dict[str, float]]  # idle, unsampled (% of a core), steal (ms)
    cpu_window: Optional[Dict[str, float]]


def cpu_figures(threads: Samples, start_ns: int, end_ns: int,
                ran: np.ndarray) -> Optional[Dict[str, float]]:
    """Idle and unsampled busy time (% of a core) and steal (ms) of all CPUs together
    between the samples bracketing ``start_ns`` .. ``end_ns``, where the sampled threads
    ran ``ran`` (% of a core each, :func:`percent_between`); None for samples without
    ``cpu_ns``."""
    if 'cpu_ns' not in threads:
        return None
    t_ns, fields = threads['t_ns'], list(threads['cpu_fields'])
    totals = threads['cpu_ns'].sum(axis=1)  # samples × fields
    cpus = threads['cpu_ns'].shape[1]
    idle_ns = (threads['cpuidle_ns'].sum(axis=1) if 'cpuidle_ns' in threads
               else totals[:, fields.index('idle')])
    idle = float(percent_between(t_ns, idle_ns, start_ns, end_ns))
    steal_ns = totals[:, fields.index('steal')]
    first, last = bracket(t_ns, start_ns, end_ns)
    return {'idle': idle, 'unsampled': 100.0 * cpus - idle - float(ran.sum()),
            'steal': float(steal_ns[last] - steal_ns[first]) * 1e-6}


def measure_spell(stamps: np.ndarray, latency_ms: np.ndarray, spell: Tuple[int, int],
                  over_ms: float, threads: Optional[Samples]) -> SpellFigures:
    """The figures of one spell: the publisher's lateness is its largest stamp gap in the
    spell minus the window's median gap; the window runs from the first thread sample to the
    last publish."""
    first, last = spell
    start_ns, last_stamp_ns = int(stamps[first]), int(stamps[last])
    end_ns = last_stamp_ns + int(latency_ms[last] * 1e6)
    gaps_ms = np.diff(stamps[max(0, first - 1):last + 1]) * 1e-6
    nominal_ms = float(np.median(np.diff(stamps))) * 1e-6
    spell_ms = latency_ms[first:last + 1]
    common = (start_ns, last_stamp_ns, end_ns, last - first + 1,
              int(np.count_nonzero(spell_ms > over_ms)), float(spell_ms.max()),
              gaps_ms.max() - nominal_ms if gaps_ms.size else 0.0)
    if threads is None:
        return SpellFigures(*common, None, None, None, None, None, None, None)
    t_ns = threads['t_ns']
    inside = t_ns[(t_ns >= start_ns) & (t_ns <= end_ns)]
    sampler_late = ((np.diff(inside).max() - int(threads['period_ns'])) * 1e-6
                    if inside.size > 1 else 0.0)
    window = (int(t_ns[0]), int(stamps[-1]))
    run_spell = percent_between(t_ns, threads['run_ns'], start_ns, end_ns)
    run_window = percent_between(t_ns, threads['run_ns'], *window)
    return SpellFigures(
        *common, sampler_late, run_spell,
        percent_between(t_ns, threads['wait_ns'], start_ns, end_ns), run_window,
        percent_between(t_ns, threads['wait_ns'], *window),
        cpu_figures(threads, start_ns, end_ns, run_spell),
        cpu_figures(threads, *window, run_window))


def describe_window(name: str, poses: Path, samples: Optional[Path],
                    args: argparse.Namespace) -> List[str]:
    """The lines for one window (none when it has no spell)."""
    data = np.fromfile(poses, dtype='<i8')
    stamps, arrivals = data[:data.size // 2], data[data.size // 2:]
    order = np.argsort(stamps, kind='stable')
    stamps, arrivals = stamps[order], arrivals[order]
    threads = load_samples(samples) if samples is not None and samples.exists() else None
    if threads is not None:  # the sampled span: the measured window and the drain
        inside = (stamps >= threads['t_ns'][0]) & (stamps <= threads['t_ns'][-1])
        stamps, arrivals = stamps[inside], arrivals[inside]
    latency_ms = (arrivals - stamps) * 1e-6
    measured = [measure_spell(stamps, latency_ms, spell, args.over, threads)
                for spell in spells(stamps, latency_ms, args.over, args.join)]
    if not measured:
        return []
    measured.sort(key=lambda figures: -figures.slow)
    origin = int(threads['t_ns'][0]) if threads is not None else int(stamps[0])
    if args.table:
        return [table_row(name, figures, origin, threads) for figures in measured
                if threads is not None and figures.slow >= args.min_slow]
    lines = [f'{name}: {len(measured)} spells over {args.over:g} ms']
    for figures in measured[:args.top]:
        lines.extend(describe_spell(figures, origin, threads))
    return lines


def describe_spell(figures: SpellFigures, origin: int,
                   threads: Optional[Samples]) -> List[str]:
    """The lines for one spell (:func:`describe_window`)."""
    head = (f'  at {(figures.start_ns - origin) * 1e-9:6.3f} s, '
            f'{(figures.last_stamp_ns - figures.start_ns) * 1e-6:7.1f} ms, {figures.poses} '
            f'poses ({figures.slow} slow), worst {figures.worst_ms:.2f} ms; publisher late '
            f'{figures.publisher_late_ms:.1f} ms')
    if threads is None:
        return [head]
    lines = [head + f'; sampler late {figures.sampler_late_ms:.1f} ms']
    if figures.cpu_spell is not None and figures.cpu_window is not None:
        spell, window = figures.cpu_spell, figures.cpu_window
        lines.append(f'    CPUs idle {spell["idle"]:5.1f} % (window {window["idle"]:5.1f}), '
                     f'busy unsampled {spell["unsampled"]:5.1f} % (window '
                     f'{window["unsampled"]:5.1f}), steal {spell["steal"]:.0f} ms (window '
                     f'{window["steal"]:.0f})')
    run_spell, wait_spell = figures.run_spell, figures.wait_spell
    run_all, wait_all = figures.run_window, figures.wait_window
    for column in np.argsort(-run_all):
        if run_all[column] < 1.0 and run_spell[column] < 5.0:
            continue
        lines.append(f'    {threads["process"][column]:>10} {threads["name"][column]:<16} '
                     f'run {run_spell[column]:5.1f} % (window {run_all[column]:5.1f}), wait '
                     f'{wait_spell[column]:5.1f} % (window {wait_all[column]:5.1f})')
    return lines


TABLE_HEAD = ('| window | at (s) | ms | slow | worst (ms) | pub. late | sampler late | '
              'main run | main wait | sender run | all run | idle | unsampled | steal (ms) |')


def table_row(name: str, figures: SpellFigures, origin: int,
              threads: Samples) -> str:
    """One spell as a table row (``--table``): thread figures in % of a core, the spell's
    then the window's; ``main`` is the target's first thread, ``sender`` its ``dds.asyn``
    threads, ``all`` every sampled thread of the three processes."""
    target = np.flatnonzero(threads['process'] == 'target')
    senders = [column for column in target if str(threads['name'][column]).startswith('dds.asyn')]

    def both(spell: np.ndarray, window: np.ndarray, columns: List[int]) -> str:
        return f'{spell[columns].sum():.0f} ({window[columns].sum():.0f})'
    run = (figures.run_spell, figures.run_window)
    every = list(range(threads['name'].size))
    return (f'| {name} | {(figures.start_ns - origin) * 1e-9:.2f} | '
            f'{(figures.end_ns - figures.start_ns) * 1e-6:.0f} | {figures.slow} | '
            f'{figures.worst_ms:.1f} | {figures.publisher_late_ms:.1f} | '
            f'{figures.sampler_late_ms:.1f} | {both(*run, [target[0]])} | '
            f'{both(figures.wait_spell, figures.wait_window, [target[0]])} | '
            f'{both(*run, senders) if senders else "-"} | {both(*run, every)} | '
            f'{_cpu_cells(figures)} |')


def _cpu_cells(figures: SpellFigures) -> str:
    """The idle and unsampled busy (spell and window, % of a core) and steal (ms) cells of a
    table row."""
    spell, window = figures.cpu_spell, figures.cpu_window
    if spell is None or window is None:
        return '- | - | -'
    return (f'{spell["idle"]:.0f} ({window["idle"]:.0f}) | {spell["unsampled"]:.0f} '
            f'({window["unsampled"]:.0f}) | {spell["steal"]:.0f}')


def main(argv: Optional[List[str]] = None) -> int:
    """Print every matching window's spells."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('traces', type=Path, help='the --keep-traces directory')
    parser.add_argument('--over', type=float, default=1.0, help='slow means over this (ms)')
    parser.add_argument('--join', type=float, default=50.0,
                        help='slow poses at most this far apart (ms) are one spell')
    parser.add_argument('--top', type=int, default=3, help='spells shown per window')
    parser.add_argument('--windows', default='*', help='glob over window names')
    parser.add_argument('--table', action='store_true',
                        help='one table row per spell with at least --min-slow slow poses')
    parser.add_argument('--min-slow', type=int, default=20)
    args = parser.parse_args(argv)
    if args.table:
        print(TABLE_HEAD + '\n' + '|---' * TABLE_HEAD.count(' | ') + '|---|')
    names = sorted(path.name[:-len('.poses.bin')] for path in args.traces.glob('*.poses.bin'))
    if not names:
        print(f'error: no *.poses.bin in {args.traces}', file=sys.stderr)
        return 1
    for name in names:
        if fnmatch(name, args.windows):
            for line in describe_window(name, args.traces / f'{name}.poses.bin',
                                        args.traces / f'{name}.threads.npz', args):
                print(line)
    return 0


if __name__ == '__main__':
    sys.exit(main())
