"""Running a campaign: chunks of runs as Dask tasks (or in this process), results kept.

:func:`run_campaign` splits the runs into chunks of ``spec.chunk`` consecutive runs, skips
the chunks already in the results folder (:class:`.ChunkStore`), and runs the others with
:func:`.run_chunk`: as tasks of a ``dask.distributed`` cluster (a :class:`LocalCluster` of
one single-threaded worker process per CPU by default, or the scheduler at ``scheduler``),
or one after the other in this process (``serial``). Each chunk's result comes back to this
process, which writes it: workers need no shared file system, and a chunk is written once
however often Dask ran it (a task whose worker died is run again elsewhere by the scheduler,
so no run is lost, and a chunk written already is never written again, so none is
duplicated). Then the runs are gathered (the chunks this call computed from memory, the
resumed ones read back), checked (every run exactly once) and summarised:
``statistics.csv``, ``summary.json``, ``summary.png`` (:mod:`.storage`).
"""

from __future__ import annotations

import csv
import json
import math
import shutil
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from rigid_body_attitude.core.errors import AttitudeError
from rigid_body_attitude.tools.cluster import (
    dask_client, default_workers, LOCAL_CLUSTER_CONFIG, local_cluster)
from rigid_body_attitude.tools.campaign.budget import estimate
from rigid_body_attitude.tools.campaign.plot import write_envelopes
from rigid_body_attitude.tools.campaign.runner import FAILURE_REASONS, run_chunk
from rigid_body_attitude.tools.campaign.spec import CampaignSpec
from rigid_body_attitude.tools.campaign.statistics import (
    ACTUATORS, CLOSED_LOOP, METRICS, percentile_table)
from rigid_body_attitude.tools.campaign.storage import ChunkStore, spec_digest

__all__ = ['CampaignError', 'CampaignResult', 'LOCAL_CLUSTER_CONFIG', 'chunk_runs',
           'dask_client', 'default_workers', 'local_cluster', 'read_runs', 'run_campaign']

#: Failed runs listed in ``summary.json`` at most (all are in the chunk files).
MAX_LISTED_FAILURES = 1000
_PARAMETER_PREFIXES = ('attitude0', 'omega_body0', 'inertia', 'effect.', 'commands')


class CampaignError(AttitudeError):
    """A campaign cannot run: no scheduler, a task that failed on every try, lost results."""


@dataclass
class CampaignResult:
    """What a campaign produced.

    Attributes:
        folder: the results folder; runs, failed: counts.
        chunks_run, chunks_resumed: chunks computed in this call and found finished already.
        elapsed: seconds of computing (chunks) and of the whole call.
        times: ``0`` and the output times [s]; statistics: percentiles (P, T) per metric.
        failures: failed runs by reason.
        closed_loop: with a controller, :func:`closed_loop_summary` (else empty).
        actuators: with wheels or magnetorquers, the percentiles of their per-run results
            (:data:`.statistics.ACTUATORS`) (else empty).
    """

    folder: Path
    runs: int
    failed: int
    chunks_run: int
    chunks_resumed: int
    compute_seconds: float
    total_seconds: float
    times: NDArray[np.float64]
    statistics: dict[str, NDArray[np.float64]] = field(default_factory=dict)
    failures: dict[str, int] = field(default_factory=dict)
    closed_loop: dict[str, Any] = field(default_factory=dict)
    actuators: dict[str, list[float]] = field(default_factory=dict)


def chunk_runs(spec: CampaignSpec) -> list[range]:
    """The run indices of each chunk (ranges: a task receives two numbers, not its runs)."""
    return [range(start, min(start + spec.chunk, spec.runs))
            for start in range(0, spec.runs, spec.chunk)]


def _progress(enabled: bool | None, spec: CampaignSpec, done: int) -> Any:
    from tqdm import tqdm
    return tqdm(total=spec.runs, initial=done, unit='run', unit_scale=True, file=sys.stderr,
                disable=None if enabled is None else not enabled, mininterval=0.5,
                desc=spec.name)


def run_campaign(spec: CampaignSpec, out: str | Path, *, scheduler: str = '',
                 workers: int = 0, client: Any = None, serial: bool = False,
                 progress: bool | None = False, plot: bool = True) -> CampaignResult:
    """Run (or resume) ``spec`` into the folder ``out``; see the module.

    ``client``: an existing ``distributed.Client`` (else one of ``scheduler`` or a local
    cluster of ``workers`` processes); ``serial``: no Dask at all. ``progress``: a bar on
    stderr (``None``: on a terminal only). ``plot``: write ``summary.png``.
    """
    begin = time.perf_counter()
    store = ChunkStore(out, spec)
    chunks = chunk_runs(spec)
    pending = [index for index in range(len(chunks)) if not store.done(index)]
    _check_disk(store.folder, spec, sum(len(chunks[index]) for index in pending))
    bar = _progress(progress, spec, spec.runs - sum(len(chunks[index]) for index in pending))
    kept: dict[int, dict[str, NDArray[Any]]] = {}
    try:
        if serial:
            for index in pending:
                kept[index] = run_chunk(spec, chunks[index])
                store.write(index, kept[index])
                bar.update(len(chunks[index]))
        elif client is not None:
            _run_on(client, spec, store, chunks, pending, bar, kept)
        elif pending:
            with dask_client(scheduler, workers) as own:
                _run_on(own, spec, store, chunks, pending, bar, kept)
    except BaseException:
        store.abandon()
        raise
    finally:
        bar.close()
    compute = time.perf_counter() - begin
    result = summarise(spec, store, len(chunks), plot, kept)
    result.chunks_run, result.chunks_resumed = len(pending), len(chunks) - len(pending)
    result.compute_seconds, result.total_seconds = compute, time.perf_counter() - begin
    return result


def _check_disk(folder: Path, spec: CampaignSpec, runs: int) -> None:
    """Refuse when the file system of ``folder`` lacks room for the rows of ``runs`` runs
    (and as much again for the summary's margin)."""
    existing = folder.absolute()
    while not existing.exists() and existing != existing.parent:
        existing = existing.parent
    need = 2 * estimate(spec).row_bytes * runs
    free = shutil.disk_usage(existing).free
    if need > free:
        raise CampaignError(f'--out {str(folder)!r}: {runs} runs need about {need / 2 ** 20:.3g}'
                            f' MiB on disk; {free / 2 ** 20:.3g} MiB free')


def _run_on(client: Any, spec: CampaignSpec, store: ChunkStore,
            chunks: list[range], pending: list[int], bar: Any,
            kept: dict[int, dict[str, NDArray[Any]]]) -> None:
    """Submit the pending chunks; write each result as it arrives (and keep it in
    ``kept``)."""
    from distributed import as_completed
    token = spec_digest(spec)[:16]
    shared = client.scatter(spec, broadcast=True)
    futures = {client.submit(run_chunk, shared, chunks[index], pure=False,
                             key=f'campaign-{token}-chunk-{index}'): index
               for index in pending}
    for future in as_completed(futures):
        index = futures[future]
        try:
            columns = future.result()
        except Exception as err:  # noqa: B902 - whatever the task raised, after Dask's retries
            raise CampaignError(f'Chunk {index} failed: {type(err).__name__}: '
                                f'{str(err).splitlines()[0] if str(err) else ""}; the '
                                f'finished chunks are kept, run again to resume') from None
        if not store.done(index):
            store.write(index, columns)
        kept[index] = columns
        bar.update(len(chunks[index]))
        future.release()


def read_runs(folder: str | Path, spec: CampaignSpec,
              kept: dict[int, dict[str, NDArray[Any]]] | None = None) -> dict[str, NDArray[Any]]:
    """Every run of a finished campaign, in run order (checked: each run exactly once); the
    chunks in ``kept`` (chunk index: the arrays just written) are not read back."""
    store = ChunkStore(folder, spec)
    count = len(chunk_runs(spec))
    missing = [index for index in range(count) if not store.done(index)]
    if missing:
        raise CampaignError(f'{len(missing)} of {count} chunks are not finished (first: '
                            f'{missing[0]}); run the campaign again to resume')
    arrays = store.read_all(count, kept)
    if not np.array_equal(arrays['run'], np.arange(spec.runs)):
        raise CampaignError(f'The chunks of {folder} do not hold each run exactly once')
    return arrays


def summarise(spec: CampaignSpec, store: ChunkStore, chunk_count: int,
              plot: bool = True, kept: dict[int, dict[str, NDArray[Any]]] | None = None
              ) -> CampaignResult:
    """Read every run back (but the chunks in ``kept``) and write ``statistics.csv``,
    ``summary.json`` and (with ``plot``) ``summary.png``."""
    arrays = read_runs(store.folder, spec, kept)
    failed = arrays['failed'].astype(bool)
    times = np.array((0.0,) + spec.output_times)
    table = percentile_table({name: arrays[name] for name in METRICS}, ~failed,
                             spec.percentiles)
    failures = {reason: int(np.sum(arrays['reason'] == index))
                for index, reason in enumerate(FAILURE_REASONS)}
    _write_statistics(store.folder / 'statistics.csv', times, spec.percentiles, table)
    summary: dict[str, Any] = {
        'name': spec.name, 'runs': spec.runs, 'succeeded': int(np.sum(~failed)),
        'failed': int(np.sum(failed)), 'failures_by_reason': failures, 'seed': str(spec.seed),
        'times': times.tolist(), 'percentiles': list(spec.percentiles),
        'statistics': {name: table[name].tolist() for name in METRICS},
        'failed_runs': _failed_runs(arrays, failed)}
    if spec.closed_loop:
        summary['closed_loop'] = closed_loop_summary(spec, arrays, failed)
    actuators = {name: _percentiles(arrays[name][~failed], spec.percentiles)
                 for name in ACTUATORS if name in arrays}
    if actuators:
        summary['actuators'] = actuators
    (store.folder / 'summary.json').write_text(json.dumps(summary, indent=1, allow_nan=True))
    if plot:
        write_envelopes(store.folder / 'summary.png', times, spec.percentiles, table,
                        f'{spec.name}: {spec.runs} runs, {int(np.sum(failed))} failed')
    return CampaignResult(folder=store.folder, runs=spec.runs, failed=int(np.sum(failed)),
                          chunks_run=0, chunks_resumed=chunk_count, compute_seconds=0.0,
                          total_seconds=0.0, times=times, statistics=table,
                          failures=failures, closed_loop=summary.get('closed_loop', {}),
                          actuators=actuators)


def closed_loop_summary(spec: CampaignSpec, arrays: dict[str, NDArray[Any]],
                        failed: NDArray[np.bool_]) -> dict[str, Any]:
    """The settling threshold, how many succeeded runs settled, and the percentiles of
    settling time [s] (inf: not settled), torque used [N m s] and peak torque [N m]."""
    ok = ~failed
    return {'settling_deg': spec.settling_deg,
            'settled': int(np.sum(np.isfinite(arrays['settling_time_s'][ok]))),
            'percentiles': {name: _percentiles(arrays[name][ok], spec.percentiles)
                            for name in CLOSED_LOOP}}


def _percentiles(values: NDArray[np.float64], percentiles: tuple[float, ...]) -> list[float]:
    """The percentiles of ``values`` (inf counts as the largest), NaN without values."""
    if values.shape[0] == 0:
        return [math.nan] * len(percentiles)
    return [float(value) for value in
            np.percentile(values, list(percentiles), method='inverted_cdf')]


def _failed_runs(arrays: dict[str, NDArray[Any]], failed: NDArray[np.bool_]
                 ) -> list[dict[str, Any]]:
    """Run, seed, reason, time and parameters of the first failed runs."""
    rows = []
    for index in np.flatnonzero(failed)[:MAX_LISTED_FAILURES]:
        row: dict[str, Any] = {
            'run': int(arrays['run'][index]), 'seed': str(arrays['seed'][index]),
            'reason': FAILURE_REASONS[int(arrays['reason'][index])],
            'failed_at': float(arrays['failed_at'][index])}
        for name, array in arrays.items():
            if name.startswith(_PARAMETER_PREFIXES):
                row[name] = np.asarray(array[index]).tolist()
        rows.append(row)
    return rows


def _write_statistics(path: Path, times: NDArray[np.float64], percentiles: tuple[float, ...],
                      table: dict[str, NDArray[np.float64]]) -> None:
    with path.open('w', newline='') as file:
        writer = csv.writer(file)
        writer.writerow(['time_s', 'metric'] + [f'p{p:g}' for p in percentiles])
        for name in METRICS:
            for column, t in enumerate(times.tolist()):
                writer.writerow([repr(t), name] + [repr(float(v))
                                                   for v in table[name][:, column]])
