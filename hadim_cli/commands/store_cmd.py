"""`hadim store check`: is a store file sound, and which of its runs can still be read?
`hadim store upgrade`: bring a store to this hadim's schema (alembic revisions)."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from hadim_cli.commands.common import StoreOption
from hadim_cli.errors import HadimError
from hadim_store.errors import DamagedStore

app = typer.Typer(help="Check a store file; upgrade a store's schema.", no_args_is_help=True)


@app.command("check")
def check(store: StoreOption = None) -> None:
    """SQLite's integrity check of the store file, then every run read back (D, timeline,
    latest checkpoint). Exit 0 if all is sound, 1 if anything is damaged; writes nothing."""
    from hadim_cli import runs
    from hadim_store import engine

    where = runs.store_location(store)
    if "://" in where:
        raise HadimError("hadim store check reads SQLite files only; check a database server "
                         "with its own tools")
    path = Path(where)
    if path.is_dir():
        raise HadimError(f"{where} is a directory, not a store file")
    if not path.is_file():
        raise HadimError(f"no store at {where}")
    try:
        engine.check_sqlite_file(path, create=False)
        schema_read = True
    except DamagedStore:  # damaged where the schema is read: say what SQLite finds, as below
        schema_read = False
    problems = engine.quick_check(path, full=True)
    typer.echo(f"{where}: " + ("integrity_check ok" if not problems else
                               f"integrity_check found {len(problems)} problem(s):"))
    for line in problems:
        typer.echo(f"  {line}")
    if schema_read:
        unreadable = _check_runs(where)
    else:
        typer.echo("  runs not read: the store's schema cannot be read")
        unreadable = 1
    if problems or unreadable:
        typer.echo("damaged: copy out what can be read (docs/store.md, 'A damaged store'); "
                   "hadim refuses to write into this file")
        raise typer.Exit(1)


@app.command("upgrade")
def upgrade(
    store: StoreOption = None,
    dry_run: Annotated[bool, typer.Option(
        "--dry-run", help="Say which revisions would be applied; write nothing.")] = False,
) -> None:
    """Bring the store to this hadim's schema: every pending revision, including those that
    opening a store does not apply (docs/store.md), in one transaction: a failure leaves the
    store as it was. A store newer than this hadim is refused, unchanged."""
    from hadim_cli import runs
    from hadim_store.api import upgrade_store

    where = runs.store_location(store)
    if "://" not in where and not Path(where).is_file():
        raise HadimError(f"no store at {where}")
    runs.opened[:] = [where]
    report = upgrade_store(where, dry_run=dry_run)
    if not report.changed:
        typer.echo(f"{report.where}: schema version {report.to_version}, up to date")
        return
    moved = (f"{report.from_version} -> {report.to_version}" if report.revisions
             else str(report.to_version))
    typer.echo(f"{report.where}: schema version {moved}"
               + (" (dry run: nothing written)" if dry_run else ""))
    for revision in report.revisions:
        typer.echo(f"  {revision.revision} {revision.title}")
    if report.stamped:
        typer.echo(f"  alembic's version table {'would be' if dry_run else 'was'} added (the "
                   "store was written by a hadim from before alembic)")


def _check_runs(where: str) -> int:
    """Read every run back; print one line per run; the number that fail."""
    from hadim_store.api import Store
    from hadim_store.errors import SchemaError

    failed = 0
    try:
        st = Store.open(where, create=False, upgrade=False)  # check writes nothing
    except SchemaError as exc:  # an older schema: not damage, but not read by this hadim
        typer.echo(f"  runs not read: {exc}")
        return 0
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
                st.stats(name)
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
    from hadim_cli.runs import short_reason

    return short_reason(exc, limit=120)
