"""`hadim sweep`: a grid of runs (configs × grid overrides × seeds) as Ray tasks into one store."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from hadim_cli.commands.common import SetOption, StoreOption
from hadim_cli.errors import HadimError

app = typer.Typer()
ALL_TASKS = "move-robot,push-object,push-with-tool"


def _shared_store(option: str | None) -> str:
    """The store as every worker must reach it: an absolute file path, or a server URL."""
    from hadim_cli import runs
    from hadim_store.engine import resolve_url, sqlite_file

    where = runs.store_location(option)
    url = resolve_url(where)
    if url.get_backend_name() == "sqlite":
        path = sqlite_file(url)
        if path is None:
            raise HadimError("a sweep needs a store its workers can reach: a file or a "
                             "database server, not an in-memory database")
        return str(path.resolve())
    return where


@app.command()
def sweep(
    name: Annotated[str, typer.Argument(help="Sweep name; its runs are NAME-CONFIG-sSEED.")],
    seeds: Annotated[str, typer.Option(help="Seeds: 0-9, 0,3,7 or a mix.")] = "0",
    config: Annotated[list[Path] | None, typer.Option(
        "--config", "-c", help="A config file (repeatable); each is one config of the grid.")
    ] = None,
    grid: Annotated[list[str] | None, typer.Option(
        help="section.key=v1,v2,... : one config per value (repeatable: the product).")] = None,
    set_: SetOption = None,
    iterations: Annotated[int, typer.Option("--iterations", "-n", min=1,
                                            help="Iterations of every run.")] = 4000,
    eval_every: Annotated[int | None, typer.Option(
        "--eval-every", min=0, help="Evaluate every N iterations (default: evaluation.every; "
        "baselines: 1000).")
    ] = None,
    address: Annotated[str | None, typer.Option(
        help="A running Ray cluster (e.g. ray://head:10001 or auto); default: a local "
        "instance on this machine's cores.")] = None,
    num_cpus: Annotated[int | None, typer.Option(
        "--num-cpus", min=1, help="Cores of the local Ray instance (default: all).")] = None,
    algo: Annotated[str | None, typer.Option(
        "--algo", help="RL baselines to run too: q-learning,dqn,a2c,curious (comma-separated); "
        "without -c the sweep holds the baselines only.")] = None,
    task: Annotated[str, typer.Option(
        "--task", help="Baselines' tasks (comma-separated).")] = ALL_TASKS,
    reward: Annotated[str, typer.Option(
        "--reward", help="Baselines' rewards (comma-separated; curious: sparse only).")
    ] = "sparse,guided",
    actions: Annotated[str, typer.Option(
        "--actions", help="Baselines' actions: discrete, continuous (a2c only) or both.")
    ] = "discrete",
    store: StoreOption = None,
) -> None:
    """Run a grid of sessions (configs × grid values × seeds, or RL baselines) on Ray.

    Every (config, grid value, seed) — and with --algo every (algorithm, task, reward, seed)
    of the RL baselines — is a run of the store, run in parallel on Ray.

    Re-running the same command resumes unfinished runs and skips finished ones. Ctrl-C
    stops every run after its current episode (checkpointed); a second Ctrl-C aborts."""
    from hadim_cli.sweep import driver
    from hadim_cli.sweep import plan as plans
    from hadim_cli.sweep.display import SweepDisplay, print_summary

    if address and num_cpus:
        raise HadimError("--num-cpus sizes a local Ray instance; a cluster (--address) has "
                         "its own")
    baselines = None if algo is None else plans.BaselineGrid(
        plans.parse_list(algo, "algo"), plans.parse_list(task, "task"),
        plans.parse_list(reward, "reward"), plans.parse_list(actions, "actions"))
    built = plans.build_plan(name, configs=config or [], grid=grid or [], sets=set_ or [],
                             seeds=seeds, iterations=iterations, eval_every=eval_every,
                             baselines=baselines)
    for line in built.left_out:
        typer.echo(f"left out: {line}", err=True)
    url = _shared_store(store)
    try:
        import ray  # noqa: F401
    except ImportError:
        raise HadimError("hadim sweep needs Ray: pip install 'hadim[sweep]'") from None
    if address:
        driver.check_address(address)  # before the store: a refused sweep creates nothing
    from hadim_store.api import Store

    with Store.open(url) as st:
        st.claim_sweep(name, built.settings())
        todo = driver.unfinished(st, built)
        outcome = driver.SweepOutcome()
        if todo:
            driver.start_ray(address, num_cpus)
            try:
                with SweepDisplay(name) as display:
                    outcome = driver.run_sweep(st, url, built, todo, display.update)
            finally:
                import ray

                ray.shutdown()
        print_summary(st, built, outcome)
    if outcome.aborted:
        raise typer.Exit(130)
    if outcome.errors:
        raise typer.Exit(1)
