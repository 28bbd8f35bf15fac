"""Reading a run from a SQLite store file with the standard library's sqlite3 alone.

A command that only looks at a run (`hadim affordances RUN`, the refusals of `resume` and
`eval` that need no learner) must answer in well under a second, and importing SQLAlchemy
alone takes half of one. :meth:`StoreReader.open` opens a store file of this hadim's schema
that SQLite finds sound (``PRAGMA quick_check``), on a read-only connection that creates no
file, and its methods return the same frozen records as :class:`~hadim_store.api.Store`'s,
with the same errors (tests/store/test_store_reader.py holds them equal). For anything else
(an older or newer schema, a file that is not a hadim store, or one SQLite finds damaged) it
returns None, and the caller opens the full ``Store``, which upgrades, refuses or reports it.

SQLite's own checks of a store file, which need no SQLAlchemy either, live here too.
"""

from __future__ import annotations

import sqlite3
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

from hadim_store import codecs, deltas, locking, migrations
from hadim_store import dataset as datasets
from hadim_store.dataset import DatasetArrays
from hadim_store.errors import RunLocked, name_taken, unknown_run
from hadim_store.records import (
    AffordanceEvent,
    AffordanceStat,
    Checkpoint,
    EpisodeRecord,
    Evaluation,
    RunRecord,
    RunStatus,
    check_iteration,
    check_name,
)

SQLITE_HEADER = b"SQLite format 3\x00"
_RUN_COLUMNS = (
    "r.name, r.status, r.seed, r.config_json, p.name, r.fork_iteration, r.versions_json, "
    "r.iterations, r.created_at, r.updated_at, r.lock_owner, r.lock_pid, r.lock_host, "
    "r.lock_heartbeat"
)
_RUNS = f"SELECT {_RUN_COLUMNS} FROM runs r LEFT JOIN runs p ON p.id = r.parent_id"


def connect_readonly(path: Path) -> sqlite3.Connection:
    """A read-only connection that creates no file. Without a `-wal` file beside it the whole
    database is in `path`, which is then opened `immutable` (so SQLite makes no `-wal`/`-shm`,
    e.g. beside a truncated file it is about to refuse); with one, a live writer may hold
    commits there, and a plain read-only connection reads them."""
    wal = path.with_name(path.name + "-wal")
    flags = "mode=ro" if wal.exists() else "mode=ro&immutable=1"
    return sqlite3.connect(f"{path.resolve().as_uri()}?{flags}", uri=True)


def quick_check(path: Path, *, full: bool = False) -> list[str]:
    """SQLite's own consistency check of a store file: [] if sound, else its findings.

    `PRAGMA quick_check` (`integrity_check` with `full`) reads every page without writing; a
    file too damaged to be checked at all gives one finding."""
    pragma = "integrity_check" if full else "quick_check"
    try:
        conn = connect_readonly(path)
        try:
            rows = [str(r[0]) for r in conn.execute(f"PRAGMA {pragma}(20)")]
        finally:
            conn.close()
    except sqlite3.DatabaseError as exc:
        return [str(exc)]
    return [] if rows == ["ok"] else rows


def _is_current(conn: sqlite3.Connection) -> bool:
    """Whether the database is a hadim store of exactly this hadim's schema."""
    facts = dict(conn.execute("SELECT key, value FROM meta"))
    revisions = [r for (r,) in conn.execute(f"SELECT version_num FROM {migrations.VERSION_TABLE}")]
    return (facts.get("application") == migrations.APPLICATION
            and facts.get("schema_version") == str(migrations.SCHEMA_VERSION)
            and revisions == [migrations.revision_id(migrations.SCHEMA_VERSION)])


def _moment(value: str) -> datetime:
    """A time as SQLAlchemy keeps it in SQLite (naive UTC text), aware."""
    return datetime.fromisoformat(value).replace(tzinfo=UTC)


def _run_record(row: tuple) -> RunRecord:
    (name, status, seed, config, parent, fork_iteration, versions, iterations, created,
     updated, *lock) = row
    holder = locking.holder(*lock)
    return RunRecord(
        name=name, status=RunStatus(status), seed=seed, config=codecs.decode_json(config),
        parent=parent, fork_iteration=fork_iteration, versions=codecs.decode_json(versions),
        iterations=iterations, created_at=_moment(created), updated_at=_moment(updated),
        lock=locking.lock_info(holder) if holder else None,
    )


class StoreReader:
    """A SQLite store file of this hadim's schema, read only, without SQLAlchemy."""

    def __init__(self, conn: sqlite3.Connection, where: str):
        self._conn = conn
        self._where = where

    @classmethod
    def open(cls, path: Path) -> StoreReader | None:
        """A reader of the store file `path`; None unless it is a hadim store of this schema
        that SQLite finds sound (the full `Store` then says what is wrong with it)."""
        try:
            with path.open("rb") as handle:
                if handle.read(len(SQLITE_HEADER)) != SQLITE_HEADER:
                    return None
        except OSError:
            return None
        if quick_check(path):
            return None
        conn = None
        try:
            conn = connect_readonly(path)
            if _is_current(conn):
                return cls(conn, str(path))
        except sqlite3.Error:
            pass
        if conn is not None:
            conn.close()
        return None

    @property
    def where(self) -> str:
        return self._where

    def close(self) -> None:
        self._conn.close()

    def __enter__(self) -> StoreReader:
        return self

    def __exit__(self, *exc_info: object) -> None:
        self.close()

    def __repr__(self) -> str:
        return f"StoreReader({self._where!r})"

    def _run_id(self, name: str) -> int:
        row = self._conn.execute("SELECT id FROM runs WHERE name = ?", (name,)).fetchone()
        if row is None:
            raise unknown_run(name, [n for (n,) in self._conn.execute("SELECT name FROM runs")])
        return row[0]

    def get_run(self, name: str) -> RunRecord:
        row = self._conn.execute(f"{_RUNS} WHERE r.name = ?", (name,)).fetchone()
        if row is None:
            self._run_id(name)  # raises UnknownRun, with the closest names
        return _run_record(row)

    def list_runs(self) -> list[RunRecord]:
        """Every run, oldest first."""
        return [_run_record(row) for row in self._conn.execute(f"{_RUNS} ORDER BY r.id")]

    def episode_extra(self, name: str, upto_iteration: int | None = None
                      ) -> tuple[int, dict[str, Any]] | None:
        """As `Store.episode_extra`: the last stored episode's end iteration and ``extra``
        (the last finished by ``upto_iteration``), without reading its arrays."""
        upto = check_iteration(upto_iteration, "upto_iteration")
        end = "first_iteration + n_iterations"
        query = f"SELECT {end}, extra_json FROM episodes WHERE run_id = ?"
        args: tuple = (self._run_id(name),)
        if upto is not None:
            query, args = f"{query} AND {end} <= ?", (*args, upto)
        row = self._conn.execute(f"{query} ORDER BY episode_index DESC LIMIT 1", args).fetchone()
        return None if row is None else (int(row[0]), codecs.decode_json(row[1]))

    def episodes(self, name: str, upto_iteration: int | None = None) -> list[EpisodeRecord]:
        """As `Store.episodes`: the stored episodes in order (those finished by
        ``upto_iteration``)."""
        upto = check_iteration(upto_iteration, "upto_iteration")
        return self._episodes(name, "first_iteration + n_iterations <= ?", upto)

    def _episodes(self, name: str, until: str, upto: int | None) -> list[EpisodeRecord]:
        query = ("SELECT episode_index, first_iteration, array_codec, actions, contexts, "
                 "outcomes, extra_json FROM episodes WHERE run_id = ?")
        args: tuple = (self._run_id(name),)
        if upto is not None:
            query, args = f"{query} AND {until}", (*args, upto)
        return [EpisodeRecord(index, first, *(codecs.decode_array(a, codec) for a in arrays),
                              codecs.decode_json(extra))
                for index, first, codec, *arrays, extra in
                self._conn.execute(f"{query} ORDER BY episode_index", args)]

    def dataset(self, name: str, upto_iteration: int | None = None) -> DatasetArrays:
        """As `Store.dataset`: D's rows in order (the first ``upto_iteration``)."""
        upto = check_iteration(upto_iteration, "upto_iteration")
        return datasets.stack(name, self._episodes(name, "first_iteration < ?", upto), upto)

    def dataset_sha256(self, name: str, upto_iteration: int | None = None) -> str:
        """As `Store.dataset_sha256`: the digest of D (of its first ``upto_iteration`` rows)."""
        return datasets.digest(self.dataset(name, upto_iteration))

    def events(self, name: str, upto_iteration: int | None = None, *,
               affordance_id: int | None = None) -> list[AffordanceEvent]:
        """As `Store.events`: H's timeline, oldest first (events at ≤ ``upto_iteration``)."""
        return [AffordanceEvent(iteration, aid, kind, given, taken,
                                tuple(codecs.decode_json(context)), competence,
                                codecs.decode_json(detail))
                for iteration, aid, kind, given, taken, context, competence, detail in
                self._per_episode("affordance_events", "kind, input_space, output_space, "
                                  "context_json, competence, detail_json", name,
                                  upto_iteration, affordance_id, "iteration, id")]

    def stats(self, name: str, upto_iteration: int | None = None, *,
              affordance_id: int | None = None) -> list[AffordanceStat]:
        """As `Store.stats`: per-episode affordance snapshots, by iteration then id."""
        return [AffordanceStat(*row) for row in self._per_episode(
            "affordance_stats", "competence, n_data, interest", name, upto_iteration,
            affordance_id, "iteration, affordance_id, id")]

    def _per_episode(self, table: str, columns: str, name: str, upto_iteration: int | None,
                     affordance_id: int | None, order: str) -> list[tuple]:
        """(iteration, affordance_id, *columns) of the run's rows of `table`, by `order`."""
        upto = check_iteration(upto_iteration, "upto_iteration")
        query = (f"SELECT iteration, affordance_id, {columns} FROM {table} "
                 "WHERE run_id = ?")
        args: tuple = (self._run_id(name),)
        if upto is not None:
            query, args = f"{query} AND iteration <= ?", (*args, upto)
        if affordance_id is not None:
            query, args = f"{query} AND affordance_id = ?", (*args, affordance_id)
        return self._conn.execute(f"{query} ORDER BY {order}", args).fetchall()

    def evaluations(self, name: str, task: str | None = None) -> list[Evaluation]:
        """As `Store.evaluations`: by iteration then insertion order; only ``task``'s if
        given."""
        query = ("SELECT iteration, task, score, points_json, created_at FROM evaluations "
                 "WHERE run_id = ?")
        args: tuple = (self._run_id(name),)
        if task is not None:
            query, args = f"{query} AND task = ?", (*args, task)
        return [Evaluation(iteration, measured, score, codecs.decode_json(points),
                           _moment(created))
                for iteration, measured, score, points, created in
                self._conn.execute(f"{query} ORDER BY iteration, id", args)]

    def checkpoint(self, name: str, at_or_before: int | None = None) -> Checkpoint | None:
        """As `Store.checkpoint`: the latest checkpoint at or before ``at_or_before``, read
        with the chain of checkpoints back to its full snapshot; None if there is none."""
        upto = check_iteration(at_or_before, "at_or_before")
        run_id = self._run_id(name)
        rows = {it: (cid, episode, created, base) for cid, it, episode, created, base in
                self._conn.execute("SELECT id, iteration, episode_index, created_at, "
                                   "base_iteration FROM checkpoints WHERE run_id = ?", (run_id,))}
        found = [it for it in rows if upto is None or it <= upto]
        if not found:
            return None
        chain = deltas.chain_to(max(found), {it: row[3] for it, row in rows.items()}, name)
        ids = [rows[it][0] for it in chain]
        levels: dict[int, dict[str, deltas.ItemRow]] = {cid: {} for cid in ids}
        items = self._conn.execute(
            "SELECT checkpoint_id, key, kind, data, text, prefix, skip FROM checkpoint_items "
            f"WHERE checkpoint_id IN ({', '.join('?' * len(ids))}) ORDER BY key", ids)
        for cid, key, *item in items:
            levels[cid][key] = deltas.ItemRow(key, *item)
        arrays, texts = deltas.resolve([levels[cid] for cid in ids])
        _, episode, created, _ = rows[chain[-1]]
        return Checkpoint(chain[-1], episode, _moment(created), arrays, texts)

    def checkpoint_iterations(self, name: str) -> list[int]:
        """As `Store.checkpoint_iterations`: the iterations of the run's checkpoints, in order."""
        return [it for (it,) in self._conn.execute(
            "SELECT iteration FROM checkpoints WHERE run_id = ? ORDER BY iteration",
            (self._run_id(name),))]

    def refuse_taken(self, name: str) -> None:
        """Raise `StoreError`, as `Store.create_run` would, if `name` is not a run name or a
        run has it already."""
        check_name(name)
        if self._conn.execute("SELECT 1 FROM runs WHERE name = ?", (name,)).fetchone():
            raise name_taken(name)

    def refuse_if_locked(self, name: str,
                         timeout_s: float = locking.DEFAULT_TIMEOUT_S) -> None:
        """Raise `RunLocked`, as `Store.acquire_lock` would, if a live process holds the
        run's lock; a free or stale lock passes (whoever writes next takes it)."""
        row = self._conn.execute("SELECT lock_owner, lock_pid, lock_host, lock_heartbeat "
                                 "FROM runs WHERE id = ?", (self._run_id(name),)).fetchone()
        holder = locking.holder(*row)
        if holder is not None and locking.stale_reason(holder, timeout_s=timeout_s) is None:
            raise RunLocked(f"run {name!r} is in use: {locking.describe(holder)}")
