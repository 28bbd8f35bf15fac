"""The `hadim` command line: a typer root joining one module per command group.

Command modules import nothing heavy at module level (torch, pymunk, sqlalchemy, matplotlib
are imported inside the commands), so `hadim --help` is instant.
"""

from __future__ import annotations

import sys
from typing import Any

import typer
from typer.core import TyperGroup

from hadim_cli.commands import (
    bench,
    config_cmd,
    inspect,
    report_cmd,
    sweep_cmd,
    training,
    world,
)
from hadim_cli.errors import HadimError
from store.errors import StoreError


class HadimGroup(TyperGroup):
    """Root group: a user's mistake becomes one line on stderr and a non-zero exit."""

    def invoke(self, ctx: typer.Context) -> Any:
        try:
            return super().invoke(ctx)
        except HadimError as exc:
            typer.echo(f"error: {exc}", err=True)
            ctx.exit(exc.exit_code)
        except typer.BadParameter as exc:
            # An impossible value (`--iterations -5`, `--seed x`): one line, like a bad config
            # value; other usage errors (an unknown option) still print the usage first.
            typer.echo(f"error: {exc.format_message()}", err=True)
            ctx.exit(2)
        except StoreError as exc:
            # The store is a separate package; its errors are a user's (bad file, unknown run).
            typer.echo(f"error: {exc}", err=True)
            ctx.exit(2)


app = typer.Typer(
    cls=HadimGroup,
    name="hadim",
    help="Hierarchical affordance discovery using intrinsic motivation: train, resume, fork, "
    "query and evaluate lifelong-learning sessions of a simulated mobile robot.",
    no_args_is_help=True,
    pretty_exceptions_enable=False,
    add_completion=False,
)
app.registered_commands += training.app.registered_commands
app.registered_commands += inspect.app.registered_commands
app.registered_commands += sweep_cmd.app.registered_commands
app.registered_commands += report_cmd.app.registered_commands
app.add_typer(inspect.runs_app, name="runs")
app.add_typer(config_cmd.app, name="config")
app.add_typer(world.app, name="world")
app.add_typer(bench.app, name="bench")


def main(argv: list[str] | None = None) -> None:
    app(args=argv if argv is not None else sys.argv[1:], prog_name="hadim")


if __name__ == "__main__":
    main()
