"""Schema migrations with alembic, on file SQLite and a real PostgreSQL server: the shipped
revisions build exactly models.py (and revision 1 exactly a store written by schema 1), a
newer store is refused unchanged, automatic revisions apply on open, others wait for
`upgrade_store`, and a failure anywhere in an upgrade leaves the store as it was."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest
from alembic.autogenerate import compare_metadata
from alembic.runtime.migration import MigrationContext
from sqlalchemy import create_engine, inspect, text

from hadim_store import SCHEMA_VERSION, SchemaError, Store, migrations, schema, upgrade_store
from hadim_store.engine import resolve_url
from hadim_store.models import Base
from hadim_store.schema import SchemaState

FIXTURES = Path(__file__).parents[1] / "fixtures"
NEXT = SCHEMA_VERSION + 1

# A revision of the tests' own, after the shipped ones.
_REVISION = '''"""{title}"""
import sqlalchemy as sa
from alembic import op

revision = "{revision}"
down_revision = "{down}"
branch_labels = None
depends_on = None
automatic = {automatic}


def upgrade():
{body}
'''


@pytest.fixture(params=["file", "postgresql"])
def url(request: pytest.FixtureRequest, tmp_path: Path) -> str:
    """An empty store location on each backend whose DDL matters."""
    if request.param == "postgresql":
        return request.getfixturevalue("postgres_url")
    return str(tmp_path / "store.db")


@pytest.fixture
def revisions(tmp_path: Path, monkeypatch: pytest.MonkeyPatch):
    """Adds revisions after the shipped ones: ``add(title, body, automatic)``, in order."""
    folder = tmp_path / "more_versions"
    folder.mkdir()
    monkeypatch.setattr(migrations, "VERSION_LOCATIONS", [*migrations.VERSION_LOCATIONS, folder])

    def add(title: str, body: str, *, automatic: bool = True) -> str:
        version = migrations.SCHEMA_VERSION + 1
        revision = migrations.revision_id(version)
        lines = "".join(f"    {line}\n" for line in body.strip().splitlines())
        (folder / f"{revision}_test.py").write_text(_REVISION.format(
            title=title, revision=revision, down=migrations.revision_id(version - 1),
            automatic=automatic, body=lines))
        monkeypatch.setattr(migrations, "SCHEMA_VERSION", version)
        return revision

    return add


def raw(url: str):
    """An engine that does nothing on its own (Store.open would upgrade)."""
    return create_engine(resolve_url(url))


def contents(url: str) -> dict:
    """Every table's columns and rows, sorted: what "the store as it was" means."""
    engine = raw(url)
    try:
        with engine.connect() as conn:
            found = {}
            for table in sorted(inspect(conn).get_table_names()):
                columns = [c["name"] for c in inspect(conn).get_columns(table)]
                rows = conn.execute(text(f'SELECT * FROM "{table}"')).all()
                found[table] = (columns, sorted(map(tuple, rows), key=repr))
            return found
    finally:
        engine.dispose()


def version_facts(url: str) -> tuple[str, list[str]]:
    engine = raw(url)
    try:
        with engine.connect() as conn:
            meta = conn.execute(text("SELECT value FROM meta WHERE key = 'schema_version'"))
            alembic = conn.execute(text(f"SELECT version_num FROM {migrations.VERSION_TABLE}"))
            return meta.scalar_one(), [r for (r,) in alembic]
    finally:
        engine.dispose()


def a_store_with_a_run(url: str, fill) -> None:
    with Store.open(url) as store:
        store.create_run(config={"a": 1}, seed=3)
        fill(store, "run-1", 3)


def migrate_empty(url: str, target: int) -> None:
    engine = raw(url)
    try:
        with engine.begin() as conn:
            empty = SchemaState(None, None)
            schema.apply(conn, empty, schema.plan(empty, target), url)
    finally:
        engine.dispose()


def test_one_revision_per_schema_version_ending_at_this_one():
    steps = schema.plan(SchemaState(None, None))
    assert [s.revision for s in steps] == [f"{v:04d}" for v in range(1, SCHEMA_VERSION + 1)]
    assert all(s.title and not s.title.startswith("0") for s in steps)  # a docstring each
    assert [s.version for s in schema.plan(SchemaState(1, None))] == \
        list(range(2, SCHEMA_VERSION + 1))


def test_the_revisions_build_exactly_the_models(url):
    migrate_empty(url, SCHEMA_VERSION)
    engine = raw(url)
    try:
        with engine.connect() as conn:
            assert compare_metadata(MigrationContext.configure(conn), Base.metadata) == []
            assert schema.read_state(conn, url).current
    finally:
        engine.dispose()
    assert version_facts(url) == (str(SCHEMA_VERSION), [migrations.revision_id(SCHEMA_VERSION)])
    with Store.open(url, create=False) as store:  # and it is a store hadim uses as it is
        assert store.create_run(config={}, seed=2**40).seed == 2**40


def _describe(path: Path) -> dict:
    engine = create_engine(f"sqlite:///{path}")
    try:
        with engine.connect() as conn:
            look = inspect(conn)
            return {table: (
                [(c["name"], str(c["type"]), c["nullable"], c["primary_key"])
                 for c in look.get_columns(table)],
                sorted((i["name"], tuple(i["column_names"]), bool(i["unique"]))
                       for i in look.get_indexes(table)),
                sorted((u["name"] or "", tuple(u["column_names"]))
                       for u in look.get_unique_constraints(table)),
                sorted((tuple(f["constrained_columns"]), f["referred_table"],
                        f["options"].get("ondelete")) for f in look.get_foreign_keys(table)),
            ) for table in look.get_table_names() if table != migrations.VERSION_TABLE}
    finally:
        engine.dispose()


def test_revision_1_is_the_schema_of_a_store_written_by_schema_1(tmp_path):
    built = tmp_path / "built.db"
    migrate_empty(str(built), 1)
    assert _describe(built) == _describe(FIXTURES / "store_v1.sqlite")
    assert version_facts(str(built)) == ("1", ["0001"])


def test_a_store_newer_than_this_hadim_is_refused_unchanged(url, fill):
    a_store_with_a_run(url, fill)
    engine = raw(url)
    with engine.begin() as conn:
        conn.execute(text(f"UPDATE {migrations.VERSION_TABLE} SET version_num = :r"),
                     {"r": migrations.revision_id(NEXT)})
    engine.dispose()
    before = contents(url)
    file_bytes = Path(url).read_bytes() if "://" not in url else None
    for attempt in (Store.open, upgrade_store):
        with pytest.raises(SchemaError, match=f"has schema version {NEXT} .* upgrade hadim"):
            attempt(url)
    assert contents(url) == before
    if file_bytes is not None:
        assert Path(url).read_bytes() == file_bytes


def test_automatic_revisions_apply_on_open_in_order_once(url, fill, revisions):
    a_store_with_a_run(url, fill)
    revisions("add notes", "op.add_column('runs', sa.Column('notes', sa.Text))")
    revisions("fill notes", "op.execute(\"UPDATE runs SET notes = coalesce(notes, '') || 'x'\")")
    with Store.open(url) as store:
        assert store.dataset("run-1").actions.shape == (12, 2)
    assert version_facts(url) == (str(NEXT + 1), [migrations.revision_id(NEXT + 1)])
    Store.open(url).close()  # current: nothing applied again
    assert contents(url)["runs"][1][0][-1] == "x"


def test_a_failing_revision_leaves_the_store_as_it_was(url, fill, revisions):
    a_store_with_a_run(url, fill)
    revisions("add notes", "op.add_column('runs', sa.Column('notes', sa.Text))")
    revisions("broken", "op.execute('DELETE FROM episodes')\nraise RuntimeError('revision bug')")
    before = contents(url)
    for attempt in (Store.open, upgrade_store):
        with pytest.raises(RuntimeError, match="revision bug"):
            attempt(url)
    assert contents(url) == before
    assert version_facts(url) == (str(SCHEMA_VERSION), [migrations.revision_id(SCHEMA_VERSION)])


def test_a_failed_upgrade_of_a_store_from_before_alembic_stamps_nothing(tmp_path, revisions):
    path = tmp_path / "v1.sqlite"
    shutil.copyfile(FIXTURES / "store_v1.sqlite", path)
    before = contents(str(path))
    revisions("broken", "raise RuntimeError('revision bug')")
    with pytest.raises(RuntimeError, match="revision bug"):
        Store.open(path)
    assert contents(str(path)) == before  # no version table, no schema-2 columns


def test_a_manual_revision_waits_for_upgrade_and_a_rebuild_cascades_nothing(url, fill,
                                                                            revisions):
    """A revision that rebuilds a parent table (SQLite: copy, DROP, rename) must not delete
    its children through ON DELETE CASCADE: the upgrade runs with SQLite's foreign keys off."""
    a_store_with_a_run(url, fill)
    with Store.open(url) as store:
        checkpoint = store.checkpoint("run-1")
    revisions("rebuild checkpoints", """
rebuild = 'always' if op.get_bind().dialect.name == 'sqlite' else 'auto'
with op.batch_alter_table('checkpoints', recreate=rebuild) as batch:
    batch.add_column(sa.Column('note', sa.String(16), nullable=False, server_default='-'))
""", automatic=False)
    before = contents(url)
    with pytest.raises(SchemaError, match="not applied on open.*hadim store upgrade --store"):
        Store.open(url)
    assert contents(url) == before
    report = upgrade_store(url)
    assert [r.title for r in report.revisions] == ["rebuild checkpoints"]
    after = contents(url)
    assert after["checkpoint_items"] == before["checkpoint_items"]
    assert after["episodes"] == before["episodes"]
    with Store.open(url) as store:
        again = store.checkpoint("run-1")
        assert again.json == checkpoint.json
        assert again.arrays["weights"].tobytes() == checkpoint.arrays["weights"].tobytes()
        if "://" not in url:  # the store's own connections have foreign keys on again
            with store.engine.connect() as conn:
                assert conn.exec_driver_sql("PRAGMA foreign_keys").scalar_one() == 1


def test_rows_left_pointing_nowhere_refuse_the_upgrade_on_sqlite(tmp_path, fill, revisions):
    path = str(tmp_path / "s.db")
    a_store_with_a_run(path, fill)
    revisions("orphan", "op.execute(\"INSERT INTO checkpoint_items (checkpoint_id, key, kind) "
                        "VALUES (999, 'k', 'json')\")")
    before = contents(path)
    with pytest.raises(SchemaError, match="foreign key points nowhere"):
        Store.open(path)
    assert contents(path) == before


def test_a_dry_run_writes_nothing(tmp_path):
    path = tmp_path / "v1.sqlite"
    shutil.copyfile(FIXTURES / "store_v1.sqlite", path)
    before = contents(str(path))
    report = upgrade_store(path, dry_run=True)
    assert (report.from_version, report.to_version, report.stamped) == (1, SCHEMA_VERSION, True)
    assert [r.revision for r in report.revisions] == ["0002", "0003"]
    assert contents(str(path)) == before
    assert upgrade_store(path).changed and not upgrade_store(path).changed


def test_a_new_revision_file_is_numbered_after_the_head_and_plans(tmp_path, monkeypatch):
    from hadim_store.migrations.__main__ import new_revision

    folder = tmp_path / "versions"
    folder.mkdir()
    monkeypatch.setattr(migrations, "VERSION_LOCATIONS", [*migrations.VERSION_LOCATIONS, folder])
    path = new_revision("add notes to runs", folder)
    assert path.name == f"{NEXT:04d}_add_notes_to_runs.py"
    monkeypatch.setattr(migrations, "SCHEMA_VERSION", NEXT)
    (step,) = schema.plan(SchemaState(SCHEMA_VERSION, migrations.revision_id(SCHEMA_VERSION)))
    assert (step.revision, step.title, step.automatic) == (f"{NEXT:04d}", "add notes to runs",
                                                           False)


def test_the_wheel_ships_the_alembic_environment():
    """env.py and versions/ are packages' modules (tests/test_first_day.py checks those are
    listed); the template is package data, which must be named in pyproject.toml."""
    import tomllib

    root = Path(__file__).parents[2]
    setup = tomllib.loads((root / "pyproject.toml").read_text())["tool"]["setuptools"]
    folder = root / "store" / "migrations"
    data = {p.relative_to(folder) for pattern in setup["package-data"]["hadim_store.migrations"]
            for p in folder.glob(pattern)}
    assert data == {p.relative_to(folder) for p in folder.rglob("*")
                    if p.is_file() and p.suffix not in (".py", ".pyc")}
    assert {"hadim_store.migrations", "hadim_store.migrations.versions"} <= set(setup["packages"])


def _before_alembic(url: str, fill) -> None:
    """A schema-2 store as a hadim from before alembic left it: no alembic table."""
    a_store_with_a_run(url, fill)
    engine = raw(url)
    with engine.begin() as conn:
        conn.execute(text(f"DROP TABLE {migrations.VERSION_TABLE}"))
    engine.dispose()


def test_processes_opening_an_old_store_at_once_upgrade_it_once(url, fill):
    """SQLite serialises the upgrades with BEGIN IMMEDIATE, a server with an advisory lock;
    each opener reads the state again inside its transaction, so the later ones find it done."""
    from concurrent.futures import ThreadPoolExecutor

    _before_alembic(url, fill)

    def open_it(_: int) -> int:
        with Store.open(url) as store:
            return store.get_run("run-1").iterations

    with ThreadPoolExecutor(4) as pool:
        assert list(pool.map(open_it, range(4))) == [12] * 4
    assert version_facts(url) == (str(SCHEMA_VERSION), [migrations.revision_id(SCHEMA_VERSION)])


_KILLED_MID_UPGRADE = """
import sys
from hadim_store import Store, migrations
migrations.VERSION_LOCATIONS.append(sys.argv[2])
migrations.SCHEMA_VERSION += 1
Store.open(sys.argv[1])
"""


def test_a_process_killed_mid_upgrade_leaves_the_store_as_it_was(url, fill, revisions,
                                                               tmp_path):
    import os
    import signal
    import subprocess
    import sys
    import time

    a_store_with_a_run(url, fill)
    marker = tmp_path / "half-done"
    revisions("slow", f"""
op.add_column('runs', sa.Column('notes', sa.Text))
op.execute('DELETE FROM checkpoint_items')
open({str(marker)!r}, 'w').close()
import time; time.sleep(120)
""")
    monkey_folder = str(migrations.VERSION_LOCATIONS[-1])
    before = contents(url)
    child = subprocess.Popen([sys.executable, "-c", _KILLED_MID_UPGRADE, url, monkey_folder],
                             env={**os.environ, "PYTHONPATH": str(Path(__file__).parents[2])})
    try:
        deadline = time.monotonic() + 60
        while not marker.exists() and child.poll() is None and time.monotonic() < deadline:
            time.sleep(0.05)
        assert marker.exists(), f"the upgrade did not start (exit {child.poll()})"
    finally:
        child.send_signal(signal.SIGKILL)
        child.wait()
    assert contents(url) == before
    assert version_facts(url) == (str(SCHEMA_VERSION), [migrations.revision_id(SCHEMA_VERSION)])
