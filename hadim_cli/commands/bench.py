"""`hadim bench`: measure how fast the parts of hadim run."""

from __future__ import annotations

import json
from typing import Annotated

import typer

from hadim_cli.commands.common import ConfigOption, JsonOption, SetOption, StoreOption
from hadim_cli.config import load_config

app = typer.Typer(help="Measure how fast the parts of hadim run.", no_args_is_help=True)


def _echo(payload: dict | list) -> None:
    """Print a benchmark's JSON; an object gets the numeric kernels it ran on
    (hadim_cli/numerics.py): figures from machines whose kernels differ are not comparable."""
    from hadim_cli.numerics import kernels

    if isinstance(payload, dict):
        payload = {**payload, "kernels": kernels()}
    typer.echo(json.dumps(payload))


@app.command("world")
def world(
    actions: Annotated[int, typer.Option("--actions", "-n", min=1,
                                         help="Random primitive actions to run.")] = 2000,
    seed: Annotated[int, typer.Option("--seed", help="Seed of scenes and actions.")] = 0,
    config: ConfigOption = None,
    set_: SetOption = None,
    json_: JsonOption = False,
) -> None:
    """Actions per second of the world, against raw pymunk stepping the same physics."""
    from hadim_cli.world.bench import bench_world

    cfg = load_config(config, set_ or [])
    result = bench_world(cfg.world, actions, seed)
    if json_:
        _echo(result.to_dict())
        return
    from rich.console import Console
    from rich.table import Table

    table = Table(title=f"world ({result.body}): {actions} random actions, seed {seed}, "
                  f"{result.substeps_per_action} physics steps per action")
    table.add_column("loop")
    table.add_column("actions/s", justify="right")
    table.add_column("µs/action", justify="right")
    table.add_row("world step (checks, physics, contacts, observation)",
                  f"{result.actions_per_s:,.0f}", f"{1e6 / result.actions_per_s:,.0f}")
    table.add_row("raw pymunk (physics only)", f"{result.raw_actions_per_s:,.0f}",
                  f"{1e6 / result.raw_actions_per_s:,.0f}")
    console = Console()
    console.print(table)
    console.print(f"overhead ratio (raw ÷ ours): {result.overhead_ratio:.2f}; "
                  f"reset {1e3 * result.reset_seconds / result.episodes:.2f} ms; "
                  f"same trajectory as raw: {result.same_trajectory}")


@app.command("train")
def train(
    iterations: Annotated[int, typer.Option("--iterations", "-n", min=1,
                                            help="Iterations of the session.")] = 4000,
    seed: Annotated[int, typer.Option("--seed", help="Seed of the session.")] = 0,
    block: Annotated[int, typer.Option("--block", min=1, help="Report every N iterations.")] = 500,
    store: Annotated[bool, typer.Option("--store/--no-store", help="Also write every episode "
                                        "and checkpoint to a temporary SQLite store.")] = False,
    config: ConfigOption = None,
    set_: SetOption = None,
    json_: JsonOption = False,
) -> None:
    """Wall time and iterations per second of a learning session (evaluation off)."""
    from hadim_cli.bench_train import bench_train

    cfg = load_config(config, set_ or [])
    result = bench_train(cfg, iterations, seed, block, with_store=store)
    if json_:
        _echo(result.to_dict())
        return
    from rich.console import Console
    from rich.table import Table

    table = Table(title=f"train: {result.iterations} iterations, seed {seed}, "
                  f"store {'on' if store else 'off'}")
    for col in ("iterations", "seconds", "iterations/s", "affordances", "store MB", "RSS MB"):
        table.add_column(col, justify="right")
    for b in result.blocks:
        table.add_row(f"{b['start']}–{b['stop']}", f"{b['seconds']:.2f}",
                      f"{b['iterations_per_s']:.1f}", str(b["affordances"]),
                      f"{b['store_bytes'] / 1e6:.1f}" if store else "–",
                      f"{b['rss_bytes'] / 1e6:.0f}")
    console = Console()
    console.print(table)
    extra = (f"; store {result.store_s:.2f} s, {result.store_bytes / 1e6:.1f} MB"
             if store else "")
    console.print(f"total {result.wall_s:.1f} s, {result.iterations_per_s:.1f} iterations/s"
                  f"{extra}")


@app.command("eval")
def eval_(
    run: Annotated[str, typer.Argument(help="A learner run of the store, e.g. run-1.")],
    task: Annotated[list[str] | None, typer.Option(
        "--task", help="A task of configs/tasks/ (repeatable; default: the run's evaluation "
        "tasks).")] = None,
    at: Annotated[int | None, typer.Option("--at", min=0, help="Use the checkpoint at or "
                                           "before this iteration (default: latest).")] = None,
    store: StoreOption = None,
    json_: JsonOption = False,
) -> None:
    """Wall and CPU time of evaluating a run's learner on each task (nothing stored)."""
    from hadim_cli import runs
    from hadim_cli.errors import HadimError
    from hadim_cli.evaluation.tasks import load_task

    for name in task or ():
        load_task(name)  # an unknown task is refused before the learner is restored
    with runs.open_reader(store, run=run) as st:  # sqlite3 alone when the file is sound
        record = st.get_run(run)
        if record.config.get("kind") == "baseline":
            raise HadimError(f"run {run} is a baseline run: bench eval times the learner's "
                             "planner")
        if at is not None and at > record.iterations:
            raise HadimError(f"--at {at} is beyond run {run}'s {record.iterations} iterations")
        session = runs.restore_session(st, record, at)
    from hadim_cli.bench_eval import bench_eval  # the learner's session: after the refusals

    tasks = tuple(task) if task else session.config.evaluation.tasks
    result = bench_eval(session, run, tasks)
    if json_:
        _echo(result.to_dict())
        return
    from rich.console import Console
    from rich.table import Table

    table = Table(title=f"eval: {run} at iteration {result.iteration}, "
                  f"{result.affordances} affordances")
    for col in ("task", "score", "points", "actions", "seconds", "CPU s", "CPU ms/action"):
        table.add_column(col, justify="right")
    for t in result.tasks:
        table.add_row(t.task, f"{t.score:.3f}", str(t.points), str(t.actions),
                      f"{t.seconds:.2f}", f"{t.cpu_seconds:.2f}",
                      f"{1e3 * t.cpu_seconds / max(t.actions, 1):.1f}")
    console = Console()
    console.print(table)
    console.print(f"total {result.seconds:.2f} s, {result.cpu_seconds:.2f} CPU s, "
                  f"{result.ms_per_action:.1f} CPU ms per action")


@app.command("env")
def env(
    steps: Annotated[int, typer.Option("--steps", "-n", min=1,
                                       help="Random actions per variant.")] = 2000,
    seed: Annotated[int, typer.Option("--seed", help="Seed of starts and actions.")] = 0,
    json_: JsonOption = False,
) -> None:
    """Steps per second of each goal environment (baselines) against `World.step` alone."""
    from hadim_cli.baselines.bench import bench_env
    from hadim_cli.baselines.tasks import TASKS

    results = [bench_env(task, reward, "discrete", steps, seed)
               for task in TASKS for reward in ("sparse", "guided")]
    if json_:
        _echo([r.to_dict() for r in results])
        return
    from rich.console import Console
    from rich.table import Table

    table = Table(title=f"goal environments: {steps} random discrete actions, seed {seed}")
    for col in ("task", "reward", "env steps/s", "World.step/s", "overhead"):
        table.add_column(col, justify="right")
    for r in results:
        table.add_row(r.task, r.reward, f"{r.env_steps_per_s:,.0f}",
                      f"{r.world_steps_per_s:,.0f}", f"{100 * r.overhead:+.0f} %")
    Console().print(table)


@app.command("baseline")
def baseline(
    algo: Annotated[str, typer.Option("--algo", help="q-learning, dqn, a2c or curious.")],
    task: Annotated[str, typer.Option("--task", help="A task of the comparison.")] = "push-object",
    reward: Annotated[str, typer.Option("--reward", help="sparse or guided.")] = "sparse",
    iterations: Annotated[int, typer.Option("--iterations", "-n", min=20,
                                            help="Iterations (a multiple of 20).")] = 3000,
    seed: Annotated[int, typer.Option("--seed", help="Seed of the run.")] = 0,
    actions: Annotated[str, typer.Option("--actions", help="discrete or continuous (a2c).")
                       ] = "discrete",
    n_envs: Annotated[int, typer.Option("--n-envs", min=1, help="Environments stepped "
                                        "together (dqn, a2c).")] = 1,
    json_: JsonOption = False,
) -> None:
    """Iterations per second of a baseline's training (no store, no evaluation)."""
    import time

    import torch

    from hadim_cli.baselines import runs as baseline_runs
    from hadim_cli.baselines.config import check_total, make_config
    from hadim_cli.config import WorldConfig

    torch.set_num_threads(1)
    cfg = make_config(algo, task, reward, actions, iterations, 0, WorldConfig(), n_envs=n_envs)
    check_total(iterations, cfg.multiple)
    session = baseline_runs.BaselineSession(cfg, seed)
    start, cpu = time.perf_counter(), time.process_time()
    baseline_runs.train(None, None, session, iterations)
    wall = time.perf_counter() - start
    cpu = time.process_time() - cpu  # what a loaded machine does not inflate
    result = {"algorithm": algo, "task": task, "reward": reward, "actions": actions,
              "n_envs": n_envs, "iterations": iterations, "seconds": wall,
              "iterations_per_s": iterations / wall, "cpu_seconds": cpu,
              "iterations_per_cpu_s": iterations / cpu}
    if json_:
        _echo(result)
        return
    typer.echo(f"{algo} {reward} {task} ({actions}, {n_envs} env): {iterations} iterations "
               f"in {wall:.1f} s, {iterations / wall:,.0f} iterations/s; "
               f"{iterations / cpu:,.0f} per CPU-second")
