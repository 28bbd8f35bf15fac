"""`hadim sweep` on a real Ray cluster: 4 short runs with the same D as runs made one by one, a
re-run that skips them, a killed worker's run retried from its checkpoint, and Ctrl-C.

The sweeps join one local Ray head that this module starts (`ray_cluster.py`): starting Ray is
most of a small sweep's cost, and the five sweeps here used to start five instances.
Every sweep that starts tasks runs in a process of its own (`_sweep`, `_start`).
tests/baselines/test_sweep.py runs its sweep on a local instance of its own, the default
without --address. Runs are a few 50-action episodes.
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path

import pytest
from typer.testing import CliRunner

from hadim_cli.app import app
from hadim_store.api import Store
from hadim_store.errors import StoreError

pytest.importorskip("ray")

ROOT = Path(__file__).resolve().parents[1]
SMALL = ["--set", "world.episode_length=50", "--eval-every", "0"]
LONG = 300  # the subprocess sweeps: six episodes, long enough to interrupt mid-way


@pytest.fixture(scope="module")
def ray_address() -> Iterator[list[str]]:
    """`--address` of a Ray head shared by the module's sweeps."""
    import ray_cluster

    saved = {key: os.environ.get(key) for key in ray_cluster.ENV}
    os.environ.update(ray_cluster.ENV)  # the drivers: this process and the subprocess sweeps
    cluster = ray_cluster.start(num_cpus=2)
    try:
        yield ["--address", cluster.address]
    finally:
        cluster.stop()
        for key, value in saved.items():
            if value is None:
                os.environ.pop(key, None)
            else:
                os.environ[key] = value


def _digest(store: Path, run: str) -> str:
    with Store.open(store, create=False) as st:
        return st.dataset_sha256(run)


def _one_by_one(runner, tmp_path: Path, seed: int, iterations: int, *args: str) -> str:
    """D's digest of the same run made with `hadim train`."""
    store = tmp_path / f"one-{seed}.db"
    result = runner.invoke(app, ["train", "-n", str(iterations), "--seed", str(seed),
                                 "--set", "world.episode_length=50", "--eval-every", "0",
                                 *args, "--name", "ref", "--store", str(store)])
    assert result.exit_code == 0, result.output
    return _digest(store, "ref")


@pytest.fixture(scope="module")
def reference(tmp_path_factory) -> str:
    """D's digest of seed 3 at LONG made with `hadim train`, what the interrupted sweeps give."""
    return _one_by_one(CliRunner(), tmp_path_factory.mktemp("reference"), 3, LONG)


@pytest.fixture(scope="module")
def four_runs(tmp_path_factory, ray_address) -> Path:
    where = tmp_path_factory.mktemp("sweep")
    store = where / "s.db"
    done = _sweep(where, [
        "four", "--seeds", "0-1", "-c", str(ROOT / "configs/random-only.toml"),
        "-c", str(ROOT / "configs/goal-babbling-only.toml"), "-n", "100", *SMALL,
        *ray_address, "--eval-every", "100", "--set", 'evaluation.tasks=["move-robot"]',
        "--store", str(store)])
    assert done.returncode == 0, (done.stdout, done.stderr)
    return store


def test_four_runs_match_runs_made_one_by_one(four_runs, runner, tmp_path):
    with Store.open(four_runs, create=False) as st:
        runs = {r.name: r for r in st.list_runs()}
    assert sorted(runs) == sorted(f"four-{c}-s{s}" for c in ("random-only", "goal-babbling-only")
                                  for s in (0, 1))
    assert all(r.status == "finished" and r.iterations == 100 and r.lock is None
               for r in runs.values())
    assert runs["four-goal-babbling-only-s1"].config["learner"]["sigma"] == 1.0
    expected = _one_by_one(runner, tmp_path, 1, 100, "-c",
                           str(ROOT / "configs/goal-babbling-only.toml"))
    assert _digest(four_runs, "four-goal-babbling-only-s1") == expected
    assert _digest(four_runs, "four-random-only-s0") != _digest(four_runs, "four-random-only-s1")


def test_rerun_skips_finished_runs(four_runs, runner, ray_address):
    with Store.open(four_runs, create=False) as st:
        before = {r.name: r.updated_at for r in st.list_runs()}
    result = runner.invoke(app, [
        "sweep", "four", "--seeds", "0-1", "-c", str(ROOT / "configs/random-only.toml"),
        "-c", str(ROOT / "configs/goal-babbling-only.toml"), "-n", "100", *SMALL,
        *ray_address, "--eval-every", "100", "--set", 'evaluation.tasks=["move-robot"]',
        "--store", str(four_runs)])
    assert result.exit_code == 0, result.output
    assert result.stdout.count("finished\t100/100") == 4
    with Store.open(four_runs, create=False) as st:
        assert {r.name: r.updated_at for r in st.list_runs()} == before


def test_report_from_the_sweep(four_runs, runner, tmp_path):
    out = tmp_path / "report"
    result = runner.invoke(app, ["report", "four", "--out", str(out), "--store", str(four_runs)])
    assert result.exit_code == 0, (result.output, result.exception)
    runs = [f"four-{c}-s{s}" for c in ("random-only", "goal-babbling-only") for s in (0, 1)]
    assert sorted(result.stdout.split()) == sorted(
        [str(out / f) for f in ("summary.json", "tables.md", "competence.png")]
        + [str(out / "timelines" / f"{r}.png") for r in runs])
    for png in [out / "competence.png", *(out / "timelines").iterdir()]:
        assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    summary = json.loads((out / "summary.json").read_text())
    assert sorted(summary["configs"]) == ["goal-babbling-only", "random-only"]
    with Store.open(four_runs, create=False) as st:
        scores = [e.score for r in runs[:2] for e in st.evaluations(r)]
        for run in runs:
            assert summary["runs"][run]["dataset_sha256"] == st.dataset_sha256(run)
    cell = summary["configs"]["random-only"]["move-robot"]["100"]
    assert cell["n"] == 2 and cell["mean"] == pytest.approx(sum(scores) / 2)
    tables = (out / "tables.md").read_text()
    assert "| random-only | move-robot | " in tables and "four-random-only-s1 |" in tables
    refused = runner.invoke(app, ["report", "nope", "--out", str(out), "--store", str(four_runs)])
    assert refused.exit_code == 2
    assert refused.stderr.strip() == f"error: no sweep named 'nope' in {four_runs} (sweeps: four)"


def _default_sigint() -> None:
    """In the sweep's process before it starts: a shell's background job (`pytest &`, a CI
    script) ignores SIGINT and its children inherit that, so the Ctrl-C the test sends would be
    lost and the sweep would run to its end."""
    signal.signal(signal.SIGINT, signal.SIG_DFL)


def _sweep(cwd: Path, args: list[str]) -> subprocess.CompletedProcess:
    """`hadim sweep ARGS` in a process of its own: a Ray driver in this test process would
    inherit what earlier tests' Ray left in it (in the full suite, after
    tests/baselines/test_sweep.py's in-process local instance, the tasks of a sweep run here
    were cancelled: "The actor never ran")."""
    return subprocess.run([sys.executable, "-m", "hadim_cli.app", "sweep", *args], cwd=cwd,
                          env=dict(os.environ, PYTHONPATH=str(ROOT)), text=True,
                          capture_output=True, timeout=600)


def _start(tmp_path: Path, name: str, seeds: str, ray_address: list[str],
           store: Path | str | None = None) -> tuple[subprocess.Popen, Path | str]:
    store = store or tmp_path / "s.db"
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    proc = subprocess.Popen(
        [sys.executable, "-m", "hadim_cli.app", "sweep", name, "--seeds", seeds, "-n", str(LONG),
         *SMALL, *ray_address, "--store", str(store)], cwd=tmp_path, env=env, text=True,
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, preexec_fn=_default_sigint)
    return proc, store


def _wait_for(store: Path | str, proc: subprocess.Popen, ready, what: str):
    deadline = time.monotonic() + 240
    while time.monotonic() < deadline:
        assert proc.poll() is None, proc.communicate()
        try:
            with Store.open(store, create=False) as st:
                found = ready(st.list_runs())
        except StoreError:  # not created yet
            found = None
        if found:
            return found
        time.sleep(0.2)
    proc.kill()
    pytest.fail(f"timed out waiting for {what}")


def test_killed_worker_is_retried_from_its_checkpoint(tmp_path, ray_address, reference):
    proc, store = _start(tmp_path, "kill", "3", ray_address)

    def mid_run(runs):
        return next((r for r in runs if r.lock and 0 < r.iterations < LONG), None)

    victim = _wait_for(store, proc, mid_run, "a run with stored episodes")
    assert victim.lock.pid != proc.pid
    os.kill(victim.lock.pid, signal.SIGKILL)
    out, err = proc.communicate(timeout=300)
    assert proc.returncode == 0, err
    with Store.open(store, create=False) as st:
        run = st.get_run("kill-default-s3")
        assert run.status == "finished" and run.iterations == LONG and run.lock is None
        assert [e.index for e in st.episodes(run.name)] == list(range(LONG // 50))
    assert _digest(store, "kill-default-s3") == reference


def test_ctrl_c_pauses_every_run_checkpointed_and_a_rerun_finishes(
        tmp_path, postgres_url, ray_address, reference):
    """On a PostgreSQL store, the shared store of a cluster."""
    proc, store = _start(tmp_path, "stop", "3-4", ray_address, postgres_url)

    def both_started(runs):
        # Both tasks hold their run. A task reads the stop flag only after an episode, so each
        # run stores at least one; and the stop has a run's six episodes to arrive in (waiting
        # for stored episodes instead left it as few as one on a fast machine).
        return len([r for r in runs if r.lock]) == 2

    _wait_for(store, proc, both_started, "two runs started")
    proc.send_signal(signal.SIGINT)
    out, err = proc.communicate(timeout=300)
    assert proc.returncode == 0, err
    assert "stopped: every run is paused" in err
    with Store.open(store, create=False) as st:
        for run in st.list_runs():
            assert run.status == "paused" and run.lock is None, run
            assert 0 < run.iterations < LONG
            assert st.checkpoint_iterations(run.name)[-1] == run.iterations
    again = _sweep(tmp_path, ["stop", "--seeds", "3-4", "-n", str(LONG), *SMALL, *ray_address,
                              "--store", str(store)])
    assert again.returncode == 0, again.stderr
    assert again.stdout.count(f"finished\t{LONG}/{LONG}") == 2
    assert _digest(store, "stop-default-s3") == reference
