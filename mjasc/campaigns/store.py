"""The campaign store: one SQLite database in the campaign folder, written as each run finishes.

A campaign is identified by the digest of its file (an edited file is a new campaign) and each run
by its index k and its method label (a campaign comparing avoidance methods runs index k once per
method; ``""`` without ``methods``); the driver writes one row per run the moment its result arrives, in its own
transaction, in WAL mode. A campaign killed at any moment (even SIGKILL) keeps every finished run;
restarted with the same command it reads which runs are done and computes only the others: none
lost, none duplicated, none recomputed.

Schema (``campaign.sqlite``)::

    campaigns(digest PRIMARY KEY, name, source, file_text, runs_defined, created_unix_s, run_unix_s, hulls JSON)
    runs(digest, idx, family, parameters JSON, seed, scenario TOML, status, attempts, error,
         metrics JSON, wall_time_s, worker, finished_unix_s, method, PRIMARY KEY (digest, idx, method))

A folder may hold several campaigns (an edited file is a new digest). ``runs_defined`` is the largest
number of runs any command asked of the campaign (``--runs 4`` and later the whole file: the
file's count), ``run_unix_s`` when a command last ran it: reports and extracts read the campaign
run last (:meth:`CampaignStore.open_existing`), the one whose exports the folder holds.

A store written before ``method`` existed (key ``(digest, idx)``) is migrated when opened: its runs
table is rebuilt with the new key in one transaction, every row with method ``""`` (nothing else
changes; its runs stay done). One written before ``run_unix_s`` gets the column, at each
campaign's creation time; one written before ``hulls`` (each family's hulls,
:mod:`mjasc.campaigns.hull_records`) gets the column empty: its hulls are unknown until a command
runs the campaign again (an older driver writing to a migrated store leaves them as they are). A
campaign whose own hull's MJCF references files (meshes) was stored, before the digest covered them,
under the digest of the MJCF and hydrodynamics.toml alone: running it again renumbers it to its
digest (:meth:`CampaignStore.adopt_earlier`), and it resumes.

**Copying.** While a command writes the store (a campaign running) and after one was killed with
``kill -9``, ``campaign.sqlite-wal`` beside it is part of the store (SQLite's write-ahead log):
copy it with ``campaign.sqlite`` (and ``-shm``), or copy the folder. Each result is also moved
into ``campaign.sqlite`` right after it is stored (a passive checkpoint, which yields to readers),
and a command that ends — done, failed or interrupted — moves everything there and empties the
``-wal`` (:meth:`CampaignStore.close`): then ``campaign.sqlite`` alone is the store.

**Reading.** Reports and extracts (:meth:`CampaignStore.open_existing`) open the store read-only
and write nothing into its folder: a read-only folder or file (a shared result, another user's
campaign) reads as well as one's own. Without a ``-wal`` file holding results they read the file
in SQLite's ``immutable`` mode (a read-only connection to a WAL-mode database otherwise creates
``-wal`` and ``-shm`` files it cannot remove); with one (a campaign running, or killed with
``kill -9``: its latest results are still in the ``-wal``) in ``mode=ro``, which reads it. A store
of an older layout is read through temporary views with the columns a migration would add.
A command that writes (:class:`CampaignStore`) and finds no store in the file (damaged, another
file) leaves no ``-wal``/``-shm`` of its own beside it.

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

from mjasc.runs.outputs import json_value

__all__ = ["CampaignStore", "StoredRun", "StoreError", "FINAL_STATUSES", "RETRY_STATUSES", "STORE_FILE",
           "record_result"]

STORE_FILE = "campaign.sqlite"
FINAL_STATUSES = frozenset({"completed", "diverged"})
RETRY_STATUSES = frozenset({"error", "timeout", "crashed"})

_SCHEMA = """
CREATE TABLE IF NOT EXISTS campaigns (
    digest TEXT PRIMARY KEY, name TEXT NOT NULL, source TEXT, file_text TEXT, runs_defined INTEGER NOT NULL,
    created_unix_s REAL NOT NULL, run_unix_s REAL, hulls TEXT);
CREATE TABLE IF NOT EXISTS runs (
    digest TEXT NOT NULL, idx INTEGER NOT NULL, family TEXT, parameters TEXT, seed INTEGER, scenario TEXT,
    status TEXT NOT NULL, attempts INTEGER NOT NULL, error TEXT, metrics TEXT, wall_time_s REAL, worker TEXT,
    finished_unix_s REAL, method TEXT NOT NULL DEFAULT '', PRIMARY KEY (digest, idx, method));
"""
_OLD_COLUMNS = ("digest, idx, family, parameters, seed, scenario, status, attempts, error, metrics, wall_time_s, "
                "worker, finished_unix_s")


class StoreError(FileNotFoundError):
    """The folder's ``campaign.sqlite`` is not a campaign store (damaged, empty, another file): one
    line naming the file. A FileNotFoundError, as a folder without a store: no campaign is here."""


def _not_a_store(path: Path, exc: sqlite3.DatabaseError) -> StoreError:
    return StoreError(f"{path}: not a campaign store ({exc})")


def _sidecars(path: Path) -> list[Path]:
    """SQLite's files beside the store ``path`` that exist now (``-wal``, ``-shm``, ``-journal``)."""
    return [p for p in (path.with_name(path.name + s) for s in ("-wal", "-shm", "-journal")) if p.exists()]


def _connect_read_only(path: Path) -> sqlite3.Connection:
    """A read-only connection to the store ``path`` that writes nothing beside it (module docstring,
    "Reading"): SQLite's ``immutable`` mode when no ``-wal`` file holds results (a read-only
    connection to a WAL-mode database would otherwise create ``-wal`` and ``-shm`` and leave them),
    ``mode=ro`` when one does (a campaign running, or killed: its latest results are there). A store
    written before the ``run_unix_s``, ``hulls`` or ``method`` columns is read through temporary
    views that add them as a migration would (nothing is migrated on disk). Raises
    :class:`StoreError` when the file is not a campaign store."""
    from urllib.parse import quote

    wal = path.with_name(path.name + "-wal")
    live = wal.exists() and wal.stat().st_size > 0
    uri = f"file:{quote(str(path.resolve()))}?mode=ro" + ("" if live else "&immutable=1")
    try:
        db = sqlite3.connect(uri, uri=True, timeout=60.0, isolation_level=None)
    except sqlite3.OperationalError as exc:  # (a -wal without -shm in a folder we cannot write: unreadable here)
        raise StoreError(f"{path}: cannot open the store read-only ({exc}; its {wal.name} holds results that "
                         f"SQLite reads only with write access to the folder)") from None
    try:
        tables = {name: {r[1] for r in db.execute(f"PRAGMA main.table_info({name})")} for name in ("campaigns", "runs")}
        if not tables["campaigns"]:
            raise StoreError(f"{path}: not a campaign store (no campaigns table)")
        if not tables["runs"]:  # (none stored yet by an older mjasc: the table a writer would make, empty)
            db.execute(_SCHEMA.split(";")[1].replace("IF NOT EXISTS runs", "temp.runs"))
            tables["runs"] = {"method"}
        missing = {"run_unix_s": "created_unix_s AS run_unix_s", "hulls": "NULL AS hulls"}
        added = [sql for col, sql in missing.items() if col not in tables["campaigns"]]
        if added:  # (an older store: the columns a migration adds, as it would fill them)
            db.execute(f"CREATE TEMP VIEW campaigns AS SELECT *, {', '.join(added)} FROM main.campaigns")
        if "method" not in tables["runs"]:
            db.execute("CREATE TEMP VIEW runs AS SELECT *, '' AS method FROM main.runs")
    except sqlite3.DatabaseError as exc:
        db.close()
        raise _not_a_store(path, exc) from None
    except BaseException:
        db.close()
        raise
    return db


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
    method: str = ""  # the compared method's label; "" in a campaign without methods


class CampaignStore:
    """The store of one campaign (``digest``) in ``folder/campaign.sqlite`` (created if missing)."""

    def __init__(self, folder: str | Path, digest: str, name: str = "", source: str = "", file_text: str = "",
                 runs_defined: int = 0, hulls: dict | None = None, *, read_only: bool = False):
        self.folder = Path(folder)
        self.path = self.folder / STORE_FILE
        self.digest = digest
        self.read_only = read_only
        if read_only:  # (reports and extracts: nothing written, not even SQLite's -wal/-shm files)
            self._db = _connect_read_only(self.path)
            return
        self.folder.mkdir(parents=True, exist_ok=True)
        sidecars = _sidecars(self.path)  # (those there before: a store that fails to open leaves no new one)
        self._db = sqlite3.connect(self.path, timeout=60.0, isolation_level=None)
        try:
            self._db.execute("PRAGMA journal_mode=WAL")
            self._db.execute("PRAGMA synchronous=NORMAL")
            self._db.executescript(_SCHEMA)
            self._migrate()
        except sqlite3.DatabaseError as exc:  # (not SQLite, or a table of another shape)
            self._db.close()
            if isinstance(exc, sqlite3.OperationalError) and "locked" in str(exc):
                raise
            for extra in set(_sidecars(self.path)) - set(sidecars):
                extra.unlink(missing_ok=True)
            raise _not_a_store(self.path, exc) from None
        if name or runs_defined:  # (a command running the campaign: the largest extent asked, run now)
            now = time.time()
            self._db.execute("INSERT INTO campaigns (digest, name, source, file_text, runs_defined, created_unix_s, "
                             "run_unix_s, hulls) VALUES (?, ?, ?, ?, ?, ?, ?, ?) ON CONFLICT (digest) DO UPDATE SET "
                             "runs_defined = MAX(runs_defined, excluded.runs_defined), "
                             "run_unix_s = excluded.run_unix_s, hulls = COALESCE(excluded.hulls, hulls)",
                             (digest, name, source, file_text, int(runs_defined), now, now,
                              None if hulls is None else json.dumps(hulls, sort_keys=True)))

    def _migrate(self) -> None:
        """Give a store written before the ``run_unix_s`` or ``hulls`` column that column and one
        written before the ``method`` column its new key (module docstring)."""
        self._add_column("campaigns", "run_unix_s", ["ALTER TABLE campaigns ADD COLUMN run_unix_s REAL",
                                                     "UPDATE campaigns SET run_unix_s = created_unix_s"])
        self._add_column("campaigns", "hulls", ["ALTER TABLE campaigns ADD COLUMN hulls TEXT"])
        self._add_column("runs", "method", [
            "DROP TABLE IF EXISTS runs_migrating",
            _SCHEMA.split(";")[1].replace("IF NOT EXISTS runs", "runs_migrating"),
            f"INSERT INTO runs_migrating ({_OLD_COLUMNS}, method) SELECT {_OLD_COLUMNS}, '' FROM runs",
            "DROP TABLE runs", "ALTER TABLE runs_migrating RENAME TO runs"])

    def _add_column(self, table: str, column: str, statements: list[str]) -> None:
        """Run ``statements`` in one transaction if ``table`` has no ``column`` (checked again inside
        it: another process may have migrated the store meanwhile)."""
        db = self._db

        def missing() -> bool:
            return column not in {r[1] for r in db.execute(f"PRAGMA table_info({table})")}

        if not missing():
            return
        db.execute("BEGIN IMMEDIATE")
        try:
            if missing():
                for sql in statements:
                    db.execute(sql)
            db.execute("COMMIT")
        except BaseException:
            db.execute("ROLLBACK")
            raise

    @classmethod
    def open_existing(cls, folder: str | Path) -> "CampaignStore":
        """The store in ``folder`` for the campaign a command ran last (for reports and extracts:
        the one whose exports and ``campaign.json`` the folder holds), opened read-only
        (:func:`_connect_read_only`: a read-only folder or file will do, and nothing is written)."""
        path = Path(folder) / STORE_FILE
        if not path.is_file():
            raise FileNotFoundError(f"{folder}: no campaign store ({STORE_FILE}) here")
        store = cls(folder, "", read_only=True)
        try:
            row = store._db.execute("SELECT digest FROM campaigns ORDER BY COALESCE(run_unix_s, created_unix_s) DESC "
                                    "LIMIT 1").fetchone()
        except sqlite3.DatabaseError as exc:
            store.close()
            raise _not_a_store(path, exc) from None
        if row is None:
            store.close()
            raise FileNotFoundError(f"{path}: holds no campaign")
        store.digest = row[0]
        return store

    @staticmethod
    def adopt_earlier(folder: str | Path, digest: str, earlier: tuple | list) -> str | None:
        """Renumber to ``digest`` the campaign a store in ``folder`` holds under one of the
        ``earlier`` digests an earlier mjasc gave the same campaign (a hull's meshes were not yet
        covered), when it holds none under ``digest``: the command that runs it again resumes it
        rather than starting it over. Returns the digest adopted (None: none; nothing written)."""
        path = Path(folder) / STORE_FILE
        if not earlier or not path.is_file():
            return None
        db = sqlite3.connect(path, timeout=60.0, isolation_level=None)
        try:
            cols = {r[1] for r in db.execute("PRAGMA table_info(campaigns)")}
            if not cols:
                return None
            db.execute("BEGIN IMMEDIATE")
            have = {r[0] for r in db.execute("SELECT digest FROM campaigns")}
            old = next((d for d in earlier if d in have), None)
            if digest in have or old is None:
                db.execute("ROLLBACK")
                return None
            for table in ("campaigns", "runs"):
                db.execute(f"UPDATE {table} SET digest = ? WHERE digest = ?", (digest, old))
            db.execute("COMMIT")
            return old
        except sqlite3.DatabaseError as exc:
            raise _not_a_store(path, exc) from None
        finally:
            db.close()

    def close(self) -> None:
        """Close the store; a writer's first moves every result from the ``-wal`` file into
        ``campaign.sqlite`` and empties it (``wal_checkpoint(TRUNCATE)``): the file alone is the
        store once a command has ended, interrupted too (module docstring, "Copying")."""
        if not self.read_only:
            try:
                self._db.execute("PRAGMA wal_checkpoint(TRUNCATE)")
            except sqlite3.DatabaseError:  # (another connection reading: SQLite checkpoints when the last one closes)
                pass
        self._db.close()

    def __enter__(self):
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    # ------------------------------------------------------------------ writing
    def record(self, index: int, *, family: str, parameters: dict, seed: int, scenario: str, status: str,
               error: str | None = None, metrics: dict | None = None, wall_time_s: float | None = None,
               worker: str | None = None, method: str = "") -> int:
        """Write run ``(index, method)``'s result (one transaction); returns its attempt count. A later
        result of the same run replaces an earlier retryable one; a final result is never replaced."""
        if status not in FINAL_STATUSES | RETRY_STATUSES:
            raise ValueError(f"status: must be one of {sorted(FINAL_STATUSES | RETRY_STATUSES)}, got {status!r}")
        db = self._db
        db.execute("BEGIN IMMEDIATE")
        try:
            row = db.execute("SELECT status, attempts FROM runs WHERE digest = ? AND idx = ? AND method = ?",
                             (self.digest, int(index), method)).fetchone()
            if row is not None and row[0] in FINAL_STATUSES:
                db.execute("COMMIT")
                return int(row[1])
            attempts = 1 + (int(row[1]) if row is not None else 0)
            db.execute(f"INSERT OR REPLACE INTO runs ({_OLD_COLUMNS}, method) "
                       f"VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?)",
                       (self.digest, int(index), family, json.dumps(parameters, sort_keys=True), int(seed), scenario,
                        status, attempts, error,
                        None if metrics is None else json.dumps(metrics, sort_keys=True, default=json_value),
                        wall_time_s, worker, time.time(), method))
            db.execute("COMMIT")
        except BaseException:
            db.execute("ROLLBACK")
            raise
        try:  # (the result into campaign.sqlite itself too, not only its -wal: module docstring, "Copying")
            db.execute("PRAGMA wal_checkpoint(PASSIVE)")
        except sqlite3.DatabaseError:
            pass
        return attempts

    # ------------------------------------------------------------------ reading
    def info(self) -> dict:
        """The campaign's digest, name, source, ``runs_defined`` (module docstring), creation time
        [Unix s], ``hulls`` (``{family: hull records}``, :mod:`mjasc.campaigns.hull_records`; None:
        not recorded) and how many campaigns the store holds in all."""
        row = self._db.execute("SELECT name, source, runs_defined, created_unix_s, hulls FROM campaigns "
                               "WHERE digest = ?", (self.digest,)).fetchone()
        n = self._db.execute("SELECT COUNT(*) FROM campaigns").fetchone()[0]
        if row is None:
            return {"digest": self.digest, "hulls": None, "campaigns_in_store": n}
        return {"digest": self.digest, "name": row[0], "source": row[1], "runs_defined": row[2],
                "created_unix_s": row[3], "hulls": _hulls(row[4]), "campaigns_in_store": n}

    def file_text(self) -> str:
        """The campaign's parsed file as stored (JSON text; "" when unknown)."""
        row = self._db.execute("SELECT file_text FROM campaigns WHERE digest = ?", (self.digest,)).fetchone()
        return (row[0] or "") if row else ""

    def done(self, max_attempts: int, method: str = "") -> set[int]:
        """Indices whose run with ``method`` needs no more work: a final status, or a retryable one
        ``max_attempts`` times."""
        rows = self._db.execute("SELECT idx FROM runs WHERE digest = ? AND method = ? AND (status IN ('completed', "
                                "'diverged') OR attempts >= ?)", (self.digest, method, int(max_attempts))).fetchall()
        return {int(r[0]) for r in rows}

    def attempts(self, method: str = "") -> dict[int, int]:
        """Attempts so far per index, of the runs with ``method``."""
        return {int(i): int(a) for i, a in self._db.execute(
            "SELECT idx, attempts FROM runs WHERE digest = ? AND method = ?", (self.digest, method))}

    def methods(self) -> list[str]:
        """The method labels of the stored runs (``[""]`` for a campaign without methods), sorted."""
        return [r[0] for r in self._db.execute("SELECT DISTINCT method FROM runs WHERE digest = ? ORDER BY method",
                                               (self.digest,))]

    def runs(self, statuses: Iterable[str] | None = None, method: str | None = None) -> list[StoredRun]:
        """Every stored run (sorted by index, then method), optionally only those with these
        statuses, or with this method label."""
        sql = ("SELECT idx, family, parameters, seed, scenario, status, attempts, error, metrics, wall_time_s, worker, "
               "method FROM runs WHERE digest = ?")
        args: list = [self.digest]
        if statuses is not None:
            statuses = list(statuses)
            sql += f" AND status IN ({', '.join('?' * len(statuses))})"
            args += statuses
        if method is not None:
            sql += " AND method = ?"
            args.append(method)
        out = []
        for r in self._db.execute(sql + " ORDER BY idx, method", args):
            out.append(StoredRun(int(r[0]), r[1], json.loads(r[2] or "{}"), int(r[3]), r[4], r[5], int(r[6]), r[7],
                                 None if r[8] is None else json.loads(r[8]), r[9], r[10], r[11]))
        return out

    def counts(self) -> dict[str, int]:
        """Runs per status."""
        return {s: int(n) for s, n in self._db.execute(
            "SELECT status, COUNT(*) FROM runs WHERE digest = ? GROUP BY status", (self.digest,))}

    # ------------------------------------------------------------------ export
    def export(self, stem: str | Path | None = None) -> dict[str, Path]:
        """Write ``runs.csv`` and ``runs.parquet`` (or ``<stem>.csv/.parquet``): one row per run,
        the metrics flattened to dotted columns (lists as JSON text); a ``method`` column after
        ``index`` when the campaign compares methods."""
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


def _hulls(text: str | None) -> dict | None:
    """The stored hull records (None: not recorded, or not readable as such)."""
    try:
        value = json.loads(text) if text else None
    except ValueError:
        return None
    return value if isinstance(value, dict) else None


def _flat(prefix: str, value, out: dict) -> None:
    if isinstance(value, dict):
        for k, v in value.items():
            _flat(f"{prefix}.{k}" if prefix else str(k), v, out)
    elif isinstance(value, list):
        out[prefix] = json.dumps(value)
    else:
        out[prefix] = value


def _flat_row(r: StoredRun) -> dict:
    row = {"index": r.index, **({"method": r.method} if r.method else {}), "family": r.family, "seed": r.seed, "status": r.status, "attempts": r.attempts,
           "error": r.error, "wall_time_s": r.wall_time_s, "worker": r.worker}
    _flat("param", r.parameters, row)
    if r.metrics:
        _flat("metric", r.metrics, row)
    return row


def record_result(store: CampaignStore, run, result: dict) -> int:
    """Store ``result`` (a run child's: status, error, summary, wall time, worker) of ``run``
    (:class:`~mjasc.campaigns.spec.RunSpec`); returns the run's attempts so far."""
    return store.record(run.index, family=run.family, parameters=run.parameters, seed=run.seed,
                        scenario=run.scenario_toml, status=result["status"], error=result.get("error"),
                        metrics=result.get("summary"), wall_time_s=result.get("wall_time_s"),
                        worker=result.get("worker"), method=getattr(run, "method", ""))
