"""`hadim store upgrade` on stores written by earlier hadims: the schema-2 fixture (written by
b982461, before alembic) and the schema-1 fixture, on SQLite and copied onto a PostgreSQL
server; upgraded, then read and resumed bit-identically. A newer store is refused by every
command with one line, its file unchanged."""

from __future__ import annotations

import hashlib
import json
import shutil
import sqlite3
from pathlib import Path

import pytest
from sqlalchemy import MetaData, create_engine, text

from hadim_cli.app import app
from hadim_store import Store, migrations, schema
from hadim_store.engine import resolve_url
from hadim_store.schema import SchemaState

FIXTURES = Path(__file__).parents[1] / "fixtures"
# runs show's dataset_sha256 of the fixtures' runs, as the hadim that wrote them computed it.
V2_RUN_1 = "18e5dcffb8f906ba4bc5e7b5a7006ec6ed3558388a98d47429ca80ba0a99f860"  # 100 iterations
V2_RUN_2 = "872c318097baf1c977718c8a1956a4142f7f180cb4ea924a2dfa29d95f6495aa"  # fork at 50
NO_EVAL = ("--eval-every", "0")


def ok(runner, *args: object) -> str:
    result = runner.invoke(app, [str(a) for a in args])
    assert result.exit_code == 0, (args, result.stderr, result.exception)
    return result.stdout


def refused(runner, *args: object) -> str:
    """The one `error:` line of a command that must exit 2."""
    result = runner.invoke(app, [str(a) for a in args])
    assert result.exit_code == 2, (args, result.stdout, result.exception)
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: "), result.stderr
    return lines[0]


def show(runner, store: object, run: str) -> dict:
    return json.loads(ok(runner, "runs", "show", run, "--json", "--store", store))


def copy_fixture(name: str, tmp_path: Path) -> Path:
    path = tmp_path / name
    shutil.copyfile(FIXTURES / name, path)
    return path


def md5(path: Path) -> str:
    return hashlib.md5(path.read_bytes()).hexdigest()


def test_a_schema_2_store_from_before_alembic_upgrades_reads_and_resumes_exactly(runner,
                                                                                 tmp_path):
    store = copy_fixture("store_v2.sqlite", tmp_path)
    out = ok(runner, "store", "upgrade", "--store", store)
    assert out.splitlines()[0] == f"{store}: schema version 2 -> {migrations.SCHEMA_VERSION}"
    assert "version table was added" in out
    assert "up to date" in ok(runner, "store", "upgrade", "--store", store)
    listed = ok(runner, "runs", "list", "--wide", "--store", store)
    assert "run-1" in listed and "run-2" in listed and "run-1@50" in listed
    one, two = show(runner, store, "run-1"), show(runner, store, "run-2")
    assert (one["dataset_sha256"], two["dataset_sha256"]) == (V2_RUN_1, V2_RUN_2)
    assert set(one["scores"]) == {"move-robot", "push-object", "push-with-tool"}
    # run-2 (a fork at 50: one full checkpoint) and run-1 (its checkpoint at 100 a delta on 50)
    # continue from the upgraded store, with the installed controller (the code that turns
    # goals into actions; D, H and the models are as stored), exactly: twice the same D.
    again = tmp_path / "again.sqlite"
    shutil.copyfile(store, again)
    for where in (store, again):
        ok(runner, "resume", "run-2", "--iterations", 150, *NO_EVAL, "--store", where)
        ok(runner, "resume", "run-1", "--iterations", 150, *NO_EVAL, "--store", where)
    with Store.open(store, create=False) as st, Store.open(again, create=False) as nd:
        assert st.dataset_sha256("run-1", upto_iteration=100) == V2_RUN_1
        assert st.dataset_sha256("run-2", upto_iteration=50) == \
            st.dataset_sha256("run-1", upto_iteration=50)
        for run in ("run-1", "run-2"):
            assert st.dataset_sha256(run) == nd.dataset_sha256(run)
        assert st.checkpoint_iterations("run-1")[-1] == 150


def _pre_alembic_schema_1_on(url: str, source: Path) -> None:
    """The schema-1 fixture's rows in a server store of schema 1 with no alembic table: what a
    hadim from before alembic left on PostgreSQL."""
    target = create_engine(resolve_url(url))
    origin = create_engine(f"sqlite:///{source}")
    try:
        with target.begin() as conn:
            empty = SchemaState(None, None)
            schema.apply(conn, empty, schema.plan(empty, 1), url)
            conn.execute(text(f"DROP TABLE {migrations.VERSION_TABLE}"))
            tables = MetaData()
            tables.reflect(conn)
            with origin.connect() as read:
                for table in tables.sorted_tables:
                    if table.name == "meta":
                        continue
                    rows = [dict(r._mapping) for r in read.execute(table.select())]
                    if rows:
                        conn.execute(table.insert(), rows)
                    conn.execute(text(f"SELECT setval(pg_get_serial_sequence('{table.name}', "
                                      f"'id'), (SELECT coalesce(max(id), 0) + 1 FROM "
                                      f"{table.name}), false)"))
    finally:
        target.dispose()
        origin.dispose()


def test_a_schema_1_store_on_postgresql_upgrades_reads_and_resumes_as_on_sqlite(
        runner, tmp_path, postgres_url):
    sqlite = copy_fixture("store_v1.sqlite", tmp_path)
    _pre_alembic_schema_1_on(postgres_url, sqlite)
    for store in (sqlite, postgres_url):
        out = ok(runner, "store", "upgrade", "--dry-run", "--store", store)
        assert f"schema version 1 -> {migrations.SCHEMA_VERSION} (dry run: nothing written)" in out
        out = ok(runner, "store", "upgrade", "--store", store)
        assert f"schema version 1 -> {migrations.SCHEMA_VERSION}" in out.splitlines()[0]
        assert "0002 " in out and "0003 " in out
        assert "run-1" in ok(runner, "runs", "list", "--store", store)
    assert show(runner, postgres_url, "run-1")["dataset_sha256"] == \
        show(runner, sqlite, "run-1")["dataset_sha256"]
    for store in (sqlite, postgres_url):
        ok(runner, "resume", "run-1", "--iterations", 150, *NO_EVAL, "--store", store)
    on_server, on_file = show(runner, postgres_url, "run-1"), show(runner, sqlite, "run-1")
    assert on_server["iterations"] == 150
    assert on_server["dataset_sha256"] == on_file["dataset_sha256"]
    assert ok(runner, "affordances", "run-1", "--json", "--store", postgres_url) == \
        ok(runner, "affordances", "run-1", "--json", "--store", sqlite)


def _stamp_newer(store: Path, *, alembic: bool) -> None:
    con = sqlite3.connect(store)
    with con:
        if alembic:
            con.execute(f"UPDATE {migrations.VERSION_TABLE} SET version_num = '9000'")
        else:
            con.execute("UPDATE meta SET value = '9000' WHERE key = 'schema_version'")
    con.execute("PRAGMA wal_checkpoint(TRUNCATE)")
    con.execute("PRAGMA journal_mode = DELETE")  # one file: its md5 is the whole store
    con.close()


@pytest.mark.parametrize("alembic", [False, True], ids=["meta", "alembic"])
def test_a_newer_store_is_refused_by_every_command_unchanged(runner, tmp_path, alembic):
    store = copy_fixture("store_v2.sqlite", tmp_path)
    if alembic:
        ok(runner, "store", "upgrade", "--store", store)
    _stamp_newer(store, alembic=alembic)
    before = md5(store)
    for command in (["runs", "list"], ["runs", "show", "run-1"], ["store", "upgrade"],
                    ["resume", "run-2", "--iterations", 100], ["train", "--iterations", 50],
                    ["fork", "run-1", "--at", 50]):
        line = refused(runner, *command, "--store", store)
        assert "has schema version 9000 but this hadim reads up to" in line, command
        assert line.endswith("upgrade hadim to open it")
    assert md5(store) == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["store_v2.sqlite"]


def test_a_manual_revision_is_one_line_until_store_upgrade(runner, tmp_path, monkeypatch):
    head = migrations.SCHEMA_VERSION
    new, prev = migrations.revision_id(head + 1), migrations.revision_id(head)
    folder = tmp_path / "versions"
    folder.mkdir()
    (folder / f"{new}_rebuild.py").write_text(
        f'"""Rebuild runs."""\nfrom alembic import op\nimport sqlalchemy as sa\n'
        f'revision = "{new}"\ndown_revision = "{prev}"\nbranch_labels = None\n'
        'depends_on = None\nautomatic = False\n\n\ndef upgrade():\n'
        "    with op.batch_alter_table('runs', recreate='always') as batch:\n"
        "        batch.add_column(sa.Column('notes', sa.Text))\n")
    monkeypatch.setattr(migrations, "VERSION_LOCATIONS", [*migrations.VERSION_LOCATIONS, folder])
    monkeypatch.setattr(migrations, "SCHEMA_VERSION", head + 1)
    store = copy_fixture("store_v2.sqlite", tmp_path)
    line = refused(runner, "runs", "list", "--store", store)
    assert f"run `hadim store upgrade --store {store}`" in line and f"{new} (Rebuild runs.)" in line
    out = ok(runner, "store", "upgrade", "--store", store)
    lines = out.splitlines()
    assert lines[0] == f"{store}: schema version 2 -> {head + 1}"
    assert lines[head - 1] == f"  {new} Rebuild runs."  # after the revisions 0003 … head
    assert show(runner, store, "run-2")["dataset_sha256"] == V2_RUN_2  # the fork's parent row
    assert show(runner, store, "run-2")["parent"] == "run-1"           # survived the rebuild


@pytest.mark.parametrize("where", ["nothing-here.sqlite", "mysql+nodriver://u@h/db",
                                   "postgresql+psycopg://u@/db?host=/nonexistent-socket-dir"])
def test_store_upgrade_of_no_store_is_one_line(runner, tmp_path, where):
    target = str(tmp_path / where) if "://" not in where else where
    refused(runner, "store", "upgrade", "--store", target)
    assert list(tmp_path.iterdir()) == []


def test_store_check_reads_old_stores_without_upgrading_them(runner, tmp_path):
    v2, v1 = copy_fixture("store_v2.sqlite", tmp_path), copy_fixture("store_v1.sqlite", tmp_path)
    for old in (v2, v1):  # schema 3 added a column: a schema-2 store is read once upgraded
        out = ok(runner, "store", "check", "--store", old)
        assert "runs not read: " in out and f"hadim store upgrade --store {old}" in out
    for store, version in ((v2, "2"), (v1, "1")):
        con = sqlite3.connect(store)
        tables = {t for (t,) in con.execute("SELECT name FROM sqlite_master WHERE type='table'")}
        assert con.execute("SELECT value FROM meta WHERE key = 'schema_version'").fetchone() == \
            (version,)
        con.close()
        assert migrations.VERSION_TABLE not in tables
    upgraded = tmp_path / "upgraded.sqlite"
    shutil.copyfile(v2, upgraded)
    ok(runner, "store", "upgrade", "--store", upgraded)
    out = ok(runner, "store", "check", "--store", upgraded)
    assert "run-1: readable (100 iterations, 2 checkpoints)" in out
