"""The CLI's contract: every mistake is one `error:` line, a non-zero exit and nothing
written; the reading commands' outputs (JSON keys, PNGs) are what docs/cli.md says."""

from __future__ import annotations

import json
import shutil
import sqlite3
from pathlib import Path

import pytest
from typer.testing import CliRunner

from hadim_cli.app import app
from hadim_cli.config import configs_dir
from hadim_store.api import Store

PNG = b"\x89PNG\r\n\x1a\n"
SMALL = ("--set", "world.episode_length=25", "--set", 'evaluation.tasks=["move-robot"]')


def invoke(runner, *args: object, **kw):
    return runner.invoke(app, [str(a) for a in args], **kw)


def ok(runner, *args: object, **kw):
    result = invoke(runner, *args, **kw)
    assert result.exit_code == 0, (args, result.stderr, result.exception)
    return result


def refused(runner, *args: object, match: str = "", **kw) -> str:
    result = invoke(runner, *args, **kw)
    assert result.exit_code == 2, (args, result.exit_code, result.stdout, result.exception)
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: "), result.stderr
    assert "Traceback" not in result.output
    assert match in lines[0], lines[0]
    return lines[0]


def snapshot(store: Path) -> list:
    """What a command could have written: every run's row, D, checkpoints and evaluations."""
    with Store.open(store, create=False) as st:
        return [(r.name, r.status, r.iterations, r.lock, r.updated_at, r.parent,
                 st.dataset_sha256(r.name), st.checkpoint_iterations(r.name),
                 st.evaluations(r.name)) for r in st.list_runs()]


@pytest.fixture(scope="module")
def trained(tmp_path_factory) -> Path:
    """run-1: 100 iterations in episodes of 25, evaluated on move-robot at 50 and 100."""
    store = tmp_path_factory.mktemp("cli") / "s.sqlite"
    result = invoke(CliRunner(), "train", "--iterations", 100, "--eval-every", 50, *SMALL,
                    "--store", store)
    assert result.exit_code == 0, (result.stderr, result.exception)
    return store


@pytest.fixture
def points_file(tmp_path) -> Path:
    """A user's own task: move-robot with two of its points."""
    text = (configs_dir() / "tasks" / "move-robot.toml").read_text()
    head, sep, tail = text.partition("points = ")
    rest = tail.split("\n", 1)[1]
    path = tmp_path / "two-points.toml"
    path.write_text(head.replace('name = "move-robot"', 'name = "two-points"') + sep
                    + "[[0.5, 0.0], [0.0, -0.5]]\n" + rest)
    return path


# --------------------------------------------------------------------------- errors

@pytest.mark.parametrize("args", [
    ("resume", "nope"),
    ("fork", "nope"),
    ("eval", "nope", "--task", "move-robot"),
    ("affordances", "nope"),
    ("affordances", "nope", "--timeline"),
    ("runs", "show", "nope"),
    ("plot", "nope"),
], ids=lambda a: " ".join(a))
def test_unknown_run(runner, trained, args):
    before = snapshot(trained)
    refused(runner, *args, "--store", trained, match="no run named 'nope'")
    assert snapshot(trained) == before


@pytest.mark.parametrize(("args", "match"), [
    (("eval", "run-1", "--task", "nope"), "unknown task 'nope'"),
    (("eval", "run-1"), "exactly one of --task"),
    (("eval", "run-1", "--task", "move-robot", "--points", "{points}"), "exactly one of --task"),
    (("eval", "run-1", "--points", "{missing}"), "not found"),
    (("eval", "run-1", "--task", "move-robot", "--at", 1000), "beyond"),
    (("eval", "run-1", "--task", "move-robot", "--at", 10), "no checkpoint at or before"),
    (("affordances", "run-1", "--at", 1000), "beyond"),
    (("affordances", "run-1", "--at", 1000, "--timeline"), "beyond"),
    (("affordances", "run-1", "--at", 10), "no checkpoint at or before"),
    (("affordances", "run-1", "--timeline", "--out", "{nodir}"), "cannot write"),
    (("affordances", "run-1", "--pa", "--timeline"), "not with --timeline"),
    (("affordances", "run-1", "--errors", "--pa"), "not with --pa"),
    (("fork", "run-1", "--at", 1000), "it has only 100 iterations"),
    (("fork", "run-1", "--at", 10), "its first checkpoint is at iteration 25"),
    (("fork", "run-1", "--set", "world.nope=1"), "unknown config key 'world.nope'"),
    (("fork", "run-1", "--set", "world.n_green=5"), "cannot change within a run"),
    (("fork", "run-1", "--name", "run-1"), "already exists"),
    (("resume", "run-1", "--iterations", 50), "already has 100 iterations"),
    (("resume", "run-1", "--iterations", 200, "--eval-every", 30), "multiple of the episode"),
    (("train", "--name", "run-1", "--iterations", 25), "already exists"),
    (("train", "--name", "bad name", "--iterations", 25), "invalid run name"),
    (("plot", "run-1", "--out", "{nodir}"), "cannot write"),
], ids=lambda a: " ".join(map(str, a)) if isinstance(a, tuple) else "")
def test_mistakes_write_nothing(runner, trained, points_file, tmp_path, args, match):
    fill = {"points": points_file, "missing": tmp_path / "missing.toml",
            "nodir": tmp_path / "no" / "such" / "dir.png"}
    args = tuple(str(a).format(**fill) for a in args)
    before = snapshot(trained)
    refused(runner, *args, "--store", trained, match=match)
    assert snapshot(trained) == before


def test_a_run_without_evaluations_has_no_plot(runner, tmp_path):
    store = tmp_path / "s.sqlite"
    ok(runner, "train", "--iterations", 20, "--set", "world.episode_length=20",
       "--eval-every", 0, "--store", store)
    refused(runner, "plot", "run-1", "--out", tmp_path / "c.png", "--store", store,
            match="no evaluations")
    assert not (tmp_path / "c.png").exists()


@pytest.mark.parametrize("args", [
    ("--set", "world.nope=1"),
    ("--set", "world.episode_length=-3"),
    ("--set", "nonsense"),
    ("--config", "missing.toml"),
    ("--eval-every", 30),
    ("--iterations", -5),  # an impossible option value: one line too, not a usage box
    ("--seed", "x"),
], ids=lambda a: " ".join(map(str, a)))
def test_train_with_a_bad_config_creates_nothing(runner, tmp_path, trained, args):
    fresh = tmp_path / "fresh.sqlite"
    refused(runner, "train", "--iterations", 25, *args, "--store", fresh)
    assert not fresh.exists()
    before = snapshot(trained)
    refused(runner, "train", "--iterations", 25, *args, "--store", trained)
    assert snapshot(trained) == before


def _junk(path: Path) -> None:
    path.write_bytes(bytes(range(256)) * 8)


def _not_a_database(path: Path) -> None:
    path.write_bytes(b"SQLite format 3\x00" + b"\x00garbage" * 100)


def _foreign(path: Path) -> None:
    con = sqlite3.connect(path)
    con.execute("CREATE TABLE notes (id INTEGER PRIMARY KEY, text TEXT)")
    con.execute("INSERT INTO notes (text) VALUES ('mine')")
    con.commit()
    con.close()


def _newer(path: Path) -> None:
    Store.open(path).close()
    con = sqlite3.connect(path)
    con.execute("UPDATE meta SET value = '99' WHERE key = 'schema_version'")
    con.commit()
    con.close()


@pytest.mark.parametrize(("make", "match"), [
    (_junk, "is not a SQLite database"),
    (_not_a_database, "corrupt or unreadable"),
    (_foreign, "is not a hadim store"),
    (_newer, "schema version 99"),
], ids=["junk", "not-a-database", "foreign", "newer-schema"])
@pytest.mark.parametrize("args", [
    ("runs", "list"),
    ("runs", "show", "run-1"),
    ("train", "--iterations", 25, "--set", "world.episode_length=25", "--eval-every", 0),
    ("resume", "run-1"),
    ("affordances", "run-1", "--timeline"),
], ids=lambda a: " ".join(map(str, a[:2])))
def test_an_unusable_store_is_refused_untouched(runner, tmp_path, make, match, args):
    path = tmp_path / "store.sqlite"
    make(path)
    content = path.read_bytes()
    refused(runner, *args, "--store", path, match=match)
    assert path.read_bytes() == content


def test_a_missing_store_is_not_created_by_readers(runner, tmp_path):
    path = tmp_path / "none.sqlite"
    for args in (("runs", "list"), ("runs", "show", "run-1"), ("resume", "run-1"),
                 ("eval", "run-1", "--task", "move-robot"), ("fork", "run-1")):
        refused(runner, *args, "--store", path, match="no store at")
    assert not path.exists()


def test_the_store_comes_from_hadim_store(runner, tmp_path, trained):
    listed = ok(runner, "runs", "list", "--json", env={"HADIM_STORE": str(trained)}).stdout
    assert [r["name"] for r in json.loads(listed)] == ["run-1"]
    elsewhere = tmp_path / "other.sqlite"
    refused(runner, "runs", "list", "--store", elsewhere, env={"HADIM_STORE": str(trained)},
            match=str(elsewhere))


# --------------------------------------------------------------------------- outputs

def test_runs_list_and_show(runner, trained):
    listed = json.loads(ok(runner, "runs", "list", "--json", "--store", trained).stdout)
    assert listed == [{"name": "run-1", "status": "finished", "seed": 0, "iterations": 100,
                       "parent": None, "damaged": False, "kind": "learner",
                       "algorithm": "hadim"}]
    info = json.loads(ok(runner, "runs", "show", "run-1", "--json", "--store", trained).stdout)
    assert {"name", "status", "iterations", "seed", "parent", "fork_iteration", "affordances",
            "scores", "dataset_sha256", "created_at", "updated_at", "versions",
            "config"} <= info.keys()
    assert info["config"]["world"]["episode_length"] == 25
    assert set(info["scores"]) == {"move-robot"}
    assert len(info["dataset_sha256"]) == 64
    babbling = info["goal_babbling"]
    n = babbling["learning_episodes"]
    assert babbling["sigma"] == 0.7 and n > 0
    assert 0.0 <= babbling["effective"] <= babbling["drawn"] <= 1.0
    gave_up = sum(c for why, c in babbling["fallbacks"].items() if why.startswith("goal-"))
    assert gave_up == round((babbling["drawn"] - babbling["effective"]) * n)
    assert "run-1" in ok(runner, "runs", "list", "--store", trained).stdout
    assert "dataset_sha256" in ok(runner, "runs", "show", "run-1", "--store", trained).stdout


def test_affordances_now_at_and_timeline(runner, trained, tmp_path):
    now = json.loads(ok(runner, "affordances", "run-1", "--json", "--store", trained).stdout)
    assert now and {"id", "input", "output", "context", "frame", "created_at", "competence",
                    "data", "interest", "accepts"} <= now[0].keys()
    for aff in now:  # a frame is one of the affordance's own relation contexts
        # A relation's frame, or the heading's for the robot's own motion.
        assert aff["frame"] is None or (aff["frame"] in aff["context"] and (
            "-" in aff["frame"] or aff["frame"] == "robot.heading"))
    events = json.loads(ok(runner, "affordances", "run-1", "--timeline", "--json",
                           "--store", trained).stdout)
    assert {"iteration", "id", "kind", "input", "output", "context", "competence",
            "detail"} <= events[0].keys()
    at = json.loads(ok(runner, "affordances", "run-1", "--at", 50, "--json",
                       "--store", trained).stdout)
    alive: set[int] = set()
    for e in events:
        if e["iteration"] <= 50:
            if e["kind"] == "created":
                alive.add(e["id"])
            elif e["kind"] == "deleted":
                alive.discard(e["id"])
    assert {a["id"] for a in at} == alive
    assert all(a["created_at"] <= 50 for a in at)
    early = json.loads(ok(runner, "affordances", "run-1", "--timeline", "--at", 50, "--json",
                          "--store", trained).stdout)
    assert early == [e for e in events if e["iteration"] <= 50]

    png = tmp_path / "tl.png"
    ok(runner, "affordances", "run-1", "--timeline", "--out", png, "--store", trained)
    assert png.read_bytes().startswith(PNG)
    implied = tmp_path / "tl2.png"
    ok(runner, "affordances", "run-1", "--out", implied, "--store", trained)
    assert implied.read_bytes().startswith(PNG)
    assert "H at iteration 100" in ok(runner, "affordances", "run-1", "--store", trained).stdout
    for v in json.loads(ok(runner, "affordances", "run-1", "--pa", "--json", "--store",
                           trained).stdout):  # (the rendering: tests/learner/test_p_a_pooled.py)
        assert {"id", "affordance", "scene", "unseen", "scene_right", "unseen_right",
                "replay"} <= v.keys()
    h = json.loads(ok(runner, "affordances", "run-1", "--json", "--store", trained).stdout)
    errors = json.loads(ok(runner, "affordances", "run-1", "--errors", "--json", "--store",
                           trained).stdout)
    assert [(e["id"], e["rows"]) for e in errors] == [(a["id"], a["data"]) for a in h]
    for e in errors:  # (what they measure: test_competence.py)
        q = e["errors"]
        assert q is None or 0.0 <= q["p50"] <= q["p90"] <= q["p99"] <= q["max"]
    assert "held-out error" in ok(runner, "affordances", "run-1", "--errors", "--store",
                                  trained).stdout


def test_affordances_count_where_each_acts_and_its_goals(runner, trained):
    """`effect`: the affordance's rows whose output changed, recounted here from the stored D;
    `goals`: its goal-babbling attempts, recounted from the stored learning episodes."""
    import numpy as np

    from hadim_cli import runs
    from hadim_cli.learner.spaces import Property, Role

    h = {a["id"]: a for a in json.loads(
        ok(runner, "affordances", "run-1", "--json", "--store", trained).stdout)}
    with runs.open_store(str(trained), create=False, writes=False) as st:
        session = runs.restore_session(st, st.get_run("run-1"))
        outcomes = st.dataset("run-1").outcomes
        attempts = [le["affordance"] for e in st.episodes("run-1")
                    for le in e.extra["learning_episodes"] if le["mode"] == "goal"]
    learner = session.learner
    layout, eps = learner.reader.layout, learner.config.zero_eps
    checked = 0
    for aff in learner.hierarchy:
        row = h[aff.id]
        assert 0 <= row["effect"] <= row["data"]
        assert row["goals"] == attempts.count(aff.id)
        if aff.output.prop is Property.POSITION:  # the robot's moves, an object's
            who = (np.zeros(len(aff.rows.t), dtype=int) if aff.output.role is Role.ROBOT
                   else aff.rows.target)
            moves = np.stack([outcomes[t, layout.space(layout.entities[e], Property.POSITION)
                                       .slice] for t, e in zip(aff.rows.t, who, strict=True)])
            moved = int((np.linalg.norm(moves, axis=1) > eps).sum())
            assert row["effect"] == moved > 0
            checked += moved < row["data"]  # (an object's rows also hold some where it stayed)
    assert checked and sum(h[a]["goals"] for a in h) > 0


def test_eval_json_and_a_user_points_file(runner, trained, points_file, tmp_path):
    out = json.loads(ok(runner, "eval", "run-1", "--task", "move-robot", "--at", 50, "--json",
                        "--store", trained).stdout)
    assert {"task", "score", "points", "iteration"} <= out.keys()
    assert out["task"] == "move-robot" and out["iteration"] == 50 and len(out["points"]) == 8
    assert 0.0 <= out["score"] <= 1.0
    for p in out["points"]:
        assert {"target", "start", "final", "error"} <= p.keys()
        assert len(p["target"]) == len(p["final"]) == 2 and 0.0 <= p["error"] <= 1.0

    mine = json.loads(ok(runner, "eval", "run-1", "--points", points_file, "--json",
                         "--store", trained).stdout)
    assert mine["task"] == "user:two-points" and mine["iteration"] == 100
    assert [p["target"] for p in mine["points"]] == [[0.5, 0.0], [0.0, -0.5]]
    table = ok(runner, "eval", "run-1", "--points", points_file, "--store", trained).stdout
    assert "two-points" in table
    with Store.open(trained, create=False) as st:
        assert {e.task for e in st.evaluations("run-1")} == {"move-robot", "user:two-points"}

    png = tmp_path / "c.png"
    assert ok(runner, "plot", "run-1", "--out", png, "--store", trained).stdout.strip() == \
        str(png)
    assert png.read_bytes().startswith(PNG)


def test_every_documented_command_has_help(runner):
    doc = (Path(__file__).resolve().parents[1] / "docs" / "cli.md").read_text()
    for command in ("train", "resume", "fork", "runs list", "runs show", "affordances", "eval",
                    "plot", "config show", "config validate", "world render", "world info",
                    "bench world", "bench train"):
        result = ok(runner, *command.split(), "--help")
        assert "Usage" in result.stdout
        assert f"hadim {command}" in doc, f"docs/cli.md does not document hadim {command}"


def test_a_store_copied_elsewhere_still_opens(runner, trained, tmp_path):
    """A store is one self-contained file (WAL checkpointed on close)."""
    copy = tmp_path / "copy.sqlite"
    shutil.copy(trained, copy)
    assert json.loads(ok(runner, "runs", "list", "--json", "--store", copy).stdout)[0][
        "iterations"] == 100
