"""The light reader (hadim_store.reader: sqlite3 alone) reads what the store reads, fails as
the store fails, and opens nothing but a sound store file of this hadim's schema."""

from __future__ import annotations

import os
import shutil
import sqlite3
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from hadim_store import (
    AffordanceEvent,
    AffordanceStat,
    EpisodeWrite,
    RunLocked,
    Store,
    StoreError,
    UnknownRun,
)
from hadim_store.locking import this_host
from hadim_store.reader import StoreReader

FIXTURES = Path(__file__).resolve().parents[1] / "fixtures"


def _episode(index: int, n: int = 5) -> EpisodeWrite:
    """An episode whose checkpoint grows as a learner's does: rows appended, a list extended,
    weights replaced; so the store writes prefix deltas, whole values and snapshots."""
    rng = np.random.default_rng(index)
    end = (index + 1) * n
    events = [AffordanceEvent(end - 1 - k, k, "created" if k else "context_replaced", "action",
                              f"space-{k}", ("a", f"b{k}"), None if k else 0.25,
                              {"added": [k], "why": "ü"}) for k in range(index % 3)]
    stats = [AffordanceStat(end, k, 0.5 / (k + 1), index + k, None if k == 2 else 1.5)
             for k in range(3, -1, -1)]
    return EpisodeWrite(
        index=index, first_iteration=index * n, actions=rng.uniform(size=(n, 2)),
        contexts=rng.uniform(size=(n, 3)), outcomes=rng.uniform(size=(n, 3)),
        events=events, stats=stats,
        extra={"hierarchy": [{"id": i} for i in range(index)], "target": 100},
        checkpoint_arrays={"rows": np.arange(2 * end, dtype=np.float32).reshape(end, 2),
                           "weights": rng.normal(size=(3, 3)), "count": np.array(end)},
        checkpoint_json={"events": list(range(end)), "rng": {"state": index}},
    )


@pytest.fixture
def path(tmp_path) -> Path:
    """run-1: 10 episodes, a snapshot every 4 checkpoints; its fork `child`; `empty`."""
    where = tmp_path / "store.db"
    with Store.open(where, snapshot_every=4) as st:
        st.create_run(config={"a": 1}, seed=3, versions={"hadim": "x"})
        for index in range(10):
            st.write_episode("run-1", _episode(index))
            for task in ("push", "move")[: index % 3]:  # tasks out of order within an iteration
                st.add_evaluation("run-1", 5 * index, task, 0.1 * index, [{"error": 0.5}])
        st.fork("run-1", at_iteration=22, config={"a": 2}, seed=4, name="child")
        st.create_run(config={}, seed=0, name="empty")
        st.acquire_lock("child", "someone")  # held by this live process
    return where


def _same_checkpoint(a, b) -> None:
    assert (a is None) == (b is None)
    if a is None:
        return
    assert (a.iteration, a.episode_index, a.created_at, a.json) == \
        (b.iteration, b.episode_index, b.created_at, b.json)
    assert list(a.arrays) == list(b.arrays)
    for key, array in a.arrays.items():
        other = b.arrays[key]
        assert array.dtype == other.dtype and array.shape == other.shape, key
        assert np.array_equal(array, other) and not array.flags.writeable, key


def _same_episodes(a, b) -> None:
    assert [(e.index, e.first_iteration, e.extra) for e in a] == \
        [(e.index, e.first_iteration, e.extra) for e in b]
    for x, y in zip(a, b, strict=True):
        for field in ("actions", "contexts", "outcomes"):
            assert np.array_equal(getattr(x, field), getattr(y, field)), field


def test_the_reader_reads_what_the_store_reads(path):
    with Store.open(path, create=False) as st, StoreReader.open(path) as reader:
        assert reader.list_runs() == st.list_runs()
        for run in ("run-1", "child", "empty"):
            assert reader.get_run(run) == st.get_run(run)
            assert reader.checkpoint_iterations(run) == st.checkpoint_iterations(run)
            for task in (None, "push", "nope"):
                assert reader.evaluations(run, task) == st.evaluations(run, task), (run, task)
            for at in (None, 0, 4, 5, 22, 23, 39, 50, 1000):
                assert reader.episode_extra(run, at) == st.episode_extra(run, at), (run, at)
                _same_episodes(reader.episodes(run, at), st.episodes(run, at))
                _same_checkpoint(reader.checkpoint(run, at), st.checkpoint(run, at))
                for aid in (None, 0, 2):
                    assert reader.events(run, at, affordance_id=aid) == \
                        st.events(run, at, affordance_id=aid), (run, at, aid)
                    assert reader.stats(run, at, affordance_id=aid) == \
                        st.stats(run, at, affordance_id=aid), (run, at, aid)
                assert reader.dataset_sha256(run, at) == st.dataset_sha256(run, at), (run, at)
                for mine, theirs in zip(reader.dataset(run, at), st.dataset(run, at),
                                        strict=True):
                    assert mine.dtype == theirs.dtype and np.array_equal(mine, theirs)
                    assert mine.flags.writeable == theirs.flags.writeable
    assert st.get_run("child").lock is not None and st.get_run("child").parent == "run-1"


def test_the_reader_fails_as_the_store_fails(path):
    with Store.open(path, create=False) as st, StoreReader.open(path) as reader:
        for call in (lambda s: s.get_run("run-2"), lambda s: s.episode_extra("chld"),
                     lambda s: s.checkpoint("nope"), lambda s: s.episode_extra("run-1", -1),
                     lambda s: s.checkpoint_iterations("nope"), lambda s: s.events("nope"),
                     lambda s: s.stats("run-1", -2), lambda s: s.evaluations("nope"),
                     lambda s: s.dataset_sha256("run-1", 1.5),
                     lambda s: s.checkpoint("run-1", True)):
            with pytest.raises(StoreError) as by_store:
                call(st)
            with pytest.raises(StoreError) as by_reader:
                call(reader)
            assert (type(by_reader.value), str(by_reader.value)) == \
                (type(by_store.value), str(by_store.value))
        assert isinstance(by_store.value, StoreError)
        for name in ("run-1", "no spaces"):  # a name taken, a name no run may have
            with pytest.raises(StoreError) as by_store:
                st.create_run(config={}, seed=0, name=name)
            with pytest.raises(StoreError) as by_reader:
                reader.refuse_taken(name)
            assert str(by_reader.value) == str(by_store.value)
        reader.refuse_taken("run-3")  # free
        with pytest.raises(UnknownRun, match="did you mean run-1"):
            reader.get_run("run-2")
        # A live holder: the store's refusal, word for word up to the heartbeat's age.
        with pytest.raises(RunLocked) as by_store:
            st.acquire_lock("child", "another")
        for refuses in (st, reader):
            with pytest.raises(RunLocked) as by_reader:
                refuses.refuse_if_locked("child")
            assert str(by_reader.value).split("last heartbeat")[0] == \
                str(by_store.value).split("last heartbeat")[0]
            refuses.refuse_if_locked("run-1")  # not locked
    con = sqlite3.connect(path)
    con.execute("UPDATE runs SET lock_heartbeat = ?, lock_host = 'elsewhere' WHERE name = "
                "'child'", (time.time() - 3600,))
    con.commit()
    con.close()
    with StoreReader.open(path) as reader, Store.open(path, create=False) as st:
        for refuses in (st, reader):
            refuses.refuse_if_locked("child")  # stale: whoever writes next takes it over
        assert st.get_run("child").lock is not None  # and nothing was written


def _files(folder: Path) -> dict[str, bytes]:
    return {p.name: p.read_bytes() if p.is_file() else b"" for p in sorted(folder.iterdir())}


@pytest.mark.parametrize("case", ["not sqlite", "empty sqlite", "foreign", "older schema",
                                  "newer schema", "damaged page", "directory", "missing"])
def test_the_reader_opens_only_a_sound_store_of_this_schema(path, tmp_path, case):
    """Anything else is the full store's to upgrade, refuse or report: the reader says None,
    and leaves the file as it found it, with nothing beside it."""
    folder = tmp_path / "case"
    folder.mkdir()
    target = folder / "x.db"
    if case == "not sqlite":
        target.write_bytes(b"hello" * 100)
    elif case in ("empty sqlite", "foreign"):
        con = sqlite3.connect(target)
        if case == "foreign":
            con.execute("CREATE TABLE meta (key TEXT, value TEXT)")
            con.execute("INSERT INTO meta VALUES ('application', 'other')")
        con.commit()
        con.close()
    elif case == "older schema":
        shutil.copy(FIXTURES / "store_v2.sqlite", target)
    elif case == "newer schema":
        shutil.copy(path, target)
        con = sqlite3.connect(target)
        con.execute("UPDATE meta SET value = '99' WHERE key = 'schema_version'")
        con.commit()
        con.close()
    elif case == "damaged page":
        data = bytearray(path.read_bytes())
        data[len(data) // 2:len(data) // 2 + 4096] = b"\xa5" * 4096
        target.write_bytes(bytes(data))
    elif case == "directory":
        target.mkdir()
    before = _files(folder)
    assert StoreReader.open(target) is None
    assert _files(folder) == before


def test_the_reader_imports_no_sqlalchemy(path):
    script = ("import sys\n"
              "from hadim_store.reader import StoreReader\n"
              "with StoreReader.open(__import__('pathlib').Path(sys.argv[1])) as r:\n"
              "    r.get_run('run-1'); r.episode_extra('run-1')\n"
              "    r.checkpoint('run-1'); r.episodes('run-1'); r.refuse_if_locked('run-1')\n"
              "print(sorted(m for m in sys.modules if m.split('.')[0] in "
              "('sqlalchemy', 'alembic')))\n")
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    out = subprocess.run([sys.executable, "-c", script, str(path)], capture_output=True,
                         text=True, check=True, env=env)
    assert out.stdout.strip() == "[]", out.stdout + out.stderr
    assert this_host()  # the holder of `child` was this host's live process
