"""The goal environments: Gymnasium's checker, the paper's rewards, snapshots."""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

from hadim_cli.baselines.env import MAX_STEPS, GoalWorldEnv, register
from hadim_cli.baselines.rewards import (
    GOAL_REWARD,
    STEP_PENALTY,
    Reward,
    guided_reward,
    reward_1,
    sparse_reward,
)
from hadim_cli.baselines.tasks import GOAL_RADIUS, TASKS
from hadim_cli.errors import HadimError


@pytest.mark.parametrize("task", TASKS)
@pytest.mark.parametrize("actions", ["discrete", "continuous"])
@pytest.mark.parametrize("reward", ["sparse", "guided"])
def test_check_env_passes_on_every_variant(task, actions, reward):
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # a checker warning is a failure here
        check_env(GoalWorldEnv(task, actions, reward), skip_render_check=True)


def test_sb3_checker_and_registered_ids():
    import gymnasium as gym
    from stable_baselines3.common.env_checker import check_env as sb3_check

    register()
    env = gym.make("hadim/push-with-tool-v0", reward="guided", actions="continuous")
    assert env.unwrapped.task.name == "push-with-tool"
    sb3_check(GoalWorldEnv("push-with-tool", "discrete", "guided"), warn=False)


def test_bad_variant_is_a_hadim_error():
    with pytest.raises(HadimError, match="reward"):
        GoalWorldEnv("move-robot", "discrete", "dense")
    with pytest.raises(HadimError, match="unknown task"):
        GoalWorldEnv("fly", "discrete", "sparse")


# --------------------------------------------------------------------------- rewards by hand

G = np.array([1.0, 0.0])


def chain(*points):
    return np.array(points, dtype=float)


def both(kind, before, after, goal=G):
    """The vectorised reward and the step loop's scalar one, checked equal."""
    vec = (sparse_reward(after[-1], goal, GOAL_RADIUS) if kind is Reward.SPARSE
           else guided_reward(before, after, goal, GOAL_RADIUS))
    one = reward_1(kind, before.tolist(), after.tolist(), tuple(goal), GOAL_RADIUS)
    assert float(vec) == one
    return one


def test_sparse_table():
    assert both(Reward.SPARSE, chain([0, 0]), chain([0.95, 0.0])) == GOAL_REWARD
    assert both(Reward.SPARSE, chain([0, 0]), chain([0.15, 0.0])) == STEP_PENALTY
    assert both(Reward.SPARSE, chain([0, 0]), chain([0.0, 0.0])) == STEP_PENALTY
    # the zone's edge is inside
    assert both(Reward.SPARSE, chain([0, 0]), chain([1.0 - GOAL_RADIUS, 0.0])) == GOAL_REWARD


def test_guided_table_move_robot():
    assert both(Reward.GUIDED, chain([0, 0]), chain([0.95, 0])) == GOAL_REWARD
    assert both(Reward.GUIDED, chain([0, 0]), chain([0.15, 0])) == pytest.approx(20.0)
    assert both(Reward.GUIDED, chain([0, 0]), chain([0.075, 0])) == pytest.approx(10.0)
    assert both(Reward.GUIDED, chain([0, 0]), chain([0.3, 0])) == pytest.approx(20.0)  # capped
    assert both(Reward.GUIDED, chain([0, 0]), chain([-0.1, 0])) == STEP_PENALTY
    assert both(Reward.GUIDED, chain([0, 0]), chain([0, 0])) == STEP_PENALTY


def test_guided_table_pushing_reads_the_chain():
    # robot, target: the target pushed 0.15 m towards the goal
    assert both(Reward.GUIDED, chain([-0.5, 0], [0, 0]), chain([-0.35, 0], [0.15, 0])) == \
        pytest.approx(20.0)
    # the target pushed away: no bonus even though the robot went towards it
    assert both(Reward.GUIDED, chain([-0.5, 0], [0, 0]), chain([-0.35, 0], [-0.05, 0])) == \
        STEP_PENALTY
    # the target still, the robot going 0.075 m towards it: half the bonus
    assert both(Reward.GUIDED, chain([-0.5, 0], [0, 0]), chain([-0.425, 0], [0, 0])) == \
        pytest.approx(10.0)
    # robot, tool, target: the tool going towards the still target
    before = chain([-0.8, 0], [-0.4, 0], [0, 0])
    assert both(Reward.GUIDED, before, chain([-0.65, 0], [-0.25, 0], [0, 0])) == \
        pytest.approx(20.0)
    # only the robot moved, towards the tool
    assert both(Reward.GUIDED, before, chain([-0.65, 0], [-0.4, 0], [0, 0])) == \
        pytest.approx(20.0)
    # only the robot moved, away from the tool
    assert both(Reward.GUIDED, before, chain([-0.95, 0], [-0.4, 0], [0, 0])) == STEP_PENALTY


def test_vectorised_equals_one_by_one_on_random_batches():
    rng = np.random.default_rng(3)
    before = rng.uniform(-1, 1, size=(500, 3, 2))
    after = before + rng.normal(0, 0.05, size=before.shape) * rng.integers(0, 2, (500, 3, 1))
    goal = rng.uniform(-1, 1, size=(500, 2))
    vec = guided_reward(before, after, goal, GOAL_RADIUS)
    one = [reward_1(Reward.GUIDED, b.tolist(), a.tolist(), tuple(g), GOAL_RADIUS)
           for b, a, g in zip(before, after, goal, strict=True)]
    assert vec.tolist() == one
    assert len(set(np.round(one, 6))) > 50  # the batch explores the bonus, not only −5


def test_env_compute_reward_relabels_a_batch():
    env = GoalWorldEnv("push-object", "discrete", "guided")
    obs, _ = env.reset(seed=1)
    _, reward, _, _, info = env.step(0)
    batch = env.compute_reward(np.stack([obs["achieved_goal"], env.goal]),
                               np.stack([env.goal, env.goal]), np.array([info, info]))
    assert batch.shape == (2,)
    assert batch[1] == GOAL_REWARD  # relabelled onto the achieved position: the goal


# --------------------------------------------------------------------------- episodes

def test_episode_ends_at_the_goal_and_after_1000_actions():
    env = GoalWorldEnv("move-robot", "discrete", "sparse")
    env.reset(seed=0)
    env.start_from(env._scene, [env._scene.robot_x + 0.05, env._scene.robot_y])
    _, reward, terminated, truncated, info = env.step(2)  # turning: it stays in the zone
    assert (reward, terminated, truncated, info["is_success"]) == (GOAL_REWARD, True, False, True)
    env.start_from(env._scene, [1.5, 1.5])
    for _ in range(MAX_STEPS - 1):
        assert not any(env.step(2)[2:4])
    _, reward, terminated, truncated, _ = env.step(2)
    assert (reward, terminated, truncated) == (STEP_PENALTY, False, True)


def test_tool_task_fails_on_robot_target_contact():
    from hadim_cli.world.scene import Scene

    env = GoalWorldEnv("push-with-tool", "discrete", "sparse")
    env.reset(seed=0)
    target, tool = env.task.objects
    scene = Scene((target.__class__(0.5, 0.0, target.radius, target.height, target.color, True),
                   tool.__class__(0.0, 1.0, tool.radius, tool.height, tool.color, True)),
                  0.0, 0.0, 0.0)
    env.start_from(scene, [1.2, 0.0])
    for _ in range(10):
        _, _, terminated, _, info = env.step(0)
        if terminated:
            break
    assert terminated and info.get("contact") and not info["is_success"]


def test_snapshot_restores_an_episode_bit_identically():
    env = GoalWorldEnv("push-object", "continuous", "guided")
    env.reset(seed=5)
    rng = np.random.default_rng(0)
    for _ in range(30):
        env.step(rng.uniform(-1, 1, 2).astype(np.float32))
    snap = env.snapshot()
    again = GoalWorldEnv("push-object", "continuous", "guided")
    obs = again.restore(snap)
    np.testing.assert_array_equal(obs["observation"], env._observation()["observation"])
    actions = rng.uniform(-1, 1, (20, 2)).astype(np.float32)
    for a in actions:
        assert again.step(a)[0]["observation"].tobytes() == env.step(a)[0]["observation"].tobytes()
    assert again.reset()[0]["desired_goal"].tolist() == env.reset()[0]["desired_goal"].tolist()


def test_reset_is_seeded():
    a = GoalWorldEnv("push-with-tool", "discrete", "sparse").reset(seed=9)[0]
    b = GoalWorldEnv("push-with-tool", "discrete", "sparse").reset(seed=9)[0]
    assert all(np.array_equal(a[k], b[k]) for k in a)
