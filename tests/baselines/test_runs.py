"""Baseline runs in the store: train, resume exactly, evaluate, plot; no pickle; bad input."""

from __future__ import annotations

import json
import pickle
import sqlite3
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from hadim_cli.app import app
from hadim_cli.baselines import runs as baseline_runs
from hadim_cli.baselines.config import make_config
from hadim_cli.config import WorldConfig
from hadim_store.api import Store

PNG = b"\x89PNG\r\n\x1a\n"
SMALL = ("--episode-length", 30, "--eval-every", 60)


def invoke(*args: object):
    return CliRunner().invoke(app, [str(a) for a in args])


def ok(*args: object):
    result = invoke(*args)
    assert result.exit_code == 0, (args, result.stderr, result.exception)
    return result


def refused(*args: object, match: str = "") -> str:
    result = invoke(*args)
    assert result.exit_code == 2, (args, result.exit_code, result.stdout, result.exception)
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: "), result.stderr
    assert match in lines[0], lines[0]
    return lines[0]


def last_checkpoint(store: Path, name: str):
    with Store.open(store, create=False) as st:
        return st.checkpoint(name)


def assert_same_state(a, b) -> None:
    assert a.iteration == b.iteration
    assert a.json == b.json
    assert sorted(a.arrays) == sorted(b.arrays)
    for key in a.arrays:
        assert a.arrays[key].tobytes() == b.arrays[key].tobytes(), key


@pytest.mark.parametrize("algo", ["dqn", "curious"])
def test_run_stores_resumes_exactly_and_evaluates(tmp_path, algo):
    """Stopping at 60 and resuming gives, at 120, the very state of an uninterrupted run:
    networks, optimiser, counters, generators, the episode in progress, the replay rows."""
    store = tmp_path / "s.sqlite"
    common = ("--algo", algo, "--task", "push-object", "--store", store, *SMALL)
    assert ok("baseline", "train", *common, "--iterations", 120).stdout.strip() == "run-1"
    ok("baseline", "train", *common, "--iterations", 60, "--horizon", 120)
    ok("resume", "run-2", "--iterations", 120, "--store", store)
    straight, resumed = last_checkpoint(store, "run-1"), last_checkpoint(store, "run-2")
    assert straight.iteration == 120
    assert_same_state(straight, resumed)
    assert resumed.json["agent"]["counters"]["_n_updates"] > 0  # it did learn
    with Store.open(store, create=False) as st:
        assert st.dataset_sha256("run-1") == st.dataset_sha256("run-2")
        scores = [(e.iteration, e.task) for e in st.evaluations("run-2")]
        assert scores == [(60, "push-object"), (60, "push-object@30"), (120, "push-object"),
                          (120, "push-object@30")]  # both measures (issue 46)
        assert st.dataset("run-1").contexts.shape == (120, 8)
    out = ok("eval", "run-2", "--task", "push-object", "--store", store, "--json").stdout
    assert '"score"' in out and '"iteration": 120' in out
    listing = ok("runs", "list", "--store", store, "--json").stdout
    assert f'"algorithm": "{algo} sparse push-object"' in listing
    assert '"kind": "baseline"' in listing
    ok("plot", "run-1", "run-2", "--out", tmp_path / "f.png", "--log-x", "--store", store)
    assert (tmp_path / "f.png").read_bytes().startswith(PNG)


def _session(algo: str, **kw):
    cfg = make_config(algo, kw.pop("task", "move-robot"), kw.pop("reward", "guided"),
                      kw.pop("actions", "discrete"), 200, kw.pop("eval_every", 0),
                      WorldConfig(), 40)
    return baseline_runs.BaselineSession(cfg, 3)


@pytest.mark.parametrize("algo,actions", [("a2c", "continuous"), ("q-learning", "discrete")])
def test_resume_is_exact_for_a2c_and_q_learning(tmp_path, algo, actions):
    with Store.open(tmp_path / "s.sqlite") as st:
        for name, stops in (("straight", (200,)), ("resumed", (100, 200))):
            cfg = _session(algo, actions=actions, eval_every=100).cfg
            baseline_runs.new_run(st, cfg, 3, name)
            for total in stops:
                session = baseline_runs.restore(st, st.get_run(name))
                baseline_runs.train(st, name, session, total)
        assert_same_state(st.checkpoint("straight"), st.checkpoint("resumed"))


@pytest.mark.parametrize(("algo", "actions", "n_envs"), [("dqn", "discrete", 2),
                                                       ("a2c", "continuous", 4)])
def test_several_environments_resume_exactly(tmp_path, algo, actions, n_envs):
    """Each environment's episode in progress, and the replay rows of all of them, are
    checkpointed: stopping half-way gives the straight run's state."""
    total = 160 * n_envs // 2
    with Store.open(tmp_path / "s.sqlite") as st:
        for name, stops in (("straight", (total,)), ("resumed", (total // 2, total))):
            cfg = make_config(algo, "push-object", "guided", actions, total, 0, WorldConfig(),
                              30, checkpoint_every=20 * n_envs, n_envs=n_envs)
            baseline_runs.new_run(st, cfg, 3, name)
            for stop in stops:
                session = baseline_runs.restore(st, st.get_run(name))
                baseline_runs.train(st, name, session, stop)
        straight = st.checkpoint("straight")
        assert_same_state(straight, st.checkpoint("resumed"))
        assert len(straight.json["agent"]["env"]) == n_envs  # one episode per environment
        assert straight.json["agent"]["counters"]["_n_updates"] > 0
        assert st.dataset("resumed").contexts.shape == (total, 8)


def test_evaluating_never_changes_training(tmp_path):
    with Store.open(tmp_path / "s.sqlite") as st:
        for name, tasks in (("quiet", ()), ("evaluated", ("push-with-tool",))):
            session = _session("dqn", task="push-with-tool", eval_every=40)
            baseline_runs.new_run(st, session.cfg, 3, name)
            baseline_runs.train(st, name, session, 120, eval_every=40, tasks=tasks)
        assert len(st.evaluations("evaluated")) == 3 * 2  # both measures
        assert_same_state(st.checkpoint("quiet"), st.checkpoint("evaluated"))


def test_checkpoint_holds_no_pickle_and_a_crafted_blob_is_refused(tmp_path):
    store = tmp_path / "s.sqlite"
    ok("baseline", "train", "--algo", "dqn", "--task", "move-robot", "--iterations", 40,
       "--eval-every", 20, "--episode-length", 20, "--store", store)
    con = sqlite3.connect(store)
    kinds = {k for (k,) in con.execute("SELECT DISTINCT kind FROM checkpoint_items")}
    assert kinds <= {"npy", "npy+zlib", "json"}
    blobs = [b for (b,) in con.execute("SELECT data FROM checkpoint_items WHERE data IS NOT "
                                       "NULL")]
    assert blobs and not any(b.startswith(b"\x80") for b in blobs)  # no pickle protocol
    con.execute("UPDATE checkpoint_items SET data = ?, kind = 'npy' WHERE key = "
                "'policy.q_net.q_net.0.weight'",
                (pickle.dumps(np.zeros(3, dtype=object)),))
    con.commit()
    con.close()
    refused("resume", "run-1", "--iterations", 60, "--store", store)
    refused("eval", "run-1", "--task", "move-robot", "--store", store)


def test_bad_input_is_one_error_line(tmp_path):
    store = tmp_path / "s.sqlite"
    base = ("baseline", "train", "--iterations", 40, "--store", store)
    refused(*base, "--algo", "ppo", "--task", "move-robot", match="unknown algorithm 'ppo'")
    refused(*base, "--algo", "dqn", "--task", "fly", match="unknown task 'fly'")
    refused(*base, "--algo", "dqn", "--task", "move-robot", "--reward", "dense",
            match="unknown reward 'dense'")
    refused(*base, "--algo", "dqn", "--task", "move-robot", "--actions", "continuous",
            match="a2c")
    refused("baseline", "train", "--algo", "dqn", "--task", "move-robot", "--iterations", 50,
            "--store", store, match="multiple of 20")
    refused(*base, "--algo", "dqn", "--task", "move-robot", "--checkpoint-every", 30,
            match="--checkpoint-every must be a multiple of 20, got 30")
    refused(*base, "--algo", "q-learning", "--task", "move-robot", "--n-envs", 2,
            match="q-learning runs one environment")
    refused(*base, "--algo", "dqn", "--task", "move-robot", "--n-envs", 4, "--eval-every", 0,
            match="--iterations must be a multiple of 80")
    assert not store.exists() or not Store.open(store).list_runs()


def test_bench_baseline_reports_its_rates():
    out = ok("bench", "baseline", "--algo", "a2c", "--n-envs", 2, "--iterations", 40,
             "--json").stdout
    result = json.loads(out)
    assert (result["algorithm"], result["n_envs"], result["iterations"]) == ("a2c", 2, 40)
    assert result["iterations_per_cpu_s"] > 0 and result["iterations_per_s"] > 0
