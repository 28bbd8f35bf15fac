"""`hadim config`: show the resolved configuration with each key's documentation."""

from __future__ import annotations

import dataclasses
import enum
import json

import typer

from hadim_cli.commands.common import ConfigOption, JsonOption, SetOption
from hadim_cli.config import Config, field_docs, load_config

app = typer.Typer(help="Inspect and validate configurations.", no_args_is_help=True)


@app.command("show")
def show(config: ConfigOption = None, set_: SetOption = None, as_json: JsonOption = False) -> None:
    """Print the resolved configuration (defaults, then --config, then --set)."""
    resolved = load_config(config, set_ or [])
    if as_json:
        typer.echo(json.dumps(resolved.to_dict(), indent=2))
        return
    from rich.console import Console
    from rich.markup import escape
    from rich.table import Table

    table = Table(title="resolved configuration")
    table.add_column("key", no_wrap=True)
    table.add_column("value", overflow="fold", max_width=24)
    table.add_column("meaning", ratio=1)
    for key, value, meaning in config_rows(resolved):
        table.add_row(escape(key), escape(value), escape(meaning))
    Console().print(table)


def config_rows(resolved: Config) -> list[tuple[str, str, str]]:
    """(key, value, meaning) of every key: the whole docstring, on one line; the keys of a
    table within a section (`world.arm`) follow it, each under its full name."""
    rows: list[tuple[str, str, str]] = []
    for section in dataclasses.fields(Config):
        _table_rows(getattr(resolved, section.name), section.name, rows)
    return rows


def _table_rows(values: object, prefix: str, rows: list[tuple[str, str, str]]) -> None:
    docs = field_docs(type(values))
    nested = []
    for f in dataclasses.fields(values):  # type: ignore[arg-type]
        value = getattr(values, f.name)
        if dataclasses.is_dataclass(value):
            nested.append((value, f"{prefix}.{f.name}"))
            shown = "(table below)"
        else:
            shown = repr(value.value if isinstance(value, enum.Enum) else value)
        rows.append((f"{prefix}.{f.name}", shown, " ".join(docs.get(f.name, "").split())))
    for value, name in nested:
        _table_rows(value, name, rows)


@app.command("validate")
def validate(config: ConfigOption = None, set_: SetOption = None) -> None:
    """Check a configuration file and overrides; exit non-zero with the first problem."""
    load_config(config, set_ or [])
    typer.echo("ok")
