"""Runs: sessions persisted in the experiment store — create, checkpoint, restore, train.

The store (package `store/`) knows nothing of the learner; this module turns a `Session` into
what one episode writes (D's rows, H's events, affordance stats, interest-map leaves and a
checkpoint) and back.
"""

from __future__ import annotations

import enum
import os
import socket
from collections.abc import Callable
from dataclasses import dataclass
from importlib import metadata
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from hadim_cli.config import Config, missing_keys, stored_config, unknown_keys
from hadim_cli.errors import HadimError
from hadim_store.records import (
    AffordanceEvent,
    AffordanceStat,
    EpisodeWrite,
    InterestRegion,
    RunRecord,
    RunStatus,
)

# The learner (and torch, through p_A) is imported inside the functions that need it, and so
# is the full store (SQLAlchemy): commands that only look at a run (`runs show`, `affordances`,
# `plot`, the refusals of `resume`, `eval` and `fork`) read a sound store file with sqlite3
# alone (`open_reader`, `light_reader`) and answer in under a second; importing torch alone
# takes seconds, SQLAlchemy half of one.
if TYPE_CHECKING:
    from hadim_cli.evaluation.runner import TaskResult
    from hadim_cli.learner.hierarchy import Event
    from hadim_cli.session import EpisodeLog, Session
    from hadim_store.api import Store
    from hadim_store.reader import StoreReader

STORE_ENV = "HADIM_STORE"
SNAPSHOT_ENV = "HADIM_SNAPSHOT_EVERY"
"""One checkpoint in this many is a full snapshot, the others deltas (store/deltas.py)."""
DEFAULT_STORE = "hadim.sqlite"
TARGET_KEY = "target"
"""Key, in an episode's `extra`, of the iterations the run was being driven to."""
HIERARCHY_KEY = "hierarchy"
"""Key, in an episode's `extra`, of H's rows at its end (`reports.affordance_rows`)."""
DEFAULT_ITERATIONS = 4000
"""What `hadim train` runs, and `hadim resume` continues a run to when it has no target."""
STATE_FORMAT = 2
READABLE_STATE_FORMATS = (1, 2)


class RunKind(enum.StrEnum):
    """What drives a run: the paper's learner, or a reinforcement-learning baseline."""

    LEARNER = "learner"
    BASELINE = "baseline"


def run_kind(run: RunRecord) -> RunKind:
    return RunKind.BASELINE if run.config.get("kind") == "baseline" else RunKind.LEARNER


def store_location(option: str | None) -> str:
    return option or os.environ.get(STORE_ENV) or DEFAULT_STORE


opened: list[str] = []
"""The store this process opened last: named in the one-line message of a database error."""


reading: list[str] = []
"""The run this process reads: named in the one line that a damaged row of it gives."""
file_damage: list[str] = []
"""SQLite's findings (`PRAGMA quick_check`) on the store this process opened to read."""


def open_store(option: str | None, *, create: bool = True, writes: bool = True,
               run: str | None = None) -> Store:
    """The store a command names (about `run`, if it names one). Its file is checked first
    (SQLite's `PRAGMA quick_check`, well under a second): one that `writes` is refused if
    damaged, rather than written into; for one that only reads, the findings are kept for
    `chosen_run` and `damaged_runs`."""
    where = store_location(option)
    opened[:] = [where]
    reading.clear()
    file_damage.clear()
    is_file = "://" not in where
    _check_path(where, create=create)
    from hadim_store import engine  # SQLAlchemy: after the refusals that need none
    from hadim_store.api import Store
    from hadim_store.errors import DamagedStore

    if is_file and Path(where).is_file() and Path(where).stat().st_size > 0:
        try:
            engine.check_sqlite_file(Path(where), create=create)
        except DamagedStore as exc:  # where the schema is read: not even the runs can be read
            raise HadimError(damage_line(run, " ".join(exc.finding.split()) or "unreadable",
                                         writes=writes)) from None
        file_damage[:] = engine.quick_check(Path(where))
        if writes and file_damage:  # writing would spread the damage
            raise HadimError(damage_line(run, " ".join(file_damage[0].split()), writes=True))
    return Store.open(where, create=create, snapshot_every=snapshot_every())


def light_reader(option: str | None) -> StoreReader | None:
    """A reader of the store `option` names that needs no SQLAlchemy (sqlite3 alone), when
    it is a SQLite file of this hadim's schema that SQLite finds sound; else None: the full
    store (`open_store`) upgrades, refuses or reports it."""
    from hadim_store.reader import StoreReader

    where = store_location(option)
    if "://" in where or not Path(where).is_file():
        return None
    reader = StoreReader.open(Path(where))
    if reader is not None:
        opened[:] = [where]
        reading.clear()
        file_damage.clear()
    return reader


def _check_path(where: str, *, create: bool) -> None:
    """The refusals of a store file's path: no file there (to read one), a directory."""
    if "://" in where:
        return
    if not create and not Path(where).exists():
        raise HadimError(f"no store at {where}: start a run with `hadim train`, or pass --store")
    if Path(where).is_dir():
        raise HadimError(f"{where} is a directory, not a store file")


def refuse_new_run(option: str | None, name: str | None) -> None:
    """Refuse, before anything heavy is imported, what the store `option` names would refuse
    of a new run: a directory in its place, a `--name` malformed or a run's already (when a
    light reader can tell). The store refuses them again as it creates the run."""
    from hadim_store.records import check_name

    _check_path(store_location(option), create=True)
    if name is None:
        return
    check_name(name)
    reader = light_reader(option)
    if reader is not None:
        with reader:
            reader.refuse_taken(name)


def open_reader(option: str | None, *, run: str | None = None) -> StoreReader | Store:
    """The store `option` names, to read a run from: the light reader when the file allows,
    else the full store, opened to read (`open_store`). Both give the reading methods of
    `hadim_store.reader.StoreReader`."""
    return light_reader(option) or open_store(option, create=False, writes=False, run=run)


def chosen_run(store: Store | StoreReader, name: str | None) -> RunRecord:
    """The run a command names, or (no name) the store's most recently updated one, said on
    stderr. In a file SQLite finds damaged, the run is first read back as `hadim store check`
    reads it: a damaged run is one line, never a silent answer."""
    from hadim_cli.progress import say

    if name is None:
        records = store.list_runs()
        if not records:
            raise HadimError(f"no run in {store_location(opened[0] if opened else None)} yet: "
                             "start one with `hadim train`")
        record = max(records, key=lambda r: r.updated_at)  # ties: the first created
        say(f"run {record.name} (the store's most recent; name a run to read another)")
    else:
        record = store.get_run(name)
    reading[:] = [record.name]
    if file_damage:
        reason = unreadable(store, record.name)
        if reason is not None:
            raise HadimError(damage_line(record.name, reason))
        say(f"warning: {opened[0]} is damaged, though run {record.name} reads back whole: "
            f"`hadim store check --store {opened[0]}` says which runs can be read")
    return record


def unreadable(store: Store, name: str) -> str | None:
    """Why run `name` cannot be read back whole (None if it can): its record, D, timeline,
    statistics, evaluations and every checkpoint, read as `hadim store check` reads them."""
    try:
        store.get_run(name)
        store.dataset_sha256(name)
        store.events(name)
        store.stats(name)
        store.evaluations(name)
        for it in store.checkpoint_iterations(name):
            store.checkpoint(name, it)
    except Exception as exc:  # noqa: BLE001 — any failure to read it back is damage
        return short_reason(exc)
    return None


def short_reason(exc: BaseException, limit: int = 60) -> str:
    """The first line of a database or decoding error, without the row content some carry
    (SQLite's "Could not decode ... with text '…'"), at most `limit` characters."""
    import re

    text = str(getattr(exc, "orig", None) or exc).strip().splitlines()
    line = re.sub(r"\s+with text\s+.*$", "", text[0] if text else type(exc).__name__)
    line = re.sub(r"\s*\(char \d+\)$", "", line)
    return line if len(line) <= limit else line[:limit - 1] + "…"


def damage_line(run: str | None, reason: str, *, writes: bool = False, limit: int = 193) -> str:
    """The one line (after `error: `, at most `limit` characters when the store's name
    allows) that a damaged store gives a command: the run, SQLite's or the decoder's reason
    (shortened, never the row's content), and the command that says what can be saved."""
    where = opened[0] if opened else "the store"
    if run is None:
        head = "the store is damaged"
    elif writes:
        head = f"run {run} untouched: the store is damaged"
    else:
        head = f"run {run} cannot be read: the store is damaged"
    tail = f"; see `hadim store check --store {where}`"
    room = max(limit - len(head) - len(tail) - 3, 12)
    short = reason if len(reason) <= room else reason[:room - 1] + "…"
    return f"{head} ({short}){tail}"


def snapshot_every() -> int:
    from hadim_store.deltas import DEFAULT_SNAPSHOT_EVERY

    raw = os.environ.get(SNAPSHOT_ENV, "").strip()
    if not raw:
        return DEFAULT_SNAPSHOT_EVERY
    try:
        value = int(raw)
    except ValueError:
        value = 0
    if value < 1:
        raise HadimError(f"{SNAPSHOT_ENV}={raw!r}: give a whole number of checkpoints ≥ 1")
    return value


def package_versions() -> dict[str, str]:
    out = {}
    for name in ("hadim", "numpy", "scipy", "torch", "pymunk", "sqlalchemy"):
        try:
            out[name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            out[name] = "unknown"
    return out


def version_note(run: RunRecord) -> str | None:
    """One line when `run` was trained by another hadim version than the installed one, or
    its config holds keys the installed version no longer has (None otherwise): a run's D, H
    and models are data, read as stored; the code that learns from them and turns goals into
    actions is the installed version's, and a removed key is ignored (`stored_config`)."""
    trained = (run.versions or {}).get("hadim")
    installed = package_versions()["hadim"]
    other = trained not in (None, "unknown", installed)
    gone, new = unknown_keys(run.config), missing_keys(run.config)
    if not other and not gone and not new:
        return None
    what = f"was trained with hadim {trained}" if other else f"is run by hadim {installed}"
    note = (f"note: run {run.name} {what}; hadim {installed} learns and acts for it (its D, "
            f"H and models as stored, the installed code)")
    if gone:
        note += f"; keys it no longer has, ignored: {', '.join(gone)}"
    if new:
        note += f"; keys it lacks, at the installed defaults: {', '.join(new)}"
    return note


def owner_id() -> str:
    return f"{socket.gethostname()}:{os.getpid()}"


# --------------------------------------------------------------------------- state

def session_state(session: Session) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
    from hadim_cli.learner.state import learner_state

    meta, arrays = learner_state(session.learner)
    # The timeline grows with the run: its own item, a list the store writes as a delta.
    events = meta.pop("events")
    return {
        "format": STATE_FORMAT,
        "learner": meta,
        "events": events,
        "episodes_done": session.episodes_done,
        "seed": session.seed,
        "rng": {"world": session.world_rng.bit_generator.state,
                "learner": session.learner_rng.bit_generator.state},
    }, arrays


def restore_session(store: Store | StoreReader, run: RunRecord, at: int | None = None,
                    config: Config | None = None) -> Session:
    """The run's session as it stood at its checkpoint at or before `at` (latest if None);
    with `config`, as a fork of it with that config would start (to check it fits)."""
    from hadim_cli.learner.state import restore_learner
    from hadim_cli.session import Session

    checkpoint = store.checkpoint(run.name, at)
    config = stored_config(run.config) if config is None else config
    session = Session(config, run.seed)
    if checkpoint is None:
        if at is not None and at > 0:
            raise HadimError(f"run {run.name} has no checkpoint at or before iteration {at}")
        return session
    meta = checkpoint.json
    if meta.get("format") not in READABLE_STATE_FORMATS:
        raise HadimError(f"run {run.name}: checkpoint format {meta.get('format')!r} is not "
                         f"supported by this hadim")
    dataset = session.learner.dataset
    for episode in store.episodes(run.name, upto_iteration=checkpoint.iteration):
        width = episode.contexts.shape[1] if episode.contexts.ndim == 2 else None
        if width != dataset.obs_size or episode.actions.shape[1:] != (dataset.action_size,):
            # A config whose world has other objects or LIDAR rays cannot read this D.
            raise HadimError(f"run {run.name}: its stored observations have {width} values "
                             f"but the config's world observes {dataset.obs_size}; the world's "
                             f"objects and LIDAR cannot change within a run")
        dataset.extend(episode.actions, episode.contexts, episode.outcomes)
    try:
        learner_meta = dict(meta["learner"])
        if "events" in meta:  # format 2 keeps the timeline apart
            learner_meta["events"] = meta["events"]
        restore_learner(session.learner, learner_meta, checkpoint.arrays)
    except (KeyError, ValueError) as exc:
        raise HadimError(f"run {run.name}: checkpoint at {checkpoint.iteration} is unusable: "
                         f"{exc}") from None
    session.world_rng.bit_generator.state = meta["rng"]["world"]
    session.learner_rng.bit_generator.state = meta["rng"]["learner"]
    if int(meta.get("seed", run.seed)) != run.seed:
        # A fork given a new seed continues with fresh generators from (seed, iteration).
        root = np.random.default_rng([run.seed, checkpoint.iteration])
        session.world_rng, session.learner_rng = root.spawn(2)
    session.episodes_done = int(meta["episodes_done"])
    return session


def _store_event(e: Event) -> AffordanceEvent:
    return AffordanceEvent(e.iteration, e.affordance_id, e.kind.value, e.input, e.output,
                           e.contexts, e.competence, dict(e.detail))


def episode_write(session: Session, log: EpisodeLog, target: int | None = None) -> EpisodeWrite:
    """What the store keeps of one episode; `target`, the iterations the run is being driven
    to, goes into its `extra` (what `hadim resume RUN` continues to)."""
    from hadim_cli.reports import affordance_rows

    d = session.learner.dataset
    stop = log.stop
    events = [_store_event(e) for le in log.learning for e in le.events]
    stats, regions = [], []
    for aff in session.learner.hierarchy:
        stats.append(AffordanceStat(stop, aff.id, float(aff.competence), len(aff.rows),
                                    float(aff.interest.interest)))
        for leaf in aff.interest.leaves():
            regions.append(InterestRegion(stop, aff.id, leaf.region_id, leaf.parent_id,
                                          tuple(leaf.low), tuple(leaf.high), leaf.n_goals,
                                          float(leaf.interest)))
    meta, arrays = session_state(session)
    extra = {"learning_episodes": [
        {"mode": le.mode.value, "start": le.start, "stop": le.stop,
         "affordance": le.affordance_id, "goal": list(le.goal), "competence": le.competence,
         "drawn": le.drawn.value, "fallbacks": [f.value for f in le.fallbacks]}
        for le in log.learning]}
    # H as `hadim affordances` shows it, kept so that it reads H without restoring the session.
    extra[HIERARCHY_KEY] = affordance_rows(session)
    if target is not None:
        extra[TARGET_KEY] = target
    return EpisodeWrite(
        index=log.index, first_iteration=log.start,
        actions=d.actions[log.start:stop].copy(), contexts=d.contexts[log.start:stop].copy(),
        outcomes=d.outcomes[log.start:stop].copy(), extra=extra, events=events, stats=stats,
        regions=regions, checkpoint_arrays=arrays, checkpoint_json=meta,
    )


def goal_babbling_share(extras: list[dict[str, Any]], sigma: float) -> dict[str, Any]:
    """How much goal babbling a run did, from its episodes' `extra` records: σ (configured),
    the share of learning episodes σ's draw sent to goal babbling (`drawn`), the share that
    did goal babbling (`effective`), and each fallback's count. `drawn` and `fallbacks` are
    None for episodes stored before they were recorded."""
    learning = [le for extra in extras for le in extra.get("learning_episodes", [])]
    n = len(learning)
    recorded = bool(learning) and all("drawn" in le for le in learning)
    counts: dict[str, int] = {}
    for le in learning:
        for why in le.get("fallbacks", ()):
            counts[why] = counts.get(why, 0) + 1
    return {
        "sigma": sigma, "learning_episodes": n,
        "drawn": (sum(le["drawn"] == "goal" for le in learning) / n) if recorded else None,
        "effective": (sum(le["mode"] == "goal" for le in learning) / n) if n else None,
        "fallbacks": dict(sorted(counts.items())) if recorded else None,
    }


# --------------------------------------------------------------------------- training

@dataclass
class Progress:
    """What the training loop reports after each episode."""

    iteration: int
    total: int
    affordances: int | None
    """|H| (None for a baseline run)."""
    scores: dict[str, float]
    scored_at: int | None = None
    """The iteration `scores` were measured at (None: no evaluation yet in this process)."""


def evaluate_tasks(session: Session, tasks: tuple[str, ...]) -> dict[str, TaskResult]:
    from hadim_cli.evaluation.runner import evaluate
    from hadim_cli.evaluation.tasks import load_task

    return {name: evaluate(session.learner, session.config.world, load_task(name))
            for name in tasks}


def train(store: Store | None, run: str | None, session: Session, total: int, *,
          eval_every: int = 0, tasks: tuple[str, ...] = (),
          on_progress: Callable[[Progress], None] | None = None,
          should_stop: Callable[[], bool] | None = None,
          owner: str | None = None) -> dict[str, float]:
    """Run `session` to `total` iterations, storing every episode (when a store is given).
    Every `eval_every` iterations the learner is evaluated on `tasks` beside the training
    (`evaluation.beside`); the evaluation under way is waited for before returning."""
    from hadim_cli.evaluation.beside import Evaluations, Scored

    scores: dict[str, float] = {}
    scored_at: list[int] = []

    def scored(result: Scored) -> None:
        scores[result.task] = result.score
        scored_at[:] = [result.iteration]
        if store is not None and run is not None:
            store.add_evaluation(run, result.iteration, result.task, result.score,
                                 result.points)

    evaluations = Evaluations(session, tasks, scored)

    def after_episode(log: EpisodeLog) -> bool:
        if store is not None and run is not None:
            store.write_episode(run, episode_write(session, log, total), owner=owner)
        it = session.iteration
        evaluations.poll()
        if eval_every and it % eval_every == 0 and tasks:
            evaluations.start()
        stopping = bool(should_stop and should_stop())
        if stopping or it >= total:
            evaluations.finish()  # nothing left to run beside it
        if on_progress is not None:
            on_progress(Progress(it, total, len(session.learner.hierarchy), dict(scores),
                                 scored_at[0] if scored_at else None))
        return stopping

    try:
        session.run(total, after_episode)
        evaluations.finish()
    finally:
        evaluations.close()
    return scores


def target_iterations(store: Store | StoreReader, run: RunRecord, default: int) -> int:
    """The iterations `run` was last driven to (by `train`, `resume`), as its last stored
    episode records them; `default` for a run without such a record (none stored yet, or
    stored by an older hadim)."""
    last = store.episode_extra(run.name)
    target = None if last is None else last[1].get(TARGET_KEY)
    return target if isinstance(target, int) and target > 0 else default


H_FIELDS = frozenset({"id", "input", "output", "context", "frame", "created_at", "competence",
                      "data", "effect", "goals", "accepts"})
"""What each of H's stored rows holds (`reports.affordance_rows`)."""


def stored_hierarchy(store: Store | StoreReader, run: RunRecord, at: int | None
                     ) -> tuple[list[dict[str, Any]], int] | None:
    """H's rows (`reports.affordance_rows`) and their iteration, as stored with the last
    episode at or before `at`: what `hadim affordances RUN` shows, read without the learner.
    None when they must be computed from a restored session (episodes from an older hadim).

    The checkpoint of that iteration is read back too (its values decoded, the learner not
    rebuilt): a table of H over a run whose state cannot be read would hide the damage that
    `resume` and `eval` refuse."""
    found = store.episode_extra(run.name, at)
    if found is None:
        if at is not None and at > 0 and run.iterations > 0:
            raise HadimError(f"run {run.name} has no checkpoint at or before iteration {at}")
        return [], 0  # nothing trained yet: H is empty
    iteration, extra = found
    rows = extra.get(HIERARCHY_KEY)
    if rows is None:
        return None
    if not isinstance(rows, list) or not all(isinstance(r, dict) and r.keys() >= H_FIELDS
                                             for r in rows):
        raise HadimError(damage_line(run.name, f"H's stored table at {iteration} is malformed"))
    store.checkpoint(run.name, iteration)
    return rows, iteration


def new_run(store: Store, config: Config, seed: int, name: str | None) -> RunRecord:
    return store.create_run(config=config.to_dict(), seed=seed, name=name,
                            versions=package_versions())




def finish_status(session: Session, total: int) -> RunStatus:
    return RunStatus.FINISHED if session.iteration >= total else RunStatus.PAUSED


def damaged_runs(store: Store | StoreReader, records: list[RunRecord]) -> list[str]:
    """The runs that cannot be read back whole, looked for only in a file SQLite finds
    damaged (`open_store`; the light reader opens only a sound one): a sound file costs
    nothing here."""
    if not file_damage:
        return []
    return [r.name for r in records if unreadable(store, r.name) is not None]
