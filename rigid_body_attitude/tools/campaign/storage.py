"""A campaign's results folder: a manifest and one Parquet file per finished chunk.

Layout of ``OUT``::

    campaign.json        what the campaign is (name, runs, chunk, seed, the spec's digest)
    chunks/00000.parquet one row per run of chunk 0 (written whole, then renamed into place);
                         the folder reads as one Parquet data set
    statistics.csv       percentiles of each metric at each output time
    summary.json         counts, failures (run, seed, reason, time), the statistics
    summary.png          dispersion envelopes over time

Chunk files are uncompressed and plainly encoded (no dictionaries, no column statistics):
random doubles hardly compress nor repeat, and writing stays cheap. A
chunk file exists only once its chunk is complete (written to a temporary name, then
renamed, which is atomic on one file system), so a campaign interrupted anywhere resumes by
running the chunks without a file; the manifest must match the spec, or the folder belongs to
another campaign and is refused. Nothing is written before the first chunk is finished: a
campaign refused or failed before that leaves the folder as it was.
"""

from __future__ import annotations

import dataclasses
from datetime import datetime
import hashlib
import json
import os
from collections.abc import Mapping
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
from numpy.typing import NDArray

from rigid_body_attitude.tools.campaign.spec import CampaignSpec, SpecError

__all__ = ['ChunkStore', 'spec_digest']


def spec_digest(spec: CampaignSpec) -> str:
    """A digest of everything that decides the runs' results (not the file's path): of its
    values, written out exactly (floats in hexadecimal), so the same campaign has the same
    digest whether read from a file or given as a mapping."""
    text = json.dumps(_canonical(replace(spec, source='')), sort_keys=True)
    return hashlib.sha256(text.encode()).hexdigest()


def _canonical(value: Any) -> Any:
    """``value`` as plain JSON values, exactly (a dataclass or object by its fields)."""
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        return {field.name: _canonical(getattr(value, field.name))
                for field in dataclasses.fields(value)}
    if isinstance(value, np.ndarray):
        return [list(value.shape), [float(item).hex() for item in value.ravel().tolist()]]
    if isinstance(value, np.generic):
        return _canonical(value.item())
    if isinstance(value, float):
        return value.hex()
    if isinstance(value, datetime):
        return value.isoformat()
    if value is None or isinstance(value, (bool, int, str)):
        return value
    if isinstance(value, Mapping):
        return [[str(key), _canonical(item)] for key, item in
                sorted(value.items(), key=lambda pair: str(pair[0]))]
    if isinstance(value, (list, tuple)):
        return [_canonical(item) for item in value]
    return {type(value).__name__: _canonical(vars(value))}


def _column(array: NDArray[Any]) -> pa.Array:
    """A NumPy column: (n,) as is, (n, k) as fixed-size lists of k."""
    if array.ndim == 1:
        return pa.array(array)
    flat = pa.array(np.ascontiguousarray(array).reshape(-1))
    return pa.FixedSizeListArray.from_arrays(flat, array.shape[1])


def table_of(columns: dict[str, NDArray[Any]]) -> pa.Table:
    """A Parquet table of a chunk's result arrays."""
    return pa.table({name: _column(array) for name, array in columns.items()})


def arrays_of(table: pa.Table) -> dict[str, NDArray[Any]]:
    """The arrays of a table written by :func:`table_of`."""
    result: dict[str, NDArray[Any]] = {}
    for name in table.column_names:
        column = table.column(name).combine_chunks()
        if pa.types.is_fixed_size_list(column.type):
            size = column.type.list_size
            result[name] = column.flatten().to_numpy(zero_copy_only=False).reshape(-1, size)
        else:
            result[name] = column.to_numpy(zero_copy_only=False)
    return result


class ChunkStore:
    """The results folder of one campaign (see the module's layout).

    Nothing is created until the first chunk is written (:meth:`write` creates the folder
    and the manifest first), so a campaign refused or failed before it finished a chunk
    leaves ``--out`` as it found it (:meth:`abandon` removes its temporary files); one that
    finished some chunks resumes when run again.
    """

    def __init__(self, folder: str | Path, spec: CampaignSpec) -> None:
        """Open ``folder`` for ``spec``; refuse a folder holding another campaign's chunks (a
        manifest without any chunk, left by a campaign that finished none, is taken over)."""
        self.folder = Path(folder)
        self.chunks = self.folder / 'chunks'
        self.manifest_path = self.folder / 'campaign.json'
        self.manifest = {'name': spec.name, 'runs': spec.runs, 'chunk': spec.chunk,
                         'seed': str(spec.seed), 'output_times': list(spec.output_times),
                         'spec_digest': spec_digest(spec), 'source': spec.source}
        self.claimed = False
        if self.manifest_path.is_file():
            try:
                found = json.loads(self.manifest_path.read_text())
            except (ValueError, UnicodeError) as err:
                raise SpecError(f'{self.manifest_path} is not a campaign manifest: '
                                f'{str(err)[:100]}') from None
            self.claimed = isinstance(found, dict) and \
                found.get('spec_digest') == self.manifest['spec_digest']
            written = self.written()
            if not self.claimed and written:
                raise SpecError(f'{self.folder} holds {written} finished chunks of another '
                                f'campaign (its campaign.json differs from this spec); choose '
                                f'another --out')

    def written(self) -> int:
        """Chunk files in the folder."""
        return sum(1 for _ in self.chunks.glob('*.parquet')) if self.chunks.is_dir() else 0

    def path(self, index: int) -> Path:
        """The file of chunk ``index``."""
        return self.chunks / f'{index:05d}.parquet'

    def done(self, index: int) -> bool:
        """Whether chunk ``index`` is written."""
        return self.path(index).is_file()

    def write(self, index: int, columns: dict[str, NDArray[Any]]) -> None:
        """Write chunk ``index`` whole (temporary file, then an atomic rename); the first
        write creates the folder and the manifest."""
        if not self.claimed:
            self.chunks.mkdir(parents=True, exist_ok=True)
            _write_atomic(self.manifest_path, json.dumps(self.manifest, indent=1).encode())
            self.claimed = True
        target = self.path(index)
        temporary = target.with_suffix(f'.{os.getpid()}.tmp')
        pq.write_table(table_of(columns), temporary, compression='none', use_dictionary=False,
                       write_statistics=False)
        os.replace(temporary, target)

    def abandon(self) -> None:
        """After a failure: remove this process's temporary files (finished chunks stay)."""
        if self.chunks.is_dir():
            for temporary in self.chunks.glob(f'*.{os.getpid()}.tmp'):
                temporary.unlink(missing_ok=True)

    def read_all(self, chunk_count: int, kept: dict[int, dict[str, NDArray[Any]]] | None = None
                 ) -> dict[str, NDArray[Any]]:
        """Every chunk's rows, concatenated in run order; the chunks in ``kept`` (the arrays
        this process wrote) are not read back."""
        kept = kept or {}
        parts = [kept[index] if index in kept else arrays_of(pq.read_table(self.path(index)))
                 for index in range(chunk_count)]
        arrays = {name: np.concatenate([part[name] for part in parts]) for name in parts[0]}
        runs = arrays['run']
        if runs.shape[0] > 1 and not np.all(runs[1:] > runs[:-1]):
            order = np.argsort(runs, kind='stable')
            arrays = {name: array[order] for name, array in arrays.items()}
        return arrays


def _write_atomic(path: Path, data: bytes) -> None:
    temporary = path.with_suffix('.tmp')
    temporary.write_bytes(data)
    os.replace(temporary, path)
