"""`hadim train`, `hadim resume`, `hadim fork`: drive learning sessions stored as runs.

Exit status: 0 when the run reaches its iterations, `driver.PAUSED_EXIT` (130) when Ctrl-C
paused it, 2 for a refusal (one `error:` line)."""

from __future__ import annotations

from typing import Annotated

import typer

from hadim_cli.commands import driver
from hadim_cli.commands.baseline import baseline_plan, resume_baseline
from hadim_cli.commands.common import ConfigOption, SetOption, StoreOption
from hadim_cli.errors import HadimError

app = typer.Typer()

IterationsOption = Annotated[int, typer.Option("--iterations", "-n", min=1,
                                               help="Total iterations (primitive actions).")]
EvalEveryOption = Annotated[int | None, typer.Option(
    "--eval-every", min=0, help="Evaluate every N iterations (default: evaluation.every; 0 off).")]


def _eval_every(option: int | None, config) -> int:
    """The evaluation period, after refusing one the run cannot keep: not a multiple of the
    episode length, or tasks of another body than the run's."""
    every = config.evaluation.every if option is None else option
    if every and every % config.world.episode_length:
        raise HadimError(f"--eval-every must be a multiple of the episode length "
                         f"({config.world.episode_length}), got {every}")
    if every:
        from hadim_cli.evaluation.tasks import check_body, load_task

        for name in config.evaluation.tasks:
            check_body(load_task(name), config.world)
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
    """Start a new learning session and store it as a run; prints the run's name.
    Ctrl-C pauses it (exit status 130) and prints the command that continues it."""
    from hadim_cli import runs
    from hadim_cli.config import load_config

    resolved = load_config(config, set_ or [])
    every = _eval_every(eval_every, resolved)
    runs.refuse_new_run(store, name)
    from hadim_cli.session import Session  # the learner and torch: after every refusal

    session = Session(resolved, seed)  # a world it cannot build is refused before the store
    with runs.open_store(store) as st:
        record = runs.new_run(st, resolved, seed, name)
        typer.echo(record.name)
        driver.drive(st, record.name, session, iterations, every, store,
                     runs.train, resolved.evaluation.tasks)


@app.command()
def resume(
    run: Annotated[str, typer.Argument(help="Run to continue.")],
    iterations: Annotated[int | None, typer.Option(
        "--iterations", "-n", min=1, help="New total (default: the iterations the run was "
        "started for; a finished run needs a larger one).")] = None,
    eval_every: EvalEveryOption = None,
    store: StoreOption = None,
) -> None:
    """Continue a paused or interrupted run from its last checkpoint, to the iterations it
    was started for (or --iterations in total)."""
    from hadim_cli import runs

    reader = runs.light_reader(store)
    if reader is not None:  # the refusals, read with sqlite3 alone (no SQLAlchemy, no agent)
        with reader:
            record = reader.get_run(run)
            plans = {runs.RunKind.LEARNER: _learner_plan, runs.RunKind.BASELINE: baseline_plan}
            plans[runs.run_kind(record)](reader, record, iterations, eval_every, store)
    resumers = {runs.RunKind.LEARNER: _resume_learner, runs.RunKind.BASELINE: resume_baseline}
    with runs.open_store(store, create=False, run=run) as st:
        record = st.get_run(run)
        resumers[runs.run_kind(record)](st, record, iterations, eval_every, store)


def _learner_plan(st, record, iterations: int | None, eval_every: int | None,
                  store_option: str | None) -> tuple[int, int]:
    """The total and evaluation period a learner's run is resumed with, after every refusal
    that needs no learner: the run already there, `--eval-every` not a multiple of the
    episode length, a run another live process drives."""
    from hadim_cli import runs
    from hadim_cli.config import stored_config
    from hadim_store.records import RunStatus

    finished = record.status is RunStatus.FINISHED
    default = record.iterations if finished else max(runs.DEFAULT_ITERATIONS, record.iterations)
    total = iterations or runs.target_iterations(st, record, default)
    driver.refuse_reached(record.name, record.iterations, total, iterations is not None,
                          store_option)
    every = _eval_every(eval_every, stored_config(record.config))
    st.refuse_if_locked(record.name)
    return total, every


def _resume_learner(st, record, iterations: int | None, eval_every: int | None,
                    store_option: str | None) -> None:
    """`hadim resume` on a learner's run: every refusal before the session is restored."""
    from hadim_cli import runs
    from hadim_cli.config import stored_config

    total, every = _learner_plan(st, record, iterations, eval_every, store_option)
    if (note := runs.version_note(record)) is not None:
        typer.echo(note, err=True)
    session = runs.restore_session(st, record)
    driver.drive(st, record.name, session, total, every, store_option, runs.train,
                 stored_config(record.config).evaluation.tasks)


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

    reader = runs.light_reader(store)
    if reader is not None:  # the refusals that need no learner, read with sqlite3 alone
        with reader:
            _fork_config(reader.get_run(run), set_)
    runs.refuse_new_run(store, name)
    with runs.open_store(store, create=False, run=run) as st:
        parent = st.get_run(run)
        config = _fork_config(parent, set_)
        if (note := runs.version_note(parent)) is not None:
            typer.echo(note, err=True)
        if set_:  # refuse, before writing anything, a config that cannot continue this history
            runs.restore_session(st, parent, parent.iterations if at is None else at, config)
        child = st.fork(run, at_iteration=at, config=config.to_dict(),
                        seed=parent.seed if seed is None else seed, name=name,
                        versions=runs.package_versions())
        typer.echo(child.name)


def _fork_config(parent, set_: list[str] | None):
    """The config a fork of `parent` runs with; a baseline run, or a `--set` key the config
    lacks, refused."""
    from hadim_cli import runs
    from hadim_cli.config import stored_config, with_overrides

    if runs.run_kind(parent) is runs.RunKind.BASELINE:
        raise HadimError(f"run {parent.name} is a baseline run: fork is for the learner's runs")
    return with_overrides(stored_config(parent.config), set_ or [])
