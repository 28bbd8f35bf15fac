"""`hadim bench eval`: the cost of evaluating a stored learner, task by task."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from typer.testing import CliRunner

from hadim_cli.app import app
from hadim_store.api import Store

SMALL = ("--set", "world.episode_length=25", "--set", 'evaluation.tasks=["move-robot"]')


def invoke(*args: object):
    return CliRunner().invoke(app, [str(a) for a in args])


@pytest.fixture(scope="module")
def trained(tmp_path_factory) -> Path:
    store = tmp_path_factory.mktemp("bench-eval") / "s.sqlite"
    result = invoke("train", "--iterations", 100, "--eval-every", 0, *SMALL, "--store", store)
    assert result.exit_code == 0, (result.stderr, result.exception)
    return store


def _evaluations(store: Path) -> list:
    with Store.open(store, create=False) as st:
        return st.evaluations("run-1")


def test_bench_eval_times_each_task_as_eval_scores_it_and_stores_nothing(trained):
    result = invoke("bench", "eval", "run-1", "--json", "--store", trained)
    assert result.exit_code == 0, (result.stderr, result.exception)
    bench = json.loads(result.stdout)
    assert bench["run"] == "run-1" and bench["iteration"] == 100
    (task,) = bench["tasks"]                     # the run's evaluation tasks by default
    assert task["task"] == "move-robot" and task["points"] == 8
    assert task["actions"] > 0 and task["cpu_seconds"] > 0 and bench["ms_per_action"] > 0
    assert _evaluations(trained) == []           # a bench stores nothing
    scored = invoke("eval", "run-1", "--task", "move-robot", "--json", "--store", trained)
    assert json.loads(scored.stdout)["score"] == task["score"]
    table = invoke("bench", "eval", "run-1", "--task", "push-object", "--store", trained)
    assert table.exit_code == 0 and "push-object" in table.stdout and "CPU" in table.stdout


@pytest.mark.parametrize("args, match", [
    (("nope",), "no run named 'nope'"),
    (("run-1", "--task", "nope"), "unknown task 'nope'"),
    (("run-1", "--at", 5000), "beyond run run-1's 100 iterations"),
])
def test_bench_eval_refuses_bad_input_in_one_line(trained, args, match):
    result = invoke("bench", "eval", *args, "--store", trained)
    assert result.exit_code == 2
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: ") and match in lines[0]
