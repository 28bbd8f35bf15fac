"""`hadim sweep` before any Ray task: the grid, names, settings, and refusals (one line, exit 2,
nothing stored changed)."""

from __future__ import annotations

import json
import os
import socket
import sqlite3
import subprocess
import sys
from pathlib import Path

import pytest

from hadim_cli.app import app
from hadim_cli.errors import HadimError
from hadim_cli.sweep.plan import RunKind, build_plan, parse_grid, parse_seeds
from hadim_store.api import Store

SMALL = ["--set", "world.episode_length=50", "-n", "100", "--eval-every", "0"]
ROOT = Path(__file__).resolve().parents[1]


def test_seeds_and_grid_syntax():
    assert parse_seeds("0-3,7,2") == [0, 1, 2, 3, 7]
    assert parse_grid(["learner.sigma=0, 0.5,1"]) == [("learner.sigma", ["0", "0.5", "1"])]
    for bad in ("3-1", "a", "1,,2", "-1"):
        with pytest.raises(HadimError):
            parse_seeds(bad)
    for bad in (["sigma=0"], ["learner.sigma"], ["learner.sigma=0,"], ["a.b=1", "a.b=2"]):
        with pytest.raises(HadimError):
            parse_grid(bad)


def test_plan_is_the_product_named_after_sweep_config_and_seed(tmp_path):
    other = tmp_path / "wide.toml"
    other.write_text("[learner]\nsigma = 0.25\n")
    plan = build_plan("s1", configs=[other], grid=["learner.tau_creation=0.2,0.4"],
                      sets=["world.episode_length=50"], seeds="0-1", iterations=100,
                      eval_every=None)
    assert [e.run for e in plan.entries] == [
        "s1-wide_tau_creation0.2-s0", "s1-wide_tau_creation0.2-s1",
        "s1-wide_tau_creation0.4-s0", "s1-wide_tau_creation0.4-s1"]
    first = plan.entries[0]
    assert first.kind is RunKind.TRAIN and first.seed == 0
    assert first.config["learner"]["sigma"] == 0.25
    assert first.config["learner"]["tau_creation"] == 0.2
    assert plan.entries[2].config["learner"]["tau_creation"] == 0.4
    assert first.eval_every == 200 and first.config["world"]["episode_length"] == 50
    # the settings are what is compared on a re-run: other iterations are other settings
    again = build_plan("s1", configs=[other], grid=["learner.tau_creation=0.2,0.4"],
                       sets=["world.episode_length=50"], seeds="0-1", iterations=200,
                       eval_every=None)
    assert again.settings() != plan.settings()


def _refused(runner, *args):
    result = runner.invoke(app, [str(a) for a in args])
    assert result.exit_code == 2, (result.output, result.exception)
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: "), result.stderr
    return lines[0]


@pytest.mark.parametrize(("args", "match"), [
    (["--grid", "learner.sigma"], "--grid"),
    (["--grid", "learner.nosuch=1,2"], "nosuch"),
    (["--seeds", "5-2"], "--seeds"),
    (["--eval-every", "30"], "multiple of the episode length"),
])
def test_bad_input_is_one_line_and_creates_nothing(runner, tmp_path, args, match):
    store = tmp_path / "s.db"
    line = _refused(runner, "sweep", "bad", *SMALL[:2], *args, "--store", store)
    assert match in line
    assert not store.exists()


def test_unusable_stores_refused(runner, tmp_path):
    assert "not an in-memory" in _refused(runner, "sweep", "x", "--store", ":memory:")
    assert "cannot use store URL" in _refused(runner, "sweep", "x", "--store", "mongodb://h/db")


def test_unreachable_servers_are_one_line_and_create_nothing(runner, tmp_path):
    pytest.importorskip("ray")
    with socket.socket() as probe:  # a port nothing listens on
        probe.bind(("127.0.0.1", 0))
        port = probe.getsockname()[1]
    store = tmp_path / "s.db"
    # a subprocess with a time limit: Ray's own connect retries such an address for minutes
    done = subprocess.run(
        [sys.executable, "-m", "hadim_cli.app", "sweep", "x", *SMALL, "--address",
         f"127.0.0.1:{port}", "--store", str(store)], cwd=tmp_path, capture_output=True,
        text=True, timeout=120, env=dict(os.environ, PYTHONPATH=str(ROOT)))
    assert done.returncode == 2, done.stderr
    assert done.stderr.strip().splitlines() == [
        f"error: cannot reach the Ray cluster at 127.0.0.1:{port}: Connection refused"]
    assert not store.exists()
    server = f"postgresql://nobody@/hadim?host={tmp_path}&port={port}"
    out = tmp_path / "report"
    for args in (["sweep", "x", *SMALL[:2], "--store", server],
                 ["report", "x", "--out", out, "--store", server]):
        assert _refused(runner, *args).startswith("error: cannot open the store at")
    assert _refused(runner, "report", "x", "--out", out, "--store", "mongodb://h/db"
                    ).startswith("error: cannot use store URL mongodb://h/db")
    assert _refused(runner, "report", "x", "--out", out, "--store", store
                    ) == f"error: no store at {store}: start a run with `hadim train`, or pass " \
                         "--store"
    assert not store.exists() and not out.exists()


def test_sweep_name_in_use_with_other_settings_changes_nothing(runner, tmp_path):
    store = tmp_path / "s.db"
    plan = build_plan("lab", configs=[], grid=[], sets=["world.episode_length=50"], seeds="0",
                      iterations=100, eval_every=0)
    with Store.open(store) as st:
        assert st.claim_sweep("lab", plan.settings()) is True
        assert st.claim_sweep("lab", plan.settings()) is False
        st.create_run(config={}, seed=0, name="keep")
    before = sqlite3.connect(store).execute("SELECT * FROM meta ORDER BY key").fetchall()
    line = _refused(runner, "sweep", "lab", *SMALL[:2], "-n", "200", "--eval-every", "0",
                    "--store", store)
    assert "sweep 'lab' is in use" in line
    with Store.open(store, create=False) as st:
        assert [r.name for r in st.list_runs()] == ["keep"]
        assert st.sweep_settings("lab") == json.loads(json.dumps(plan.settings()))
        assert st.sweeps() == ["lab"]
    assert sqlite3.connect(store).execute("SELECT * FROM meta ORDER BY key").fetchall() == before


def test_worker_refuses_a_hand_made_run_of_the_same_name_and_skips_when_stopped(tmp_path):
    from hadim_cli.config import load_config
    from hadim_cli.sweep.worker import run_entry

    store = tmp_path / "s.db"
    plan = build_plan("lab", configs=[], grid=[], sets=["world.episode_length=50"], seeds="0-1",
                      iterations=100, eval_every=0)
    with Store.open(store) as st:
        st.create_run(config=load_config().to_dict(), seed=0, name="lab-default-s0")
    with pytest.raises(HadimError, match="exists with another config or seed"):
        run_entry(str(store), plan.entries[0], lambda: False)
    assert run_entry(str(store), plan.entries[1], lambda: True).status == "skipped"
    with Store.open(store, create=False) as st:
        assert [(r.name, r.iterations) for r in st.list_runs()] == [("lab-default-s0", 0)]
