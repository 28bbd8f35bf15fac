"""Tabular Q-learning learns a short move goal; CURIOUS's module choice by learning progress."""

from __future__ import annotations

import numpy as np
import pytest

from hadim_cli.baselines.curious import (
    ModularGoalEnv,
    learning_progress,
    module_probabilities,
)
from hadim_cli.baselines.env import GoalWorldEnv
from hadim_cli.baselines.qlearning import QLearningParams, TabularQ
from hadim_cli.baselines.rewards import GOAL_REWARD, STEP_PENALTY
from hadim_cli.world.scene import Scene

START, GOAL = Scene((), -0.25, 0.2, np.pi), [0.2, 0.2]  # 0.45 m behind the robot


class ShortMove(GoalWorldEnv):
    """move-robot from one start to one goal, 30 actions per episode."""

    def __init__(self):
        super().__init__("move-robot", "discrete", "sparse", max_steps=30)

    def reset(self, *, seed=None, options=None):
        super().reset(seed=seed)
        return self.start_from(START, GOAL), {}


@pytest.mark.parametrize("seed", [0, 1])
def test_q_learning_learns_a_short_move_goal(seed):
    env = ShortMove()
    q = TabularQ(env, QLearningParams(alpha=0.5, cells=40, eps_fraction=0.5), 2000,
                 np.random.default_rng(seed))
    obs, _ = env.reset()
    assert not _greedy_reaches(q, env, obs)  # it does not know the way before learning
    q.learn(2000)
    obs, _ = env.reset()
    assert _greedy_reaches(q, env, obs)


def _greedy_reaches(q, env, obs) -> int:
    for step in range(1, 13):
        obs, reward, terminated, _, _ = env.step(q.greedy(obs))
        if terminated:
            return step
    return 0


def test_q_learning_is_seeded():
    tables = []
    for _ in range(2):
        q = TabularQ(ShortMove(), QLearningParams(), 1000, np.random.default_rng(4))
        q.learn(300)
        tables.append(q.state_dict()[1])
    assert all(np.array_equal(tables[0][k], tables[1][k]) for k in tables[0])


def test_learning_progress_and_module_probabilities():
    assert learning_progress([]) == 0.0
    assert learning_progress([1]) == 0.0
    assert learning_progress([0, 0, 1, 1]) == 1.0
    assert learning_progress([1, 1, 0, 0]) == 1.0  # absolute: forgetting counts too
    assert learning_progress([1] * 400 + [0] * 300) == 0.0  # the last 300 only
    np.testing.assert_allclose(module_probabilities([0.0, 0.0, 0.0]), [1 / 3] * 3)
    np.testing.assert_allclose(module_probabilities([0.0, 0.3, 0.1]),
                               [0.4 / 3, 0.4 / 3 + 0.6 * 0.75, 0.4 / 3 + 0.6 * 0.25])


def test_curious_draws_modules_by_progress_and_rewards_the_active_slot():
    env = ModularGoalEnv(GoalWorldEnv("push-with-tool", "discrete", "sparse"))
    env.outcomes = [[0] * 10 + [1] * 10, [0] * 20, [0] * 20]  # only the robot progresses
    env.reset(seed=0)
    picks = []
    for _ in range(300):
        obs, _ = env.reset()
        picks.append(env.module)
        desired = obs["desired_goal"]
        assert desired[6 + env.module] == 1.0 and desired[6:].sum() == 1.0
        slots = desired[:6].reshape(3, 2)
        assert not np.delete(slots, env.module, axis=0).any()
    share = np.bincount(picks, minlength=3) / len(picks)
    assert share[0] == pytest.approx(0.4 / 3 + 0.6, abs=0.08)  # p = 0.733
    a = env.encode(np.array([0.5, 0.5]), 2)
    assert env.compute_reward(a, env.encode(np.array([0.55, 0.5]), 2), None) == GOAL_REWARD
    assert env.compute_reward(a, env.encode(np.array([0.8, 0.5]), 2), None) == STEP_PENALTY


@pytest.mark.parametrize("algorithm", ["dqn", "a2c"])
def test_learning_in_chunks_writes_nothing_to_the_temporary_directory(
        algorithm, tmp_path, monkeypatch):
    """SB3's own logger makes a new directory under the system's temporary one at every
    `learn` call: one per chunk, thousands per sweep (2488 were found after a day of test
    runs). The agents log nowhere (torch may keep its own caches there)."""
    import tempfile

    from hadim_cli.baselines.agents import make_agent
    from hadim_cli.baselines.config import BaselineConfig

    monkeypatch.delenv("SB3_LOGDIR", raising=False)
    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path))
    agent = make_agent(BaselineConfig(algorithm, "move-robot", "sparse", episode_length=20,
                                      params={"learning_starts": 5}
                                      if algorithm == "dqn" else {}), seed=0)
    for _ in range(3):
        agent.learn(10)
    assert agent.iterations >= 30
    assert not [p.name for p in tmp_path.iterdir() if p.name.startswith("SB3-")]
