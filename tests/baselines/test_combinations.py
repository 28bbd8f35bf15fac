"""Every algorithm × reward × actions of the comparison runs: learns on its reward and action
space, is stored as a run, resumes, and evaluates on its task's file."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from hadim_cli.baselines import runs as baseline_runs
from hadim_cli.baselines.config import Actions, Algorithm, make_config, refusal
from hadim_cli.baselines.env import DISCRETE_WHEELS
from hadim_cli.baselines.rewards import GOAL_REWARD, STEP_PENALTY, Reward
from hadim_cli.baselines.tasks import TASKS
from hadim_cli.config import WorldConfig
from hadim_cli.evaluation.tasks import load_task
from hadim_store.api import Store


@pytest.fixture(autouse=True)
def _one_thread():
    import torch

    before = torch.get_num_threads()
    torch.set_num_threads(1)  # as the commands do; 2 shared cores
    yield
    torch.set_num_threads(before)


COMBOS = [(a.value, r.value, x.value) for a in Algorithm for r in Reward for x in Actions
          if refusal(a, r, x) is None]


def test_the_comparison_is_every_algorithm_with_both_rewards_and_a2c_also_continuous():
    assert COMBOS == [
        ("q-learning", "sparse", "discrete"), ("q-learning", "guided", "discrete"),
        ("dqn", "sparse", "discrete"), ("dqn", "guided", "discrete"),
        ("a2c", "sparse", "discrete"), ("a2c", "sparse", "continuous"),
        ("a2c", "guided", "discrete"), ("a2c", "guided", "continuous"),
        ("curious", "sparse", "discrete")]


@pytest.mark.parametrize(("index", "combo"), list(enumerate(COMBOS)), ids=lambda c: str(c))
def test_every_combination_learns_stores_resumes_and_evaluates(tmp_path, index, combo):
    algo, reward, actions = combo
    task = TASKS[index % len(TASKS)]  # each task gets three combinations
    cfg = make_config(algo, task, reward, actions, 200, 20, WorldConfig(), 20)
    with Store.open(tmp_path / "s.sqlite") as st:
        baseline_runs.new_run(st, cfg, 5, "r")
        session = baseline_runs.BaselineSession(cfg, 5)
        baseline_runs.train(st, "r", session, 40)
        session = baseline_runs.restore(st, st.get_run("r"))
        write = session.run_chunk(20)
        assert session.iteration == 60 and st.get_run("r").iterations == 40
    rewards = set(write.extra["rewards"])
    if reward == "sparse":
        assert rewards <= {STEP_PENALTY, GOAL_REWARD}
    else:
        assert max(rewards) > 0  # moving or pushing the right way, within 20 random steps
    discrete = [any(np.array_equal(a, w) for w in DISCRETE_WHEELS) for a in write.actions]
    assert all(discrete) == (actions == "discrete")
    two = dataclasses.replace(load_task(task), points=load_task(task).points[:2])
    result = session.evaluate(two)
    assert 0.0 <= result.score <= 1.0
    assert [p.target for p in result.points] == list(two.points)


def test_a_baseline_stored_before_a_world_key_existed_reads_it_at_the_installed_default():
    """A stored baseline's world lacks the keys added after it (e.g. `settle_time`): the
    installed version's defaults stand for them (`config.stored_config`)."""
    from hadim_cli.baselines.config import read_config

    cfg = make_config("dqn", "push-object", "sparse", "discrete", 100, 0, WorldConfig())
    assert cfg.world_config == WorldConfig()
    stored = cfg.to_dict()
    del stored["baseline"]["world"]["settle_time"]
    assert read_config(stored).world_config.settle_time == WorldConfig().settle_time
