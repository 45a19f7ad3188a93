"""The SQLite results store of ``sosp bench``: one row per finished run, written at once.

Durability: the database runs in WAL mode while a campaign writes it and every finished run is
one transaction, written by the parent process only. When the writer closes it, the database
goes back to a single file (rollback journal), so that readers (``sosp report``) and a
finished campaign leave no ``-wal``/``-shm`` files behind. A run that crashed or was killed
is simply absent and is run again on resume; the unique key
``(scenario, fingerprint, method, params, seed, time_limit)`` means nothing is stored twice.
A failed run (status ``error``) is replaced only when it is retried (``--retry-failed``) and a
success is never overwritten.

Table ``simulations`` holds the days of ``sosp simulate --db`` (:meth:`Store.put_simulation`),
one row per :data:`SIMULATION_KEY`, kept once stored.

Schema version :data:`SCHEMA_VERSION` is kept in table ``meta``. A database of an older
version (1: no ``bound_count`` column; 2: no ``simulations`` table) is read as it is and
upgraded in place when a campaign or a simulation writes to it (:data:`_UPGRADES`, nothing
else changes); any other version is refused with an :class:`~sosp.errors.InputError` before
anything is written.
"""

from __future__ import annotations

import os
import sqlite3
from collections.abc import Iterable, Iterator, Mapping
from contextlib import closing, contextmanager, suppress
from pathlib import Path
from typing import Any

from sosp.campaign.spec import KEY_COLUMNS
from sosp.errors import InputError

#: Bump when the tables change; older or newer databases are refused, except the versions of
#: :data:`_UPGRADES`.
SCHEMA_VERSION = 3

#: What identifies a simulated day (``sosp simulate``): table ``simulations``' unique key.
SIMULATION_KEY = ("scenario", "fingerprint", "plan", "method", "seed", "rate", "outage_hours",
                  "cloud", "freeze", "time_limit")  # fmt: skip

_SIMULATIONS = f"""CREATE TABLE IF NOT EXISTS simulations (
    id INTEGER PRIMARY KEY,
    scenario TEXT NOT NULL,
    fingerprint TEXT NOT NULL,
    plan TEXT NOT NULL,  -- a hash of the morning plan (sosp.simulate.plan_fingerprint)
    method TEXT NOT NULL,
    seed INTEGER NOT NULL,
    rate REAL NOT NULL,
    outage_hours REAL NOT NULL,
    cloud REAL NOT NULL,
    freeze REAL NOT NULL,
    time_limit REAL NOT NULL,
    urgent INTEGER,
    replans INTEGER,
    changes INTEGER,
    replan_s_mean REAL,
    replan_s_max REAL,
    realised_profit REAL,
    hindsight_profit REAL,
    ratio REAL,
    version TEXT NOT NULL,
    finished_at TEXT NOT NULL,
    UNIQUE ({", ".join(SIMULATION_KEY)})
);
"""

#: Older schema version -> the statements that bring it to the next one.
_UPGRADES: dict[str, tuple[str, ...]] = {
    # 2: the count that goes with a run's bound (PBA-STC's F*: targets its bound covers).
    "1": ("ALTER TABLE runs ADD COLUMN bound_count INTEGER",),
    # 3: the days of ``sosp simulate --db``.
    "2": (_SIMULATIONS,),
}

#: Seconds to wait for another writer when opening (then: "database is locked").
OPEN_TIMEOUT = 2.0

#: Seconds to wait for a write lock when storing one run.
WRITE_TIMEOUT = 60.0


_SCHEMA = """
CREATE TABLE IF NOT EXISTS meta (key TEXT PRIMARY KEY, value TEXT NOT NULL);
CREATE TABLE IF NOT EXISTS instances (
    scenario TEXT NOT NULL,
    fingerprint TEXT NOT NULL,
    name TEXT,
    targets INTEGER,
    en INTEGER,
    tn INTEGER,
    orbits INTEGER,
    PRIMARY KEY (scenario, fingerprint)
);
CREATE TABLE IF NOT EXISTS runs (
    id INTEGER PRIMARY KEY,
    scenario TEXT NOT NULL,
    fingerprint TEXT NOT NULL,
    method TEXT NOT NULL,
    params TEXT NOT NULL,
    seed INTEGER NOT NULL,
    time_limit REAL NOT NULL,
    status TEXT NOT NULL,
    message TEXT,
    profit REAL,
    observed INTEGER,
    bound REAL,
    bound_count INTEGER,
    energy REAL,
    memory REAL,
    runtime REAL,
    iterations INTEGER,
    feasible INTEGER,
    verdict TEXT,
    schedule TEXT,
    version TEXT NOT NULL,
    finished_at TEXT NOT NULL,
    UNIQUE (scenario, fingerprint, method, params, seed, time_limit)
);
"""


#: The side files of a database in WAL mode.
SIDE_SUFFIXES = ("-wal", "-shm", "-journal")


def _in_wal_mode(path: Path) -> bool:
    """Whether the database file's header says WAL (bytes 18-19 are 2), read without SQLite."""
    with suppress(OSError), open(path, "rb") as fh:
        return fh.read(20)[18:20] == b"\x02\x02"
    return False  # unreadable


@contextmanager
def new_database_guard(path: str | os.PathLike[str]) -> Iterator[None]:
    """Remove a database this block created if the block fails before storing any run.

    A campaign or simulation refused after the database was opened (a scenario file that does
    not load, an interrupted start) then leaves no empty database behind; an existing database
    and one holding runs or simulations are always kept.
    """
    p = Path(path)
    created = not p.exists()
    try:
        yield
    except BaseException:
        if created and p.exists():
            runs = 0  # also when it is no database or has no runs table
            uri = p.resolve().as_uri() + "?mode=ro"
            with suppress(sqlite3.DatabaseError), closing(sqlite3.connect(uri, uri=True)) as conn:
                sql = "SELECT (SELECT COUNT(*) FROM runs) + (SELECT COUNT(*) FROM simulations)"
                runs = conn.execute(sql).fetchone()[0]
            if runs == 0:
                for f in (p, *(p.with_name(p.name + s) for s in SIDE_SUFFIXES)):
                    f.unlink(missing_ok=True)
        raise


class Store:
    """An open results database.

    Parameters
    ----------
    path
        The SQLite file (created with its folder's permission when missing, unless
        ``readonly``).
    readonly
        Open for reading only (reports); the file must exist. No side file is created: a
        database left in WAL mode with no writer attached is opened as immutable.
    allow_empty
        With ``readonly``: accept an empty file (no tables) as a database with no runs.

    Raises
    ------
    InputError
        If the file is not a sosp results database, has another schema version, or is
        locked by another writer.
    """

    def __init__(
        self, path: str | os.PathLike[str], readonly: bool = False, allow_empty: bool = False
    ) -> None:
        self.path = str(path)
        self.readonly = readonly
        self.allow_empty = allow_empty
        self.empty = False
        p = Path(path)
        if readonly and not p.is_file():
            raise InputError("results database not found", source=self.path)
        if not readonly and not p.parent.is_dir():
            raise InputError(f"folder does not exist: {p.parent}", source=self.path)
        try:
            if readonly:
                uri = p.resolve().as_uri() + "?mode=ro"
                sides = [p.with_name(p.name + s) for s in ("-wal", "-shm")]
                if _in_wal_mode(p) and not any(f.exists() for f in sides):
                    # No writer is attached (it would hold the -wal and -shm files): reading
                    # as immutable creates no side files, which a plain read-only connection
                    # to a WAL database would leave behind.
                    uri += "&immutable=1"
                self.conn = sqlite3.connect(uri, uri=True, timeout=OPEN_TIMEOUT)
            else:
                self.conn = sqlite3.connect(self.path, timeout=OPEN_TIMEOUT, isolation_level=None)
            self.conn.row_factory = sqlite3.Row
            self._check_or_init(readonly)
        except sqlite3.DatabaseError as exc:
            with suppress(Exception):  # closing a half-open connection
                self.conn.close()
            if isinstance(exc, sqlite3.OperationalError) and (
                "locked" in str(exc) or "busy" in str(exc)
            ):
                raise InputError(
                    "database is locked by another process (is another sosp bench writing it?)",
                    source=self.path,
                ) from None
            raise InputError(f"not a sosp results database ({exc})", source=self.path) from None

    @contextmanager
    def _transaction(self) -> Iterator[sqlite3.Cursor]:
        """One write transaction: BEGIN IMMEDIATE, COMMIT, or ROLLBACK on any error."""
        cur = self.conn.cursor()
        cur.execute("BEGIN IMMEDIATE")
        try:
            yield cur
            cur.execute("COMMIT")
        except BaseException:
            if self.conn.in_transaction:
                cur.execute("ROLLBACK")
            raise

    def _check_or_init(self, readonly: bool) -> None:
        cur = self.conn.cursor()
        tables = {r[0] for r in cur.execute("SELECT name FROM sqlite_master WHERE type='table'")}
        version = None
        if "meta" in tables:
            row = cur.execute("SELECT value FROM meta WHERE key='schema_version'").fetchone()
            if row is None:
                raise InputError("database has no schema version: not a sosp results database")
            version = str(row[0])
            if version != str(SCHEMA_VERSION) and version not in _UPGRADES:
                raise InputError(
                    f"database schema version {row[0]} is not {SCHEMA_VERSION} (made by another "
                    "sosp version); use a new --db file",
                    source=self.path,
                )
        elif tables:
            raise InputError("not a sosp results database (no meta table)", source=self.path)
        elif readonly:
            if not self.allow_empty:
                raise InputError("empty database: no runs stored", source=self.path)
            self.empty = True
        if readonly:
            return
        # Take the write lock now: a database locked by another writer is refused at once.
        cur.execute("PRAGMA journal_mode=WAL")
        cur.execute("PRAGMA synchronous=NORMAL")
        if "meta" not in tables:
            cur.executescript(_SCHEMA + _SIMULATIONS)
        with self._transaction() as cur:
            while version is not None and version != str(SCHEMA_VERSION):
                for statement in _UPGRADES[version]:
                    cur.execute(statement)
                version = str(int(version) + 1)
                cur.execute("UPDATE meta SET value=? WHERE key='schema_version'", (version,))
            if "meta" not in tables:
                from sosp import __version__

                cur.executemany(
                    "INSERT OR IGNORE INTO meta(key, value) VALUES (?, ?)",
                    [("schema_version", str(SCHEMA_VERSION)), ("created_by", __version__)],
                )
        self.conn.execute(f"PRAGMA busy_timeout={int(WRITE_TIMEOUT * 1000)}")

    # ------------------------------------------------------------------ reading
    def done_keys(self, include_failed: bool = True) -> set[tuple[Any, ...]]:
        """Keys of stored runs (failed ones too unless ``include_failed`` is False)."""
        if self.empty:
            return set()
        sql = f"SELECT {', '.join(KEY_COLUMNS)} FROM runs"
        if not include_failed:
            sql += " WHERE status != 'error'"
        return {tuple(r) for r in self.conn.execute(sql)}

    def rows(self, where: str = "", args: Iterable[Any] = ()) -> list[dict[str, Any]]:
        """All runs (``where`` is an optional SQL condition with ``?`` arguments)."""
        sql = "SELECT * FROM runs" + (f" WHERE {where}" if where else "") + " ORDER BY id"
        return [dict(r) for r in self.conn.execute(sql, tuple(args))]

    def instances(self) -> list[dict[str, Any]]:
        """The instance table: scenario, fingerprint, name, targets, en, tn, orbits."""
        return [dict(r) for r in self.conn.execute("SELECT * FROM instances")]

    def simulations(self, where: str = "", args: Iterable[Any] = ()) -> list[dict[str, Any]]:
        """The stored days of ``sosp simulate`` (none in a database older than schema 3)."""
        if "simulations" not in {r[0] for r in self.conn.execute("SELECT name FROM sqlite_master")}:
            return []
        sql = "SELECT * FROM simulations" + (f" WHERE {where}" if where else "") + " ORDER BY id"
        return [dict(r) for r in self.conn.execute(sql, tuple(args))]

    def count(self) -> int:
        return int(self.conn.execute("SELECT COUNT(*) FROM runs").fetchone()[0])

    # ------------------------------------------------------------------ writing
    def put_instances(self, infos: Iterable[Mapping[str, Any]]) -> None:
        """Record the scenarios' sizes (EN, TN, ...) in one transaction (existing rows kept)."""
        with self._transaction() as cur:
            cur.executemany(
                "INSERT OR IGNORE INTO instances VALUES "
                "(:scenario, :fingerprint, :name, :targets, :en, :tn, :orbits)",
                infos,
            )

    def put(self, row: Mapping[str, Any]) -> bool:
        """Store one finished run in one transaction; returns True if a row was written.

        An existing success is kept; an existing failure is replaced.
        """
        cols = [r[1] for r in self.conn.execute("PRAGMA table_info(runs)") if r[1] != "id"]
        updates = ", ".join(f"{c}=excluded.{c}" for c in cols if c not in KEY_COLUMNS)
        with self._transaction() as cur:
            cur.execute(
                f"INSERT INTO runs({', '.join(cols)}) VALUES ({', '.join('?' * len(cols))}) "
                f"ON CONFLICT({', '.join(KEY_COLUMNS)}) DO UPDATE SET {updates} "
                "WHERE runs.status = 'error'",
                [row.get(c) for c in cols],
            )
            return cur.rowcount > 0

    def put_simulation(self, row: Mapping[str, Any]) -> bool:
        """Store one simulated day in one transaction; returns False (and writes nothing) when
        a day of the same :data:`SIMULATION_KEY` is stored already."""
        cols = [r[1] for r in self.conn.execute("PRAGMA table_info(simulations)") if r[1] != "id"]
        with self._transaction() as cur:
            cur.execute(
                f"INSERT OR IGNORE INTO simulations({', '.join(cols)}) "
                f"VALUES ({', '.join('?' * len(cols))})",
                [row.get(c) for c in cols],
            )
            return cur.rowcount > 0

    def close(self) -> None:
        """Close; a writer first folds the WAL back into the file and leaves WAL mode, so the
        database is one file again (another writer still attached keeps WAL mode)."""
        if not self.readonly:
            with suppress(sqlite3.DatabaseError):  # busy: another connection uses it; keep WAL
                self.conn.execute("PRAGMA wal_checkpoint(TRUNCATE)")
                self.conn.execute("PRAGMA journal_mode=DELETE")
        self.conn.close()

    def __enter__(self) -> Store:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
