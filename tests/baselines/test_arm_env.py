"""The goal environments on the arm: the same `GoalWorldEnv`, following what the arm's world
declares (its effector, joints and moves); Gymnasium's checker, contacts, snapshots, seeds."""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

from hadim_cli.baselines.env import GoalWorldEnv, register
from hadim_cli.baselines.tasks import ARM_TASKS
from hadim_cli.config import Body, WorldConfig
from hadim_cli.errors import HadimError
from hadim_cli.world.kinematics import effector_position, inner_reach, outer_reach
from hadim_cli.world.scene import ArmScene

ARM = WorldConfig(body=Body.ARM)


def arm_env(task: str, actions: str = "discrete", reward: str = "sparse") -> GoalWorldEnv:
    return GoalWorldEnv(task, actions, reward, ARM, max_steps=30)


@pytest.mark.parametrize("task", ARM_TASKS)
@pytest.mark.parametrize("actions", ["discrete", "continuous"])
def test_check_env_passes_on_every_arm_variant(task, actions):
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # a checker warning is a failure here
        check_env(arm_env(task, actions, "guided"), skip_render_check=True)


def test_the_arm_env_observes_and_acts_as_the_arm_declares():
    env = arm_env("arm-push-with-tool")
    assert env.columns == ["effector.x", "effector.y", "effector.joint1", "effector.joint2",
                           "effector.joint3", "obj1.x", "obj1.y", "obj2.x", "obj2.y",
                           "goal.x", "goal.y"]
    assert env.action_space.n == 6  # each joint one way, then the other
    assert env.wheels(3).tolist() == [0.0, -1.0, 0.0]
    obs, _ = env.reset(seed=3)
    joints = obs["observation"][2:5]
    assert np.allclose(obs["observation"][:2], effector_position((0.6, 0.5, 0.4), joints),
                       atol=1e-3)
    after = env.step(0)[0]["observation"]  # the shoulder turns, counter-clockwise
    assert after[2] > joints[0] and np.allclose(after[3:5], joints[1:], atol=2e-3)
    with pytest.raises(HadimError, match="unknown task 'move-robot' for the arm"):
        GoalWorldEnv("move-robot", "discrete", "sparse", ARM)


def test_arm_starts_and_goals_lie_where_the_arm_reaches():
    near, far = inner_reach((0.6, 0.5, 0.4), (2.0, 2.0)), outer_reach((0.6, 0.5, 0.4))
    for task in ARM_TASKS:
        env = arm_env(task)
        for seed in range(20):
            obs, _ = env.reset(seed=seed)
            goal = np.linalg.norm(obs["desired_goal"])
            if task == "reach":
                assert near <= goal <= far
            else:
                target = np.linalg.norm(obs["observation"][5:7])
                assert near <= target <= far and goal <= far + 0.05 + 0.12
            if task == "arm-push-with-tool":  # the tool too, where the effector gets behind it
                assert np.linalg.norm(obs["observation"][7:9]) <= far


def test_arm_tool_task_fails_on_effector_target_contact():
    env = arm_env("arm-push-with-tool", "continuous")
    env.reset(seed=0)
    target, tool = env.task.objects
    # The target just beyond the bent arm's effector at (0.5, 0), the tool out of the way.
    scene = ArmScene((target.__class__(0.8, 0.0, target.radius, target.height, target.color,
                                       True),
                      tool.__class__(-0.8, 0.6, tool.radius, tool.height, tool.color, True)),
                     (-1.201, 1.61, 1.61))
    env.start_from(scene, [1.2, 0.0])
    for _ in range(20):
        _, _, terminated, _, info = env.step(np.array([0.0, -1.0, -1.0], dtype=np.float32))
        if terminated:
            break
    assert terminated and info.get("contact") and not info["is_success"]


def test_arm_snapshot_restores_an_episode_bit_identically_and_resets_are_seeded():
    env = arm_env("arm-push", "continuous", "guided")
    env.reset(seed=5)
    rng = np.random.default_rng(0)
    for _ in range(10):
        env.step(rng.uniform(-1, 1, 3).astype(np.float32))
    again = arm_env("arm-push", "continuous", "guided")
    obs = again.restore(env.snapshot())
    np.testing.assert_array_equal(obs["observation"], env._observation()["observation"])
    for a in rng.uniform(-1, 1, (10, 3)).astype(np.float32):
        assert again.step(a)[0]["observation"].tobytes() == env.step(a)[0]["observation"].tobytes()
    a, b = (arm_env("reach").reset(seed=9)[0] for _ in range(2))
    assert all(np.array_equal(a[k], b[k]) for k in a)


def test_the_arm_variants_are_registered():
    import gymnasium as gym

    register()
    env = gym.make("hadim/arm-push-with-tool-v0", actions="continuous")
    assert env.unwrapped.task.name == "arm-push-with-tool"
    assert env.unwrapped.world.layout.actor == "effector"
