"""`hadim report`: the tables and figures of docs/results.md from a store and a sweep."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from hadim_cli.commands.common import StoreOption

app = typer.Typer()


@app.command()
def report(
    sweep: Annotated[list[str], typer.Argument(help="The sweep(s) to report on, together "
                                               "(e.g. rl-grid-paper rl-grid-fixed "
                                               "rl-grid-learner).")],
    out: Annotated[Path, typer.Option("--out", "-o", help="Folder to write into.")],
    at: Annotated[list[int] | None, typer.Option(
        "--at", min=0, help="An iteration of the score table (repeatable; default: up to 5 "
        "spread over the evaluated ones).")] = None,
    store: StoreOption = None,
) -> None:
    """The tables and figures of docs/results.md from a sweep's runs; prints the files.

    Competence curves per config, affordance timelines, the per-seed H table with p_A, and
    summary.json."""
    from hadim_cli import runs
    from hadim_cli.report.write import write_report

    with runs.open_store(store, create=False) as st:
        for path in write_report(st, sweep, out, at):
            typer.echo(str(path))
