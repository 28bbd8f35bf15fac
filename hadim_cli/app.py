"""The `hadim` command line: a typer root joining one module per command group.

Command modules import nothing heavy at module level (torch, pymunk, sqlalchemy, matplotlib
are imported inside the commands), so `hadim --help` is instant.
"""

from __future__ import annotations

import sys
import traceback
from pathlib import Path
from types import SimpleNamespace
from typing import Annotated, Any

import typer
from typer.core import TyperGroup

from hadim_cli.commands import (
    baseline,
    bench,
    config_cmd,
    inspect,
    report_cmd,
    store_cmd,
    sweep_cmd,
    training,
    world,
)
from hadim_cli.errors import HadimError
from hadim_store.errors import StoreError

_METAVARS = {"<bool>": "", "<int>": "N", "<int range>": "N", "<float>": "X", "<path>": "FILE"}


def _plain_metavars(command: Any) -> None:
    """Name every parameter's value in --help as a reader would (`N`, `FILE`, `TEXT`, `RUN`),
    not by its Python annotation (`<int range>`, `<list[str]>`, `<bool>` for a flag)."""
    help_option = command.get_help_option(SimpleNamespace(help_option_names=["--help"]))
    for param in [*command.params, *([help_option] if help_option is not None else [])]:
        if param.metavar is not None or not hasattr(param, "display_type"):
            continue
        if param.param_type_name == "argument":
            param.metavar = param.name.upper()
        else:
            param.metavar = _METAVARS.get(param.display_type(None), "TEXT")
    for sub in getattr(command, "commands", {}).values():
        _plain_metavars(sub)


class HadimGroup(TyperGroup):
    """Root group: a user's mistake becomes one line on stderr and a non-zero exit."""

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        _plain_metavars(self)

    def main(self, args: Any = None, prog_name: str | None = None,
             complete_var: str | None = None, standalone_mode: bool = True,
             **extra: Any) -> Any:
        """click's standalone mode, but a usage error (an unknown command or option, a value
        that does not parse) is one `error:` line and exit status 2, not a boxed usage."""
        click = _click_exceptions()
        if not standalone_mode:
            return super().main(args, prog_name, complete_var, standalone_mode=False, **extra)
        try:
            code = super().main(args, prog_name, complete_var, standalone_mode=False, **extra)
        except click.UsageError as exc:
            message = " ".join(exc.format_message().split())
            if message:  # empty: a group called alone, whose help is already printed
                where = f" (see `{exc.ctx.command_path} --help`)" if exc.ctx else ""
                typer.echo(f"error: {message}{where}", err=True)
            sys.exit(2)
        except click.ClickException as exc:
            typer.echo(f"error: {' '.join(exc.format_message().split())}", err=True)
            sys.exit(exc.exit_code)
        except _abort():
            typer.echo("aborted", err=True)
            sys.exit(1)
        sys.exit(code if isinstance(code, int) else 0)

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
            if not _is_damage(exc):
                # The store is a separate package; its errors are a user's (bad file, unknown
                # run, a run in use).
                typer.echo(f"error: {exc}", err=True)
                ctx.exit(2)
            _say_damaged(exc)
            ctx.exit(2)
        except Exception as exc:
            if not _is_damage(exc):
                raise
            _say_damaged(exc)
            ctx.exit(2)


def _click_exceptions():
    """click's exceptions as typer raises them: its own copy of click since typer 0.2x."""
    try:
        from typer._click import exceptions
    except ImportError:  # an older typer, on click itself
        from click import exceptions
    return exceptions


def _abort() -> type[BaseException]:
    """The exception click raises when a user aborts (typer's own copy keeps it beside its
    other exceptions, in `typer.exceptions`)."""
    try:
        from typer.exceptions import Abort
    except ImportError:  # an older typer, on click itself
        from click.exceptions import Abort
    return Abort


def _say_damaged(exc: BaseException) -> None:
    """A store that cannot be read is not a bug of hadim: one line, the run named, no row
    content (a driver's message may quote the bytes it could not decode)."""
    from hadim_cli.runs import damage_line, reading, short_reason

    typer.echo(f"error: {damage_line(reading[0] if reading else None, short_reason(exc))}",
               err=True)


def _is_damage(exc: BaseException) -> bool:
    """A database driver's error, a stored value the store refuses to decode, or a value
    the store's code cannot make sense of: what damaged bytes look like when read."""
    from hadim_store.errors import CodecError

    if isinstance(exc, CodecError) or _is_database_error(exc):
        return True
    if not isinstance(exc, ValueError | TypeError | KeyError | IndexError):
        return False
    import hadim_store

    root = str(Path(hadim_store.__file__).resolve().parent)
    return any(f.filename.startswith(root) for f in traceback.extract_tb(exc.__traceback__))


def _is_database_error(exc: BaseException) -> bool:
    """A database driver's error, through SQLAlchemy or not, without importing either here."""
    sa_exc = sys.modules.get("sqlalchemy.exc")
    if sa_exc is not None and isinstance(exc, sa_exc.DBAPIError):
        return True
    sqlite3 = sys.modules.get("sqlite3")
    return sqlite3 is not None and isinstance(exc, sqlite3.DatabaseError)


app = typer.Typer(
    cls=HadimGroup,
    name="hadim",
    help="Hierarchical affordance discovery using intrinsic motivation: train, resume, fork, "
    "query and evaluate lifelong-learning sessions of a simulated mobile robot.",
    no_args_is_help=True,
    pretty_exceptions_enable=False,
    add_completion=False,
)


def _print_version(value: bool) -> None:
    if value:
        from importlib import metadata

        try:
            version = metadata.version("hadim")
        except metadata.PackageNotFoundError:  # a source checkout run without installing
            from hadim_cli import __version__ as version
        typer.echo(f"hadim {version}")
        raise typer.Exit()


@app.callback()
def _root(
    version: Annotated[bool, typer.Option("--version", callback=_print_version, is_eager=True,
                                          help="Print hadim's version and exit.")] = False,
) -> None:
    """Hierarchical affordance discovery using intrinsic motivation: train, resume, fork,
    query and evaluate lifelong-learning sessions of a simulated mobile robot."""


app.registered_commands += training.app.registered_commands
app.registered_commands += inspect.app.registered_commands
app.registered_commands += sweep_cmd.app.registered_commands
app.registered_commands += report_cmd.app.registered_commands
app.add_typer(inspect.runs_app, name="runs")
app.add_typer(config_cmd.app, name="config")
app.add_typer(world.app, name="world")
app.add_typer(bench.app, name="bench")
app.add_typer(baseline.app, name="baseline")
app.add_typer(store_cmd.app, name="store")


def main(argv: list[str] | None = None) -> None:
    app(args=argv if argv is not None else sys.argv[1:], prog_name="hadim")


if __name__ == "__main__":
    main()
