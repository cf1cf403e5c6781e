"""Explain the slow spells of kept benchmark windows from their poses and thread samples.

Reads the ``NAME.poses.bin`` and ``NAME.threads.npz`` that ``node_throughput.py
--keep-traces DIR --sample-threads MS`` keeps for each window. A *spell* is a run of poses
slower than ``--over`` ms whose stamps lie at most ``--join`` ms apart. For each window with
a spell it prints the spells with the most slow poses, each with:

* its start (s after the first thread sample), length, slow poses and worst latency;
* the publisher's largest gap between two consecutive stamps in it, minus the nominal period
  (the bench publisher was that late: it stamps at publish time);
* the sampler's largest lateness in it (``_thread_sampler.py``): another process of the
  bench, so a late sampler beside a late publisher is the whole machine stalled;
* for every thread that ran at least 1 % of a core in the window: its run time and its
  run-queue wait in % of a core over the spell, beside the same over the window (first
  sample to last publish; poses stamped before the sampler started are left out). A
  thread that waits far more than usual did not get a CPU; one that runs far more spins.

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
from typing import List, Optional, Tuple

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


def percent_between(times_ns: np.ndarray, cumulative_ns: np.ndarray, start_ns: int,
                    end_ns: int) -> np.ndarray:
    """% of one core each column of ``cumulative_ns`` grew by between the samples
    bracketing ``start_ns`` .. ``end_ns``."""
    first = max(0, int(np.searchsorted(times_ns, start_ns, side='right')) - 1)
    last = min(times_ns.size - 1, int(np.searchsorted(times_ns, end_ns, side='left')))
    if last <= first:
        last = min(times_ns.size - 1, first + 1)
    span = max(1, int(times_ns[last] - times_ns[first]))
    return 100.0 * (cumulative_ns[last] - cumulative_ns[first]) / span


def describe_window(name: str, poses: Path, samples: Optional[Path], rate_hz: float,
                    args: argparse.Namespace) -> List[str]:
    """The lines for one window (none when it has no spell)."""
    data = np.fromfile(poses, dtype='<i8')
    stamps, arrivals = data[:data.size // 2], data[data.size // 2:]
    order = np.argsort(stamps, kind='stable')
    stamps, arrivals = stamps[order], arrivals[order]
    threads = np.load(samples) if samples is not None and samples.exists() else None
    if threads is not None:  # the sampled span: the measured window and the drain
        inside = (stamps >= threads['t_ns'][0]) & (stamps <= threads['t_ns'][-1])
        stamps, arrivals = stamps[inside], arrivals[inside]
    latency_ms = (arrivals - stamps) * 1e-6
    found = spells(stamps, latency_ms, args.over, args.join)
    if not found:
        return []
    found.sort(key=lambda spell: -int(np.count_nonzero(
        latency_ms[spell[0]:spell[1] + 1] > args.over)))
    lines = [f'{name}: {len(found)} spells over {args.over:g} ms']
    origin = int(threads['t_ns'][0]) if threads is not None else int(stamps[0])
    if args.table:
        return [table_row(name, stamps, latency_ms, spell, origin, args.over, threads)
                for spell in found if threads is not None and np.count_nonzero(
                    latency_ms[spell[0]:spell[1] + 1] > args.over) >= args.min_slow]
    for first, last in found[:args.top]:
        lines.extend(describe_spell(stamps, latency_ms, (first, last), origin, rate_hz,
                                    args.over, threads))
    return lines


def describe_spell(stamps: np.ndarray, latency_ms: np.ndarray, spell: Tuple[int, int],
                   origin: int, rate_hz: float, over_ms: float,
                   threads: Optional[np.lib.npyio.NpzFile]) -> List[str]:
    """The lines for one spell (:func:`describe_window`)."""
    first, last = spell
    start_ns, end_ns = int(stamps[first]), int(stamps[last])
    gaps_ms = np.diff(stamps[max(0, first - 1):last + 1]) * 1e-6
    publisher_late = (gaps_ms.max() - 1e3 / rate_hz) if gaps_ms.size else 0.0
    slow = int(np.count_nonzero(latency_ms[first:last + 1] > over_ms))
    head = (f'  at {(start_ns - origin) * 1e-9:6.3f} s, {(end_ns - start_ns) * 1e-6:7.1f} ms, '
            f'{last - first + 1} poses ({slow} slow), worst '
            f'{latency_ms[first:last + 1].max():.2f} ms; publisher late '
            f'{publisher_late:.1f} ms')
    if threads is None:
        return [head]
    t_ns = threads['t_ns']
    inside = (t_ns >= start_ns) & (t_ns <= end_ns + int(latency_ms[last] * 1e6))
    period_ms = float(threads['period_ns']) * 1e-6
    intervals = np.diff(t_ns[inside]) * 1e-6
    late = intervals.max() - period_ms if intervals.size else 0.0
    lines = [head + f'; sampler late {late:.1f} ms']
    spell_end = end_ns + int(latency_ms[last] * 1e6)
    run_spell = percent_between(t_ns, threads['run_ns'], start_ns, spell_end)
    wait_spell = percent_between(t_ns, threads['wait_ns'], start_ns, spell_end)
    window = (int(t_ns[0]), int(stamps[-1]))  # from the first sample to the last publish
    run_all = percent_between(t_ns, threads['run_ns'], *window)
    wait_all = percent_between(t_ns, threads['wait_ns'], *window)
    for column in np.argsort(-run_all):
        if run_all[column] < 1.0 and run_spell[column] < 5.0:
            continue
        lines.append(f'    {threads["process"][column]:>10} {threads["name"][column]:<16} '
                     f'run {run_spell[column]:5.1f} % (window {run_all[column]:5.1f}), wait '
                     f'{wait_spell[column]:5.1f} % (window {wait_all[column]:5.1f})')
    return lines


TABLE_HEAD = ('| window | at (s) | ms | slow | worst (ms) | pub. late | sampler late | '
              'main run | main wait | sender run | all run |')


def table_row(name: str, stamps: np.ndarray, latency_ms: np.ndarray, spell: Tuple[int, int],
              origin: int, over_ms: float, threads: np.lib.npyio.NpzFile) -> str:
    """One spell as a table row (``--table``): thread figures in % of a core, the spell's
    then the window's; ``main`` is the target's first thread, ``sender`` its ``dds.asyn``
    threads, ``all`` every sampled thread of the three processes."""
    first, last = spell
    start_ns = int(stamps[first])
    end_ns = int(stamps[last]) + int(latency_ms[last] * 1e6)
    t_ns = threads['t_ns']
    period_ns = int(threads['period_ns'])
    inside = t_ns[(t_ns >= start_ns) & (t_ns <= end_ns)]
    sampler_late = (np.diff(inside).max() - period_ns) * 1e-6 if inside.size > 1 else 0.0
    gaps_ms = np.diff(stamps[max(0, first - 1):last + 1]) * 1e-6
    nominal_ms = float(np.median(np.diff(stamps))) * 1e-6
    publisher_late = gaps_ms.max() - nominal_ms if gaps_ms.size else 0.0
    target = np.flatnonzero(threads['process'] == 'target')
    senders = [column for column in target if str(threads['name'][column]).startswith('dds.asyn')]
    window = (int(t_ns[0]), int(stamps[-1]))

    def figures(key: str, columns: List[int]) -> str:
        spell_value = percent_between(t_ns, threads[key], start_ns, end_ns)[columns].sum()
        whole_value = percent_between(t_ns, threads[key], *window)[columns].sum()
        return f'{spell_value:.0f} ({whole_value:.0f})'
    every = list(range(threads['name'].size))
    slow = int(np.count_nonzero(latency_ms[first:last + 1] > over_ms))
    return (f'| {name} | {(start_ns - origin) * 1e-9:.2f} | {(end_ns - start_ns) * 1e-6:.0f} | '
            f'{slow} | {latency_ms[first:last + 1].max():.1f} | {publisher_late:.1f} | '
            f'{sampler_late:.1f} | {figures("run_ns", [target[0]])} | '
            f'{figures("wait_ns", [target[0]])} | '
            f'{figures("run_ns", senders) if senders else "-"} | {figures("run_ns", every)} |')


def rate_of(name: str) -> float:
    """The rate in a window's name (``node_15000_w2`` -> 15000)."""
    for word in name.split('_'):
        if word.isdigit():
            return float(word)
    raise SystemExit(f'error: no rate in the window name {name!r}')


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
                                        args.traces / f'{name}.threads.npz', rate_of(name),
                                        args):
                print(line)
    return 0


if __name__ == '__main__':
    sys.exit(main())
