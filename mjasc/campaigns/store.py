"""The campaign store: one SQLite database in the campaign folder, written as each run finishes.

A campaign is identified by the digest of its file (an edited file is a new campaign) and each run
by its index k; the driver writes one row per run the moment its result arrives, in its own
transaction, in WAL mode. A campaign killed at any moment (even SIGKILL) keeps every finished run;
restarted with the same command it reads which runs are done and computes only the others: none
lost, none duplicated, none recomputed.

Schema (``campaign.sqlite``)::

    campaigns(digest PRIMARY KEY, name, source, file_text, runs_defined, created_unix_s)
    runs(digest, idx, family, parameters JSON, seed, scenario TOML, status, attempts, error,
         metrics JSON, wall_time_s, worker, finished_unix_s, PRIMARY KEY (digest, idx))

Statuses: ``completed`` and ``diverged`` are results (a divergence is deterministic: the run
replays it); ``error`` (the run raised), ``timeout`` (over the per-run time limit) and ``crashed``
(its process died) are retried up to the campaign's attempt limit, then stay as the run's result.
:func:`CampaignStore.export` writes the runs as CSV and Parquet (flattened metrics, one column per
key path).
"""

from __future__ import annotations

import csv
import json
import sqlite3
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Iterable

__all__ = ["CampaignStore", "StoredRun", "FINAL_STATUSES", "RETRY_STATUSES", "STORE_FILE"]

STORE_FILE = "campaign.sqlite"
FINAL_STATUSES = frozenset({"completed", "diverged"})
RETRY_STATUSES = frozenset({"error", "timeout", "crashed"})

_SCHEMA = """
CREATE TABLE IF NOT EXISTS campaigns (
    digest TEXT PRIMARY KEY, name TEXT NOT NULL, source TEXT, file_text TEXT, runs_defined INTEGER NOT NULL,
    created_unix_s REAL NOT NULL);
CREATE TABLE IF NOT EXISTS runs (
    digest TEXT NOT NULL, idx INTEGER NOT NULL, family TEXT, parameters TEXT, seed INTEGER, scenario TEXT,
    status TEXT NOT NULL, attempts INTEGER NOT NULL, error TEXT, metrics TEXT, wall_time_s REAL, worker TEXT,
    finished_unix_s REAL, PRIMARY KEY (digest, idx));
"""


@dataclass(frozen=True)
class StoredRun:
    """One run's row: index, family, drawn parameters, seed, scenario text, status, attempts so far,
    error (one line), metrics (the run's summary, a dict), wall time [s], worker."""

    index: int
    family: str
    parameters: dict
    seed: int
    scenario: str
    status: str
    attempts: int
    error: str | None
    metrics: dict | None
    wall_time_s: float | None
    worker: str | None


class CampaignStore:
    """The store of one campaign (``digest``) in ``folder/campaign.sqlite`` (created if missing)."""

    def __init__(self, folder: str | Path, digest: str, name: str = "", source: str = "", file_text: str = "",
                 runs_defined: int = 0):
        self.folder = Path(folder)
        self.folder.mkdir(parents=True, exist_ok=True)
        self.path = self.folder / STORE_FILE
        self.digest = digest
        self._db = sqlite3.connect(self.path, timeout=60.0, isolation_level=None)
        self._db.execute("PRAGMA journal_mode=WAL")
        self._db.execute("PRAGMA synchronous=NORMAL")
        self._db.executescript(_SCHEMA)
        if name or runs_defined:
            self._db.execute("INSERT OR IGNORE INTO campaigns VALUES (?, ?, ?, ?, ?, ?)",
                             (digest, name, source, file_text, int(runs_defined), time.time()))

    @classmethod
    def open_existing(cls, folder: str | Path) -> "CampaignStore":
        """The store in ``folder`` for its most recent campaign (for reports)."""
        path = Path(folder) / STORE_FILE
        if not path.is_file():
            raise FileNotFoundError(f"{folder}: no campaign store ({STORE_FILE}) here")
        db = sqlite3.connect(path)
        row = db.execute("SELECT digest FROM campaigns ORDER BY created_unix_s DESC LIMIT 1").fetchone()
        db.close()
        if row is None:
            raise FileNotFoundError(f"{path}: holds no campaign")
        return cls(folder, row[0])

    def close(self) -> None:
        self._db.close()

    def __enter__(self):
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    # ------------------------------------------------------------------ writing
    def record(self, index: int, *, family: str, parameters: dict, seed: int, scenario: str, status: str,
               error: str | None = None, metrics: dict | None = None, wall_time_s: float | None = None,
               worker: str | None = None) -> int:
        """Write run ``index``'s result (one transaction); returns its attempt count. A later
        result of the same run replaces an earlier retryable one; a final result is never replaced."""
        if status not in FINAL_STATUSES | RETRY_STATUSES:
            raise ValueError(f"status: must be one of {sorted(FINAL_STATUSES | RETRY_STATUSES)}, got {status!r}")
        db = self._db
        db.execute("BEGIN IMMEDIATE")
        try:
            row = db.execute("SELECT status, attempts FROM runs WHERE digest = ? AND idx = ?",
                             (self.digest, int(index))).fetchone()
            if row is not None and row[0] in FINAL_STATUSES:
                db.execute("COMMIT")
                return int(row[1])
            attempts = 1 + (int(row[1]) if row is not None else 0)
            db.execute("INSERT OR REPLACE INTO runs VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?)",
                       (self.digest, int(index), family, json.dumps(parameters, sort_keys=True), int(seed), scenario,
                        status, attempts, error, None if metrics is None else json.dumps(metrics, sort_keys=True),
                        wall_time_s, worker, time.time()))
            db.execute("COMMIT")
        except BaseException:
            db.execute("ROLLBACK")
            raise
        return attempts

    # ------------------------------------------------------------------ reading
    def info(self) -> dict:
        row = self._db.execute("SELECT name, source, runs_defined, created_unix_s FROM campaigns WHERE digest = ?",
                               (self.digest,)).fetchone()
        if row is None:
            return {"digest": self.digest}
        return {"digest": self.digest, "name": row[0], "source": row[1], "runs_defined": row[2],
                "created_unix_s": row[3]}

    def done(self, max_attempts: int) -> set[int]:
        """Indices that need no more work: a final status, or a retryable one ``max_attempts`` times."""
        rows = self._db.execute("SELECT idx FROM runs WHERE digest = ? AND (status IN ('completed', 'diverged') "
                                "OR attempts >= ?)", (self.digest, int(max_attempts))).fetchall()
        return {int(r[0]) for r in rows}

    def attempts(self) -> dict[int, int]:
        return {int(i): int(a) for i, a in
                self._db.execute("SELECT idx, attempts FROM runs WHERE digest = ?", (self.digest,))}

    def runs(self, statuses: Iterable[str] | None = None) -> list[StoredRun]:
        """Every stored run (sorted by index), optionally only those with these statuses."""
        sql = ("SELECT idx, family, parameters, seed, scenario, status, attempts, error, metrics, wall_time_s, worker "
               "FROM runs WHERE digest = ?")
        args: list = [self.digest]
        if statuses is not None:
            statuses = list(statuses)
            sql += f" AND status IN ({', '.join('?' * len(statuses))})"
            args += statuses
        out = []
        for r in self._db.execute(sql + " ORDER BY idx", args):
            out.append(StoredRun(int(r[0]), r[1], json.loads(r[2] or "{}"), int(r[3]), r[4], r[5], int(r[6]), r[7],
                                 None if r[8] is None else json.loads(r[8]), r[9], r[10]))
        return out

    def counts(self) -> dict[str, int]:
        """Runs per status."""
        return {s: int(n) for s, n in self._db.execute(
            "SELECT status, COUNT(*) FROM runs WHERE digest = ? GROUP BY status", (self.digest,))}

    # ------------------------------------------------------------------ export
    def export(self, stem: str | Path | None = None) -> dict[str, Path]:
        """Write ``runs.csv`` and ``runs.parquet`` (or ``<stem>.csv/.parquet``): one row per run,
        the metrics flattened to dotted columns (lists as JSON text)."""
        rows = [_flat_row(r) for r in self.runs()]
        stem = Path(stem) if stem is not None else self.folder / "runs"
        columns: list[str] = []
        for r in rows:
            columns += [k for k in r if k not in columns]
        files = {"csv": stem.with_suffix(".csv"), "parquet": stem.with_suffix(".parquet")}
        with open(files["csv"], "w", newline="") as f:
            w = csv.DictWriter(f, fieldnames=columns)
            w.writeheader()
            w.writerows(rows)
        import pyarrow as pa
        import pyarrow.parquet as pq

        table = pa.Table.from_pylist([{c: r.get(c) for c in columns} for r in rows]) if rows else pa.table({})
        pq.write_table(table, files["parquet"])
        return files


def _flat(prefix: str, value, out: dict) -> None:
    if isinstance(value, dict):
        for k, v in value.items():
            _flat(f"{prefix}.{k}" if prefix else str(k), v, out)
    elif isinstance(value, list):
        out[prefix] = json.dumps(value)
    else:
        out[prefix] = value


def _flat_row(r: StoredRun) -> dict:
    row = {"index": r.index, "family": r.family, "seed": r.seed, "status": r.status, "attempts": r.attempts,
           "error": r.error, "wall_time_s": r.wall_time_s, "worker": r.worker}
    _flat("param", r.parameters, row)
    if r.metrics:
        _flat("metric", r.metrics, row)
    return row
