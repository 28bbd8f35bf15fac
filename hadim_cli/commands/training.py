"""`hadim train`, `hadim resume`, `hadim fork`: drive learning sessions stored as runs."""

from __future__ import annotations

import shlex
import signal
from contextlib import contextmanager
from typing import Annotated

import typer

from hadim_cli.commands.common import ConfigOption, SetOption, StoreOption
from hadim_cli.errors import HadimError
from hadim_cli.heartbeat import keep_alive as _heartbeat

app = typer.Typer()

IterationsOption = Annotated[int, typer.Option("--iterations", "-n", min=1,
                                               help="Total iterations (primitive actions).")]
EvalEveryOption = Annotated[int | None, typer.Option(
    "--eval-every", min=0, help="Evaluate every N iterations (default: evaluation.every; 0 off).")]


@contextmanager
def _interruptible():
    """Ctrl-C asks the loop to stop after the current episode; a second one, while an episode
    is still running, aborts it (its iterations are not stored). The handler stays installed
    until the run's status is written, so a late Ctrl-C cannot leave it half-recorded."""
    flag = {"stop": False, "armed": True}

    def handler(signum, frame):  # noqa: ARG001
        if flag["stop"] and flag["armed"]:
            raise KeyboardInterrupt
        flag["stop"] = True

    def disarm() -> None:
        flag["armed"] = False

    previous = signal.signal(signal.SIGINT, handler)
    try:
        yield (lambda: flag["stop"]), disarm
    finally:
        signal.signal(signal.SIGINT, previous)


def _resume_hint(run_name: str, total: int, store_option: str | None) -> str:
    where = f" --store {shlex.quote(store_option)}" if store_option else ""
    return f"hadim resume {run_name} --iterations {total}{where}"


def _drive(store, run_name: str, session, total: int, eval_every: int,
           store_option: str | None = None, train=None, tasks: tuple[str, ...] | None = None,
           ) -> None:
    """Train `session` to `total` under the run's lock, with progress and Ctrl-C pause;
    `train` and `tasks` default to the learner's (a baseline run passes its own)."""
    import time

    from hadim_cli import runs
    from hadim_cli.progress import Reporter, say, summary
    from hadim_store.records import RunStatus

    owner = runs.owner_id()
    began, start = time.monotonic(), session.iteration
    with _interruptible() as (should_stop, disarm):
        store.acquire_lock(run_name, owner)
        stored = store.get_run(run_name).iterations
        if stored != session.iteration:  # another process wrote to it while we loaded it
            store.release_lock(run_name, owner)
            raise HadimError(f"run {run_name} moved from iteration {session.iteration} to "
                             f"{stored} while loading; run the command again")
        store.set_status(run_name, RunStatus.RUNNING)
        status, aborted = RunStatus.FAILED, False
        try:
            with _heartbeat(store, run_name, owner), \
                    Reporter(run_name, session.iteration, total) as reporter:
                (train or runs.train)(
                    store, run_name, session, total, eval_every=eval_every,
                    tasks=session.config.evaluation.tasks if tasks is None else tasks,
                    on_progress=reporter.update, should_stop=should_stop, owner=owner)
            status = runs.finish_status(session, total)
        except KeyboardInterrupt:
            # The episode in progress is lost; every stored one is intact and resumable.
            status, aborted = RunStatus.PAUSED, True
        finally:
            disarm()
            if _holds_lock(store, run_name, owner):  # never overwrite a new holder's status
                store.set_status(run_name, status)
                store.release_lock(run_name, owner)
    if status is RunStatus.PAUSED:
        done = store.get_run(run_name).iterations
        # Through `say`: with `2>&1 | tee log`, Ctrl-C has killed tee; the terminal still
        # gets the command, and the exit status stays the documented one.
        say(f"{'aborted' if aborted else 'paused'} at iteration {done}; continue with: "
            f"{_resume_hint(run_name, total, store_option)}")
    if not aborted:
        say(summary(store, run_name, start, time.monotonic() - began, store_option))
    if aborted:
        raise typer.Exit(130)


def _holds_lock(store, run_name: str, owner: str) -> bool:
    lock = store.get_run(run_name).lock
    return lock is not None and lock.owner == owner


def _eval_every(option: int | None, config) -> int:
    every = config.evaluation.every if option is None else option
    if every and every % config.world.episode_length:
        raise HadimError(f"--eval-every must be a multiple of the episode length "
                         f"({config.world.episode_length}), got {every}")
    return every


@app.command()
def train(
    iterations: IterationsOption = 4000,
    config: ConfigOption = None,
    set_: SetOption = None,
    seed: Annotated[int, typer.Option(help="Seed of the session's root generator.")] = 0,
    name: Annotated[str | None, typer.Option(help="Run name (default run-N).")] = None,
    eval_every: EvalEveryOption = None,
    store: StoreOption = None,
) -> None:
    """Start a new learning session and store it as a run; prints the run's name."""
    from hadim_cli import runs
    from hadim_cli.config import load_config
    from hadim_cli.session import Session

    resolved = load_config(config, set_ or [])
    every = _eval_every(eval_every, resolved)
    with runs.open_store(store) as st:
        record = runs.new_run(st, resolved, seed, name)
        typer.echo(record.name)
        _drive(st, record.name, Session(resolved, seed), iterations, every, store)


@app.command()
def resume(
    run: Annotated[str, typer.Argument(help="Run to continue.")],
    iterations: Annotated[int | None, typer.Option("--iterations", "-n", min=1,
                                                   help="New total (default: 4000).")] = None,
    eval_every: EvalEveryOption = None,
    store: StoreOption = None,
) -> None:
    """Continue a run from its last checkpoint up to --iterations in total."""
    from hadim_cli import runs

    with runs.open_store(store, create=False) as st:
        record = st.get_run(run)
        if record.config.get("kind") == "baseline":
            from hadim_cli.commands.baseline import resume_baseline

            resume_baseline(st, record, iterations, eval_every, store)
            return
        session = runs.restore_session(st, record)
        total = iterations or max(4000, record.iterations)
        if session.iteration >= total:
            raise HadimError(f"run {run} already has {session.iteration} iterations "
                             f"(asked for {total}); pass a larger --iterations")
        _drive(st, run, session, total, _eval_every(eval_every, session.config), store)


@app.command()
def fork(
    run: Annotated[str, typer.Argument(help="Run to fork.")],
    at: Annotated[int | None, typer.Option("--at", min=0, help="Fork from the checkpoint at "
                                           "or before this iteration (default: latest).")] = None,
    set_: SetOption = None,
    seed: Annotated[int | None, typer.Option(help="Seed (default: the parent's).")] = None,
    name: Annotated[str | None, typer.Option(help="Name of the new run.")] = None,
    store: StoreOption = None,
) -> None:
    """A new run whose history up to a checkpoint is the parent's; the parent is untouched."""
    from hadim_cli import runs
    from hadim_cli.config import stored_config, with_overrides

    with runs.open_store(store, create=False) as st:
        parent = st.get_run(run)
        if parent.config.get("kind") == "baseline":
            raise HadimError(f"run {run} is a baseline run: fork is for the learner's runs")
        config = with_overrides(stored_config(parent.config), set_ or [])
        if set_:  # refuse, before writing anything, a config that cannot continue this history
            runs.restore_session(st, parent, parent.iterations if at is None else at, config)
        child = st.fork(run, at_iteration=at, config=config.to_dict(),
                        seed=parent.seed if seed is None else seed, name=name,
                        versions=runs.package_versions())
        typer.echo(child.name)
