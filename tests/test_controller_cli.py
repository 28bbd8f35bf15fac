"""The search controller as a user meets it: a run trained with it (`--set
controller.kind=search`) is deterministic; `hadim eval RUN --controller KIND` evaluates a run
with the other controller as a diagnostic that is not stored; a bad kind is one `error:`
line."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from typer.testing import CliRunner

from hadim_cli.app import app

SMALL = ("--set", "world.episode_length=25", "--set", 'evaluation.tasks=["move-robot"]',
         "--set", "controller.kind=search")


def invoke(*args: object):
    return CliRunner().invoke(app, [str(a) for a in args])


@pytest.fixture(scope="module")
def searched(tmp_path_factory) -> Path:
    """run-1 and run-2: the same 150 iterations with the search controller."""
    store = tmp_path_factory.mktemp("search") / "s.sqlite"
    for _ in range(2):
        result = invoke("train", "--iterations", 150, "--eval-every", 0, *SMALL,
                        "--store", store)
        assert result.exit_code == 0, (result.stderr, result.exception)
    return store


def _show(store: Path, run: str) -> dict:
    result = invoke("runs", "show", run, "--json", "--store", store)
    assert result.exit_code == 0, result.stderr
    return json.loads(result.stdout)


def test_a_run_trained_with_the_search_controller_repeats_bit_for_bit(searched):
    one, two = _show(searched, "run-1"), _show(searched, "run-2")
    assert one["config"]["controller"]["kind"] == "search"
    assert one["dataset_sha256"] == two["dataset_sha256"]


def _evaluations(store: Path) -> int:
    from hadim_cli.runs import open_store

    with open_store(str(store), create=False, writes=False) as st:
        return len(st.evaluations("run-1"))


def test_eval_with_another_controller_is_a_diagnostic_not_stored(searched):
    before = _evaluations(searched)
    result = invoke("eval", "run-1", "--task", "move-robot", "--controller", "rules",
                    "--json", "--store", searched)
    assert result.exit_code == 0, result.stderr
    assert 0.0 <= json.loads(result.stdout)["score"] <= 1.0
    assert _evaluations(searched) == before
    stored = invoke("eval", "run-1", "--task", "move-robot", "--store", searched)
    assert stored.exit_code == 0, stored.stderr
    assert _evaluations(searched) == before + 1


def test_an_unknown_controller_is_one_error_line(searched):
    result = invoke("eval", "run-1", "--task", "move-robot", "--controller", "magic",
                    "--store", searched)
    assert result.exit_code == 2
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: ") and "magic" in lines[0]
