"""Where a store's schema stands, and moving it to this hadim's with alembic.

A store's version is ``meta.schema_version``; since alembic, the store also has alembic's
version table with the matching revision id (``hadim_store.migrations``). A store from
before alembic has no version table: it is stamped with the revision of its
``schema_version`` first, then upgraded like any other. Reading the state needs plain SQL
only; alembic is imported when a store is created or upgraded, not when one of the current
schema is opened.
"""

from __future__ import annotations

import os
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass

from sqlalchemy import Connection, inspect, select, text

from hadim_store import migrations
from hadim_store.errors import SchemaError
from hadim_store.models import Base, Meta


@dataclass(frozen=True)
class SchemaState:
    """A database's schema: ``version`` None for an empty database; ``revision`` None for a
    store from before alembic (no version table)."""

    version: int | None
    revision: str | None

    @property
    def current(self) -> bool:
        return (self.version == migrations.SCHEMA_VERSION
                and self.revision == migrations.revision_id(migrations.SCHEMA_VERSION))


@dataclass(frozen=True)
class Revision:
    """One revision of ``store/migrations/versions``: the version it brings a store to."""

    revision: str
    version: int
    title: str
    automatic: bool  # applied when a store is opened; else by `hadim store upgrade` only


@dataclass(frozen=True)
class Upgrade:
    """What bringing a store to this hadim's schema did (or, dry, would do)."""

    where: str
    from_version: int
    to_version: int
    revisions: tuple[Revision, ...]
    stamped: bool  # the store had no alembic version table: one was added

    @property
    def changed(self) -> bool:
        return bool(self.revisions) or self.stamped


def _too_new(where: str, version: int) -> SchemaError:
    return SchemaError(f"{where} has schema version {version} but this hadim reads up to "
                       f"{migrations.SCHEMA_VERSION}: upgrade hadim to open it")


def read_state(conn: Connection, where: str) -> SchemaState:
    """The schema of the database ``conn`` is on. Raises :class:`SchemaError` for a database
    that is not a hadim store, a corrupt one, or one newer than this hadim."""
    tables = inspect(conn).get_table_names()
    if not tables:
        return SchemaState(None, None)
    if Meta.__tablename__ not in tables:
        raise SchemaError(f"{where} is not a hadim store (it has tables but no hadim metadata)")
    facts = {key: value for key, value in conn.execute(select(Meta.key, Meta.value))}
    if facts.get("application") != migrations.APPLICATION:
        raise SchemaError(
            f"{where} is not a hadim store (application={facts.get('application')!r})")
    try:
        version = int(facts["schema_version"])
    except (KeyError, ValueError) as exc:
        raise SchemaError(f"{where} is a corrupt hadim store: no valid schema_version") from exc
    if version > migrations.SCHEMA_VERSION:
        raise _too_new(where, version)
    revision = None
    if migrations.VERSION_TABLE in tables:
        rows = [r for (r,) in conn.execute(
            text(f"SELECT version_num FROM {migrations.VERSION_TABLE}"))]
        if len(rows) != 1 or migrations.version_of(rows[0]) is None:
            raise SchemaError(f"{where} is a corrupt hadim store: alembic revision {rows!r} is "
                              "not one of hadim's")
        revision = rows[0]
        at = migrations.version_of(revision)
        if at > migrations.SCHEMA_VERSION:
            raise _too_new(where, at)
        if at != version:
            raise SchemaError(f"{where} is a corrupt hadim store: schema_version {version} but "
                              f"alembic revision {revision}")
    return SchemaState(version, revision)


def create(conn: Connection) -> None:
    """The tables of ``models.py`` in an empty database, stamped with the head revision."""
    Base.metadata.create_all(conn)
    conn.execute(Meta.__table__.insert(), [
        {"key": "application", "value": migrations.APPLICATION},
        {"key": "schema_version", "value": str(migrations.SCHEMA_VERSION)},
    ])
    _stamp(conn, migrations.SCHEMA_VERSION)


def plan(state: SchemaState, target: int | None = None) -> list[Revision]:
    """The revisions taking a database at ``state`` (an empty one too) to schema ``target``
    (this hadim's by default), in order."""
    script = _script()
    head = migrations.revision_id(migrations.SCHEMA_VERSION)
    if script.get_current_head() != head:
        raise SchemaError(f"this hadim's migrations end at {script.get_current_head()} but its "
                          f"schema is version {migrations.SCHEMA_VERSION}: a broken install")
    target = migrations.SCHEMA_VERSION if target is None else target
    base = migrations.revision_id(state.version) if state.version else None
    steps = list(reversed(list(script.iterate_revisions(migrations.revision_id(target), base))))
    found = [migrations.version_of(s.revision) for s in steps]
    if found != list(range((state.version or 0) + 1, target + 1)):
        raise SchemaError(f"this hadim's migrations from schema version {state.version} are not "
                          f"one step per version ({[s.revision for s in steps]}): a broken install")
    return [Revision(s.revision, migrations.version_of(s.revision),
                     (s.doc or "").strip().splitlines()[0] if s.doc else s.revision,
                     bool(getattr(s.module, "automatic", False))) for s in steps]


def apply(conn: Connection, state: SchemaState, steps: list[Revision], where: str) -> None:
    """Stamp a store from before alembic, then run ``steps`` (from ``plan``), on ``conn``'s
    open transaction (the caller commits, or rolls everything back). On SQLite the caller has
    turned foreign keys off (``foreign_keys_off``) so that a table rebuild cascades nothing;
    they are checked here, before the caller commits."""
    from alembic import command

    if state.version is not None and state.revision is None:
        _stamp(conn, state.version)
    if steps:
        command.upgrade(_config(conn), steps[-1].revision)
    if conn.dialect.name == "sqlite":
        orphans = conn.exec_driver_sql("PRAGMA foreign_key_check").fetchall()
        if orphans:
            raise SchemaError(f"cannot upgrade {where}: the upgrade left rows whose foreign key "
                              f"points nowhere ({orphans[0][0]}); nothing was changed")


@contextmanager
def foreign_keys_off(conn: Connection) -> Iterator[None]:
    """SQLite only: foreign keys off on this connection (outside any transaction: inside one
    the pragma is ignored), on again after — a rebuilt parent table must not cascade."""
    raw = conn.connection.driver_connection
    raw.execute("PRAGMA foreign_keys = OFF")
    try:
        yield
    finally:
        raw.execute("PRAGMA foreign_keys = ON")


def _stamp(conn: Connection, version: int) -> None:
    from alembic import command

    command.stamp(_config(conn), migrations.revision_id(version))


def _config(conn: Connection | None):
    from alembic.config import Config

    config = Config()
    config.set_main_option("script_location", _ini(str(migrations.SCRIPT_LOCATION)))
    config.set_main_option("path_separator", "os")
    config.set_main_option("version_locations", _ini(
        os.pathsep.join(str(p) for p in migrations.VERSION_LOCATIONS)))
    config.attributes["connection"] = conn
    return config


def _ini(value: str) -> str:
    return value.replace("%", "%%")  # alembic's Config interpolates like an .ini file


def _script():
    from alembic.script import ScriptDirectory

    return ScriptDirectory.from_config(_config(None))
