"""`hadim config`: show the resolved configuration with each key's documentation."""

from __future__ import annotations

import dataclasses
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
    from rich.table import Table

    table = Table(title="resolved configuration")
    table.add_column("key", no_wrap=True)
    table.add_column("value", overflow="fold", max_width=24)
    table.add_column("meaning", ratio=1)
    for key, value, meaning in config_rows(resolved):
        table.add_row(key, value, meaning)
    Console().print(table)


def config_rows(resolved: Config) -> list[tuple[str, str, str]]:
    """(key, value, meaning) of every key: the whole docstring, on one line."""
    rows = []
    for section in dataclasses.fields(Config):
        values = getattr(resolved, section.name)
        docs = field_docs(type(values))
        for f in dataclasses.fields(values):
            rows.append((f"{section.name}.{f.name}", repr(getattr(values, f.name)),
                         " ".join(docs.get(f.name, "").split())))
    return rows


@app.command("validate")
def validate(config: ConfigOption = None, set_: SetOption = None) -> None:
    """Check a configuration file and overrides; exit non-zero with the first problem."""
    load_config(config, set_ or [])
    typer.echo("ok")
