"""One sweep entry driven as a normal run of the store; runs inside a Ray worker process.

Each entry is idempotent: a finished run is left alone, an unfinished one (paused, failed, or
`running` under a dead holder) continues from its last checkpoint, so a retried task (its
worker was killed) or a re-run sweep loses at most the episode that was in progress.
"""

from __future__ import annotations

import json
import signal
import time
from collections.abc import Callable
from dataclasses import dataclass

from hadim_cli.errors import HadimError
from hadim_cli.sweep.plan import RunKind, SweepEntry

# A holder on another host is stale only after the store's lock timeout: wait that long.
LOCK_WAIT_MARGIN_S = 15.0


@dataclass(frozen=True)
class EntryResult:
    run: str
    status: str
    """The run's status afterwards: finished, paused (stopped by Ctrl-C), or `skipped`."""
    iterations: int


def run_entry(store_url: str, entry: SweepEntry,
              should_stop: Callable[[], bool]) -> EntryResult:
    """Drive `entry` to its iterations (or until `should_stop`), as a normal run."""
    previous = _ignore_sigint()  # Ctrl-C is the driver's: it asks us to stop via should_stop
    try:
        if should_stop():
            return EntryResult(entry.run, "skipped", 0)
        return RUNNERS[entry.kind](store_url, entry, should_stop)
    finally:
        if previous is not None:
            signal.signal(signal.SIGINT, previous)


def _ignore_sigint():
    try:
        return signal.signal(signal.SIGINT, signal.SIG_IGN)
    except ValueError:  # not the main thread: nothing to restore
        return None


def _train(store_url: str, entry: SweepEntry, should_stop: Callable[[], bool]) -> EntryResult:
    from hadim_cli import runs
    from hadim_cli.config import config_from_dict
    from hadim_cli.heartbeat import keep_alive
    from hadim_store.records import RunStatus

    def create(store):
        return runs.new_run(store, config_from_dict(entry.config), entry.seed, entry.run)

    def work(store, owner: str) -> RunStatus:
        session = runs.restore_session(store, store.get_run(entry.run))
        store.set_status(entry.run, RunStatus.RUNNING)
        tasks = session.config.evaluation.tasks
        with keep_alive(store, entry.run, owner):
            _catch_up_evaluation(store, entry, session.iteration, tasks,
                                 lambda missing: runs.evaluate_tasks(session, missing))
            runs.train(store, entry.run, session, entry.iterations,
                       eval_every=entry.eval_every, tasks=tasks,
                       should_stop=should_stop, owner=owner)
        return runs.finish_status(session, entry.iterations)

    return _locked_run(store_url, entry, create, work)


def _baseline(store_url: str, entry: SweepEntry,
              should_stop: Callable[[], bool]) -> EntryResult:
    from hadim_cli.baselines import runs as baseline_runs
    from hadim_cli.baselines.config import read_config
    from hadim_cli.heartbeat import keep_alive
    from hadim_store.records import RunStatus

    cfg = read_config(entry.config)
    if cfg.algorithm != "q-learning":  # ours, numpy only: no torch to load
        import torch

        torch.set_num_threads(1)  # one run per core, as `hadim baseline train`

    def create(store):
        return baseline_runs.new_run(store, cfg, entry.seed, entry.run)

    def work(store, owner: str) -> RunStatus:
        session = baseline_runs.restore(store, store.get_run(entry.run))
        store.set_status(entry.run, RunStatus.RUNNING)
        with keep_alive(store, entry.run, owner):
            _catch_up_evaluation(store, entry, session.iteration, (cfg.task,),
                                 lambda missing: baseline_runs.evaluate_tasks(session, missing))
            baseline_runs.train(store, entry.run, session, entry.iterations,
                                eval_every=entry.eval_every, tasks=(cfg.task,),
                                should_stop=should_stop, owner=owner)
        return (RunStatus.FINISHED if session.iteration >= entry.iterations
                else RunStatus.PAUSED)

    return _locked_run(store_url, entry, create, work)


def _locked_run(store_url: str, entry: SweepEntry, create: Callable, work: Callable
                ) -> EntryResult:
    """`work(store, owner)` on the entry's run (created by `create(store)` if new) under its
    lock; the status it returns is written, `failed` if it raised."""
    from hadim_cli import runs
    from hadim_store.api import Store
    from hadim_store.records import RunStatus

    with Store.open(store_url, create=False) as store:
        record = _existing_or_new(store, entry, create)
        if record.status == RunStatus.FINISHED.value and record.iterations >= entry.iterations:
            return EntryResult(entry.run, "skipped", record.iterations)
        owner = runs.owner_id()
        _acquire(store, entry.run, owner)
        status = RunStatus.FAILED
        try:
            status = work(store, owner)
        finally:
            if _holds_lock(store, entry.run, owner):
                store.set_status(entry.run, status)
                store.release_lock(entry.run, owner)
        return EntryResult(entry.run, status.value, store.get_run(entry.run).iterations)


def _catch_up_evaluation(store, entry: SweepEntry, it: int, tasks: tuple[str, ...],
                         evaluate: Callable) -> None:
    """A worker killed between an episode's write and its evaluation: evaluate now (evaluation
    changes nothing of the learner, so the run's D is unaffected)."""
    if not (it and entry.eval_every and it % entry.eval_every == 0 and tasks):
        return
    done = {e.task for e in store.evaluations(entry.run) if e.iteration == it}
    missing = tuple(t for t in tasks if t not in done)
    if not missing:
        return
    for name, result in evaluate(missing).items():
        store.add_evaluation(entry.run, it, name, result.score, result.to_dict()["points"])


def _existing_or_new(store, entry: SweepEntry, create: Callable):
    from hadim_store.errors import StoreError, UnknownRun

    try:
        record = store.get_run(entry.run)
    except UnknownRun:
        try:
            return create(store)
        except StoreError:  # created meanwhile by a retry of this task
            record = store.get_run(entry.run)
    if record.seed != entry.seed or record.config != json.loads(json.dumps(entry.config)):
        raise HadimError(f"run {entry.run} exists with another config or seed than this sweep "
                         "gives it (made by hand?): rename or delete it")
    return record


def _acquire(store, run: str, owner: str) -> None:
    """Take the run's lock, waiting for a holder on another host to go stale."""
    from hadim_store.errors import RunLocked

    deadline = time.monotonic() + store.lock_timeout + LOCK_WAIT_MARGIN_S
    while True:
        try:
            store.acquire_lock(run, owner)
            return
        except RunLocked:
            if time.monotonic() > deadline:
                raise
            time.sleep(1.0)


def _holds_lock(store, run: str, owner: str) -> bool:
    lock = store.get_run(run).lock
    return lock is not None and lock.owner == owner


RUNNERS: dict[RunKind, Callable[[str, SweepEntry, Callable[[], bool]], EntryResult]] = {
    RunKind.TRAIN: _train,
    RunKind.BASELINE: _baseline,
}
