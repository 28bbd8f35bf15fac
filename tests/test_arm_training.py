"""The learner on the arm (`configs/arm.toml`): `hadim train` runs and stores a run, `hadim
resume` continues it bit for bit, `hadim affordances` lists what it found (its evaluation:
tests/test_arm_tasks.py)."""

from __future__ import annotations

import json
from pathlib import Path

from test_cli import ok

from hadim_cli.config import configs_dir
from hadim_store import Store

ARM = ("--config", str(configs_dir() / "arm.toml"), "--set", "world.episode_length=50")
N = 200


def train(runner, store: Path, iterations: int) -> str:
    out = ok(runner, "train", *ARM, "--iterations", iterations, "--seed", 1, "--eval-every", 0,
             "--store", store).stdout
    return out.strip().splitlines()[0]


def test_an_arm_run_trains_resumes_exactly_and_lists_what_it_found(runner, tmp_path):
    store = tmp_path / "arm.sqlite"
    whole = train(runner, store, N)
    half = train(runner, store, N // 2)
    ok(runner, "resume", half, "--iterations", N, "--store", store)
    shown = [json.loads(ok(runner, "runs", "show", r, "--json", "--store", store).stdout)
             for r in (whole, half)]
    assert shown[0]["config"]["world"]["body"] == "arm"
    assert shown[0]["dataset_sha256"] == shown[1]["dataset_sha256"]
    with Store.open(store) as st:
        x, y = st.checkpoint(whole, N), st.checkpoint(half, N)
        assert x.json == y.json
        assert sorted(x.arrays) == sorted(y.arrays)
        for key, value in x.arrays.items():
            assert value.tobytes() == y.arrays[key].tobytes(), key
    h = [json.loads(ok(runner, "affordances", r, "--json", "--store", store).stdout)
         for r in (whole, half)]
    assert h[0] == h[1]
    found = {(a["input"], a["output"]) for a in h[0]}
    assert ("action", "robot.position") in found  # the effector's motion, the actor's role
    timeline = ok(runner, "affordances", whole, "--timeline", "--store", store).stdout
    assert "created" in timeline
    # p_A is asked about the arm's own scene: the rover's task scenes place a robot.
    table = ok(runner, "affordances", whole, "--store", store).stdout
    assert "p_A on the objects of the scene of seed 0" in table
