"""The sweep's results: one Parquet table, one row per finished task, written as results arrive.

``DIR/runs.parquet`` is always a whole, valid Parquet file: new rows are
buffered and the file is rewritten to a temporary name and renamed over the
old one (atomic on POSIX) at most every ``flush_s`` seconds, and at the end.
A sweep killed at any moment therefore keeps every row flushed before it (a
``SIGKILL`` loses at most the last ``flush_s`` seconds of results; Ctrl-C
loses nothing), and ``--resume`` runs only the keys the table lacks or holds as
failed (``error``) or ``lost``.

Columns are whatever the rows hold: the task's columns (``run_key``, scene,
seed, one per parameter, ``pedvr_version``), ``status`` (``ok``, ``error``: the
task raised, its message in ``error``; ``lost``: its worker died more often
than Dask allows) and every metric flattened to a dotted name. Rows with
different columns (an error row has no metrics; newer pedvr versions add
metrics) are unified, missing values being null. A rewrite costs time in
proportion to the table; at thousands of rows it is tens of milliseconds.
"""

from __future__ import annotations

import os
import time
from pathlib import Path
from typing import Any

import pyarrow as pa
import pyarrow.parquet as pq

TABLE_NAME = "runs.parquet"
# Columns that are often all null in a batch: typed, so every file has one schema for them.
TEXT = {
    "error": pa.string(),
    "recording": pa.string(),
    "pedvr_git_commit": pa.string(),
    "pedvr_git_dirty": pa.bool_(),
    "pedvr_git_diff": pa.string(),
    "numpy_version": pa.string(),
    "numba_version": pa.string(),
    "dask_version": pa.string(),
}


class ResultTable:
    """The Parquet table in ``folder``; rows from :meth:`add`, written by :meth:`flush`."""

    def __init__(self, folder: Path, *, flush_s: float = 2.0, metadata: dict[str, str] | None = None) -> None:
        self.path = folder / TABLE_NAME
        self.flush_s = flush_s
        self.metadata = metadata or {}
        self._table: pa.Table | None = _read(self.path) if self.path.is_file() else None
        self._pending: list[dict[str, Any]] = []
        self._last = time.monotonic()

    def rows(self) -> int:
        return (0 if self._table is None else self._table.num_rows) + len(self._pending)

    def finished_keys(self) -> set[str]:
        """Keys of tasks that need not run again: those with an ``ok`` row. A row that failed
        (``error``) or was lost runs again on resume: a failure may have been the machine's (a
        worker that died holding the result), or code fixed since (issue 25.7)."""
        return set(self.status_of(("ok",)))

    def status_of(self, statuses: tuple[str, ...] = ("ok",)) -> dict[str, str]:
        """run_key -> status for the rows whose status is one of ``statuses``."""
        if self._table is None:
            return {}
        keys = self._table.column("run_key").to_pylist()
        status = self._table.column("status").to_pylist()
        return {k: s for k, s in zip(keys, status, strict=True) if s in statuses}

    def provenances(self) -> list[tuple[dict[str, Any], int]]:
        """The distinct codes of the ``ok`` rows (:mod:`pedvr.provenance`) and their counts."""
        from collections import Counter

        from pedvr.provenance import COLUMNS

        if self._table is None:
            return []
        names = self._table.column_names
        cols = {c: self._table.column(c).to_pylist() for c in COLUMNS if c in names}
        status = self._table.column("status").to_pylist()
        count = Counter(
            tuple(cols[c][i] if c in cols else None for c in COLUMNS)
            for i in range(self._table.num_rows)
            if status[i] == "ok"
        )
        return [(dict(zip(COLUMNS, k, strict=True)), n) for k, n in count.most_common()]

    def keys(self) -> set[str]:
        return set() if self._table is None else set(self._table.column("run_key").to_pylist())

    def add(self, row: dict[str, Any]) -> None:
        self._pending.append(row)
        if time.monotonic() - self._last >= self.flush_s:
            self.flush()

    def flush(self) -> None:
        """Write every row so far to ``runs.parquet`` (atomically); a row replaces an older one
        with the same ``run_key`` (a lost task that ran again on resume)."""
        self._last = time.monotonic()
        if not self._pending:
            return
        new = rows_to_table(self._pending)
        self._pending = []
        table = new if self._table is None else _replace_keys(self._table, new)
        meta = dict(table.schema.metadata or {})
        meta.update({k.encode(): v.encode() for k, v in self.metadata.items()})
        table = table.replace_schema_metadata(meta)
        tmp = self.path.with_name(f".{self.path.name}.{os.getpid()}.tmp")
        pq.write_table(table, tmp)
        os.replace(tmp, self.path)
        self._table = table


def rows_to_table(rows: list[dict[str, Any]]) -> pa.Table:
    """Rows with possibly different keys → one table with every key as a column (nulls where absent)."""
    keys = list(dict.fromkeys(k for r in rows for k in r))
    return pa.Table.from_pydict({k: pa.array([r.get(k) for r in rows], type=TEXT.get(k)) for k in keys})


def _replace_keys(old: pa.Table, new: pa.Table) -> pa.Table:
    import pyarrow.compute as pc

    keep = pc.invert(pc.is_in(old.column("run_key"), value_set=new.column("run_key")))
    return pa.concat_tables([old.filter(keep), new], promote_options="permissive")


def read_table(folder: Path) -> pa.Table:
    """The table of a sweep folder (``DIR/runs.parquet``)."""
    return _read(folder / TABLE_NAME)


def _read(path: Path) -> pa.Table:
    from pedvr.sweep.errors import SweepError

    try:
        table = pq.read_table(path)
    except (OSError, pa.ArrowException) as exc:
        raise SweepError(f"{path}: not a readable Parquet table ({exc})") from None
    if "run_key" not in table.column_names or "status" not in table.column_names:
        raise SweepError(f"{path}: not a sweep's table (it has no run_key and status columns)")
    return table
