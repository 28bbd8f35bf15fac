"""CURIOUS's mechanisms against Colas et al. (ICML 2019), each with a test that fails when it
is wrong (each checked by planting its bug and seeing the test fail):

- module choice: p(m) = 0.4 / N + 0.6 · LP(m) / ΣLP (test_algorithms.py);
- the module encoding: one (x, y) slot per module, only the active one filled, then a one-hot
  module descriptor; a module's outcome is its entity's position;
- modular HER: a relabelled transition gets a module drawn by LP and that module's outcome at
  a *future* step of the *same* episode as goal (k = 4: 80 % of a batch relabelled), its
  achieved goals re-encoded in that module, its reward recomputed.
"""

from __future__ import annotations

import numpy as np
import pytest

from hadim_cli.baselines.agents import make_agent
from hadim_cli.baselines.config import make_config
from hadim_cli.baselines.curious import ModularGoalEnv, encode_goals, entity_positions
from hadim_cli.baselines.env import GoalWorldEnv
from hadim_cli.baselines.rewards import GOAL_REWARD, STEP_PENALTY
from hadim_cli.config import WorldConfig

EPISODE = 10
ROVER_OBJECTS = 4
"""The rover's first object column: after its position and its heading's cos, sin."""


def test_encoding_of_many_goals_is_the_env_encoding():
    env = ModularGoalEnv(GoalWorldEnv("push-with-tool", "discrete", "sparse"))
    obs = np.array([[0.1, 0.2, 1.0, 0.0, 0.5, 0.6, -0.7, -0.8]] * 3, dtype=np.float32)
    modules = np.array([0, 1, 2])
    positions = entity_positions(obs, modules, ROVER_OBJECTS)
    np.testing.assert_allclose(positions, [[0.1, 0.2], [0.5, 0.6], [-0.7, -0.8]], rtol=1e-6)
    encoded = encode_goals(positions, modules, 3)
    for row, m in zip(encoded, modules, strict=True):
        np.testing.assert_array_equal(row, env.encode(positions[m], int(m)))
        assert row[6 + m] == 1.0 and row[6:].sum() == 1.0  # one-hot descriptor
        assert np.count_nonzero(row[:6]) == 2  # only the active slot


def test_the_achieved_goal_is_the_active_modules_entity():
    env = ModularGoalEnv(GoalWorldEnv("push-with-tool", "discrete", "sparse"))
    obs, _ = env.reset(seed=3)
    m = env.module
    at = entity_positions(obs["observation"][None], [m], ROVER_OBJECTS)
    np.testing.assert_allclose(obs["achieved_goal"], encode_goals(at, np.array([m]), 3)[0])


@pytest.fixture(scope="module")
def buffer():
    """A CURIOUS agent's buffer holding 3 episodes on module 0 of push-with-tool, written by
    hand: at step t every entity sits at x = t (+ 100 per episode), so a relabelled goal says
    which step it came from."""
    cfg = make_config("curious", "push-with-tool", "sparse", "discrete", 1000, 0, WorldConfig(),
                      episode_length=EPISODE)
    agent = make_agent(cfg, 0)
    buf = agent.model.replay_buffer
    env = agent.envs[0]
    for episode in range(3):
        for t in range(EPISODE):
            def obs_at(step, e=episode):
                x = 100.0 * e + step
                o = np.array([[x, 0.0, 1.0, 0.0, x, 1.0, x, 2.0]], dtype=np.float32)
                goal = env.encode(np.array([99.0, 99.0]), 0)[None]
                achieved = entity_positions(o, [0], ROVER_OBJECTS)
                return {"observation": o, "achieved_goal": encode_goals(
                    achieved, np.array([0]), 3), "desired_goal": goal}
            last = t == EPISODE - 1
            buf.add(obs_at(t), obs_at(t + 1), np.array([[0]]), np.array([STEP_PENALTY]),
                    np.array([last]), [{"TimeLimit.truncated": last}])
    return buf, env


def test_modular_her_relabels_module_and_a_future_goal_of_the_same_episode(buffer):
    buf, env = buffer
    env.outcomes = [[0] * 20, [0] * 10 + [1] * 10, [0] * 20]  # module 1 progresses
    np.random.seed(0)
    n = 4000
    index = np.random.randint(0, 3 * EPISODE, size=n)
    samples = buf._get_virtual_samples(index, np.zeros(n, dtype=int))
    desired = samples.observations["desired_goal"].numpy()
    modules = desired[:, 6:].argmax(axis=1)
    share = np.bincount(modules, minlength=3) / n
    np.testing.assert_allclose(share, [0.4 / 3, 0.4 / 3 + 0.6, 0.4 / 3], atol=0.03)
    obs = samples.observations["observation"].numpy()
    goal_x = desired[np.arange(n), 2 * modules]
    episode_of = obs[:, 0] // 100
    assert np.all(goal_x // 100 == episode_of)  # the same episode
    assert np.all(goal_x >= obs[:, 0] + 1)  # a future outcome (next observation or later)
    first = index % EPISODE == 0  # from an episode's first step: any of its later outcomes
    assert len(np.unique((goal_x - obs[:, 0])[first])) == EPISODE  # not only the final one
    achieved = samples.next_observations["achieved_goal"].numpy()
    assert np.all(achieved[:, 6:].argmax(axis=1) == modules)  # re-encoded in the module
    np.testing.assert_allclose(achieved[np.arange(n), 2 * modules],
                               samples.next_observations["observation"].numpy()[:, 0])
    reached = np.isclose(goal_x, obs[:, 0] + 1)
    rewards = samples.rewards.numpy().ravel()
    assert np.all(rewards[reached] == GOAL_REWARD) and np.all(rewards[~reached] == STEP_PENALTY)


def test_modular_her_replays_four_relabelled_transitions_per_real_one(buffer):
    buf, _ = buffer
    assert buf.n_sampled_goal == 4 and buf.goal_selection_strategy.name == "FUTURE"
    assert buf.her_ratio == pytest.approx(0.8)
