"""The gyro loop and the sender threads on different CPUs, or not: the same-run comparisons.

Reads the interleaved runs of ``results/node/cpu_split/ab_<n>.json`` (``node_throughput.py
--repeats``), takes every window at 10–20 kHz of the two variants (the labels differ between
runs: :data:`VARIANTS`) and prints, per rate and variant, the number of windows, the median and
mean of their p99 latency, how many were over 1 ms, the median and largest maximum latency and
the median CPU (% of a core). Findings in ``NOTES.md``, section 17; the figures in
``rigid_body_attitude/ros/cpu_split.py`` and the README come from here.

Usage: ``python bench/cpu_split_ab.py [--results-dir DIR]``
"""

import argparse
import json
from pathlib import Path
import statistics
from typing import Dict, List

BENCH = Path(__file__).resolve().parent

#: Run → target label → variant. Run 1: the split as a prototype at every rate
#: (``prototype.diff``) against the node of that day; runs 2 and 3: the node with its split
#: above 8 kHz against the same node with ``separate_cpus_above_hz:=0.0``.
VARIANTS = {
    'ab_1.json': {'split': 'split', 'node': 'no split'},
    'ab_2.json': {'node': 'split', 'no_split': 'no split'},
    'ab_3.json': {'node': 'split', 'no_split': 'no split'},
}

RATES = (10000.0, 15000.0, 20000.0)


def pooled_windows(folder: Path) -> Dict[tuple, List[dict]]:
    """(variant, rate) → the windows of every run."""
    windows: Dict[tuple, List[dict]] = {}
    for name, labels in VARIANTS.items():
        run = json.loads((folder / name).read_text())
        for label, variant in labels.items():
            for row in run['targets'][label]['rows']:
                if row['rate_hz'] in RATES:
                    windows.setdefault((variant, row['rate_hz']), []).extend(row['windows'])
    return windows


def table(windows: Dict[tuple, List[dict]]) -> List[str]:
    """The comparison as a Markdown table."""
    lines = ['| rate (Hz) | variant | windows | p99 median (ms) | p99 mean | over 1 ms '
             '| max median (ms) | max largest | CPU median (%) |',
             '|---|---|---|---|---|---|---|---|---|']
    for rate in RATES:
        for variant in ('split', 'no split'):
            chosen = windows[(variant, rate)]
            p99 = [window['latency_p99_ms'] for window in chosen]
            largest = [window['latency_max_ms'] for window in chosen]
            cpu = [window['cpu_percent'] for window in chosen]
            lines.append(
                f'| {rate:.0f} | {variant} | {len(chosen)} | {statistics.median(p99):.2f} '
                f'| {statistics.fmean(p99):.2f} | {sum(value > 1.0 for value in p99)} '
                f'| {statistics.median(largest):.1f} | {max(largest):.1f} '
                f'| {statistics.median(cpu):.1f} |')
    return lines


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--results-dir', type=Path,
                        default=BENCH / 'results' / 'node' / 'cpu_split')
    args = parser.parse_args()
    print('\n'.join(table(pooled_windows(args.results_dir))))


if __name__ == '__main__':
    main()
