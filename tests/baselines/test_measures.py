"""Issue 46: the two measures (budgeted score, episode success), `hadim eval --budget`, the
log-spaced schedule, the long grid (idempotent, stops a learned run), the fixed variant, the
claims table, the diagnostics."""

from __future__ import annotations

import dataclasses
from datetime import UTC, datetime
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from hadim_cli.app import app
from hadim_cli.baselines import grid
from hadim_cli.baselines import runs as baseline_runs
from hadim_cli.baselines.config import make_config
from hadim_cli.baselines.diagnose import training_blocks
from hadim_cli.baselines.env import GoalWorldEnv
from hadim_cli.baselines.features import goal_frame
from hadim_cli.baselines.qlearning import Grid, robot_frame_cells
from hadim_cli.baselines.variants import Variant, apply_variant
from hadim_cli.config import WorldConfig
from hadim_cli.evaluation.metric import (
    check_budget,
    measure_name,
    split_measure,
    zone_count,
    zone_share,
)
from hadim_cli.report.measures import claims_table, run_curve
from hadim_store.api import Store
from hadim_store.records import Evaluation


def invoke(*args: object):
    return CliRunner().invoke(app, [str(a) for a in args])


def test_measure_names_budgets_and_the_goal_zone():
    assert measure_name("push-object", 1000) == "push-object@1000"
    assert measure_name("push-object", None) == "push-object"
    assert split_measure("push-object@1000") == ("push-object", 1000)
    assert split_measure("user:mine") == ("user:mine", None)
    assert check_budget(1) == 1 and check_budget(10_000) == 10_000
    for bad in (0, -3, 10_001):
        with pytest.raises(ValueError, match="--budget"):
            check_budget(bad)
    points = [{"final": [0.0, 0.05], "target": [0.0, 0.0]},
              {"final": [0.0, 0.2], "target": [0.0, 0.0]},
              {"final": [0.0, 0.0], "target": [0.0, 0.0], "contact_failed": True}]
    assert zone_count(points) == 1 and zone_share(points) == pytest.approx(1 / 3)


def _baseline_run(store: Path, name: str = "b", total: int = 80, eval_at=(40, 80)) -> None:
    cfg = make_config("q-learning", "move-robot", "guided", "discrete", total, 0, WorldConfig(),
                      episode_length=30, checkpoint_every=20)
    cfg = dataclasses.replace(cfg, eval_at=tuple(eval_at))
    with Store.open(store) as st:
        baseline_runs.new_run(st, cfg, 0, name)
        session = baseline_runs.BaselineSession(cfg, 0)
        baseline_runs.train(st, name, session, total, tasks=("move-robot",))


def test_training_stores_both_measures_on_the_schedule(tmp_path):
    store = tmp_path / "s.sqlite"
    _baseline_run(store)
    with Store.open(store, create=False) as st:
        found = [(e.iteration, e.task) for e in st.evaluations("b")]
        episode = st.evaluations("b", task="move-robot@30")
    assert found == [(40, "move-robot"), (40, "move-robot@30"),
                     (80, "move-robot"), (80, "move-robot@30")]
    assert all(p["actions"] <= 30 for e in episode for p in e.points)


def test_eval_with_a_budget_stores_task_at_budget_and_counts_the_goal_zone(tmp_path):
    store = tmp_path / "s.sqlite"
    _baseline_run(store, total=40, eval_at=())
    result = invoke("eval", "b", "--task", "move-robot", "--budget", 200, "--store", store,
                    "--json")
    assert result.exit_code == 0, result.stderr
    import json

    payload = json.loads(result.stdout)
    assert payload["task"] == "move-robot@200" and payload["budget"] == 200
    assert payload["in_zone"] == zone_count(payload["points"])
    assert payload["points_total"] == 8
    assert payload["actions"] == sum(p["actions"] for p in payload["points"])
    for bad, says in ((0, "at least 1"), (10_001, "at most 10000")):
        refused = invoke("eval", "b", "--task", "move-robot", "--budget", bad, "--store", store)
        assert refused.exit_code == 2
        lines = refused.stderr.strip().splitlines()
        assert len(lines) == 1 and lines[0].startswith("error: ") and says in lines[0]
    with Store.open(store, create=False) as st:
        assert [e.task for e in st.evaluations("b")] == ["move-robot@200"]  # nothing else


def test_the_learner_gets_the_episode_measure(tmp_path):
    store = tmp_path / "s.sqlite"
    assert invoke("train", "-n", 100, "--eval-every", 0, "--store", store).exit_code == 0
    result = invoke("eval", "run-1", "--task", "move-robot", "--budget", 1000, "--store", store,
                    "--json")
    assert result.exit_code == 0, result.stderr
    assert '"task": "move-robot@1000"' in result.stdout and '"in_zone"' in result.stdout


@pytest.fixture
def tiny_grid(monkeypatch):
    """The grid at test size: move-robot q-learning, evaluations at 20 and 40."""
    monkeypatch.setattr(grid, "LOG_SCHEDULE", (20, 40, 60))
    monkeypatch.setattr(grid, "CHUNK", 20)
    monkeypatch.setattr(grid, "EPISODE_ACTIONS", 30)
    monkeypatch.setattr(grid, "PAPER_HORIZON", 60)
    return [grid.GridEntry("move-robot", "q-learning", "guided", 0)]


def test_the_grid_is_idempotent_and_resumes(tmp_path, tiny_grid):
    log: list[str] = []
    with Store.open(tmp_path / "g.sqlite") as st:
        grid.run_grid(st, tiny_grid, lambda: False, log.append, stages=(40,))
        first = st.dataset_sha256(tiny_grid[0].run)
        grid.run_grid(st, tiny_grid, lambda: False, log.append, stages=(40,))
        assert st.dataset_sha256(tiny_grid[0].run) == first  # done: skipped
        assert any(line.endswith(": at 40") for line in log)
        grid.run_grid(st, tiny_grid, lambda: False, log.append, stages=(40, 60))
        record = st.get_run(tiny_grid[0].run)
        assert record.iterations == 60 and record.lock is None
        assert {e.task for e in st.evaluations(record.name)} == {"move-robot", "move-robot@30"}
        assert st.sweep_settings("rl-grid-paper")["entries"][0]["run"] == record.name
    out = invoke("resume", record.name, "--iterations", 80, "--store", tmp_path / "g.sqlite")
    assert out.exit_code == 0, out.stderr  # a run of the store like any other


def test_the_grid_stops_a_run_that_learned(tmp_path, tiny_grid, monkeypatch):
    monkeypatch.setattr(grid, "LEARNED", 0.0)  # any evaluation counts as learned
    with Store.open(tmp_path / "g.sqlite") as st:
        grid.run_grid(st, tiny_grid, lambda: False, lambda _: None, stages=(60,))
        record = st.get_run(tiny_grid[0].run)
        assert record.iterations == 20 and record.status == "finished"
        assert grid.learned_at(st, tiny_grid[0]) == 20


def test_the_fixed_variant_and_its_config():
    base = make_config("dqn", "push-object", "guided", "discrete", 50_000, 0, WorldConfig())
    fixed = apply_variant(base, Variant.FIXED)
    assert apply_variant(base, Variant.PAPER) == base and base.variant == "paper"
    assert fixed.variant == "fixed" and fixed.params["reward_scale"] == 0.001
    assert fixed.params["goal_frame"] and fixed.params["her"]["n_sampled_goal"] == 4
    assert fixed.params["her"]["copy_info_dict"]  # the guided reward reads the chain
    q = apply_variant(make_config("q-learning", "move-robot", "sparse", "discrete", 1000, 0,
                                  WorldConfig()), Variant.FIXED)
    assert q.params["frame"] == "robot" and "reward_scale" not in q.params


def test_a_fixed_dqn_with_her_on_the_guided_reward_resumes_exactly(tmp_path):
    cfg = apply_variant(make_config("dqn", "push-object", "guided", "discrete", 120, 0,
                                    WorldConfig(), episode_length=30, checkpoint_every=20),
                        Variant.FIXED)
    with Store.open(tmp_path / "s.sqlite") as st:
        for name, stops in (("straight", (120,)), ("resumed", (60, 120))):
            baseline_runs.new_run(st, cfg, 3, name)
            for total in stops:
                session = baseline_runs.restore(st, st.get_run(name))
                baseline_runs.train(st, name, session, total)
        a, b = st.checkpoint("straight"), st.checkpoint("resumed")
        assert a.json == b.json and sorted(a.arrays) == sorted(b.arrays)
        assert "buffer.info.chain_before" in a.arrays
        assert all(a.arrays[k].tobytes() == b.arrays[k].tobytes() for k in a.arrays)
        rewards = np.concatenate([e.extra["rewards"] for e in st.episodes("straight")])
    assert set(np.unique(rewards)) <= {-5.0, 1000.0} | set(rewards[rewards > 0])  # unscaled


def test_the_goal_in_the_robots_frame():
    import torch

    # robot at (1, 1) facing +y; goal 0.5 m ahead of it; one object 0.2 m to its right
    obs = torch.tensor([[1.0, 1.0, 0.0, 1.0, 1.2, 1.0]])
    achieved, desired = torch.tensor([[1.2, 1.0]]), torch.tensor([[1.2, 1.5]])
    rel = goal_frame(obs, achieved, desired, 1).numpy()[0]
    np.testing.assert_allclose(rel, [0.0, -0.2, 0.5, 0.0], atol=1e-6)  # right is −y
    cells = robot_frame_cells({"observation": np.array([0, 0, 1, 0], np.float32),
                               "achieved_goal": np.zeros(2, np.float32),
                               "desired_goal": np.array([0.0, 0.4], np.float32)}, 16,
                              Grid.of(GoalWorldEnv("move-robot")))
    assert cells == [12, 3]  # 90° to the left: sector 12 of 16 (−π … π); ring 3: 0.3–0.5 m


def _ev(it: int, task: str, score: float, inside: int, of: int = 4) -> Evaluation:
    points = [{"final": [0.0, 0.0 if i < inside else 1.0], "target": [0.0, 0.0],
               "actions": 10} for i in range(of)]
    return Evaluation(it, task, score, points, datetime.now(UTC))


def test_the_claims_table_reads_both_measures_and_carries_a_learned_run_forward():
    learned = [_ev(10_000, "move-robot", 0.4, 1), _ev(10_000, "move-robot@1000", 0.5, 2),
               _ev(20_000, "move-robot", 0.8, 4), _ev(20_000, "move-robot@1000", 0.9, 4)]
    slow = [_ev(it, name, 0.1, 0) for it in (10_000, 20_000, 50_000)
            for name in ("move-robot", "move-robot@1000")]
    a = run_curve("a", learned, "move-robot", 1000, 20_000)
    b = run_curve("b", slow, "move-robot", 1000, 50_000)
    assert a.learned_at == 20_000 and b.learned_at is None
    assert a.at(50_000) == (0.8, 1.0) and b.at(60_000) is None
    table = claims_table({"move-robot": {"dqn (sparse)": [a, b]}})
    row = table.splitlines()[-1]
    assert "1/2: 20,000, not by 50,000" in row
    assert "0.45 / 50%" in row  # at 50 000: a carried forward, b measured
    assert "learned in 10k–20k" in row


def test_training_blocks_count_episodes_the_goal_zone_and_coverage():
    class Chunk:
        def __init__(self, first, rewards, ends, xy):
            self.first_iteration, self.extra = first, {"rewards": rewards, "ends": ends}
            self.contexts = np.array([[x, y, 1, 0, 0, 0] for x, y in xy], float)

    chunks = [Chunk(0, [-5, -5, 1000, -5], [[2, True, False]], [(0, 0)] * 4),
              Chunk(4, [-5, -5, -5, -5], [[3, False, True]], [(1, 1)] * 4)]
    blocks = training_blocks(chunks, 4, (4, 5))
    assert [(b.episodes, b.reached) for b in blocks] == [(1, 1), (1, 0)]
    assert blocks[0].mean_return == 990 and blocks[1].mean_length == 5
    assert blocks[0].robot_coverage == pytest.approx(1 / 400)


def test_diagnose_a_stored_run(tmp_path):
    import json

    store = tmp_path / "s.sqlite"
    _baseline_run(store, total=80, eval_at=())
    out = invoke("baseline", "diagnose", "b", "--block", 40, "--store", store, "--json")
    assert out.exit_code == 0, out.stderr
    found = json.loads(out.stdout)
    assert [b["start"] for b in found["blocks"]] == [0, 40]
    assert sum(b["episodes"] for b in found["blocks"]) >= 2  # 30-action episodes
    assert found["value_scale"]["possible"] == pytest.approx([-500.0, 1000.0])
    assert found["table_states"] > 0
    text = invoke("baseline", "diagnose", "b", "--store", store)
    assert text.exit_code == 0 and "values on" in text.stdout
