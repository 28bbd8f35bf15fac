"""`hadim sweep` on a real local Ray instance: 4 short runs with the same D as runs made one by
one, a re-run that skips them, a killed worker's run retried from its checkpoint, and Ctrl-C.

Each sweep starts its own small Ray instance (--num-cpus 2); runs are a few 50-action episodes.
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from hadim_cli.app import app
from store.api import Store
from store.errors import StoreError

pytest.importorskip("ray")

ROOT = Path(__file__).resolve().parents[1]
SMALL = ["--set", "world.episode_length=50", "--eval-every", "0", "--num-cpus", "2"]
LONG = 300  # the subprocess sweeps: long enough to interrupt mid-way


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
def four_runs(tmp_path_factory) -> Path:
    from typer.testing import CliRunner

    store = tmp_path_factory.mktemp("sweep") / "s.db"
    result = CliRunner().invoke(app, [
        "sweep", "four", "--seeds", "0-1", "-c", str(ROOT / "configs/random-only.toml"),
        "-c", str(ROOT / "configs/goal-babbling-only.toml"), "-n", "100", *SMALL,
        "--eval-every", "100", "--set", 'evaluation.tasks=["move-robot"]', "--store", str(store)])
    assert result.exit_code == 0, (result.output, result.exception)
    return store


def test_four_runs_match_runs_made_one_by_one(four_runs, runner, tmp_path):
    with Store.open(four_runs, create=False) as st:
        runs = {r.name: r for r in st.list_runs()}
    assert sorted(runs) == sorted(f"four-{c}-s{s}" for c in ("random-only", "goal-babbling-only")
                                  for s in (0, 1))
    assert all(r.status == "finished" and r.iterations == 100 and r.lock is None
               for r in runs.values())
    assert runs["four-goal-babbling-only-s1"].config["learner"]["sigma"] == 1.0
    for seed in (0, 1):
        expected = _one_by_one(runner, tmp_path, seed, 100, "-c",
                               str(ROOT / "configs/goal-babbling-only.toml"))
        assert _digest(four_runs, f"four-goal-babbling-only-s{seed}") == expected
    assert _digest(four_runs, "four-random-only-s0") != _digest(four_runs, "four-random-only-s1")


def test_rerun_skips_finished_runs(four_runs, runner):
    with Store.open(four_runs, create=False) as st:
        before = {r.name: r.updated_at for r in st.list_runs()}
    result = runner.invoke(app, [
        "sweep", "four", "--seeds", "0-1", "-c", str(ROOT / "configs/random-only.toml"),
        "-c", str(ROOT / "configs/goal-babbling-only.toml"), "-n", "100", *SMALL,
        "--eval-every", "100", "--set", 'evaluation.tasks=["move-robot"]',
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


def _start(tmp_path: Path, name: str, seeds: str,
           store: Path | str | None = None) -> tuple[subprocess.Popen, Path | str]:
    store = store or tmp_path / "s.db"
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    proc = subprocess.Popen(
        [sys.executable, "-m", "hadim_cli.app", "sweep", name, "--seeds", seeds, "-n", str(LONG),
         *SMALL, "--store", str(store)], cwd=tmp_path, env=env, text=True,
        stdout=subprocess.PIPE, stderr=subprocess.PIPE)
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


def test_killed_worker_is_retried_from_its_checkpoint(runner, tmp_path):
    proc, store = _start(tmp_path, "kill", "3")

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
    assert _digest(store, "kill-default-s3") == _one_by_one(runner, tmp_path, 3, LONG)


def test_ctrl_c_pauses_every_run_checkpointed_and_a_rerun_finishes(tmp_path, postgres_url):
    """On a PostgreSQL store, the shared store of a cluster."""
    proc, store = _start(tmp_path, "stop", "3-4", postgres_url)

    def both_running(runs):
        return len([r for r in runs if r.lock and r.iterations > 0]) == 2

    _wait_for(store, proc, both_running, "two runs with stored episodes")
    proc.send_signal(signal.SIGINT)
    out, err = proc.communicate(timeout=300)
    assert proc.returncode == 0, err
    assert "stopped: every run is paused" in err
    with Store.open(store, create=False) as st:
        for run in st.list_runs():
            assert run.status == "paused" and run.lock is None, run
            assert 0 < run.iterations < LONG
            assert st.checkpoint_iterations(run.name)[-1] == run.iterations
    again, _ = _start(tmp_path, "stop", "3-4", postgres_url)
    out, err = again.communicate(timeout=300)
    assert again.returncode == 0, err
    assert out.count(f"finished\t{LONG}/{LONG}") == 2
