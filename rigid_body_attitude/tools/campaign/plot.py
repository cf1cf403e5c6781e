"""The campaign's summary figure: dispersion envelopes of every metric over time (PNG)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from rigid_body_attitude.tools.campaign.statistics import METRICS, UNITS

__all__ = ['write_envelopes']


def write_envelopes(path: Path, times: NDArray[np.float64], percentiles: tuple[float, ...],
                    table: dict[str, NDArray[np.float64]], title: str) -> None:
    """One panel per metric: the band between the lowest and highest requested percentile,
    and each percentile as a line, over the output times."""
    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt

    figure, axes = plt.subplots(len(METRICS), 1, figsize=(8, 2.2 * len(METRICS)), sharex=True)
    order = np.argsort(percentiles)
    for axis, name in zip(axes, METRICS):
        values = table[name]
        low, high = values[order[0]], values[order[-1]]
        axis.fill_between(times, low, high, alpha=0.25, color='tab:blue',
                          label=f'p{percentiles[order[0]]:g}–p{percentiles[order[-1]]:g}')
        for index in order:
            axis.plot(times, values[index], linewidth=1.0,
                      label=f'p{percentiles[index]:g}')
        axis.set_ylabel(f'{name}\n[{UNITS[name]}]', fontsize=8)
        axis.grid(True, alpha=0.3)
    axes[0].legend(fontsize=7, ncol=len(percentiles) + 1, loc='upper left')
    axes[0].set_title(title)
    axes[-1].set_xlabel('time [s]')
    figure.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    figure.savefig(path, dpi=100)
    plt.close(figure)
