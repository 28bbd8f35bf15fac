"""`hadim baseline train`: the paper's reinforcement-learning comparison (§5.3) as runs."""

from __future__ import annotations

from typing import Annotated

import typer

from hadim_cli.commands import driver
from hadim_cli.commands.common import StoreOption
from hadim_cli.errors import HadimError

app = typer.Typer(help="Reinforcement-learning baselines (paper §5.3): Q-learning, DQN, A2C, "
                  "CURIOUS.", no_args_is_help=True)


def _threads() -> None:
    import torch

    torch.set_num_threads(1)  # 2 shared cores: seeds run as parallel processes instead


@app.command("train")
def train(
    algo: Annotated[str, typer.Option("--algo", help="q-learning, dqn, a2c or curious.")],
    task: Annotated[str, typer.Option("--task", help="move-robot, push-object or "
                                      "push-with-tool (the rover); reach, arm-push or "
                                      "arm-push-with-tool (the arm).")],
    reward: Annotated[str, typer.Option("--reward", help="sparse or guided (curious: "
                                        "sparse).")] = "sparse",
    actions: Annotated[str, typer.Option("--actions", help="discrete (the paper's 4) or "
                                         "continuous (a2c only).")] = "discrete",
    iterations: Annotated[int, typer.Option("--iterations", "-n", min=20, help="Total "
                                            "iterations (a multiple of 20 × --n-envs).")] = 50_000,
    seed: Annotated[int, typer.Option(help="Seed of the run's root generator.")] = 0,
    eval_every: Annotated[int, typer.Option("--eval-every", min=0, help="Evaluate on the "
                                            "task every N iterations (0 off).")] = 1000,
    horizon: Annotated[int | None, typer.Option("--horizon", min=1, help="Iterations the "
                                                "exploration schedule spans (default: "
                                                "--iterations).")] = None,
    episode_length: Annotated[int, typer.Option("--episode-length", min=1, help="Actions "
                                                "before an episode is cut.")] = 1000,
    checkpoint_every: Annotated[int | None, typer.Option(
        "--checkpoint-every", min=20, help="Iterations between checkpoints (a multiple of 20; "
        "default: --eval-every, else 1000).")] = None,
    n_envs: Annotated[int, typer.Option(
        "--n-envs", min=1, help="Environments stepped together (dqn, a2c); iterations count "
        "all of their steps.")] = 1,
    name: Annotated[str | None, typer.Option(help="Run name (default run-N).")] = None,
    store: StoreOption = None,
) -> None:
    """Train a baseline on one task and store it as a run; prints the run's name."""
    from hadim_cli import runs
    from hadim_cli.baselines.config import check_total, make_config, task_world

    cfg = make_config(algo, task, reward, actions, horizon or iterations, eval_every,
                      task_world(task), episode_length, checkpoint_every, n_envs)
    check_total(iterations, cfg.multiple)
    runs.refuse_new_run(store, name)
    from hadim_cli.baselines import runs as baseline_runs  # torch: after every refusal

    with runs.open_store(store) as st:
        record = baseline_runs.new_run(st, cfg, seed, name)
        typer.echo(record.name)
        _threads()
        session = baseline_runs.BaselineSession(cfg, seed)
        driver.drive(st, record.name, session, iterations, eval_every, store,
                     baseline_runs.train, (cfg.task,))


def baseline_plan(st, record, iterations: int | None, eval_every: int | None,
                  store_option: str | None) -> tuple[int, int]:
    """The total and evaluation period a baseline run is resumed with, after every refusal
    that needs no agent: a total or `--eval-every` its agent's steps do not divide, the run
    already there, a run another live process drives."""
    from hadim_cli import runs
    from hadim_cli.baselines.config import check_total, read_config
    from hadim_store.records import RunStatus

    cfg = read_config(record.config)
    finished = record.status is RunStatus.FINISHED
    default = record.iterations if finished else max(cfg.horizon, record.iterations)
    total = iterations or runs.target_iterations(st, record, default)
    multiple = cfg.multiple
    check_total(total, multiple)
    every = cfg.eval_every if eval_every is None else eval_every
    if every % multiple:
        raise HadimError(f"--eval-every must be a multiple of {multiple}, got {every}")
    driver.refuse_reached(record.name, record.iterations, total, iterations is not None,
                          store_option)
    st.refuse_if_locked(record.name)
    return total, every


def resume_baseline(st, record, iterations: int | None, eval_every: int | None,
                    store_option: str | None) -> None:
    """`hadim resume` on a baseline run: every refusal before the agent is restored."""
    from hadim_cli.baselines import runs as baseline_runs
    from hadim_cli.baselines.config import read_config

    total, every = baseline_plan(st, record, iterations, eval_every, store_option)
    _threads()
    session = baseline_runs.restore(st, record)
    driver.drive(st, record.name, session, total, every, store_option,
                 baseline_runs.train, (read_config(record.config).task,))


@app.command("diagnose")
def diagnose(
    run: Annotated[str, typer.Argument(help="A baseline run.")],
    block: Annotated[int, typer.Option("--block", min=1, help="Iterations per row of the "
                                       "training table.")] = 10_000,
    store: StoreOption = None,
    as_json: Annotated[bool, typer.Option("--json", help="Print JSON.")] = False,
) -> None:
    """Why a baseline does (not) learn: training episodes and returns, the goal zone reached
    in training, exploration coverage, the scale of its values (docs/baselines.md)."""
    import json

    from hadim_cli import runs
    from hadim_cli.baselines.diagnose import diagnose as measure

    with runs.open_reader(store, run=run) as st:  # sqlite3 alone when the file is sound
        if runs.run_kind(st.get_run(run)) is not runs.RunKind.BASELINE:
            raise HadimError(f"run {run} is a learner run: diagnose is for baseline runs")
        _threads()
        found = measure(st, run, block)
    if as_json:
        typer.echo(json.dumps(found, indent=1))
        return
    typer.echo(f"{run} at {found['iterations']}: blocks of {block} iterations")
    typer.echo("  start  episodes  reached  mean return  mean length  robot cells  goal-entity "
               "cells")
    for b in found["blocks"]:
        typer.echo(f"{b['start']:>7} {b['episodes']:>9} {b['reached']:>8} "
                   f"{b['mean_return']:>12.0f} {b['mean_length']:>12.0f} "
                   f"{b['robot_coverage']:>11.0%} {b['goal_entity_coverage']:>12.0%}")
    v = found["value_scale"]
    if v is not None:
        typer.echo(f"values on {v['states']} stored states: greedy mean {v['greedy_mean']:.3g} "
                   f"(min {v['greedy_min']:.3g}, max {v['greedy_max']:.3g}); between the "
                   f"actions {v['action_gap']:.3g}; the returns it got from them "
                   f"{v['return_mean']:.3g}; possible {v['possible'][0]:.3g} … "
                   f"{v['possible'][1]:.3g}")
    if "table_states" in found:
        typer.echo(f"table: {found['table_states']} states visited")
