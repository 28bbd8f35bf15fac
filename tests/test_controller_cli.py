"""The controller as a user meets it: a removed planner key (`--set planner.convoy=true`, or
one in a config file) is one `error:` line naming it, exit 2, nothing stored; `hadim eval
RUN --exact LEVEL` imagines levels by the room's physics as a diagnostic that is not stored;
an unknown level is one `error:` line; a run of another hadim version is acted for by the
installed code, which says so in one line, naming the keys it ignores or fills in; a tool that
starts off the robot–target line, on a scene nothing was decided on, pushes the target."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from typer.testing import CliRunner

from hadim_cli.app import app

SMALL = ("--set", "world.episode_length=25", "--set", 'evaluation.tasks=["move-robot"]')


def invoke(*args: object):
    return CliRunner().invoke(app, [str(a) for a in args])


@pytest.fixture(scope="module")
def trained(tmp_path_factory) -> Path:
    """run-1: 150 iterations."""
    store = tmp_path_factory.mktemp("controller") / "s.sqlite"
    result = invoke("train", "--iterations", 150, "--eval-every", 0, *SMALL, "--store", store)
    assert result.exit_code == 0, (result.stderr, result.exception)
    return store


def _one_error(result, *words: str) -> None:
    assert result.exit_code == 2, (result.exit_code, result.stdout)
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: "), result.stderr
    for word in words:
        assert word in lines[0]


def _runs(store: Path) -> int:
    from hadim_cli.runs import open_store

    with open_store(str(store), create=False, writes=False) as st:
        return len(st.list_runs())


def _evaluations(store: Path) -> int:
    from hadim_cli.runs import open_store

    with open_store(str(store), create=False, writes=False) as st:
        return len(st.evaluations("run-1"))


@pytest.mark.parametrize("key", ["learner.surface_relations", "learner.p_a_pooled",
                                 "learner.context_splits"])
def test_a_removed_learner_key_is_one_error_line_and_nothing_is_stored(trained, key):
    before = _runs(trained)
    result = invoke("train", "--iterations", 50, *SMALL, "--set", f"{key}=1", "--store",
                    trained)
    _one_error(result, key)
    assert _runs(trained) == before


@pytest.mark.parametrize("key", ["convoy", "navigation", "route_beam", "max_depth"])
def test_a_removed_planner_key_is_one_error_line_and_nothing_is_stored(trained, key):
    before = _runs(trained)
    result = invoke("train", "--iterations", 50, *SMALL, "--set", f"planner.{key}=true",
                    "--store", trained)
    _one_error(result, f"planner.{key}")
    assert _runs(trained) == before


def test_a_config_file_with_a_removed_planner_key_is_one_error_line(trained, tmp_path):
    config = tmp_path / "old.toml"
    config.write_text("[planner]\nconvoy_plan = true\n")
    before = _runs(trained)
    result = invoke("train", "--iterations", 50, "--config", config, "--store", trained)
    _one_error(result, "planner.convoy_plan")
    assert _runs(trained) == before


def test_the_search_variant_section_is_gone(trained):
    result = invoke("train", "--iterations", 50, *SMALL, "--set", "controller.kind=search",
                    "--store", trained)
    _one_error(result, "controller")


@pytest.mark.parametrize("levels", [("navigation",), ("push",), ("navigation", "push", "tool")])
def test_eval_with_exact_levels_is_a_diagnostic_not_stored(trained, levels):
    before = _evaluations(trained)
    flags = [a for level in levels for a in ("--exact", level)]
    result = invoke("eval", "run-1", "--task", "move-robot", *flags, "--json",
                    "--store", trained)
    assert result.exit_code == 0, result.stderr
    assert 0.0 <= json.loads(result.stdout)["score"] <= 1.0
    assert _evaluations(trained) == before


def test_an_unknown_exact_level_is_one_error_line(trained):
    result = invoke("eval", "run-1", "--task", "move-robot", "--exact", "magic",
                    "--store", trained)
    _one_error(result, "magic")


def _trained_by(store: Path, version: str) -> None:
    import sqlite3

    with sqlite3.connect(store) as db:
        db.execute("UPDATE runs SET versions_json = ? WHERE name = 'run-1'",
                   (json.dumps({"hadim": version}),))


@pytest.mark.parametrize("command", [
    ("eval", "run-1", "--task", "move-robot"),
    ("fork", "run-1", "--name", "child"),
    ("resume", "run-1", "--iterations", 175),
])
def test_a_run_of_another_version_is_acted_for_by_the_installed_code_in_one_line(
        trained, tmp_path, command):
    import shutil

    store = tmp_path / "copy.sqlite"
    shutil.copy(trained, store)
    _trained_by(store, "0.0.1")
    result = invoke(*command, "--store", store)
    assert result.exit_code == 0, result.stderr
    notes = [line for line in result.stderr.splitlines() if "0.0.1" in line]
    assert len(notes) == 1 and "run-1" in notes[0], result.stderr
    _trained_by(store, _installed())
    again = invoke("eval", "run-1", "--task", "move-robot", "--store", store)
    assert again.exit_code == 0 and "trained with" not in again.stderr


def test_a_stored_run_s_removed_and_missing_keys_are_named_in_the_one_line(trained, tmp_path):
    """A run stored with a key the installed version removed (a learner switch) and without
    one it added: evaluated and resumed by the installed code, which names both in its one
    note; the run itself is left as stored."""
    import shutil
    import sqlite3

    store = tmp_path / "copy.sqlite"
    shutil.copy(trained, store)
    with sqlite3.connect(store) as db:
        (text,) = db.execute("SELECT config_json FROM runs WHERE name = 'run-1'").fetchone()
        config = json.loads(text)
        config["learner"]["surface_relations"] = False
        del config["planner"]["agreement"]
        db.execute("UPDATE runs SET config_json = ? WHERE name = 'run-1'",
                   (json.dumps(config),))
    for command in (("eval", "run-1", "--task", "move-robot"),
                    ("resume", "run-1", "--iterations", 175)):
        result = invoke(*command, "--store", store)
        assert result.exit_code == 0, result.stderr
        notes = [line for line in result.stderr.splitlines() if line.startswith("note:")]
        assert len(notes) == 1, result.stderr
        assert "ignored: learner.surface_relations" in notes[0]
        assert "installed defaults: planner.agreement" in notes[0]
    with sqlite3.connect(store) as db:
        (text,) = db.execute("SELECT config_json FROM runs WHERE name = 'run-1'").fetchone()
    assert json.loads(text) == config


def _installed() -> str:
    from importlib import metadata

    return metadata.version("hadim")


@pytest.mark.scenario
def test_a_tool_that_starts_off_the_robot_target_line_pushes_the_target(tmp_path):
    """Seed 2 trained for 1500 iterations, on `push-with-tool-side` (a scene no choice of the
    controller was made on: the robot facing away, the tool off the robot–target line): the
    controller brings the robot behind the tool, the tool behind the target, and pushes the
    target toward each point, never touching it with the robot."""
    store = tmp_path / "tool.sqlite"
    result = invoke("train", "--iterations", 1500, "--seed", 2, "--eval-every", 0,
                    "--store", store)
    assert result.exit_code == 0, result.stderr
    out = invoke("eval", "run-1", "--task", "push-with-tool-side", "--json", "--store", store)
    assert out.exit_code == 0, out.stderr
    points = json.loads(out.stdout)["points"]
    assert not any(p["contact_failed"] for p in points)
    assert all(p["error"] <= 0.5 for p in points), [round(p["error"], 2) for p in points]
    assert sum(p["error"] for p in points) / len(points) <= 0.3
