"""Fleet replay: many bags through :func:`~rigid_body_attitude.tools.replay.replay_bag`, as
Dask tasks, one row per bag in one table.

Bags are named by a folder (its bags: sub-folders with ``metadata.yaml``, ``.db3`` and
``.mcap`` files) or a glob pattern. Each bag is replayed with the same options into
``OUT/<bag name>_replayed``; a ground-truth topic is compared where the bag has it and skipped
where it does not. A bag that cannot be replayed (unreadable, wrong topics) gives a row with
its error, and the others go on. The table (:data:`COLUMNS`) is printed and written to
``OUT/fleet.csv``; the energy and momentum drift columns (:data:`DYNAMICS_COLUMNS`) are left
out for a gyro scene, which simulates no body.
"""

from __future__ import annotations

import csv
import glob
import math
import time
from collections.abc import Sequence
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np

from rigid_body_attitude.bag import BagReader
from rigid_body_attitude.core.errors import AttitudeError, InputError
from rigid_body_attitude.tools.cluster import dask_client
from rigid_body_attitude.tools.replay.options import ReplayOptions
from rigid_body_attitude.tools.replay.run import ReplayResult, replay_bag

__all__ = ['COLUMNS', 'DYNAMICS_COLUMNS', 'find_bags', 'format_table', 'replay_fleet',
           'replay_one', 'table_columns']

COLUMNS = ('bag', 'status', 'gyro_messages', 'used', 'rejected', 'energy_drift',
           'momentum_drift', 'truth_samples', 'error_max_deg', 'error_mean_deg',
           'error_rms_deg', 'error_final_deg', 'seconds', 'output', 'error')
#: The columns of a dynamics scene only (a gyro scene simulates no body).
DYNAMICS_COLUMNS = ('energy_drift', 'momentum_drift')
_BAG_SUFFIXES = ('.db3', '.mcap')


def _is_bag_folder(path: Path) -> bool:
    return path.is_dir() and (path / 'metadata.yaml').is_file()


def find_bags(pattern: str) -> list[Path]:
    """The bags of a folder (or the folder itself if it is one bag), or of a glob pattern,
    sorted; :class:`InputError` when there are none."""
    path = Path(pattern).expanduser()
    if _is_bag_folder(path):
        return [path]
    if path.is_dir():
        candidates = sorted(path.iterdir())
    else:
        candidates = [Path(name) for name in sorted(glob.glob(str(path)))]
    bags = [item for item in candidates
            if _is_bag_folder(item) or (item.is_file() and item.suffix in _BAG_SUFFIXES
                                        and not (item.parent / 'metadata.yaml').is_file())]
    bags += sorted({item.parent for item in candidates
                    if item.is_file() and item.suffix in _BAG_SUFFIXES
                    and _is_bag_folder(item.parent) and item.parent not in bags})
    if not bags:
        raise InputError(f'No bag in {pattern!r} (a bag folder with metadata.yaml, a .db3 or '
                         f'.mcap file, a folder of them or a glob pattern)')
    return sorted(bags)


def _output_names(bags: Sequence[Path]) -> list[str]:
    """``<name>_replayed`` per bag; bags of the same name get their position as a prefix."""
    stems = [bag.stem if bag.is_file() else bag.name for bag in bags]
    return [f'{stem}_replayed' if stems.count(stem) == 1 else f'{index:04d}_{stem}_replayed'
            for index, stem in enumerate(stems)]


def _row(bag: Path, result: ReplayResult, seconds: float) -> dict[str, Any]:
    errors = result.errors
    degrees = np.degrees(errors.errors) if errors is not None and errors.count else None
    drifts = {} if result.scene.rate_source != 'dynamics' else {
        'energy_drift': result.diagnostics.energy_drift,
        'momentum_drift': result.diagnostics.momentum_drift}
    return {
        'bag': str(bag), 'status': 'ok', 'gyro_messages': result.gyro_messages,
        'used': result.used, 'rejected': sum(result.rejected.values()), **drifts,
        'truth_samples': 0 if errors is None else errors.count,
        'error_max_deg': math.nan if degrees is None else float(degrees.max()),
        'error_mean_deg': math.nan if degrees is None else float(degrees.mean()),
        'error_rms_deg': math.nan if degrees is None else float(np.sqrt(np.mean(degrees ** 2))),
        'error_final_deg': math.nan if degrees is None else float(degrees[-1]),
        'seconds': seconds, 'output': str(result.output_path), 'error': ''}


def replay_one(bag: str | Path, output: str | Path,
               options: ReplayOptions = ReplayOptions()) -> dict[str, Any]:
    """Replay one bag (the ground truth only if the bag has its topic); a row of
    :data:`COLUMNS`, with ``status`` ``error`` and the message when the bag cannot be
    replayed."""
    begin = time.perf_counter()
    bag = Path(bag)
    try:
        if options.ground_truth_topic:
            with BagReader(bag) as reader:
                if options.ground_truth_topic not in reader.topics:
                    options = replace(options, ground_truth_topic='',
                                      start_from_ground_truth=None)
        result = replay_bag(bag, output, options, progress=False, keep_series=False)
    except (AttitudeError, OSError, UnicodeError) as err:
        text = str(err).splitlines()[0] if str(err) else type(err).__name__
        row: dict[str, Any] = {name: math.nan for name in COLUMNS
                               if name not in DYNAMICS_COLUMNS}
        row.update(bag=str(bag), status='error', output='', error=text,
                   seconds=time.perf_counter() - begin)
        return row
    return _row(bag, result, time.perf_counter() - begin)


def replay_fleet(bags: Sequence[str | Path], out: str | Path,
                 options: ReplayOptions = ReplayOptions(), *, scheduler: str = '',
                 workers: int = 0, client: Any = None, serial: bool = False,
                 progress: bool | None = False) -> list[dict[str, Any]]:
    """Replay ``bags`` into the folder ``out`` (one output bag each) as Dask tasks (or in
    this process with ``serial``); the rows (:data:`COLUMNS`) in the bags' order, also
    written to ``out/fleet.csv``."""
    from tqdm import tqdm
    paths = [Path(bag) for bag in bags]
    folder = Path(out)
    folder.mkdir(parents=True, exist_ok=True)
    outputs = [folder / name for name in _output_names(paths)]
    rows: list[dict[str, Any]] = []
    bar = tqdm(total=len(paths), unit='bag', disable=None if progress is None else not progress)
    try:
        if serial:
            for bag, output in zip(paths, outputs):
                rows.append(replay_one(bag, output, options))
                bar.update(1)
        elif client is not None:
            rows = _on_cluster(client, paths, outputs, options, bar)
        else:
            with dask_client(scheduler, workers or min(len(paths), 64)) as own:
                rows = _on_cluster(own, paths, outputs, options, bar)
    finally:
        bar.close()
    write_table(rows, folder / 'fleet.csv')
    return rows


def _on_cluster(client: Any, paths: list[Path], outputs: list[Path], options: ReplayOptions,
                bar: Any) -> list[dict[str, Any]]:
    from distributed import as_completed
    futures = {client.submit(replay_one, str(bag), str(output), options, pure=False): index
               for index, (bag, output) in enumerate(zip(paths, outputs))}
    rows: list[dict[str, Any]] = [{} for _ in paths]
    for future in as_completed(futures):
        rows[futures[future]] = future.result()
        bar.update(1)
    return rows


def table_columns(rows: Sequence[dict[str, Any]]) -> list[str]:
    """:data:`COLUMNS`, without :data:`DYNAMICS_COLUMNS` unless a row has them (a bag
    replayed with a dynamics scene)."""
    dynamics = any(name in row for row in rows for name in DYNAMICS_COLUMNS)
    return [name for name in COLUMNS if dynamics or name not in DYNAMICS_COLUMNS]


def write_table(rows: Sequence[dict[str, Any]], path: Path) -> None:
    """The rows as CSV (:func:`table_columns`)."""
    columns = table_columns(rows)
    with path.open('w', newline='') as file:
        writer = csv.DictWriter(file, fieldnames=columns)
        writer.writeheader()
        for row in rows:
            writer.writerow({name: row.get(name, '') for name in columns})


def _cell(value: Any) -> str:
    if isinstance(value, float):
        return '-' if math.isnan(value) else f'{value:.4g}'
    return str(value)


def format_table(rows: Sequence[dict[str, Any]]) -> str:
    """A Markdown table of the rows (errors last)."""
    shown = [name for name in table_columns(rows) if name != 'output']
    lines = ['| ' + ' | '.join(shown) + ' |', '|' + '---|' * len(shown)]
    for row in rows:
        lines.append('| ' + ' | '.join(_cell(row.get(name, '')) for name in shown) + ' |')
    return '\n'.join(lines)
