"""`hadim world render|info` and `hadim bench world`."""

from __future__ import annotations

import json

import numpy as np
import pytest

from hadim_cli.app import app


def test_render_writes_a_png(runner, tmp_path) -> None:
    out = tmp_path / "scene.png"
    result = runner.invoke(app, ["world", "render", "--seed", "3", "--out", str(out),
                                 "--random-actions", "5"])
    assert result.exit_code == 0, result.output
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_render_with_an_actions_file(runner, tmp_path) -> None:
    csv = tmp_path / "actions.csv"
    csv.write_text("1,1\n1,1\n-1,1\n")
    npy = tmp_path / "actions.npy"
    np.save(npy, np.ones((3, 2)))
    for path in (csv, npy):
        out = tmp_path / f"{path.suffix[1:]}.png"
        result = runner.invoke(app, ["world", "render", "--seed", "1", "--out", str(out),
                                     "--episode-actions", str(path), "--no-lidar"])
        assert result.exit_code == 0, result.output
        assert out.exists()


def test_render_refuses_bad_input(runner, tmp_path) -> None:
    bad = tmp_path / "bad.csv"
    bad.write_text("1,2\n")
    out = str(tmp_path / "x.png")
    for extra in (["--episode-actions", str(bad)],
                  ["--episode-actions", str(tmp_path / "missing.csv")],
                  ["--episode-actions", str(bad), "--random-actions", "2"],
                  ["--set", "world.n_green=-1"]):
        result = runner.invoke(app, ["world", "render", "--seed", "1", "--out", out, *extra])
        assert result.exit_code == 2, (extra, result.output)


def test_info_lists_the_scene(runner) -> None:
    result = runner.invoke(app, ["world", "info", "--seed", "3", "--json"])
    assert result.exit_code == 0, result.output
    doc = json.loads(result.output)
    kinds = [row["kind"] for row in doc["entities"]]
    assert kinds == ["robot"] + ["green"] * 6 + ["red"] * 3
    table = runner.invoke(app, ["world", "info", "--seed", "3"])
    assert table.exit_code == 0 and "obj9" in table.output


def test_bench_world_json(runner) -> None:
    result = runner.invoke(app, ["bench", "world", "--actions", "15", "--json",
                                 "--set", "world.episode_length=10"])
    assert result.exit_code == 0, result.output
    doc = json.loads(result.output)
    assert {"actions_per_s", "raw_actions_per_s", "overhead_ratio"} <= doc.keys()
    assert doc["actions"] == 15 and doc["episodes"] == 2 and doc["same_trajectory"] is True
    assert doc["overhead_ratio"] > 0


ARM = ["--config", "configs/arm.toml"]


@pytest.fixture
def in_checkout(monkeypatch):
    """Run from the checkout, where `configs/arm.toml` is the path the docs give."""
    from hadim_cli.config import configs_dir

    monkeypatch.chdir(configs_dir().parent)


def test_render_draws_the_arm_s_scene(runner, tmp_path, in_checkout) -> None:
    out = tmp_path / "arm.png"
    result = runner.invoke(app, ["world", "render", "--seed", "3", "--out", str(out), *ARM,
                                 "--random-actions", "5"])
    assert result.exit_code == 0, result.output
    assert result.output.strip() == f"wrote {out}"
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    three = tmp_path / "three.csv"
    three.write_text("1,0,-1\n0.5,0.5,0.5\n")
    result = runner.invoke(app, ["world", "render", "--seed", "3", "--out", str(out), *ARM,
                                 "--episode-actions", str(three)])
    assert result.exit_code == 0, result.output
    two = tmp_path / "two.csv"  # the rover's actions are not the arm's
    two.write_text("1,1\n")
    result = runner.invoke(app, ["world", "render", "--seed", "3", "--out", str(out), *ARM,
                                 "--episode-actions", str(two)])
    assert result.exit_code == 2
    assert "must hold N rows of 3 joint speeds (joint1, joint2, joint3)" in result.stderr


def test_info_lists_the_arm_s_scene(runner, in_checkout) -> None:
    result = runner.invoke(app, ["world", "info", "--seed", "3", "--json", *ARM])
    assert result.exit_code == 0, result.output
    rows = json.loads(result.output)["entities"]
    assert [row["kind"] for row in rows] == ["effector"] + ["green"] * 6 + ["red"] * 3
    assert len(rows[0]["joints"]) == 3
    table = runner.invoke(app, ["world", "info", "--seed", "3", *ARM])
    assert table.exit_code == 0 and "effector" in table.output


def test_bench_world_on_the_arm(runner, in_checkout) -> None:
    result = runner.invoke(app, ["bench", "world", "--actions", "15", "--json", *ARM,
                                 "--set", "world.episode_length=10"])
    assert result.exit_code == 0, result.output
    doc = json.loads(result.output)
    assert doc["body"] == "arm" and doc["actions"] == 15 and doc["episodes"] == 2
    assert doc["same_trajectory"] is True and doc["overhead_ratio"] > 0
    table = runner.invoke(app, ["bench", "world", "--actions", "5", *ARM])
    assert table.exit_code == 0 and "world (arm)" in table.output


@pytest.mark.parametrize("override", ["world.arm.joint_limits=[4.0, 1.0]",
                                      "world.arm.link_lengths=[0.5]", "world.body=leg"])
def test_a_bad_arm_value_is_one_error_line(runner, tmp_path, in_checkout, override) -> None:
    out = tmp_path / "x.png"
    result = runner.invoke(app, ["world", "render", "--seed", "1", "--out", str(out), *ARM,
                                 "--set", override])
    assert result.exit_code == 2
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: config key 'world."), lines
    assert not out.exists()

