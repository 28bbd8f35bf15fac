"""Shared fixtures: a CLI runner, small configurations, and a real PostgreSQL server."""

from __future__ import annotations

import os
import sys
from collections.abc import Iterator
from pathlib import Path

import pytest
from typer.testing import CliRunner

import hadim_cli  # noqa: F401  (before numpy loads: it pins the numeric kernels)

sys.path.append(str(Path(__file__).resolve().parent))  # for postgres_server
import postgres_server  # noqa: E402


@pytest.fixture
def runner() -> CliRunner:
    return CliRunner()


@pytest.fixture(scope="session")
def postgres() -> Iterator[postgres_server.PostgresServer]:
    """One PostgreSQL server for the whole test session (started on first use)."""
    reason = postgres_server.missing_reason()
    if reason is not None:
        if os.environ.get(postgres_server.REQUIRE_ENV):
            pytest.fail(f"{reason} (and {postgres_server.REQUIRE_ENV} is set)")
        pytest.skip(reason)
    server = postgres_server.start()
    try:
        yield server
    finally:
        server.stop()


@pytest.fixture
def postgres_url(postgres: postgres_server.PostgresServer) -> Iterator[str]:
    """The URL of a fresh, empty store on the test server (its own schema)."""
    yield postgres.url(postgres.new_schema())
