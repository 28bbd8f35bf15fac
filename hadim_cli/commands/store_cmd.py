"""`hadim store check`: is a store file sound, and which of its runs can still be read?"""

from __future__ import annotations

from pathlib import Path

import typer

from hadim_cli.commands.common import StoreOption
from hadim_cli.errors import HadimError

app = typer.Typer(help="Check a store file.", no_args_is_help=True)


@app.command("check")
def check(store: StoreOption = None) -> None:
    """SQLite's integrity check of the store file, then every run read back (D, timeline,
    latest checkpoint). Exit 0 if all is sound, 1 if anything is damaged; writes nothing."""
    from hadim_cli import runs
    from store import engine

    where = runs.store_location(store)
    if "://" in where:
        raise HadimError("hadim store check reads SQLite files only; check a database server "
                         "with its own tools")
    path = Path(where)
    if not path.is_file():
        raise HadimError(f"no store at {where}")
    engine.check_sqlite_file(path, create=False)
    problems = engine.quick_check(path, full=True)
    typer.echo(f"{where}: " + ("integrity_check ok" if not problems else
                               f"integrity_check found {len(problems)} problem(s):"))
    for line in problems:
        typer.echo(f"  {line}")
    unreadable = _check_runs(where)
    if problems or unreadable:
        typer.echo("damaged: copy out what can be read (docs/store.md, 'A damaged store'); "
                   "hadim refuses to write into this file")
        raise typer.Exit(1)


def _check_runs(where: str) -> int:
    """Read every run back; print one line per run; the number that fail."""
    from store.api import Store

    failed = 0
    try:
        st = Store.open(where, create=False)
    except Exception as exc:  # noqa: BLE001 — the report is the point: say why, do not raise
        typer.echo(f"  the run table cannot be read: {_reason(exc)}")
        return 1
    with st:
        try:
            names = [r.name for r in st.list_runs()]
        except Exception as exc:  # noqa: BLE001
            typer.echo(f"  the run table cannot be read: {_reason(exc)}")
            return 1
        for name in names:
            try:
                record = st.get_run(name)
                st.dataset_sha256(name)
                st.events(name)
                st.evaluations(name)
                iterations = st.checkpoint_iterations(name)
            except Exception as exc:  # noqa: BLE001
                failed += 1
                typer.echo(f"  {name}: DAMAGED ({_reason(exc)})")
                continue
            bad = _damaged_checkpoints(st, name, iterations)
            failed += bool(bad)
            typer.echo(f"  {name}: {'DAMAGED' if bad else 'readable'} ({record.iterations} "
                       f"iterations, {len(iterations)} checkpoints"
                       + (f"; unreadable at {', '.join(map(str, bad))}" if bad else "") + ")")
    return failed


def _damaged_checkpoints(st, name: str, iterations: list[int]) -> list[int]:
    bad = []
    for it in iterations:
        try:
            st.checkpoint(name, it)
        except Exception:  # noqa: BLE001
            bad.append(it)
    return bad


def _reason(exc: BaseException) -> str:
    return str(getattr(exc, "orig", None) or exc).splitlines()[0]
