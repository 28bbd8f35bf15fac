"""Opening stores: foreign files refused untouched, schema versions, SQLite settings."""

from __future__ import annotations

import os
import sqlite3

import pytest
from sqlalchemy import text

from hadim_store import SCHEMA_VERSION, SchemaError, Store, StoreError


def _files(path):
    return sorted(p.name for p in path.parent.iterdir())


def test_foreign_sqlite_file_refused_and_unchanged(tmp_path):
    path = tmp_path / "other.db"
    with sqlite3.connect(path) as conn:
        conn.execute("CREATE TABLE invoices (id INTEGER PRIMARY KEY, total REAL)")
        conn.execute("INSERT INTO invoices VALUES (1, 9.5)")
    conn.close()
    before = path.read_bytes()
    with pytest.raises(SchemaError, match="not a hadim store"):
        Store.open(path)
    assert path.read_bytes() == before
    assert _files(path) == ["other.db"]


def test_foreign_meta_table_refused(tmp_path):
    path = tmp_path / "other.db"
    with sqlite3.connect(path) as conn:
        conn.execute("CREATE TABLE meta (key TEXT PRIMARY KEY, value TEXT)")
        conn.execute("INSERT INTO meta VALUES ('application', 'mlflow')")
    conn.close()
    before = path.read_bytes()
    with pytest.raises(SchemaError, match="application='mlflow'"):
        Store.open(path)
    assert path.read_bytes() == before


def test_random_bytes_refused_and_unchanged(tmp_path):
    path = tmp_path / "noise.db"
    path.write_bytes(os.urandom(4096))
    before = path.read_bytes()
    with pytest.raises(SchemaError, match="not a SQLite database"):
        Store.open(path)
    assert path.read_bytes() == before
    assert _files(path) == ["noise.db"]


def test_corrupt_sqlite_refused(tmp_path):
    path = tmp_path / "corrupt.db"
    path.write_bytes(b"SQLite format 3\x00" + os.urandom(4096))
    before = path.read_bytes()
    with pytest.raises(SchemaError):
        Store.open(path)
    assert path.read_bytes() == before


def test_missing_store_without_create(tmp_path):
    with pytest.raises(StoreError, match="no hadim store"):
        Store.open(tmp_path / "absent.db", create=False)
    assert not (tmp_path / "absent.db").exists()
    with pytest.raises(StoreError, match="not a directory"):
        Store.open(tmp_path / "nowhere" / "x.db")


def test_reopen_and_url_forms(tmp_path):
    path = tmp_path / "s.db"
    with Store.open(path) as first:
        first.create_run(config={"a": 1}, seed=1)
    with Store.open(f"sqlite:///{path}", create=False) as again:
        assert again.get_run("run-1").config == {"a": 1}
    with Store.open(str(path)) as again:
        assert again.where == str(path)
    with Store.open(":memory:") as memory:
        assert memory.list_runs() == []


def _set_version(path, version):
    with sqlite3.connect(path) as conn:
        conn.execute("UPDATE meta SET value = ? WHERE key = 'schema_version'", (str(version),))
    conn.close()


def test_newer_schema_refused(tmp_path):
    path = tmp_path / "s.db"
    Store.open(path).close()
    _set_version(path, SCHEMA_VERSION + 1)
    before = path.read_bytes()
    with pytest.raises(SchemaError, match="upgrade hadim"):
        Store.open(path)
    assert path.read_bytes() == before


def test_file_sqlite_pragmas(file_store):
    with file_store.engine.connect() as conn:
        assert conn.exec_driver_sql("PRAGMA journal_mode").scalar_one() == "wal"
        assert conn.exec_driver_sql("PRAGMA foreign_keys").scalar_one() == 1
        assert conn.exec_driver_sql("PRAGMA busy_timeout").scalar_one() == 10_000


def test_meta_rows(store):
    with store.engine.connect() as conn:
        rows = dict(conn.exec_driver_sql("SELECT key, value FROM meta").all())
    assert rows == {"application": "hadim", "schema_version": str(SCHEMA_VERSION)}


def test_readers_see_committed_data_while_a_writer_is_open(tmp_path, make_episode):
    path = tmp_path / "s.db"
    with Store.open(path) as writer, Store.open(path) as reader:
        writer.create_run(config={}, seed=1)
        writer.write_episode("run-1", make_episode(0, 0))
        with writer.session_scope() as session:  # holds SQLite's write lock
            session.execute(text("UPDATE runs SET iterations = 999"))
            assert reader.get_run("run-1").iterations == 4  # WAL: not blocked, not dirty
            assert reader.dataset("run-1").actions.shape == (4, 2)
        assert reader.get_run("run-1").iterations == 999


def test_two_store_objects_write_in_turn(tmp_path, make_episode):
    path = tmp_path / "s.db"
    with Store.open(path) as one, Store.open(path) as two:
        one.create_run(config={}, seed=1)
        two.create_run(config={}, seed=1)
        one.write_episode("run-2", make_episode(0, 0))
        two.write_episode("run-1", make_episode(0, 0))
        assert [r.iterations for r in one.list_runs()] == [4, 4]
