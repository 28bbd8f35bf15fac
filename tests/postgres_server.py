"""A throw-away PostgreSQL server for the tests: `initdb` + `pg_ctl` in a temporary directory.

PostgreSQL refuses to run as root, so under root the server runs as the `postgres` user (its
data directory is created in /tmp and chowned to it). It listens on a Unix socket only, in that
directory, on a random port number, so parallel test sessions never collide. Trust
authentication; fsync off (nothing here must survive the machine).
"""

from __future__ import annotations

import os
import pwd
import shutil
import socket
import subprocess
import tempfile
import uuid
from dataclasses import dataclass
from pathlib import Path

SERVER_USER = "postgres"
# CI sets this so that a machine without PostgreSQL fails the PostgreSQL tests instead of
# skipping them.
REQUIRE_ENV = "HADIM_REQUIRE_POSTGRES"


@dataclass(frozen=True)
class PostgresServer:
    root: Path
    port: int

    def url(self, schema: str | None = None) -> str:
        """The test database's URL; with `schema`, one whose tables live in that schema."""
        url = f"postgresql+psycopg://postgres@/hadim?host={self.root}&port={self.port}"
        return url if schema is None else f"{url}&options=-csearch_path%3D{schema}"

    def new_schema(self) -> str:
        """A fresh, empty schema: a new empty store for one test, 100× cheaper than a database."""
        name = f"t_{uuid.uuid4().hex[:12]}"
        with self.connect("hadim") as conn:
            conn.execute(f'CREATE SCHEMA "{name}"')
        return name

    def connect(self, database: str):
        """A psycopg connection (autocommit) to one of the server's databases."""
        import psycopg

        return psycopg.connect(host=str(self.root), port=self.port, user="postgres",
                               dbname=database, autocommit=True)

    def stop(self) -> None:
        _run_as_server_user(["pg_ctl", "-D", str(self.root / "data"), "-m", "immediate",
                             "-w", "stop"], self.root, check=False)
        shutil.rmtree(self.root, ignore_errors=True)


def missing_reason() -> str | None:
    """Why no server can be started here, or None."""
    for tool in ("initdb", "pg_ctl"):
        if shutil.which(tool) is None:
            return f"PostgreSQL's {tool} is not on PATH"
    if os.geteuid() == 0:
        try:
            pwd.getpwnam(SERVER_USER)
        except KeyError:
            return f"running as root and there is no {SERVER_USER!r} user to run the server"
    return None


def start() -> PostgresServer:
    root = Path(tempfile.mkdtemp(prefix="hadim-pg-"))
    if os.geteuid() == 0:
        user = pwd.getpwnam(SERVER_USER)
        os.chown(root, user.pw_uid, user.pw_gid)
    port = _free_port()
    data = root / "data"
    try:
        _run_as_server_user(["initdb", "-D", str(data), "-U", "postgres", "--auth=trust",
                             "-E", "UTF8", "--no-sync", "--no-instructions"], root)
        options = (f"-k {root} -p {port} -c listen_addresses='' -c fsync=off "
                   "-c synchronous_commit=off -c full_page_writes=off -c max_connections=60")
        _run_as_server_user(["pg_ctl", "-D", str(data), "-o", options, "-l",
                             str(root / "server.log"), "-w", "-t", "60", "start"], root)
        server = PostgresServer(root, port)
        with server.connect("postgres") as conn:
            conn.execute("CREATE DATABASE hadim")
    except BaseException:
        _run_as_server_user(["pg_ctl", "-D", str(data), "-m", "immediate", "stop"], root,
                            check=False)
        shutil.rmtree(root, ignore_errors=True)
        raise
    return server


def _run_as_server_user(argv: list[str], cwd: Path, *, check: bool = True) -> None:
    user = SERVER_USER if os.geteuid() == 0 else None
    done = subprocess.run(argv, cwd=cwd, user=user, capture_output=True, text=True,
                          check=False)
    if check and done.returncode != 0:
        raise RuntimeError(f"{' '.join(argv[:2])} failed ({done.returncode}): "
                           f"{done.stderr.strip() or done.stdout.strip()}")


def _free_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return probe.getsockname()[1]
