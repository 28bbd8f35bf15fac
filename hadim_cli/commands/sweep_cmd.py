"""`hadim sweep`: a grid of runs (configs × grid overrides × seeds) as Ray tasks into one store."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from hadim_cli.commands.common import SetOption, StoreOption
from hadim_cli.errors import HadimError

app = typer.Typer()


def _shared_store(option: str | None) -> str:
    """The store as every worker must reach it: an absolute file path, or a server URL."""
    from hadim_cli import runs
    from store.engine import resolve_url, sqlite_file

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
        "--eval-every", min=0, help="Evaluate every N iterations (default: evaluation.every).")
    ] = None,
    address: Annotated[str | None, typer.Option(
        help="A running Ray cluster (e.g. ray://head:10001 or auto); default: a local "
        "instance on this machine's cores.")] = None,
    num_cpus: Annotated[int | None, typer.Option(
        "--num-cpus", min=1, help="Cores of the local Ray instance (default: all).")] = None,
    store: StoreOption = None,
) -> None:
    """Run every (config, grid value, seed) as a run of the store, in parallel on Ray.

    Re-running the same command resumes unfinished runs and skips finished ones. Ctrl-C
    stops every run after its current episode (checkpointed); a second Ctrl-C aborts."""
    from hadim_cli.sweep import driver
    from hadim_cli.sweep import plan as plans
    from hadim_cli.sweep.display import SweepDisplay, print_summary

    if address and num_cpus:
        raise HadimError("--num-cpus sizes a local Ray instance; a cluster (--address) has "
                         "its own")
    built = plans.build_plan(name, configs=config or [], grid=grid or [], sets=set_ or [],
                             seeds=seeds, iterations=iterations, eval_every=eval_every)
    url = _shared_store(store)
    try:
        import ray  # noqa: F401
    except ImportError:
        raise HadimError("hadim sweep needs Ray: pip install 'hadim[sweep]'") from None
    from store.api import Store

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
