"""Stores on a database server (PostgreSQL): URLs, one-line errors, foreign databases."""

from __future__ import annotations

import pytest
import sqlalchemy as sa

from hadim_store import SchemaError, Store, StoreError
from hadim_store.engine import resolve_url


def test_plain_postgresql_url_means_psycopg3():
    assert resolve_url("postgresql://u@h/db").drivername == "postgresql+psycopg"
    assert resolve_url("postgresql+psycopg://u@h/db").drivername == "postgresql+psycopg"


@pytest.mark.parametrize("url", ["mongodb://host/db", "postgresql+nosuch://u@h/db"])
def test_unknown_scheme_is_one_line(url):
    with pytest.raises(StoreError, match="cannot use store URL") as caught:
        Store.open(url)
    assert "\n" not in str(caught.value)


def test_unreachable_server_is_one_line(tmp_path):
    with pytest.raises(StoreError, match="cannot open the store at") as caught:
        Store.open(f"postgresql+psycopg://postgres@/hadim?host={tmp_path}&port=1")
    assert "\n" not in str(caught.value)


def test_foreign_database_refused_and_unchanged(postgres_url):
    engine = sa.create_engine(postgres_url)
    with engine.begin() as conn:
        conn.execute(sa.text("CREATE TABLE invoices (id INTEGER PRIMARY KEY, total REAL)"))
    with pytest.raises(SchemaError, match="not a hadim store"):
        Store.open(postgres_url)
    with engine.connect() as conn:
        assert sa.inspect(conn).get_table_names() == ["invoices"]
    engine.dispose()


def test_largest_seed_and_password_hidden(postgres_url):
    with Store.open(postgres_url) as store:
        assert store.create_run(config={}, seed=2**63 - 1).seed == 2**63 - 1
    url = postgres_url.replace("postgres@", "postgres:secret@")
    with Store.open(url) as store:  # trust authentication ignores the password
        assert "secret" not in store.where and "***" in store.where
