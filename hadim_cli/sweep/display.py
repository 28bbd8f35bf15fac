"""The sweep's rich progress display (stderr, on a terminal) and its final summary (stdout)."""

from __future__ import annotations

import typer

from hadim_cli.sweep.driver import SweepOutcome, SweepStatus
from hadim_cli.sweep.plan import SweepPlan


class SweepDisplay:
    """One bar for the whole sweep: iterations, and runs done / running / failed / pending."""

    def __init__(self, name: str) -> None:
        from rich.console import Console
        from rich.progress import (
            BarColumn,
            MofNCompleteColumn,
            Progress,
            TextColumn,
            TimeElapsedColumn,
        )

        console = Console(stderr=True)
        self._progress = Progress(
            TextColumn("[bold]{task.fields[sweep]}"), BarColumn(), MofNCompleteColumn(),
            TextColumn("{task.fields[runs]}"), TimeElapsedColumn(), console=console,
            disable=not console.is_terminal,
        )
        self._task = self._progress.add_task("sweep", total=None, sweep=name, runs="")

    def __enter__(self) -> SweepDisplay:
        self._progress.__enter__()
        return self

    def __exit__(self, *exc_info: object) -> None:
        self._progress.__exit__(*exc_info)

    def update(self, status: SweepStatus) -> None:
        runs = (f"runs: {status.done} done, {status.running} running, {status.failed} failed, "
                f"{status.pending} pending")
        self._progress.update(self._task, completed=status.iterations, total=status.total,
                              runs=runs)


def print_summary(store, plan: SweepPlan, outcome: SweepOutcome) -> None:
    """One line per run on stdout (run, status, iterations); why runs failed, and how to go on,
    on stderr."""
    stored = {r.name: r for r in store.list_runs()}
    for entry in plan.entries:
        record = stored.get(entry.run)
        status = record.status if record else "not started"
        iterations = record.iterations if record else 0
        typer.echo(f"{entry.run}\t{status}\t{iterations}/{entry.iterations}")
    for run, message in outcome.errors.items():
        typer.echo(f"run {run} failed: {message}", err=True)
    if outcome.stopped or outcome.aborted:
        typer.echo(f"{'aborted' if outcome.aborted else 'stopped'}: every run is paused at its "
                   f"last stored episode; run the same hadim sweep command again to continue",
                   err=True)
