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

RunArg = Annotated[str | None, typer.Argument(
    help="Run name, e.g. run-7 (default: the store's most recently updated run).")]
AtOption = Annotated[int | None, typer.Option("--at", min=0, help="Use the checkpoint at or "
                                              "before this iteration (default: latest).")]


def _console():
    from rich.console import Console

    return Console()


@runs_app.command("list")
def runs_list(
    store: StoreOption = None,
    as_json: JsonOption = False,
    wide: Annotated[bool, typer.Option("--wide", help="Every column (seed, parent, the "
                                       "time to the second): wider than 80 columns.")] = False,
) -> None:
    """Every run of the store: name, what it runs, status, iterations, last update."""
    from rich.table import Table

    from hadim_cli import runs

    with runs.open_reader(store) as st:  # sqlite3 alone when the file is sound
        records = st.list_runs()
        damaged = runs.damaged_runs(st, records)
    if as_json:
        typer.echo(json.dumps([{"name": r.name, "status": r.status.value, "seed": r.seed,
                                "iterations": r.iterations, "parent": r.parent,
                                "damaged": r.name in damaged, **_kind(r.config)}
                               for r in records], indent=2))
    else:
        table = Table(title=f"runs in {runs.store_location(store)}", title_justify="left")
        table.add_column("name", no_wrap=True)
        if wide:
            table.add_column("kind", no_wrap=True)
        table.add_column("algorithm" if wide else "runs", overflow="fold")
        for col in ("status", "iterations", *(("seed", "parent") if wide else ()), "updated"):
            table.add_column(col, no_wrap=True, justify="right" if col == "iterations" else
                             "left")
        for r in records:
            kind = _kind(r.config)
            what = kind["algorithm"] if kind["kind"] == "baseline" or wide else kind["kind"]
            status = "DAMAGED" if r.name in damaged else r.status.value
            parent = f"{r.parent}@{r.fork_iteration}" if r.parent else ""
            table.add_row(r.name, *((kind["kind"],) if wide else ()), what, status,
                          str(r.iterations), *((str(r.seed), parent) if wide else ()),
                          r.updated_at.strftime("%Y-%m-%d %H:%M" + (":%S" if wide else "")))
        console = _console()
        if wide:  # every column whole, however wide: the user asked for it
            from rich.console import Console

            from hadim_cli.reports import least_width

            console = Console(width=max(console.width, least_width(table)))
        console.print(table)
    if damaged:
        raise HadimError(runs.damage_line(None, f"{', '.join(damaged)} cannot be read"))


def _kind(config: dict) -> dict[str, str]:
    """A run's kind (learner or baseline) and algorithm, from its stored config."""
    if config.get("kind") == "baseline":
        b = config["baseline"]
        return {"kind": "baseline", "algorithm": f"{b['algorithm']} {b['reward']} {b['task']}"}
    return {"kind": "learner", "algorithm": "hadim"}


def _refuse_baseline(record, what: str) -> None:
    from hadim_cli import runs

    if runs.run_kind(record) is runs.RunKind.BASELINE:
        algorithm = _kind(record.config)["algorithm"]
        raise HadimError(f"run {record.name} is a baseline run ({algorithm}): {what} is for "
                         "the learner's runs")


@runs_app.command("show")
def runs_show(run: RunArg = None, store: StoreOption = None, as_json: JsonOption = False) -> None:
    """Status, iterations, parent, config, affordances, latest scores and D's digest."""
    from rich.table import Table

    from hadim_cli import runs

    with runs.open_reader(store, run=run) as st:  # sqlite3 alone when the file is sound
        r = runs.chosen_run(st, run)
        run = r.name
        # |H| from the last episode's per-affordance stats: decoding the checkpoint's arrays
        # would be slow on a long run and fail on a damaged one that `show` should still show.
        n_aff = sum(1 for s in st.stats(run, upto_iteration=r.iterations)
                    if s.iteration == r.iterations)
        # Each score with the iteration it was measured at: a run resumed with evaluation off,
        # or a fork, may hold no score of its latest iterations.
        latest: dict[str, dict] = {}
        for e in st.evaluations(run):  # by iteration: the last one of a task wins
            latest[e.task] = {"score": e.score, "iteration": e.iteration}
        kind = _kind(r.config)
        babbling = None
        if runs.run_kind(r) is runs.RunKind.LEARNER:
            sigma = r.config.get("learner", {}).get("sigma")
            babbling = runs.goal_babbling_share([e.extra for e in st.episodes(run)], sigma)
        info = {
            "name": r.name, "status": r.status.value, "iterations": r.iterations,
            "seed": r.seed, "parent": r.parent, "fork_iteration": r.fork_iteration,
            **kind, "affordances": n_aff, "scores": latest, "goal_babbling": babbling,
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
    table.add_column("key", no_wrap=True)
    table.add_column("value", overflow="fold")
    for key, value in info.items():
        if key != "config":
            table.add_row(key, _show_value(key, value, r.iterations))
    _console().print(table)


def _show_value(key: str, value, iterations: int) -> str:
    """A value of `runs show` as a reader wants it: no Python reprs, scores with iterations."""
    if value is None:
        return "—"
    if key == "scores":
        return "\n".join(
            f"{task}: {s['score']:.3f} at iteration {s['iteration']}"
            + ("" if s["iteration"] == iterations else " (not re-evaluated since)")
            for task, s in value.items()) or "none (train with --eval-every, or hadim eval)"
    if key == "goal_babbling":
        def pct(x) -> str:
            return "—" if x is None else f"{100 * x:.1f} %"
        falls = ", ".join(f"{k} {v}" for k, v in (value["fallbacks"] or {}).items())
        return (f"effective {pct(value['effective'])} of {value['learning_episodes']} learning "
                f"episodes (σ {value['sigma']}, drawn {pct(value['drawn'])})"
                + (f"; fallbacks: {falls}" if falls else ""))
    if key == "lock":
        return f"{value['owner']} (pid {value['pid']} on {value['host']}, heartbeat " \
               f"{value['heartbeat']})"
    if isinstance(value, dict):
        return ", ".join(f"{k} {v}" for k, v in value.items())
    return str(value)


@app.command()
def affordances(
    run: RunArg = None,
    timeline: Annotated[bool, typer.Option("--timeline", help="Show every change of H.")] = False,
    at: AtOption = None,
    out: Annotated[Path | None, typer.Option(
        "--out", help="Draw the timeline to a PNG (implies --timeline).")] = None,
    pa: Annotated[bool, typer.Option(
        "--pa", help="p_A of each affordance on the reference scene's entities and on objects "
        "of sizes and shades never seen in training.")] = False,
    errors: Annotated[bool, typer.Option(
        "--errors", help="Each forward model's error on its own rows, each left out of its "
        "own fit (m for positions).")] = False,
    store: StoreOption = None,
    as_json: JsonOption = False,
) -> None:
    """The affordance hierarchy H of a run (as it stood at --at), its timeline, or its p_A."""
    from hadim_cli import runs

    if pa and (timeline or out is not None):
        raise HadimError("--pa shows p_A of H at one iteration: not with --timeline or --out")
    if errors and (pa or timeline or out is not None):
        raise HadimError("--errors shows the models of H at one iteration: not with --pa, "
                         "--timeline or --out")
    if timeline or out is not None:
        with runs.open_reader(store, run=run) as st:
            record = _learner_run(st, run, at, "affordances")
            _show_timeline(st.events(record.name, upto_iteration=at), record, at, out, as_json)
        return
    # H's table is stored with every episode, and read with the checkpoint it stands for by
    # sqlite3 alone when the file allows; p_A and the models' errors (and H of a run stored by
    # an older hadim) need the session restored.
    with runs.open_reader(store, run=run) as st:
        record = _learner_run(st, run, at, "affordances")
        stored = None if pa or errors else runs.stored_hierarchy(st, record, at)
        session = runs.restore_session(st, record, at) if stored is None else None
    if session is None:
        rows, iteration = stored
    elif pa or errors:
        _show_models(session, pa, as_json)
        return
    else:
        from hadim_cli.reports import affordance_rows

        rows, iteration = affordance_rows(session), session.iteration
    if as_json:
        typer.echo(json.dumps(rows, indent=2))
    else:
        from hadim_cli.config import stored_config
        from hadim_cli.reports import probed_on_task, render_h_table, rows_shown
        from hadim_cli.world.layout import actor_of

        world = stored_config(record.config).world
        render_h_table(_console(), rows_shown(rows, actor_of(world.body)), iteration,
                       probed_on_task(world))


def _learner_run(st, run: str | None, at: int | None, what: str):
    """The learner's run `run` names (the most recent if None), refused if a baseline's or
    if `at` is beyond its iterations."""
    from hadim_cli import runs

    record = runs.chosen_run(st, run)
    _refuse_baseline(record, what)
    if at is not None and at > record.iterations:
        raise HadimError(f"--at {at} is beyond run {record.name}'s {record.iterations} "
                         "iterations")
    return record


def _show_timeline(events, record, at: int | None, out: Path | None, as_json: bool) -> None:
    """The timeline as a table or JSON (the stored names), and its figure; the table and the
    figure name the actor as the run's world does."""
    from hadim_cli.config import stored_config
    from hadim_cli.reports import events_shown, render_timeline
    from hadim_cli.world.layout import actor_of

    shown = events_shown(events, actor_of(stored_config(record.config).world.body))
    if out is not None:
        from hadim_cli.plots import timeline_figure

        timeline_figure(shown, record.iterations if at is None else at, out,
                        title=f"run {record.name}: affordance timeline")
        typer.echo(f"wrote {out}", err=as_json)  # stdout stays pure JSON with --json
    if as_json:
        typer.echo(json.dumps([_event_json(e) for e in events], indent=2))
    else:
        render_timeline(_console(), shown)


def _show_models(session, pa: bool, as_json: bool) -> None:
    """`--pa` (p_A on probe objects) or `--errors` (each forward model's held-out errors)."""
    if pa:
        from hadim_cli.pa_probes import verdicts
        from hadim_cli.reports import render_p_a

        found = verdicts(session)
        if as_json:
            typer.echo(json.dumps([v.as_json() for v in found], indent=2))
        else:
            from dataclasses import replace

            from hadim_cli.learner.spaces import shown_as

            actor = session.world.layout.actor
            render_p_a(_console(), [replace(v, affordance=shown_as(v.affordance, actor))
                                    for v in found], session.iteration, actor)
        return
    from hadim_cli.reports import error_rows, render_errors, rows_shown

    rows = error_rows(session)
    if as_json:
        typer.echo(json.dumps(rows, indent=2))
    else:
        render_errors(_console(), rows_shown(rows, session.world.layout.actor),
                      session.iteration)


def _event_json(e) -> dict:
    return {"iteration": e.iteration, "id": e.affordance_id, "kind": e.kind,
            "input": e.input_space, "output": e.output_space, "context": list(e.context),
            "competence": e.competence, "detail": e.detail}


@app.command("eval")
def eval_cmd(
    run: RunArg = None,
    task: Annotated[str | None, typer.Option("--task", help="A task of configs/tasks/.")] = None,
    points: Annotated[Path | None, typer.Option("--points", help="Your own task file.")] = None,
    at: AtOption = None,
    animate: Annotated[Path | None, typer.Option(
        "--animate", help="Also draw every point's attempt, action by action, to this GIF.")
    ] = None,
    exact: Annotated[list[str] | None, typer.Option(
        "--exact", help="Imagine a level of the chain by the world's physics instead of its "
        "learned model (a diagnostic, not stored): navigation (the actor's own motion: the "
        "rover's drive, the arm's kinematics), push (a body pushed by the actor) or tool (a "
        "body pushed by another); repeat to combine.")
    ] = None,
    budget: Annotated[int | None, typer.Option(
        "--budget", help="Actions per point instead of the task's own (1-10000; stored as "
        "TASK@N, e.g. push-object@1000: the episode-success measure of docs/baselines.md)."
    )] = None,
    store: StoreOption = None,
    as_json: JsonOption = False,
) -> None:
    """Evaluate a run (learner or baseline) on a task's target points and store the score."""
    from hadim_cli import runs
    from hadim_cli.evaluation.tasks import load_task, load_task_file
    from hadim_cli.reports import render_eval

    if (task is None) == (points is None):
        raise HadimError("give exactly one of --task NAME or --points FILE")
    chosen = _with_budget(load_task(task) if task is not None else load_task_file(points),
                          budget)
    diagnostic = animate is not None or bool(exact)
    reader = runs.light_reader(store)
    if reader is not None:  # the refusals that need no learner, read with sqlite3 alone
        with reader:
            run = _eval_refusals(reader, run, at, chosen, diagnostic).name
    with runs.open_store(store, create=False, run=run) as st:
        record = _eval_refusals(st, run, at, chosen, diagnostic)
        if runs.run_kind(record) is runs.RunKind.BASELINE:
            result, session = _eval_baseline(st, record, chosen, at)
        else:
            result, session = _eval_learner(st, record, chosen, at, tuple(exact or ()),
                                            animate is not None)
    if animate is not None:
        from hadim_cli.evaluation.animate import animate as draw

        # The world's config draws its body (an arm's links); the rover's ignores it.
        draw(result.recordings, session.world.layout, animate, arm=session.config.world.arm)
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


def _eval_refusals(st, run: str | None, at: int | None, chosen, diagnostic: bool):
    """The run `eval` evaluates, after every refusal that needs neither the learner nor the
    agent: `--at` beyond it, a learner's diagnostic on a baseline run, a task the run's
    world or policy cannot attempt."""
    from hadim_cli import runs
    from hadim_cli.baselines.config import check_fits, read_config
    from hadim_cli.config import stored_config
    from hadim_cli.evaluation.tasks import check_task

    record = runs.chosen_run(st, run)
    if at is not None and at > record.iterations:
        raise HadimError(f"--at {at} is beyond run {record.name}'s {record.iterations} "
                         "iterations")
    if runs.run_kind(record) is runs.RunKind.LEARNER:
        check_task(chosen, stored_config(record.config).world)
        return record
    if diagnostic:
        raise HadimError("--animate and --exact are diagnostics of the learner's "
                         f"controller; run {record.name} is a baseline run")
    check_fits(read_config(record.config), chosen)
    return record


def _with_budget(task, budget: int | None):
    """`task` with another budget, named `TASK@N` so its scores never join the task's own."""
    import dataclasses

    from hadim_cli.evaluation.metric import check_budget, measure_name

    if budget is None:
        return task
    try:
        check_budget(budget)
    except ValueError as exc:
        raise HadimError(str(exc)) from None
    return dataclasses.replace(task, budget=budget, name=measure_name(task.name, budget))


def _eval_baseline(st, record, chosen, at: int | None):
    """A baseline's greedy policy on `chosen` (a task of another kind was refused by
    `_eval_refusals`)."""
    from hadim_cli.baselines import runs as baseline_runs

    session = baseline_runs.restore(st, record, at)
    result = session.evaluate(chosen)
    st.add_evaluation(record.name, session.iteration, chosen.name, result.score,
                      result.to_dict()["points"])
    return result, session


def _eval_learner(st, record, chosen, at: int | None, exact: tuple[str, ...], animate: bool):
    """The learner's H on `chosen` (a target it cannot reach was refused by
    `_eval_refusals`). With `exact` levels the score is a diagnostic, not stored."""
    from hadim_cli import runs
    from hadim_cli.evaluation.exact import exact_levels
    from hadim_cli.evaluation.runner import evaluate

    if (note := runs.version_note(record)) is not None:
        typer.echo(note, err=True)
    session = runs.restore_session(st, record, at)
    with exact_levels(session.learner, session.config.world, exact):
        result = evaluate(session.learner, session.config.world, chosen, record=animate)
    if not exact:  # an exact level: a diagnostic
        st.add_evaluation(record.name, session.iteration, chosen.name, result.score,
                          result.to_dict()["points"])
    return result, session


@app.command()
def plot(
    run: Annotated[list[str] | None, typer.Argument(
        help="Run name(s); several runs are drawn together, grouped by algorithm (paper "
        "Fig. 5). Default: the store's most recently updated run.")] = None,
    out: Annotated[Path, typer.Option("--out", help="PNG to write.")] = Path("curves.png"),
    log_x: Annotated[bool, typer.Option("--log-x", help="Iterations on a log axis.")] = False,
    store: StoreOption = None,
) -> None:
    """Draw stored evaluation scores over iterations: one run, or several (paper Fig. 2, 5).

    One panel per task; several runs are drawn as mean ± std per algorithm and reward."""
    from hadim_cli import runs
    from hadim_cli.plots import comparison_figure, competence_figure

    groups: dict[str, list] = {}
    with runs.open_reader(store, run=run[0] if run and len(run) == 1 else None) as st:
        run = run or [runs.chosen_run(st, None).name]
        for name in dict.fromkeys(run):
            record = runs.chosen_run(st, name)
            evaluations = st.evaluations(name)
            if not evaluations:
                raise HadimError(f"run {name} has no evaluations yet (train with --eval-every, "
                                 f"or run hadim eval)")
            groups.setdefault(_group(record.config), []).append(evaluations)
    if len(run) == 1:
        competence_figure({run[0]: groups.popitem()[1][0]}, out,
                          title=f"run {run[0]}: evaluation scores")
    else:
        comparison_figure(groups, out, ("move-robot", "push-object", "push-with-tool"),
                          log_x=log_x)
    typer.echo(str(out))


def _group(config: dict) -> str:
    """The curve a run belongs to: the learner, or algorithm + reward (+ continuous actions)."""
    from hadim_cli.report.baselines import group_label

    return group_label(config, "learner")
