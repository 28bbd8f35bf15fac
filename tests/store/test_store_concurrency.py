"""8 processes writing runs into one store at once, on file SQLite and on PostgreSQL: no
"database is locked", no lost or duplicated episode, and the run lock still admits one driver."""

from __future__ import annotations

import subprocess
import sys
import time
from pathlib import Path

import pytest

from hadim_store import Store

WRITERS = 8
EPISODES = 6
SCRIPT = Path(__file__).with_name("concurrent_writer.py")


@pytest.mark.parametrize("backend", ["file", "postgresql"])
def test_eight_writers_at_once(backend, request, tmp_path, make_episode):
    url = (str(tmp_path / "shared.db") if backend == "file"
           else request.getfixturevalue("postgres_url"))
    with Store.open(url) as store:
        store.create_run(config={}, seed=0, name="contended")
    writers = [
        subprocess.Popen([sys.executable, str(SCRIPT), url, str(tmp_path), str(i), str(EPISODES),
                          str(WRITERS)], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                         text=True)
        for i in range(WRITERS)
    ]
    deadline = time.monotonic() + 120
    while len(list(tmp_path.glob("ready-*"))) < WRITERS and time.monotonic() < deadline:
        time.sleep(0.01)  # all imported: then they start at the same moment
    (tmp_path / "go").touch()
    results = [w.communicate(timeout=120) for w in writers]
    for writer, (_, err) in zip(writers, results, strict=True):
        assert writer.returncode == 0, err
        assert "locked" not in err
    outcomes = sorted(out.split()[1] for out, _ in results)
    assert outcomes == ["refused"] * (WRITERS - 1) + ["won"]

    with Store.open(url, create=False) as store, Store.open("sqlite://") as expected:
        runs = {r.name: r for r in store.list_runs()}
        assert sorted(runs) == sorted(["contended"] + [f"run-{i}" for i in range(1, 9)])
        for name, run in runs.items():
            if name == "contended":
                continue
            writer = run.config["writer"]
            assert [e.index for e in store.episodes(name)] == list(range(EPISODES))
            assert run.iterations == 4 * EPISODES and run.lock is None
            reference = expected.create_run(config={}, seed=0, name=f"w{writer}")
            for k in range(EPISODES):
                expected.write_episode(reference.name, make_episode(k, 4 * k, seed=writer))
            assert store.dataset_sha256(name) == expected.dataset_sha256(reference.name)
        assert runs["contended"].lock is None and runs["contended"].iterations == 0
