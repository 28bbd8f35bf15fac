"""The run lifecycle end to end (issue #4): train, resume, fork, pause, crash, lock, read.

Every test uses a real SQLite file in tmp_path. Most drive the CLI in-process with CliRunner;
the ones that need a real process (SIGKILL, SIGINT, a writer in another process) start
`python -m hadim_cli.app` and talk to it only through the store.
"""

from __future__ import annotations

import io
import json
import os
import re
import signal
import sqlite3
import subprocess
import sys
import time
import zlib
from pathlib import Path

import numpy as np
import pytest

from hadim_cli import runs
from hadim_cli.app import app
from hadim_store.api import Store

SEED = 5
# Long enough for a non-empty H (the first affordances appear at ~24 iterations); runs go in
# whole episodes, so N and N // 2 are multiples of the episode length used with them.
N = 300
SHORT_EPISODES = ("--set", "world.episode_length=50")
# The subprocess tests: long enough to interrupt mid-way, short enough to finish quickly.
N_PROC = 400

pytestmark = pytest.mark.scenario  # whole runs through the CLI: seconds each


# --------------------------------------------------------------------------- helpers

def invoke(runner, *args: object):
    return runner.invoke(app, [str(a) for a in args])


def ok(runner, *args: object):
    result = invoke(runner, *args)
    assert result.exit_code == 0, (args, result.stderr, result.exception)
    return result


def refused(runner, *args: object, match: str = ""):
    """The command fails with exactly one `error: ...` line on stderr and no traceback."""
    result = invoke(runner, *args)
    assert result.exit_code != 0, (args, result.stdout)
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: "), result.stderr
    assert "Traceback" not in result.output
    assert match in lines[0], lines[0]
    return lines[0]


def show(runner, store: Path, run: str) -> dict:
    return json.loads(ok(runner, "runs", "show", run, "--json", "--store", store).stdout)


def sha(runner, store: Path, run: str) -> str:
    return show(runner, store, run)["dataset_sha256"]


def affordances_json(runner, store: Path, run: str, *extra: object) -> list:
    return json.loads(ok(runner, "affordances", run, "--json", "--store", store, *extra).stdout)


def eval_score(runner, store: Path, run: str) -> float:
    out = ok(runner, "eval", run, "--task", "move-robot", "--json", "--store", store).stdout
    return json.loads(out)["score"]


def train(runner, store: Path, iterations: int, *extra: object) -> str:
    out = ok(runner, "train", "--iterations", iterations, "--eval-every", 0, "--store", store,
             *extra).stdout
    return out.strip().splitlines()[0]


def assert_contiguous(store_path: Path, run: str, iterations: int) -> None:
    with Store.open(store_path, create=False) as st:
        episodes = st.episodes(run)
        checkpoints = st.checkpoint_iterations(run)
    assert [e.index for e in episodes] == list(range(len(episodes)))
    first = 0
    for e in episodes:
        assert e.first_iteration == first
        first += len(e.actions)
    assert first == iterations
    assert len(set(checkpoints)) == len(checkpoints) and checkpoints[-1] == iterations


def integrity_ok(store_path: Path) -> None:
    con = sqlite3.connect(store_path)
    try:
        assert con.execute("PRAGMA integrity_check").fetchone()[0] == "ok"
        assert con.execute("PRAGMA foreign_key_check").fetchall() == []
    finally:
        con.close()


def start_training(store: Path, cwd: Path, iterations: int = 4000) -> subprocess.Popen:
    """`hadim train` in its own process; far more iterations than the tests let it run."""
    env = {k: v for k, v in os.environ.items() if k != runs.STORE_ENV}
    return subprocess.Popen(
        [sys.executable, "-m", "hadim_cli.app", "train", "--iterations", str(iterations),
         "--eval-every", "0", "--seed", str(SEED), "--store", str(store)],
        cwd=cwd, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
    )


def wait_for_iterations(store: Path, run: str, at_least: int, proc: subprocess.Popen,
                        timeout: float = 60.0) -> int:
    """Poll the store (as any reader would) until `run` has stored `at_least` iterations."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        assert proc.poll() is None, f"training ended early: {proc.communicate()}"
        if store.exists():
            try:
                with Store.open(store, create=False) as st:
                    done = st.get_run(run).iterations
                if done >= at_least:
                    return done
            except Exception:  # noqa: BLE001 — the store or run may not exist yet
                pass
        time.sleep(0.05)
    proc.kill()
    raise AssertionError(f"{run} did not reach {at_least} iterations in {timeout} s")


@pytest.fixture(scope="module")
def reference(tmp_path_factory) -> dict:
    """An uninterrupted run of N_PROC iterations (seed SEED), and its digest at N."""
    from typer.testing import CliRunner

    runner = CliRunner()
    store = tmp_path_factory.mktemp("reference") / "ref.sqlite"
    run = train(runner, store, N_PROC, "--seed", SEED)
    with Store.open(store, create=False) as st:
        return {"store": store, "run": run, "sha": st.dataset_sha256(run),
                "sha_n": st.dataset_sha256(run, N)}


# --------------------------------------------------------------------------- 1. determinism

def test_resume_continues_exactly(runner, tmp_path):
    store = tmp_path / "s.sqlite"
    whole = train(runner, store, N, "--seed", SEED, *SHORT_EPISODES)
    half = train(runner, store, N // 2, "--seed", SEED, *SHORT_EPISODES)
    assert show(runner, store, half)["iterations"] == N // 2
    ok(runner, "resume", half, "--iterations", N, "--eval-every", 0, "--store", store)

    a, b = show(runner, store, whole), show(runner, store, half)
    assert a["iterations"] == b["iterations"] == N
    assert a["status"] == b["status"] == "finished"
    assert a["dataset_sha256"] == b["dataset_sha256"]
    h = affordances_json(runner, store, whole)
    assert h, "H is empty: the comparison would prove little"
    # The robot's motion is read in its heading's frame from its first episodes on: the
    # resumed run restored a FramedModel from the checkpoint at N // 2.
    assert any(aff["frame"] is not None for aff in h)
    assert a["affordances"] == b["affordances"] == len(h)
    assert h == affordances_json(runner, store, half)
    timeline = ["affordances", "--timeline", "--json", "--store", store]
    assert ok(runner, *timeline[:1], whole, *timeline[1:]).stdout == \
        ok(runner, *timeline[:1], half, *timeline[1:]).stdout
    assert eval_score(runner, store, whole) == eval_score(runner, store, half)
    assert_contiguous(store, half, N)


def test_same_seed_same_data_other_seed_other_data(runner, tmp_path):
    store = tmp_path / "s.sqlite"
    kw = ("--set", "world.episode_length=20")
    a = train(runner, store, 60, "--seed", 1, *kw)
    b = train(runner, store, 60, "--seed", 1, *kw)
    c = train(runner, store, 60, "--seed", 2, *kw)
    assert sha(runner, store, a) == sha(runner, store, b) != sha(runner, store, c)


# --------------------------------------------------------------------------- 2. fork

def test_fork_with_same_config_continues_as_parent(runner, tmp_path):
    store = tmp_path / "s.sqlite"
    parent = train(runner, store, N, "--seed", SEED, *SHORT_EPISODES)
    before = show(runner, store, parent)
    child = ok(runner, "fork", parent, "--at", N // 2, "--store", store).stdout.strip()
    assert child != parent

    forked = show(runner, store, child)
    assert forked["parent"] == parent and forked["fork_iteration"] == N // 2
    assert forked["iterations"] == N // 2 and forked["status"] == "paused"
    with Store.open(store, create=False) as st:
        assert forked["dataset_sha256"] == st.dataset_sha256(parent, N // 2)
    after = show(runner, store, parent)
    assert {k: v for k, v in after.items() if k != "updated_at"} == \
        {k: v for k, v in before.items() if k != "updated_at"}
    assert after["updated_at"] == before["updated_at"]

    ok(runner, "resume", child, "--iterations", N, "--eval-every", 0, "--store", store)
    assert sha(runner, store, child) == before["dataset_sha256"]
    assert affordances_json(runner, store, child) == affordances_json(runner, store, parent)
    assert show(runner, store, parent) == after
    assert_contiguous(store, child, N)


def test_fork_with_a_new_seed_diverges(runner, tmp_path):
    store = tmp_path / "s.sqlite"
    kw = ("--set", "world.episode_length=20")
    parent = train(runner, store, 80, "--seed", 1, *kw)
    child = ok(runner, "fork", parent, "--at", 40, "--seed", 9, "--store", store).stdout.strip()
    ok(runner, "resume", child, "--iterations", 80, "--eval-every", 0, "--store", store)
    with Store.open(store, create=False) as st:
        assert st.dataset_sha256(child, 40) == st.dataset_sha256(parent, 40)
        assert st.dataset_sha256(child) != st.dataset_sha256(parent)


# --------------------------------------------------------------------------- 3. evaluation

def test_evaluation_changes_nothing_of_the_learner(runner, tmp_path):
    store = tmp_path / "s.sqlite"
    kw = ("--iterations", 100, "--seed", SEED, "--set", "world.episode_length=25",
          "--set", 'evaluation.tasks=["move-robot"]', "--store", store)
    off = ok(runner, "train", *kw, "--eval-every", 0).stdout.strip()
    on = ok(runner, "train", *kw, "--eval-every", 50).stdout.strip()
    assert affordances_json(runner, store, off), "H is empty: evaluation would do nothing"
    with Store.open(store, create=False) as st:
        assert [(e.iteration, e.task) for e in st.evaluations(on)] == \
            [(50, "move-robot"), (100, "move-robot")]
        assert st.evaluations(off) == []
    assert sha(runner, store, on) == sha(runner, store, off)
    assert affordances_json(runner, store, on) == affordances_json(runner, store, off)
    assert show(runner, store, on)["scores"].keys() == {"move-robot"}


# --------------------------------------------------------------------------- 4 & 7. crash

def test_sigkill_then_resume_recovers(runner, tmp_path, reference):
    store = tmp_path / "s.sqlite"
    proc = start_training(store, tmp_path)
    try:
        wait_for_iterations(store, "run-1", 100, proc)
        # 7. Reading commands work on a store another process is writing.
        listed = json.loads(ok(runner, "runs", "list", "--json", "--store", store).stdout)
        assert [(r["name"], r["status"]) for r in listed] == [("run-1", "running")]
        live = show(runner, store, "run-1")
        assert live["status"] == "running" and 100 <= live["iterations"] <= N_PROC
        ok(runner, "runs", "list", "--store", store)
        ok(runner, "runs", "show", "run-1", "--store", store)
        ok(runner, "affordances", "run-1", "--store", store)
        ok(runner, "affordances", "run-1", "--timeline", "--store", store)
        wait_for_iterations(store, "run-1", 200, proc)
    finally:
        proc.send_signal(signal.SIGKILL)
        proc.wait(timeout=30)
    assert proc.returncode == -signal.SIGKILL

    with Store.open(store, create=False) as st:
        record = st.get_run("run-1")
    assert record.status.value == "running" and record.lock is not None  # a dead holder
    assert 200 <= record.iterations < N_PROC
    integrity_ok(store)

    ok(runner, "resume", "run-1", "--iterations", N_PROC, "--eval-every", 0, "--store", store)
    info = show(runner, store, "run-1")
    assert info["status"] == "finished" and info["iterations"] == N_PROC
    with Store.open(store, create=False) as st:
        assert st.get_run("run-1").lock is None
    integrity_ok(store)
    assert_contiguous(store, "run-1", N_PROC)
    assert info["dataset_sha256"] == reference["sha"]


# --------------------------------------------------------------------------- 5. Ctrl-C

def test_ctrl_c_pauses_after_the_episode(runner, tmp_path, reference):
    store = tmp_path / "s.sqlite"
    proc = start_training(store, tmp_path, iterations=N_PROC)
    try:
        wait_for_iterations(store, "run-1", 100, proc)
        proc.send_signal(signal.SIGINT)
        out, err = proc.communicate(timeout=60)
    finally:
        if proc.poll() is None:
            proc.kill()
    assert proc.returncode == 130, err  # a paused run is told from a finished one
    assert "Traceback" not in err
    # One command to continue, the same in the pause line and in the summary's "next".
    hint = f"hadim resume run-1 --store {store}"
    assert f"continue with: {hint}\n" in err and f"    {hint}\n" in err, err
    assert len(set(re.findall(r"hadim resume [^\n]*", err))) == 1, err
    assert out.strip() == "run-1"

    info = show(runner, store, "run-1")
    assert info["status"] == "paused" and 100 <= info["iterations"] < N_PROC
    assert info["iterations"] % 100 == 0  # stopped at an episode's end
    with Store.open(store, create=False) as st:
        assert st.get_run("run-1").lock is None
    # Without --iterations: to the iterations it was started for.
    ok(runner, "resume", "run-1", "--eval-every", 0, "--store", store)
    info = show(runner, store, "run-1")
    assert info["status"] == "finished" and info["iterations"] == N_PROC
    assert info["dataset_sha256"] == reference["sha"]
    assert_contiguous(store, "run-1", N_PROC)


# --------------------------------------------------------------------------- 6. locking

def test_a_run_is_driven_by_one_process_at_a_time(runner, tmp_path):
    store = tmp_path / "s.sqlite"
    run = train(runner, store, 40, "--set", "world.episode_length=20")
    # Another live process of this host holds the lock: this test's own pid, under an owner
    # string that is not the one the in-process CLI will use.
    holder = f"{runs.owner_id()}-other"
    with Store.open(store, create=False) as st:
        assert st.acquire_lock(run, holder) is None
        digest = st.dataset_sha256(run)
    line = refused(runner, "resume", run, "--iterations", 80, "--eval-every", 0,
                   "--store", store, match="in use")
    assert str(os.getpid()) in line
    info = show(runner, store, run)
    assert info["iterations"] == 40 and info["dataset_sha256"] == digest
    assert info["status"] == "finished"  # the refused command changed nothing
    with Store.open(store, create=False) as st:
        assert st.get_run(run).lock.owner == holder
        assert st.release_lock(run, holder)
    ok(runner, "resume", run, "--iterations", 80, "--eval-every", 0, "--store", store)
    assert show(runner, store, run)["iterations"] == 80


def test_a_second_process_is_refused(runner, tmp_path):
    """The same, with the holder a real other process: a `hadim resume` subprocess."""
    store = tmp_path / "s.sqlite"
    run = train(runner, store, 40, "--set", "world.episode_length=20")
    with Store.open(store, create=False) as st:
        st.acquire_lock(run, runs.owner_id())
    try:
        env = {k: v for k, v in os.environ.items() if k != runs.STORE_ENV}
        done = subprocess.run(
            [sys.executable, "-m", "hadim_cli.app", "resume", run, "--iterations", "80",
             "--eval-every", "0", "--store", str(store)],
            cwd=tmp_path, env=env, capture_output=True, text=True, timeout=120,
        )
    finally:
        with Store.open(store, create=False) as st:
            st.release_lock(run, runs.owner_id())
    assert done.returncode == 2
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: ") and "in use" in lines[0]
    assert show(runner, store, run)["iterations"] == 40


# --------------------------------------------------------------------------- 9. no pickle

class _Payload:
    """Would create `marker` if anything ever unpickled it."""

    def __init__(self, marker: Path):
        self.marker = marker

    def __reduce__(self):
        return (os.system, (f"touch {self.marker}",))


def test_a_crafted_checkpoint_blob_is_refused(runner, tmp_path):
    store = tmp_path / "s.sqlite"
    run = train(runner, store, 60, "--set", "world.episode_length=20")
    marker = tmp_path / "pwned"
    evil = np.empty(1, dtype=object)
    evil[0] = _Payload(marker)
    buffer = io.BytesIO()
    np.save(buffer, evil, allow_pickle=True)
    blob = buffer.getvalue()

    con = sqlite3.connect(store)
    try:
        latest = con.execute("SELECT c.id FROM checkpoints c JOIN runs r ON r.id = c.run_id "
                             "WHERE r.name = ? ORDER BY c.iteration DESC LIMIT 1",
                             (run,)).fetchone()[0]
        rows = con.execute("SELECT key, kind FROM checkpoint_items WHERE checkpoint_id = ? "
                           "AND kind != 'json' ORDER BY key", (latest,)).fetchall()
        assert rows, "the checkpoint holds no arrays"
        key, kind = next((k, c) for k, c in rows if k.endswith("rows.t"))
        data = zlib.compress(blob) if kind == "npy+zlib" else blob
        con.execute("UPDATE checkpoint_items SET data = ? WHERE checkpoint_id = ? AND key = ?",
                    (data, latest, key))
        con.commit()
    finally:
        con.close()

    digest = sha(runner, store, run)
    refused(runner, "resume", run, "--iterations", 100, "--eval-every", 0, "--store", store,
            match="refused")
    # H's table is read from the episodes' records, and the checkpoint it stands for is read
    # back with it: the blob is refused there too, as by what restores the session (`--pa`).
    refused(runner, "affordances", run, "--store", store, match="refused")
    refused(runner, "affordances", run, "--pa", "--store", store, match="refused")
    refused(runner, "eval", run, "--task", "move-robot", "--store", store, match="refused")
    assert not marker.exists()
    info = show(runner, store, run)
    assert info["iterations"] == 60 and info["dataset_sha256"] == digest
    assert info["status"] == "finished"
    with Store.open(store, create=False) as st:
        assert st.get_run(run).lock is None and st.evaluations(run) == []
    # The plain numpy reader agrees: with allow_pickle=False it refuses too.
    with pytest.raises(ValueError):
        np.load(io.BytesIO(blob), allow_pickle=False)
    assert not marker.exists()


def test_the_lock_is_kept_alive_through_a_long_step(runner, tmp_path, monkeypatch):
    """A step longer than the lock timeout (here a slow evaluation) must not let another
    process take the lock over as stale: the trainer's heartbeat thread keeps it fresh."""
    import threading

    from hadim_store.errors import RunLocked

    # Margins wide enough for a loaded CI machine: beats every timeout/4 = 0.5 s, one slow
    # step of 2.5 × timeout; the thief polls throughout.
    timeout = 2.0
    monkeypatch.setattr(runs, "open_store", lambda option, create=True, writes=True, run=None:
                        Store.open(runs.store_location(option), create=create,
                                   lock_timeout=timeout))
    slept = []

    def slow_evaluation(session, tasks):
        if not slept:  # one step longer than the timeout is enough to show it
            slept.append(True)
            time.sleep(2.5 * timeout)
        return {}

    monkeypatch.setattr(runs, "evaluate_tasks", slow_evaluation)
    store = tmp_path / "s.sqlite"
    with Store.open(store) as st:
        st.create_run(config={}, seed=0, name="decoy")  # the store exists for the thief
    stolen, done = [], threading.Event()

    def thief() -> None:
        with Store.open(store, create=False, lock_timeout=timeout) as st:
            while not done.wait(0.1):
                try:
                    if any(r.name == "run-1" and r.lock is not None for r in st.list_runs()):
                        # None: the lock was free (the trainer released it between our two
                        # reads, at the end of the run); a LockInfo: a live lock taken as stale.
                        if st.acquire_lock("run-1", "thief") is not None:
                            stolen.append(True)
                        st.release_lock("run-1", "thief")
                        return
                except RunLocked:
                    pass

    thread = threading.Thread(target=thief)
    thread.start()
    try:
        ok(runner, "train", "--iterations", 20, "--set", "world.episode_length=20",
           "--eval-every", 20, "--store", store)
    finally:
        done.set()
        thread.join()
    assert not stolen
    assert show(runner, store, "run-1")["status"] == "finished"


def test_a_second_ctrl_c_aborts_the_episode(runner, tmp_path, monkeypatch):
    """Two Ctrl-C in the middle of an episode: that episode is dropped, the run is paused at
    the last stored episode, exit 130, and resuming gives the uninterrupted run's D."""
    from hadim_cli.session import TrainingActuator

    act = TrainingActuator.act

    def act_and_interrupt(self, action):
        if len(self.dataset) == 30:  # mid-way through the second episode of 20
            os.kill(os.getpid(), signal.SIGINT)
            os.kill(os.getpid(), signal.SIGINT)
        return act(self, action)

    store = tmp_path / "s.sqlite"
    kw = ("--seed", SEED, "--set", "world.episode_length=20", "--eval-every", 0,
          "--store", store)
    monkeypatch.setattr(TrainingActuator, "act", act_and_interrupt)
    handler = signal.getsignal(signal.SIGINT)  # ignored, in a job started in the background
    result = invoke(runner, "train", "--iterations", 60, *kw)
    monkeypatch.setattr(TrainingActuator, "act", act)
    assert result.exit_code == 130, (result.stderr, result.exception)
    assert "Traceback" not in result.output
    assert f"aborted at iteration 20 of 60; continue with: hadim resume run-1 " \
           f"--store {store}" in result.stderr
    info = show(runner, store, "run-1")
    assert info["status"] == "paused" and info["iterations"] == 20
    assert signal.getsignal(signal.SIGINT) is handler

    ok(runner, "resume", "run-1", "--iterations", 60, "--eval-every", 0, "--store", store)
    ok(runner, "train", "--iterations", 60, *kw)
    assert sha(runner, store, "run-1") == sha(runner, store, "run-2")
    assert_contiguous(store, "run-1", 60)
