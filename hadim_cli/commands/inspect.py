"""`hadim runs`, `hadim affordances`, `hadim eval`, `hadim plot`: read and evaluate runs."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Annotated

import typer

from hadim_cli.commands.common import JsonOption, StoreOption
from hadim_cli.errors import HadimError

runs_app = typer.Typer(help="List and show stored runs.", no_args_is_help=True)
app = typer.Typer()

RunArg = Annotated[str, typer.Argument(help="Run name, e.g. run-7.")]
AtOption = Annotated[int | None, typer.Option("--at", min=0, help="Use the checkpoint at or "
                                              "before this iteration (default: latest).")]


def _console():
    from rich.console import Console

    return Console()


@runs_app.command("list")
def runs_list(store: StoreOption = None, as_json: JsonOption = False) -> None:
    """Every run of the store."""
    from rich.table import Table

    from hadim_cli import runs

    with runs.open_store(store, create=False) as st:
        records = st.list_runs()
    if as_json:
        typer.echo(json.dumps([{"name": r.name, "status": r.status.value, "seed": r.seed,
                                "iterations": r.iterations, "parent": r.parent}
                               for r in records], indent=2))
        return
    table = Table(title=f"runs in {runs.store_location(store)}")
    for col in ("name", "status", "iterations", "seed", "parent", "updated"):
        table.add_column(col)
    for r in records:
        parent = f"{r.parent}@{r.fork_iteration}" if r.parent else ""
        table.add_row(r.name, r.status.value, str(r.iterations), str(r.seed), parent,
                      r.updated_at.strftime("%Y-%m-%d %H:%M:%S"))
    _console().print(table)


@runs_app.command("show")
def runs_show(run: RunArg, store: StoreOption = None, as_json: JsonOption = False) -> None:
    """Status, iterations, parent, config, affordances, latest scores and D's digest."""
    from rich.table import Table

    from hadim_cli import runs

    with runs.open_store(store, create=False) as st:
        r = st.get_run(run)
        # |H| from the last episode's per-affordance stats: decoding the checkpoint's arrays
        # would be slow on a long run and fail on a damaged one that `show` should still show.
        n_aff = sum(1 for s in st.stats(run, upto_iteration=r.iterations)
                    if s.iteration == r.iterations)
        latest: dict[str, float] = {}
        for e in st.evaluations(run):
            latest[e.task] = e.score
        sigma = r.config.get("learner", {}).get("sigma")
        babbling = runs.goal_babbling_share([e.extra for e in st.episodes(run)], sigma)
        info = {
            "name": r.name, "status": r.status.value, "iterations": r.iterations,
            "seed": r.seed, "parent": r.parent, "fork_iteration": r.fork_iteration,
            "affordances": n_aff, "scores": latest, "goal_babbling": babbling,
            "dataset_sha256": st.dataset_sha256(run),
            "lock": None if r.lock is None else {
                "owner": r.lock.owner, "pid": r.lock.pid, "host": r.lock.host,
                "heartbeat": r.lock.heartbeat.isoformat()},
            "created_at": r.created_at.isoformat(), "updated_at": r.updated_at.isoformat(),
            "versions": r.versions, "config": r.config,
        }
    if as_json:
        typer.echo(json.dumps(info, indent=2))
        return
    table = Table(title=f"run {r.name}", show_header=False)
    for key, value in info.items():
        if key != "config":
            table.add_row(key, str(value))
    _console().print(table)


@app.command()
def affordances(
    run: RunArg,
    timeline: Annotated[bool, typer.Option("--timeline", help="Show every change of H.")] = False,
    at: AtOption = None,
    out: Annotated[Path | None, typer.Option(
        "--out", help="Draw the timeline to a PNG (implies --timeline).")] = None,
    store: StoreOption = None,
    as_json: JsonOption = False,
) -> None:
    """The affordance hierarchy H of a run (as it stood at --at), or its timeline."""
    from hadim_cli import runs
    from hadim_cli.reports import affordance_rows, render_h_table, render_timeline

    with runs.open_store(store, create=False) as st:
        record = st.get_run(run)
        if at is not None and at > record.iterations:
            raise HadimError(f"--at {at} is beyond run {run}'s {record.iterations} iterations")
        events = st.events(run, upto_iteration=at)
        if timeline or out is not None:
            if out is not None:
                from hadim_cli.plots import timeline_figure

                timeline_figure(events, record.iterations if at is None else at, out)
            if as_json:
                typer.echo(json.dumps([_event_json(e) for e in events], indent=2))
            else:
                render_timeline(_console(), events)
            return
        session = runs.restore_session(st, record, at)
    rows = affordance_rows(session)
    if as_json:
        typer.echo(json.dumps(rows, indent=2))
    else:
        render_h_table(_console(), rows, session.iteration)


def _event_json(e) -> dict:
    return {"iteration": e.iteration, "id": e.affordance_id, "kind": e.kind,
            "input": e.input_space, "output": e.output_space, "context": list(e.context),
            "competence": e.competence, "detail": e.detail}


@app.command("eval")
def eval_cmd(
    run: RunArg,
    task: Annotated[str | None, typer.Option("--task", help="A task of configs/tasks/.")] = None,
    points: Annotated[Path | None, typer.Option("--points", help="Your own task file.")] = None,
    at: AtOption = None,
    animate: Annotated[Path | None, typer.Option(
        "--animate", help="Also draw every point's attempt, action by action, to this GIF.")
    ] = None,
    exact: Annotated[list[str] | None, typer.Option(
        "--exact", help="Replace a level of the chain by an exact one (diagnostic, not "
        "stored): navigation.")] = None,
    store: StoreOption = None,
    as_json: JsonOption = False,
) -> None:
    """Evaluate a run's H on a task's target points and store the score."""
    from hadim_cli import runs
    from hadim_cli.evaluation.exact import exact_levels
    from hadim_cli.evaluation.runner import evaluate
    from hadim_cli.evaluation.tasks import load_task, load_task_file
    from hadim_cli.reports import render_eval

    if (task is None) == (points is None):
        raise HadimError("give exactly one of --task NAME or --points FILE")
    chosen = load_task(task) if task is not None else load_task_file(points)
    with runs.open_store(store, create=False) as st:
        record = st.get_run(run)
        if at is not None and at > record.iterations:
            raise HadimError(f"--at {at} is beyond run {run}'s {record.iterations} iterations")
        session = runs.restore_session(st, record, at)
        with exact_levels(session.learner, session.config.world, tuple(exact or ())):
            result = evaluate(session.learner, session.config.world, chosen,
                              record=animate is not None)
        if not exact:
            # A score with an exact level is a diagnostic, not the learner's.
            st.add_evaluation(run, session.iteration, chosen.name, result.score,
                              result.to_dict()["points"])
    if animate is not None:
        from hadim_cli.evaluation.animate import animate as draw

        draw(result.recordings, session.world.layout, animate)
    if as_json:
        payload = result.to_dict()
        payload["iteration"] = session.iteration
        if animate is not None:
            payload["animation"] = str(animate)
        typer.echo(json.dumps(payload, indent=2))
    else:
        render_eval(_console(), result, session.iteration)
        if animate is not None:
            typer.echo(f"wrote {animate}")


@app.command()
def plot(
    run: RunArg,
    out: Annotated[Path, typer.Option("--out", help="PNG to write.")] = Path("curves.png"),
    store: StoreOption = None,
) -> None:
    """Draw the run's stored evaluation scores over iterations (paper Fig. 2)."""
    from hadim_cli import runs
    from hadim_cli.plots import competence_figure

    with runs.open_store(store, create=False) as st:
        st.get_run(run)
        evaluations = st.evaluations(run)
    if not evaluations:
        raise HadimError(f"run {run} has no evaluations yet (train with --eval-every, or "
                         f"run hadim eval)")
    competence_figure({run: evaluations}, out)
    typer.echo(str(out))
