"""`hadim world render|info` and `hadim bench world`."""

from __future__ import annotations

import json

import numpy as np

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
