"""Opening a store: URL resolution, file checks done before anything is written, engine
set-up (WAL, busy timeout, foreign keys on SQLite) and schema creation or migration.
"""

from __future__ import annotations

import sqlite3
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import replace
from pathlib import Path

from sqlalchemy import Connection, Engine, create_engine, event, text
from sqlalchemy.engine import URL, make_url
from sqlalchemy.exc import ArgumentError, DBAPIError, NoSuchModuleError, OperationalError
from sqlalchemy.pool import StaticPool

from hadim_store import migrations, schema
from hadim_store.errors import DamagedStore, SchemaError, StoreError
from hadim_store.reader import SQLITE_HEADER, connect_readonly, quick_check

BUSY_TIMEOUT_S = 10.0
# Execution option read by the "begin" hook: write scopes take SQLite's write lock up front so
# that two writers queue on busy_timeout instead of failing on a stale read snapshot.
BEGIN_MODE_OPTION = "hadim_sqlite_begin"


def resolve_url(url: str | Path) -> URL:
    """A SQLAlchemy URL from a URL string or a plain file path (``:memory:`` for memory).

    ``postgresql://`` without a driver means psycopg 3, the driver hadim installs.
    """
    if isinstance(url, Path) or "://" not in url:
        path = str(url)
        return make_url("sqlite://" if path == ":memory:" else f"sqlite:///{path}")
    try:
        resolved = make_url(url)
    except ArgumentError as exc:
        raise StoreError(f"not a store URL or path: {url!r} ({exc})") from exc
    if resolved.drivername == "postgresql":
        resolved = resolved.set(drivername="postgresql+psycopg")
    return resolved


def is_sqlite(url: URL) -> bool:
    return url.get_backend_name() == "sqlite"


def sqlite_file(url: URL) -> Path | None:
    """The database file of a SQLite URL; None for in-memory or other backends."""
    if not is_sqlite(url) or url.database in (None, "", ":memory:"):
        return None
    return Path(url.database)


def check_sqlite_file(path: Path, *, create: bool) -> None:
    """Refuse, without writing anything, a file that is not an empty or hadim SQLite store."""
    if not path.exists():
        if not create:
            raise StoreError(f"no hadim store at {path}")
        if not path.parent.is_dir():
            raise StoreError(f"cannot create a store at {path}: {path.parent} is not a directory")
        return
    if path.is_dir():
        raise SchemaError(f"{path} is a directory, not a SQLite database")
    if path.stat().st_size == 0:
        if not create:
            raise StoreError(f"no hadim store at {path} (the file is empty)")
        return
    with path.open("rb") as handle:
        if handle.read(len(SQLITE_HEADER)) != SQLITE_HEADER:
            raise SchemaError(f"{path} is not a SQLite database")
    readonly = create_engine(
        "sqlite://", creator=lambda: connect_readonly(path), poolclass=StaticPool)
    try:
        with readonly.connect() as conn:
            version = schema.read_state(conn, str(path)).version
    except DBAPIError as exc:
        if getattr(exc.orig, "sqlite_errorcode", None) == sqlite3.SQLITE_CORRUPT:
            raise _damaged(path, str(exc.orig)) from exc  # a store's pages, not a foreign file
        raise SchemaError(f"{path} is a corrupt or unreadable SQLite database: {exc.orig}") from exc
    finally:
        readonly.dispose()
    if version is None and not create:
        raise StoreError(f"no hadim store at {path} (the database is empty)")


def require_intact(path: Path) -> None:
    """Refuse to write into a damaged store: writing would spread the damage."""
    problems = quick_check(path)
    if problems:
        # SQLite's report may span lines ("*** in database main ***\nOn tree page …"): one line.
        first = " ".join(problems[0].split())
        raise _damaged(path, f"{first}{' …' if len(problems) > 1 else ''}")


def _damaged(path: Path, finding: str) -> DamagedStore:
    """The refusal of a store SQLite finds damaged (its `finding`), before anything is written."""
    short = finding if len(finding) <= 60 else finding[:59] + "…"
    error = DamagedStore(f"the store is damaged ({short}); nothing was written: see `hadim "
                         f"store check --store {path}`")
    error.finding = finding
    return error


def make_engine(url: URL) -> Engine:
    """One engine for one store object; SQLite gets WAL, busy timeout and foreign keys."""
    if not is_sqlite(url):
        return _server_engine(url)
    in_memory = sqlite_file(url) is None
    if in_memory:
        # One shared connection, or each new connection would see its own empty database.
        engine = create_engine(url, poolclass=StaticPool, connect_args={"check_same_thread": False})
    else:
        engine = create_engine(url, connect_args={"timeout": BUSY_TIMEOUT_S})

    @event.listens_for(engine, "connect")
    def _on_connect(dbapi_connection, _record) -> None:
        # pysqlite's own implicit BEGIN is off; the "begin" hook below emits ours.
        dbapi_connection.isolation_level = None
        cursor = dbapi_connection.cursor()
        cursor.execute(f"PRAGMA busy_timeout = {int(BUSY_TIMEOUT_S * 1000)}")
        cursor.execute("PRAGMA foreign_keys = ON")
        if not in_memory:
            cursor.execute("PRAGMA journal_mode = WAL")
        cursor.close()

    @event.listens_for(engine, "begin")
    def _on_begin(conn: Connection) -> None:
        mode = conn.get_execution_options().get(BEGIN_MODE_OPTION, "DEFERRED")
        conn.exec_driver_sql(f"BEGIN {mode}")

    return engine


def prepare_schema(engine: Engine, where: str, *, create: bool, explicit: bool = False,
                   dry_run: bool = False, upgrade: bool = True) -> schema.Upgrade | None:
    """Create the tables in an empty database (None), or bring an older schema to this hadim's,
    in one transaction that a failure rolls back whole; a store already current is untouched.

    Opening applies only revisions marked ``automatic``; ``explicit`` (`hadim store upgrade`)
    applies them all. ``dry_run`` says what would be done and writes nothing. Without
    ``upgrade``, a store needing one is refused (one only lacking alembic's stamp is used)."""
    with _server_errors(engine, where), engine.connect() as conn, _schema_connection(conn):
        conn = conn.execution_options(**{BEGIN_MODE_OPTION: "IMMEDIATE"})
        with conn.begin() as transaction:
            if is_postgresql(engine.url):
                # Processes opening a new server store at once: one creates, the others wait.
                conn.execute(text("SELECT pg_advisory_xact_lock(:key)"), {"key": SCHEMA_LOCK_KEY})
            state = schema.read_state(conn, where)
            if state.version is None:
                if not create:
                    raise StoreError(f"no hadim store at {where}")
                schema.create(conn)
                return None
            report = schema.Upgrade(where, state.version, migrations.SCHEMA_VERSION, (),
                                    stamped=state.revision is None)
            if state.current or (not upgrade and state.version == migrations.SCHEMA_VERSION):
                return report
            if not upgrade:
                raise SchemaError(f"{where} has schema version {state.version} and this hadim "
                                  f"reads {migrations.SCHEMA_VERSION}: run `hadim store upgrade "
                                  f"--store {where}` first")
            report = replace(report, revisions=tuple(schema.plan(state)))
            _refuse_manual(report, explicit)
            if dry_run:
                transaction.rollback()
                return report
            path = sqlite_file(engine.url)
            if path is not None:
                require_intact(path)  # an upgrade would spread damage: refuse first
            schema.apply(conn, state, list(report.revisions), where)
            return report


def _refuse_manual(report: schema.Upgrade, explicit: bool) -> None:
    manual = [r for r in report.revisions if not r.automatic]
    if manual and not explicit:
        raise SchemaError(
            f"{report.where} has schema version {report.from_version} and this hadim uses "
            f"{report.to_version}; revision {manual[0].revision} ({manual[0].title}) is not "
            f"applied on open: back the store up, then run `hadim store upgrade --store "
            f"{report.where}`")


@contextmanager
def _schema_connection(conn: Connection) -> Iterator[None]:
    """SQLite: foreign keys off while the schema changes (a rebuilt table must not cascade)."""
    if not is_sqlite(conn.engine.url):
        yield
        return
    with schema.foreign_keys_off(conn):
        yield


# --- database servers (PostgreSQL): engine, one-line errors -------------------------------
# Arbitrary, fixed: the advisory lock serialising schema creation on a server.
SCHEMA_LOCK_KEY = 0x4841_4449_4D00


def is_postgresql(url: URL) -> bool:
    return url.get_backend_name() == "postgresql"


def _server_engine(url: URL) -> Engine:
    """An engine for a database server; an unknown scheme or missing driver is one line."""
    try:
        return create_engine(url, pool_pre_ping=True)
    except (NoSuchModuleError, ArgumentError, ImportError) as exc:
        shown = url.render_as_string(hide_password=True)
        raise StoreError(
            f"cannot use store URL {shown}: {_first_line(exc)} (use a file path, "
            "sqlite:///FILE or postgresql+psycopg://USER@HOST/DATABASE)"
        ) from exc


@contextmanager
def _server_errors(engine: Engine, where: str) -> Iterator[None]:
    """A server that cannot be reached or refuses us is the user's problem: one line."""
    try:
        yield
    except OperationalError as exc:
        if is_sqlite(engine.url):
            raise
        raise StoreError(f"cannot open the store at {where}: {_first_line(exc.orig)}") from exc


def _first_line(exc: BaseException | None) -> str:
    lines = str(exc).strip().splitlines()
    return lines[0] if lines else type(exc).__name__
