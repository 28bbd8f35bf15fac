"""The store's API: one :class:`Store` object per opened store, frozen records in and out."""

from __future__ import annotations

import numbers
import os
import re
import time
from collections.abc import Iterator, Mapping, Sequence
from contextlib import contextmanager
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

import numpy as np
from sqlalchemy import URL, Engine, Select, delete, func, insert, literal, select, text, update
from sqlalchemy.exc import IntegrityError
from sqlalchemy.orm import Session, sessionmaker

from hadim_store import codecs, deltas, locking
from hadim_store import dataset as datasets
from hadim_store import engine as engines
from hadim_store.dataset import DatasetArrays
from hadim_store.errors import RunLocked, StoreError, name_taken, unknown_run
from hadim_store.models import (
    AffordanceEventRow,
    AffordanceStatRow,
    CheckpointItem,
    CheckpointRow,
    Episode,
    EvaluationRow,
    InterestRegionRow,
    Meta,
    Run,
)
from hadim_store.records import (
    AffordanceEvent,
    AffordanceStat,
    Checkpoint,
    EpisodeRecord,
    EpisodeWrite,
    Evaluation,
    InterestRegion,
    LockInfo,
    RunRecord,
    RunStatus,
    check_iteration,
    check_name,
)
from hadim_store.schema import Upgrade

DEFAULT_LOCK_TIMEOUT_S = locking.DEFAULT_TIMEOUT_S
_AUTO_NAME_RE = re.compile(r"run-(\d+)")
_MAX_SEED = 2**63 - 1
_KIND_MAX = 32
# On a database server, write scopes lock the rows of the runs they touch (SELECT … FOR UPDATE)
# and auto-naming takes this advisory lock; SQLite's BEGIN IMMEDIATE serialises writes anyway.
_LOCK_RUN_ROWS = "hadim_lock_run_rows"
_AUTO_NAME_LOCK_KEY = 0x4841_4449_4D01
_SWEEP_PREFIX = "sweep:"
_META_KEY_MAX = 64
# Rows that belong to one episode of a run; copied on fork up to the checkpoint's episode.
_PER_EPISODE = (Episode, AffordanceEventRow, AffordanceStatRow, InterestRegionRow)




def _now() -> datetime:
    return datetime.now(UTC).replace(tzinfo=None)


def _aware(moment: datetime) -> datetime:
    return moment.replace(tzinfo=UTC)


def _locate(url: str | Path, *, create: bool) -> tuple[URL, str]:
    """The store's URL and how to name it in messages; a SQLite file is checked first, read
    only (not a hadim store, or too new: refused with nothing written)."""
    resolved = engines.resolve_url(url)
    path = engines.sqlite_file(resolved)
    if path is not None:
        engines.check_sqlite_file(path, create=create)
    return resolved, str(path) if path is not None else resolved.render_as_string(
        hide_password=True)


def upgrade_store(url: str | Path, *, dry_run: bool = False) -> Upgrade:
    """Bring an existing store to this hadim's schema: every pending revision, including those
    not applied on open, in one transaction (a failure leaves the store as it was).

    ``dry_run`` reports what would be applied and writes nothing. See docs/store.md."""
    resolved, where = _locate(url, create=False)
    engine = engines.make_engine(resolved)
    try:
        report = engines.prepare_schema(engine, where, create=False, explicit=True,
                                        dry_run=dry_run)
    finally:
        engine.dispose()
    assert report is not None  # create=False: an empty database was refused
    return report


class Store:
    """A hadim experiment store on one SQLAlchemy engine.

    Open with :meth:`Store.open`; close with :meth:`close` or use it as a context manager.
    Every method runs in its own transaction; writes are atomic.
    """

    def __init__(self, engine: Engine, where: str, *, lock_timeout: float, compress: bool,
                 snapshot_every: int = deltas.DEFAULT_SNAPSHOT_EVERY):
        self._engine = engine
        self._where = where
        self._sessions = sessionmaker(engine, expire_on_commit=False)
        self._sqlite = engine.dialect.name == "sqlite"
        self.lock_timeout = float(lock_timeout)
        self.compress = compress
        self.snapshot_every = max(1, int(snapshot_every))
        # run id → its last checkpoint written by this object: the base of the next delta.
        self._last: dict[int, deltas.LastWritten] = {}

    @classmethod
    def open(
        cls,
        url: str | Path,
        *,
        create: bool = True,
        lock_timeout: float = DEFAULT_LOCK_TIMEOUT_S,
        compress: bool = True,
        snapshot_every: int = deltas.DEFAULT_SNAPSHOT_EVERY,
        upgrade: bool = True,
    ) -> Store:
        """Open (and with ``create``, initialise) the store at a path or SQLAlchemy URL.

        A file that is not SQLite, or a SQLite database that is not a hadim store, is refused
        with :class:`SchemaError` before anything is written to it. Without ``upgrade`` a store
        that would need one is refused too (one of this schema from before alembic is read as
        it is, unstamped): opening then writes nothing to the schema. An older schema is
        migrated; a newer one is refused. ``compress`` deflates new arrays with zlib.
        One checkpoint in ``snapshot_every`` that this object writes for a run is a full
        snapshot, the others deltas (1: all full); see :mod:`hadim_store.deltas`.
        """
        resolved, where = _locate(url, create=create)
        engine = engines.make_engine(resolved)
        try:
            engines.prepare_schema(engine, where, create=create, upgrade=upgrade)
        except BaseException:
            engine.dispose()
            raise
        return cls(engine, where, lock_timeout=lock_timeout, compress=compress,
                   snapshot_every=snapshot_every)

    @property
    def where(self) -> str:
        """The store's file path, or its URL with any password hidden."""
        return self._where

    @property
    def engine(self) -> Engine:
        return self._engine

    def close(self) -> None:
        self._engine.dispose()

    def __enter__(self) -> Store:
        return self

    def __exit__(self, *exc_info: object) -> None:
        self.close()

    def __repr__(self) -> str:
        return f"Store({self._where!r})"

    def flush_wal(self) -> None:
        """SQLite: move the write-ahead log's pages into the database file (a WAL checkpoint),
        so that the file's size is the store's; nothing on other backends."""
        if not engines.is_sqlite(self._engine.url) or engines.sqlite_file(self._engine.url) is None:
            return
        with self._engine.connect() as conn:
            conn.exec_driver_sql("PRAGMA wal_checkpoint(TRUNCATE)")

    @contextmanager
    def session_scope(self, *, write: bool = True) -> Iterator[Session]:
        """A session whose work is committed on success and rolled back on any error."""
        session = self._sessions()
        try:
            if write and self._sqlite:
                session.connection(execution_options={engines.BEGIN_MODE_OPTION: "IMMEDIATE"})
            elif write:
                # A server has no database-wide write lock: writes lock the run's row instead.
                session.info[_LOCK_RUN_ROWS] = True
            yield session
            session.commit()
        except BaseException:
            session.rollback()
            raise
        finally:
            session.close()

    # ------------------------------------------------------------------ runs

    def create_run(
        self,
        *,
        config: Mapping[str, Any],
        seed: int,
        name: str | None = None,
        parent: str | None = None,
        fork_iteration: int | None = None,
        versions: Mapping[str, Any] | None = None,
    ) -> RunRecord:
        """A new, empty, ``paused`` run; named ``run-N`` (next free N) when ``name`` is None.

        ``parent``/``fork_iteration`` only label the run; use :meth:`fork` to copy history.
        """
        with self.session_scope() as session:
            parent_id = _run_row(session, parent).id if parent is not None else None
            row = self._new_run(
                session,
                config=config,
                seed=seed,
                name=name,
                parent_id=parent_id,
                fork_iteration=check_iteration(fork_iteration, "fork_iteration"),
                versions=versions,
                iterations=0,
            )
            return _run_record(session, row)

    def get_run(self, name: str) -> RunRecord:
        with self.session_scope(write=False) as session:
            return _run_record(session, _run_row(session, name))

    def list_runs(self) -> list[RunRecord]:
        """Every run, oldest first."""
        with self.session_scope(write=False) as session:
            rows = session.scalars(select(Run).order_by(Run.id)).all()
            names = {row.id: row.name for row in rows}
            return [_run_record(session, row, names) for row in rows]

    def set_status(self, name: str, status: RunStatus | str) -> RunRecord:
        try:
            status = RunStatus(status)
        except ValueError as exc:
            allowed = ", ".join(s.value for s in RunStatus)
            raise StoreError(f"unknown run status {status!r} (one of: {allowed})") from exc
        with self.session_scope() as session:
            row = _run_row(session, name)
            row.status = status.value
            row.updated_at = _now()
            session.flush()
            return _run_record(session, row)

    def delete_run(self, name: str) -> None:
        """Delete a run and everything it stored; forks of it keep their copies.

        Refused while another live owner holds the run's lock.
        """
        with self.session_scope() as session:
            row = _run_row(session, name)
            holder = _holder(row)
            if holder is not None and self._stale(holder) is None:
                raise RunLocked(f"cannot delete run {name!r}: {locking.describe(holder)}")
            self._last.pop(row.id, None)
            session.execute(delete(Run).where(Run.id == row.id))

    # ---------------------------------------------------------------- sweeps

    def claim_sweep(self, name: str, settings: Mapping[str, Any]) -> bool:
        """Record a sweep's settings under its name; True if new, False if the same settings
        are already recorded. Other settings under a recorded name raise :class:`StoreError`
        and change nothing. Kept in ``meta`` as ``sweep:NAME`` (no schema change)."""
        key = f"{_SWEEP_PREFIX}{check_name(name)}"
        if len(key) > _META_KEY_MAX:
            raise StoreError(f"sweep name {name!r} is too long")
        wanted = codecs.encode_json(dict(settings))
        with self.session_scope() as session:
            if session.info.get(_LOCK_RUN_ROWS):
                session.execute(text("SELECT pg_advisory_xact_lock(:key)"),
                                {"key": _AUTO_NAME_LOCK_KEY})
            stored = session.scalar(select(Meta.value).where(Meta.key == key))
            if stored is None:
                session.add(Meta(key=key, value=wanted))
                return True
            if stored != wanted:
                raise StoreError(f"sweep {name!r} is in use in {self._where} with other "
                                 "settings (configs, grid, seeds, iterations or evaluation): "
                                 "give this one another name")
            return False

    def sweep_settings(self, name: str) -> dict[str, Any] | None:
        """The settings a sweep was claimed with, or None for an unknown sweep."""
        with self.session_scope(write=False) as session:
            stored = session.scalar(select(Meta.value).where(Meta.key == f"{_SWEEP_PREFIX}{name}"))
        return None if stored is None else codecs.decode_json(stored)

    def sweeps(self) -> list[str]:
        """The names of every claimed sweep, sorted."""
        with self.session_scope(write=False) as session:
            keys = session.scalars(select(Meta.key).where(Meta.key.like(f"{_SWEEP_PREFIX}%")))
            return sorted(k[len(_SWEEP_PREFIX):] for k in keys)

    # -------------------------------------------------------------- episodes

    def write_episode(self, name: str, episode: EpisodeWrite, *, owner: str | None = None) -> None:
        """Store one episode and everything it produced, in one transaction.

        Episode indices start at 0 and are contiguous; an index already stored is refused, as
        is a ``first_iteration`` other than the run's stored iteration count. With ``owner``,
        the write is refused unless ``owner`` holds the run's lock, and refreshes its heartbeat.
        """
        _validate_episode(episode)
        memory = None
        with self.session_scope() as session:
            run = _run_row(session, name)
            if owner is not None and run.lock_owner != owner:
                raise RunLocked(f"run {name!r} is not locked by {owner!r}: not writing")
            _check_next_episode(session, run, episode)
            memory = self._add_episode_rows(session, run, episode)
            now = _now()
            run.iterations = episode.end_iteration
            run.updated_at = now
            if owner is not None:
                run.lock_heartbeat = time.time()
        if memory is not None:  # only once committed: a failed write keeps the old base
            self._last[run.id] = memory

    def _add_episode_rows(self, session: Session, run: Run,
                          episode: EpisodeWrite) -> deltas.LastWritten | None:
        run_id = run.id
        codec = codecs.NPY_ZLIB if self.compress else codecs.NPY
        arrays = {
            key: codecs.encode_array(getattr(episode, key), compress=self.compress)
            for key in ("actions", "contexts", "outcomes")
        }
        session.add(
            Episode(
                run_id=run_id,
                episode_index=episode.index,
                first_iteration=episode.first_iteration,
                n_iterations=episode.n_iterations,
                array_codec=codec,
                extra_json=codecs.encode_json(dict(episode.extra)),
                **arrays,
            )
        )
        try:
            session.flush()
        except IntegrityError as exc:
            raise StoreError(f"episode {episode.index} is already stored") from exc
        tag = {"run_id": run_id, "episode_index": episode.index}
        _insert(session, AffordanceEventRow, [tag | _event_values(e) for e in episode.events])
        _insert(session, AffordanceStatRow, [tag | _stat_values(s) for s in episode.stats])
        _insert(session, InterestRegionRow, [tag | _region_values(r) for r in episode.regions])
        if episode.checkpoint_arrays is not None or episode.checkpoint_json is not None:
            return self._add_checkpoint(session, run, episode)
        return None

    def _add_checkpoint(self, session: Session, run: Run,
                        episode: EpisodeWrite) -> deltas.LastWritten:
        """Write the checkpoint, as a delta against the run's previous one when this object
        wrote that one and it is still the run's latest; returns the memory for the next."""
        arrays = episode.checkpoint_arrays or {}
        texts = episode.checkpoint_json or {}
        clash = set(arrays) & set(texts)
        if clash:
            raise StoreError(f"checkpoint keys used for both an array and JSON: {sorted(clash)}")
        base = self._delta_base(session, run)
        encoded = deltas.checkpoint_items(
            {_item_key(k): v for k, v in arrays.items()},
            {_item_key(k): v for k, v in texts.items()},
            compress=self.compress, base=base, snapshot_every=self.snapshot_every,
            run_created=run.created_at, iteration=episode.end_iteration,
        )
        row = CheckpointRow(
            run_id=run.id,
            iteration=episode.end_iteration,
            episode_index=episode.index,
            created_at=_now(),
            base_iteration=base.iteration if encoded.delta else None,
        )
        session.add(row)
        session.flush()
        _insert(session, CheckpointItem, [
            {"checkpoint_id": row.id, "key": r.key, "kind": r.kind, "data": r.data,
             "text": r.text, "prefix": r.prefix, "skip": r.skip}
            for r in encoded.rows
        ])
        encoded.memory.checkpoint_id = row.id
        return encoded.memory

    def _delta_base(self, session: Session, run: Run) -> deltas.LastWritten | None:
        """The remembered last checkpoint of ``run``, if it is still the run's latest."""
        last = self._last.get(run.id)
        if last is None or last.run_created != run.created_at:
            return None
        latest = _checkpoint_row(session, run.id, None)
        if latest is None or latest.id != last.checkpoint_id or latest.iteration != last.iteration:
            return None
        return last

    def episodes(self, name: str, upto_iteration: int | None = None) -> list[EpisodeRecord]:
        """Stored episodes in order; with ``upto_iteration=t``, those finished by iteration t."""
        upto = check_iteration(upto_iteration, "upto_iteration")
        with self.session_scope(write=False) as session:
            query = _episodes_query(_run_row(session, name).id)
            if upto is not None:
                query = query.where(Episode.first_iteration + Episode.n_iterations <= upto)
            return [_episode_record(row) for row in session.scalars(query)]

    def episode_extra(self, name: str, upto_iteration: int | None = None
                      ) -> tuple[int, dict[str, Any]] | None:
        """The last stored episode's end iteration and ``extra`` (with ``upto_iteration=t``, the
        last finished by iteration t), without reading its arrays; None if there is none."""
        upto = check_iteration(upto_iteration, "upto_iteration")
        end = Episode.first_iteration + Episode.n_iterations
        with self.session_scope(write=False) as session:
            query = (select(end, Episode.extra_json)
                     .where(Episode.run_id == _run_row(session, name).id)
                     .order_by(Episode.episode_index.desc()).limit(1))
            if upto is not None:
                query = query.where(end <= upto)
            row = session.execute(query).first()
        return None if row is None else (int(row[0]), codecs.decode_json(row[1]))

    def dataset(self, name: str, upto_iteration: int | None = None) -> DatasetArrays:
        """D: every stored iteration's action, context and outcome, concatenated in order.

        With ``upto_iteration=t``, the first t rows (D as it was after t iterations). An empty
        run gives three empty float64 arrays of shape (0,).
        """
        upto = check_iteration(upto_iteration, "upto_iteration")
        with self.session_scope(write=False) as session:
            query = _episodes_query(_run_row(session, name).id)
            if upto is not None:
                query = query.where(Episode.first_iteration < upto)
            rows = [_episode_record(row) for row in session.scalars(query)]
        return datasets.stack(name, rows, upto)

    def dataset_sha256(self, name: str, upto_iteration: int | None = None) -> str:
        """A digest of D (dtype, shape and bytes of actions, contexts, outcomes, in that order).

        Equal data sets give equal digests however they were split into episodes.
        """
        return datasets.digest(self.dataset(name, upto_iteration))

    # ---------------------------------------------------------- learner state

    def events(
        self, name: str, upto_iteration: int | None = None, *, affordance_id: int | None = None
    ) -> list[AffordanceEvent]:
        """The affordance timeline, oldest first; with ``upto_iteration``, events at ≤ it."""
        query = select(AffordanceEventRow).order_by(
            AffordanceEventRow.iteration, AffordanceEventRow.id
        )
        rows = self._select_upto(name, query, AffordanceEventRow, upto_iteration, affordance_id)
        return [_event_record(row) for row in rows]

    def stats(
        self, name: str, upto_iteration: int | None = None, *, affordance_id: int | None = None
    ) -> list[AffordanceStat]:
        """Per-episode affordance snapshots, by iteration then affordance id."""
        query = select(AffordanceStatRow).order_by(
            AffordanceStatRow.iteration, AffordanceStatRow.affordance_id, AffordanceStatRow.id
        )
        rows = self._select_upto(name, query, AffordanceStatRow, upto_iteration, affordance_id)
        return [
            AffordanceStat(r.iteration, r.affordance_id, r.competence, r.n_data, r.interest)
            for r in rows
        ]

    def _select_upto(
        self, name: str, query: Select, model: type, upto: int | None, affordance_id: int | None
    ) -> list[Any]:
        upto = check_iteration(upto, "upto_iteration")
        with self.session_scope(write=False) as session:
            query = query.where(model.run_id == _run_row(session, name).id)
            if upto is not None:
                query = query.where(model.iteration <= upto)
            if affordance_id is not None:
                query = query.where(model.affordance_id == affordance_id)
            return list(session.scalars(query))

    def interest_regions(
        self, name: str, iteration: int | None = None, *, affordance_id: int | None = None
    ) -> list[InterestRegion]:
        """The latest interest-map snapshot at or before ``iteration`` (the last if None)."""
        upto = check_iteration(iteration, "iteration")
        with self.session_scope(write=False) as session:
            run_id = _run_row(session, name).id
            latest = select(func.max(InterestRegionRow.iteration)).where(
                InterestRegionRow.run_id == run_id
            )
            if upto is not None:
                latest = latest.where(InterestRegionRow.iteration <= upto)
            snapshot = session.scalar(latest)
            if snapshot is None:
                return []
            query = (
                select(InterestRegionRow)
                .where(InterestRegionRow.run_id == run_id, InterestRegionRow.iteration == snapshot)
                .order_by(InterestRegionRow.affordance_id, InterestRegionRow.region_id)
            )
            if affordance_id is not None:
                query = query.where(InterestRegionRow.affordance_id == affordance_id)
            return [_region_record(row) for row in session.scalars(query)]

    def checkpoint(self, name: str, at_or_before: int | None = None) -> Checkpoint | None:
        """The latest checkpoint at or before ``at_or_before`` (the last if None), or None.

        A delta checkpoint is read with the chain of checkpoints back to its full snapshot."""
        upto = check_iteration(at_or_before, "at_or_before")
        with self.session_scope(write=False) as session:
            run_id = _run_row(session, name).id
            row = _checkpoint_row(session, run_id, upto)
            if row is None:
                return None
            rows = {r.iteration: r for r in session.scalars(
                select(CheckpointRow).where(CheckpointRow.run_id == run_id))}
            chain = [rows[it] for it in deltas.chain_to(
                row.iteration, {it: r.base_iteration for it, r in rows.items()}, name)]
            levels: dict[int, dict[str, deltas.ItemRow]] = {c.id: {} for c in chain}
            items = session.scalars(
                select(CheckpointItem)
                .where(CheckpointItem.checkpoint_id.in_(list(levels)))
                .order_by(CheckpointItem.key)
            )
            for item in items:
                levels[item.checkpoint_id][item.key] = deltas.ItemRow(
                    item.key, item.kind, item.data, item.text, item.prefix, item.skip)
            arrays, texts = deltas.resolve([levels[c.id] for c in chain])
            return Checkpoint(
                row.iteration, row.episode_index, _aware(row.created_at), arrays, texts
            )

    def checkpoint_iterations(self, name: str) -> list[int]:
        with self.session_scope(write=False) as session:
            run_id = _run_row(session, name).id
            query = (
                select(CheckpointRow.iteration)
                .where(CheckpointRow.run_id == run_id)
                .order_by(CheckpointRow.iteration)
            )
            return list(session.scalars(query))

    # ------------------------------------------------------------------ fork

    def fork(
        self,
        parent: str,
        *,
        at_iteration: int | None = None,
        config: Mapping[str, Any],
        seed: int,
        name: str | None = None,
        versions: Mapping[str, Any] | None = None,
    ) -> RunRecord:
        """A new ``paused`` run continuing ``parent`` from its latest checkpoint ≤ at_iteration.

        Episodes, events, stats, interest regions and checkpoints up to that checkpoint's
        episode, and evaluations at or before its iteration, are copied in one transaction;
        the parent is not modified. ``at_iteration=None`` forks from the last checkpoint.
        """
        with self.session_scope() as session:
            source = _run_row(session, parent)
            chosen = _fork_checkpoint(session, source, at_iteration)
            row = self._new_run(
                session,
                config=config,
                seed=seed,
                name=name,
                parent_id=source.id,
                fork_iteration=chosen.iteration,
                versions=versions,
                iterations=chosen.iteration,
            )
            _copy_history(session, source.id, row.id, chosen)
            return _run_record(session, row)

    def rewind(self, name: str, *, to_checkpoint: int | None = None) -> RunRecord:
        """Discard everything after a checkpoint, so the run can resume from it exactly.

        Keeps the latest checkpoint at or before ``to_checkpoint`` (the last one if None) and
        deletes later episodes, events, stats, regions, checkpoints and evaluations, in one
        transaction. Refused while another live owner holds the lock.
        """
        with self.session_scope() as session:
            row = _run_row(session, name)
            holder = _holder(row)
            if holder is not None and self._stale(holder) is None:
                raise RunLocked(f"cannot rewind run {name!r}: {locking.describe(holder)}")
            chosen = _fork_checkpoint(session, row, to_checkpoint)
            for model in _PER_EPISODE:
                session.execute(
                    delete(model.__table__).where(
                        model.__table__.c.run_id == row.id,
                        model.__table__.c.episode_index > chosen.episode_index,
                    )
                )
            for model in (CheckpointRow, EvaluationRow):
                session.execute(
                    delete(model.__table__).where(
                        model.__table__.c.run_id == row.id,
                        model.__table__.c.iteration > chosen.iteration,
                    )
                )
            self._last.pop(row.id, None)
            row.iterations = chosen.iteration
            row.updated_at = _now()
            session.flush()
            return _run_record(session, row)

    # ----------------------------------------------------------- evaluations

    def add_evaluation(
        self, name: str, iteration: int, task: str, score: float, points: Sequence[Any] = ()
    ) -> Evaluation:
        iteration = check_iteration(iteration, "iteration")
        if not isinstance(task, str) or not task or len(task) > 128:
            raise StoreError(f"evaluation task must be a name of 1-128 characters, got {task!r}")
        checked = codecs.finite_or_none(score, "evaluation score")
        if checked is None:
            raise StoreError("evaluation score must be a number")
        row = EvaluationRow(
            iteration=iteration,
            task=task,
            score=checked,
            points_json=codecs.encode_json(list(points)),
            created_at=_now(),
        )
        with self.session_scope() as session:
            row.run_id = _run_row(session, name).id
            session.add(row)
            session.flush()
            return _evaluation_record(row)

    def evaluations(self, name: str, task: str | None = None) -> list[Evaluation]:
        """Evaluations by iteration then insertion order; only ``task``'s if given."""
        with self.session_scope(write=False) as session:
            query = (
                select(EvaluationRow)
                .where(EvaluationRow.run_id == _run_row(session, name).id)
                .order_by(EvaluationRow.iteration, EvaluationRow.id)
            )
            if task is not None:
                query = query.where(EvaluationRow.task == task)
            return [_evaluation_record(row) for row in session.scalars(query)]

    # --------------------------------------------------------------- locking

    def acquire_lock(self, name: str, owner: str) -> LockInfo | None:
        """Take the run's lock for ``owner`` (re-entrant for the same owner).

        Returns the stale lock it took over (dead pid on this host, or no heartbeat for
        ``lock_timeout`` seconds), else None. Raises :class:`RunLocked` if a live owner holds it.
        """
        if not owner or len(owner) > 128:
            raise StoreError("lock owner must be a non-empty string of at most 128 characters")
        mine = {
            "lock_owner": owner,
            "lock_pid": os.getpid(),
            "lock_host": locking.this_host(),
            "lock_heartbeat": time.time(),
        }
        with self.session_scope() as session:
            row = _run_row(session, name)
            free = (Run.lock_owner.is_(None)) | (Run.lock_owner == owner)
            if _conditional_update(session, row.id, free, mine):
                return None
            session.refresh(row)
            holder = _holder(row)
            if holder is None:  # released between our two statements
                if _conditional_update(session, row.id, Run.lock_owner.is_(None), mine):
                    return None
                raise RunLocked(f"run {name!r} was locked by another process meanwhile")
            if self._stale(holder) is None:
                raise RunLocked(f"run {name!r} is in use: {locking.describe(holder)}")
            same = (Run.lock_owner == holder.owner) & (Run.lock_heartbeat == holder.heartbeat)
            if not _conditional_update(session, row.id, same, mine):
                raise RunLocked(f"run {name!r} was taken over by another process meanwhile")
            return locking.lock_info(holder)

    def refuse_if_locked(self, name: str) -> None:
        """Raise :class:`RunLocked`, as :meth:`acquire_lock` would, if a live process holds the
        run's lock; a free or stale lock passes (whoever writes next takes it). Writes nothing."""
        with self.session_scope(write=False) as session:
            holder = _holder(_run_row(session, name))
        if holder is not None and self._stale(holder) is None:
            raise RunLocked(f"run {name!r} is in use: {locking.describe(holder)}")

    def heartbeat(self, name: str, owner: str) -> None:
        """Refresh ``owner``'s lock; raises :class:`RunLocked` if ``owner`` no longer holds it."""
        with self.session_scope() as session:
            row = _run_row(session, name)
            if not _conditional_update(
                session, row.id, Run.lock_owner == owner, {"lock_heartbeat": time.time()}
            ):
                session.refresh(row)
                holder = _holder(row)
                now_held = f"now {locking.describe(holder)}" if holder else "it is not locked"
                raise RunLocked(f"run {name!r} is no longer locked by {owner!r}: {now_held}")

    def release_lock(self, name: str, owner: str) -> bool:
        """Release ``owner``'s lock; False if ``owner`` did not hold it (nothing changed)."""
        cleared = {"lock_owner": None, "lock_pid": None, "lock_host": None, "lock_heartbeat": None}
        with self.session_scope() as session:
            row = _run_row(session, name)
            return _conditional_update(session, row.id, Run.lock_owner == owner, cleared)

    def _stale(self, holder: locking.Holder) -> str | None:
        return locking.stale_reason(holder, timeout_s=self.lock_timeout)

    # --------------------------------------------------------------- helpers

    def _new_run(
        self,
        session: Session,
        *,
        config: Mapping[str, Any],
        seed: int,
        name: str | None,
        parent_id: int | None,
        fork_iteration: int | None,
        versions: Mapping[str, Any] | None,
        iterations: int,
    ) -> Run:
        if not isinstance(config, Mapping):
            raise StoreError(f"run config must be a mapping, got {type(config).__name__}")
        if (
            isinstance(seed, bool)
            or not isinstance(seed, numbers.Integral)
            or not (0 <= seed <= _MAX_SEED)
        ):
            raise StoreError(f"seed must be an integer in [0, 2**63 - 1], got {seed!r}")
        if name is None:
            name = _next_auto_name(session)
        else:
            check_name(name)
            if session.scalar(select(Run.id).where(Run.name == name)) is not None:
                raise name_taken(name)
        now = _now()
        row = Run(
            name=name,
            status=RunStatus.PAUSED.value,
            seed=int(seed),
            config_json=codecs.encode_json(dict(config)),
            parent_id=parent_id,
            fork_iteration=fork_iteration,
            versions_json=codecs.encode_json(dict(versions or {})),
            iterations=iterations,
            created_at=now,
            updated_at=now,
        )
        session.add(row)
        try:
            session.flush()
        except IntegrityError as exc:
            raise name_taken(name) from exc
        return row


# ---------------------------------------------------------------- module helpers


def _run_row(session: Session, name: str) -> Run:
    query = select(Run).where(Run.name == name)
    if session.info.get(_LOCK_RUN_ROWS):
        query = query.with_for_update()
    row = session.scalar(query)
    if row is not None:
        return row
    raise unknown_run(name, list(session.scalars(select(Run.name))))


def _next_auto_name(session: Session) -> str:
    if session.info.get(_LOCK_RUN_ROWS):  # two creators must not both pick run-N
        session.execute(text("SELECT pg_advisory_xact_lock(:key)"), {"key": _AUTO_NAME_LOCK_KEY})
    numbers = [
        int(match.group(1))
        for candidate in session.scalars(select(Run.name).where(Run.name.like("run-%")))
        if (match := _AUTO_NAME_RE.fullmatch(candidate))
    ]
    return f"run-{max(numbers, default=0) + 1}"


def _holder(row: Run) -> locking.Holder | None:
    return locking.holder(row.lock_owner, row.lock_pid, row.lock_host, row.lock_heartbeat)


def _conditional_update(session: Session, run_id: int, condition: Any, values: dict) -> bool:
    """UPDATE runs SET values WHERE id = run_id AND condition; whether a row changed."""
    result = session.execute(
        update(Run.__table__).where(Run.__table__.c.id == run_id, condition).values(**values)
    )
    return result.rowcount == 1


def _run_record(session: Session, row: Run, names: Mapping[int, str] | None = None) -> RunRecord:
    parent = None
    if row.parent_id is not None:
        parent = (
            names[row.parent_id]
            if names
            else session.scalar(select(Run.name).where(Run.id == row.parent_id))
        )
    holder = _holder(row)
    return RunRecord(
        name=row.name,
        status=RunStatus(row.status),
        seed=row.seed,
        config=codecs.decode_json(row.config_json),
        parent=parent,
        fork_iteration=row.fork_iteration,
        versions=codecs.decode_json(row.versions_json),
        iterations=row.iterations,
        created_at=_aware(row.created_at),
        updated_at=_aware(row.updated_at),
        lock=locking.lock_info(holder) if holder else None,
    )


def _validate_episode(episode: EpisodeWrite) -> None:
    check_iteration(episode.index, "episode index")
    check_iteration(episode.first_iteration, "first_iteration")
    lengths = {np.shape(getattr(episode, key))[:1] for key in DatasetArrays._fields}
    if any(np.ndim(getattr(episode, key)) == 0 for key in DatasetArrays._fields):
        raise StoreError("episode actions, contexts and outcomes must have one row per iteration")
    if len(lengths) != 1 or episode.n_iterations < 1:
        raise StoreError(
            "episode actions, contexts and outcomes must have the same number (≥ 1) of rows, "
            f"got {[np.shape(getattr(episode, k))[0] for k in DatasetArrays._fields]}"
        )
    low, high = episode.first_iteration, episode.end_iteration
    for what, items in (
        ("event", episode.events),
        ("stat", episode.stats),
        ("region", episode.regions),
    ):
        for item in items:
            if not low <= item.iteration <= high:
                raise StoreError(
                    f"{what} at iteration {item.iteration} is outside episode {episode.index} "
                    f"(iterations {low}..{high})"
                )
    for event in episode.events:
        if not isinstance(event.kind, str) or not 0 < len(event.kind) <= _KIND_MAX:
            raise StoreError(f"event kind must be 1-{_KIND_MAX} characters, got {event.kind!r}")


def _check_next_episode(session: Session, run: Run, episode: EpisodeWrite) -> None:
    last = session.scalar(select(func.max(Episode.episode_index)).where(Episode.run_id == run.id))
    expected = 0 if last is None else last + 1
    if last is not None and episode.index <= last:
        raise StoreError(f"run {run.name!r} already has episode {episode.index}")
    if episode.index != expected:
        raise StoreError(
            f"run {run.name!r}: episode {episode.index} is not contiguous (next is {expected})"
        )
    if episode.first_iteration != run.iterations:
        raise StoreError(
            f"run {run.name!r}: episode {episode.index} starts at iteration "
            f"{episode.first_iteration} but the run has {run.iterations} iterations stored"
        )


def _insert(session: Session, model: type, rows: list[dict[str, Any]]) -> None:
    if rows:
        session.execute(insert(model.__table__), rows)


def _item_key(key: Any) -> str:
    if not isinstance(key, str) or not 0 < len(key) <= 255:
        raise StoreError(f"checkpoint item keys must be strings of 1-255 characters, got {key!r}")
    return key


def _event_values(event: AffordanceEvent) -> dict[str, Any]:
    return {
        "iteration": int(event.iteration),
        "affordance_id": int(event.affordance_id),
        "kind": str(event.kind),
        "input_space": str(event.input_space),
        "output_space": str(event.output_space),
        "context_json": codecs.encode_json([str(space) for space in event.context]),
        "competence": codecs.finite_or_none(event.competence, "event competence"),
        "detail_json": codecs.encode_json(dict(event.detail)),
    }


def _stat_values(stat: AffordanceStat) -> dict[str, Any]:
    return {
        "iteration": int(stat.iteration),
        "affordance_id": int(stat.affordance_id),
        "competence": codecs.finite_or_none(stat.competence, "stat competence"),
        "n_data": int(stat.n_data),
        "interest": codecs.finite_or_none(stat.interest, "stat interest"),
    }


def _region_values(region: InterestRegion) -> dict[str, Any]:
    return {
        "iteration": int(region.iteration),
        "affordance_id": int(region.affordance_id),
        "region_id": int(region.region_id),
        "parent_id": None if region.parent_id is None else int(region.parent_id),
        "low_json": codecs.encode_json([float(x) for x in region.low]),
        "high_json": codecs.encode_json([float(x) for x in region.high]),
        "n_goals": int(region.n_goals),
        "interest": codecs.finite_or_none(region.interest, "region interest"),
    }


def _episodes_query(run_id: int) -> Select:
    return select(Episode).where(Episode.run_id == run_id).order_by(Episode.episode_index)


def _episode_record(row: Episode) -> EpisodeRecord:
    return EpisodeRecord(
        index=row.episode_index,
        first_iteration=row.first_iteration,
        actions=codecs.decode_array(row.actions, row.array_codec),
        contexts=codecs.decode_array(row.contexts, row.array_codec),
        outcomes=codecs.decode_array(row.outcomes, row.array_codec),
        extra=codecs.decode_json(row.extra_json),
    )


def _event_record(row: AffordanceEventRow) -> AffordanceEvent:
    return AffordanceEvent(
        iteration=row.iteration,
        affordance_id=row.affordance_id,
        kind=row.kind,
        input_space=row.input_space,
        output_space=row.output_space,
        context=tuple(codecs.decode_json(row.context_json)),
        competence=row.competence,
        detail=codecs.decode_json(row.detail_json),
    )


def _region_record(row: InterestRegionRow) -> InterestRegion:
    return InterestRegion(
        iteration=row.iteration,
        affordance_id=row.affordance_id,
        region_id=row.region_id,
        parent_id=row.parent_id,
        low=tuple(codecs.decode_json(row.low_json)),
        high=tuple(codecs.decode_json(row.high_json)),
        n_goals=row.n_goals,
        interest=row.interest,
    )


def _evaluation_record(row: EvaluationRow) -> Evaluation:
    return Evaluation(
        iteration=row.iteration,
        task=row.task,
        score=row.score,
        points=codecs.decode_json(row.points_json),
        created_at=_aware(row.created_at),
    )


def _checkpoint_row(session: Session, run_id: int, upto: int | None) -> CheckpointRow | None:
    query = select(CheckpointRow).where(CheckpointRow.run_id == run_id)
    if upto is not None:
        query = query.where(CheckpointRow.iteration <= upto)
    return session.scalar(query.order_by(CheckpointRow.iteration.desc()).limit(1))


def _fork_checkpoint(session: Session, source: Run, at_iteration: int | None) -> CheckpointRow:
    """The latest checkpoint of ``source`` at or before ``at_iteration``; raises if none."""
    at_iteration = check_iteration(at_iteration, "iteration")
    if at_iteration is not None and at_iteration > source.iterations:
        raise StoreError(
            f"run {source.name!r} has no iteration {at_iteration}: "
            f"it has only {source.iterations} iterations"
        )
    chosen = _checkpoint_row(session, source.id, at_iteration)
    if chosen is not None:
        return chosen
    first = session.scalar(
        select(func.min(CheckpointRow.iteration)).where(CheckpointRow.run_id == source.id)
    )
    if first is None:
        raise StoreError(f"run {source.name!r} has no checkpoint to start from")
    raise StoreError(
        f"run {source.name!r} has no checkpoint at or before iteration {at_iteration}: "
        f"its first checkpoint is at iteration {first}"
    )


def _copy_rows(session: Session, model: type, relabel: tuple[str, int], condition: Any) -> None:
    """INSERT INTO model SELECT ... of existing rows, with column ``relabel[0]`` set anew."""
    table = model.__table__
    column, value = relabel
    columns = [c for c in table.columns if c.name != "id"]
    selected = [literal(value).label(column) if c.name == column else c for c in columns]
    session.execute(
        insert(table).from_select([c.name for c in columns], select(*selected).where(condition))
    )


def _copy_history(session: Session, source_id: int, new_id: int, chosen: CheckpointRow) -> None:
    for model in _PER_EPISODE:
        table = model.__table__
        up_to_episode = table.c.episode_index <= chosen.episode_index
        _copy_rows(
            session, model, ("run_id", new_id), (table.c.run_id == source_id) & up_to_episode
        )
    evaluations = EvaluationRow.__table__
    _copy_rows(
        session,
        EvaluationRow,
        ("run_id", new_id),
        (evaluations.c.run_id == source_id) & (evaluations.c.iteration <= chosen.iteration),
    )
    checkpoints = session.scalars(
        select(CheckpointRow)
        .where(CheckpointRow.run_id == source_id, CheckpointRow.iteration <= chosen.iteration)
        .order_by(CheckpointRow.iteration)
    ).all()
    for old in checkpoints:
        new = CheckpointRow(
            run_id=new_id,
            iteration=old.iteration,
            episode_index=old.episode_index,
            created_at=old.created_at,
            base_iteration=old.base_iteration,
        )
        session.add(new)
        session.flush()
        _copy_rows(
            session,
            CheckpointItem,
            ("checkpoint_id", new.id),
            CheckpointItem.__table__.c.checkpoint_id == old.id,
        )
