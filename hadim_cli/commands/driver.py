"""Driving a run to a number of iterations: the run's lock, progress, Ctrl-C as a pause, the
closing summary. Shared by `hadim train`, `hadim resume`, `hadim baseline train`; the session
and its training loop are passed in, so this module knows no kind of run.

Ctrl-C finishes the current episode, checkpoints and exits with `PAUSED_EXIT` (the shell's code
for SIGINT): a script tells a paused run from a finished one (exit 0). The command printed to
continue is `resume_command`, the same in the pause line and in the summary, and `hadim resume
RUN` alone continues to the iterations the run was started for (`runs.target_iterations`).
"""

from __future__ import annotations

import shlex
import signal
from collections.abc import Callable
from contextlib import contextmanager

import typer

from hadim_cli.errors import HadimError
from hadim_cli.heartbeat import keep_alive

PAUSED_EXIT = 130
"""Exit status of a run paused (or aborted) by Ctrl-C: 128 + SIGINT, as a shell reports it."""


@contextmanager
def interruptible():
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


def store_flag(store_option: str | None) -> str:
    return f" --store {shlex.quote(store_option)}" if store_option else ""


def resume_command(run_name: str, store_option: str | None) -> str:
    """How to continue a paused run: to the iterations it was started for."""
    return f"hadim resume {run_name}{store_flag(store_option)}"


def further_command(run_name: str, iterations: int, store_option: str | None) -> str:
    """How to take a finished run further (twice its iterations, as an example)."""
    return f"hadim resume {run_name} --iterations {2 * iterations}{store_flag(store_option)}"


def drive(store, run_name: str, session, total: int, eval_every: int,
          store_option: str | None, train: Callable, tasks: tuple[str, ...]) -> None:
    """Train `session` to `total` with `train` (`runs.train` or the baselines'), under the
    run's lock, with progress and Ctrl-C as a pause; then the summary."""
    import time

    from hadim_cli import runs
    from hadim_cli.progress import Reporter, say, summary
    from hadim_store.records import RunStatus

    owner = runs.owner_id()
    began, start = time.monotonic(), session.iteration
    with interruptible() as (should_stop, disarm):
        store.acquire_lock(run_name, owner)
        stored = store.get_run(run_name).iterations
        if stored != session.iteration:  # another process wrote to it while we loaded it
            store.release_lock(run_name, owner)
            raise HadimError(f"run {run_name} moved from iteration {session.iteration} to "
                             f"{stored} while loading; run the command again")
        store.set_status(run_name, RunStatus.RUNNING)
        status, aborted = RunStatus.FAILED, False
        try:
            with keep_alive(store, run_name, owner), \
                    Reporter(run_name, session.iteration, total) as reporter:
                train(store, run_name, session, total, eval_every=eval_every, tasks=tasks,
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
        say(f"{'aborted' if aborted else 'paused'} at iteration {done} of {total}; continue "
            f"with: {resume_command(run_name, store_option)}")
    if not aborted:
        say(summary(store, run_name, start, time.monotonic() - began, store_option))
    if status is RunStatus.PAUSED:
        raise typer.Exit(PAUSED_EXIT)


def _holds_lock(store, run_name: str, owner: str) -> bool:
    lock = store.get_run(run_name).lock
    return lock is not None and lock.owner == owner


def refuse_reached(run_name: str, have: int, total: int, asked: bool,
                   store_option: str | None) -> None:
    """One line, before anything is restored, when the run already has `total` iterations."""
    if have < total:
        return
    further = further_command(run_name, have, store_option)
    if asked:
        raise HadimError(f"run {run_name} already has {have} iterations (asked for {total}); "
                         f"to go further: {further}")
    raise HadimError(f"run {run_name} is finished at {have} iterations; to go further: "
                     f"{further}")
