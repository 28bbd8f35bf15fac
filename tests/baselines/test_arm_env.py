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
from hadim_cli.world.kinematics import effector_position, inner_reach, outer_reach, pose_angles
from hadim_cli.world.layout import Property
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
    assert env.columns == ["effector.x", "effector.y", "effector.cos", "effector.sin",
                           "effector.joint2", "effector.joint3", "obj1.x", "obj1.y", "obj2.x",
                           "obj2.y", "goal.x", "goal.y"]
    assert env.action_space.n == 6  # each joint one way, then the other
    assert env.wheels(3).tolist() == [0.0, -1.0, 0.0]
    obs, _ = env.reset(seed=3)
    joints = pose_angles(obs["observation"][2:4], obs["observation"][4:6])
    assert np.allclose(obs["observation"][:2], effector_position((0.6, 0.5, 0.4), joints),
                       atol=1e-3)
    after = env.step(0)[0]["observation"]  # the shoulder turns, counter-clockwise
    turned = pose_angles(after[2:4], after[4:6])
    assert turned[0] > joints[0] and np.allclose(turned[1:], joints[1:], atol=2e-3)
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
                target = np.linalg.norm(obs["observation"][env.position_columns(1)])
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


def _cli(*args: object):
    from typer.testing import CliRunner

    from hadim_cli.app import app

    return CliRunner().invoke(app, [str(a) for a in args])


def test_a_baseline_trains_and_is_evaluated_on_an_arm_task_through_the_cli(tmp_path):
    """`hadim baseline train --task arm-push`: the task's body chooses the world; the stored
    evaluation follows the pushed object, read where the arm's observation holds it (after
    the effector's position and its three joints), from the scene's own place."""
    import json

    from hadim_cli.evaluation.tasks import load_task

    store = tmp_path / "arm.sqlite"
    result = _cli("baseline", "train", "--algo", "dqn", "--task", "arm-push", "-n", 40,
                  "--eval-every", 20, "--episode-length", 20, "--store", store)
    assert result.exit_code == 0, (result.stderr, result.exception)
    shown = json.loads(_cli("runs", "show", "run-1", "--json", "--store", store).stdout)
    assert shown["config"]["baseline"]["world"]["body"] == "arm"
    out = _cli("eval", "run-1", "--task", "arm-push", "--json", "--store", store)
    assert out.exit_code == 0, out.stderr
    task = load_task("arm-push")
    obj = task.scene.objects[0]
    assert json.loads(out.stdout)["actor"] == "effector"
    points = json.loads(out.stdout)["points"]
    assert [tuple(p["target"]) for p in points] == [tuple(p) for p in task.points]
    for p in points:
        np.testing.assert_allclose(p["start"], [obj.x, obj.y], atol=1e-3)


def test_q_learning_trains_evaluates_and_resumes_on_the_arm_through_the_cli(tmp_path):
    """`hadim baseline train --algo q-learning --task reach`: a table of the arm's six moves,
    evaluated on the arm's task, and a run resumed half-way ends with the same table."""
    import json

    from hadim_store import Store

    store = tmp_path / "arm.sqlite"
    common = ("--algo", "q-learning", "--task", "reach", "--eval-every", 20,
              "--episode-length", 20, "--store", store)
    result = _cli("baseline", "train", *common, "-n", 40, "--name", "straight")
    assert result.exit_code == 0, (result.stderr, result.exception)
    assert _cli("baseline", "train", *common, "-n", 20, "--name", "resumed").exit_code == 0
    assert _cli("resume", "resumed", "--iterations", 40, "--store", store).exit_code == 0
    out = _cli("eval", "straight", "--task", "reach", "--json", "--store", store)
    assert out.exit_code == 0, out.stderr
    evaluated = json.loads(out.stdout)
    assert evaluated["actor"] == "effector" and len(evaluated["points"]) == 8
    with Store.open(store) as st:
        a, b = st.checkpoint("straight"), st.checkpoint("resumed")
        assert [e.task for e in st.evaluations("straight")][:2] == ["reach", "reach@20"]
    assert a.arrays["q.values"].shape[1] == 6 and len(a.arrays["q.keys"]) > 1
    assert all(a.arrays[k].tobytes() == b.arrays[k].tobytes() for k in a.arrays)


def _arm_state(env: GoalWorldEnv, obs: dict, joints, objects=None, goal=None) -> dict:
    """`obs` with the arm posed by `joints` (the effector where they put it), the objects
    and the goal moved where given."""
    obs = {k: v.copy() for k, v in obs.items()}
    o = obs["observation"]
    q = np.asarray(joints, dtype=np.float64)
    cols = {(s.entity, s.prop): c for s, c in env.observed}
    o[cols[("effector", Property.POSITION)]] = effector_position((0.6, 0.5, 0.4), q)
    o[cols[("effector", Property.ORIENTATION)]] = (np.cos(q[0]), np.sin(q[0]))
    o[cols[("effector", Property.JOINTS)]] = q[1:]
    for i, xy in enumerate(objects or ()):
        o[cols[(f"obj{i + 1}", Property.POSITION)]] = xy
    if goal is not None:
        obs["desired_goal"] = np.asarray(goal, dtype=np.float32)
    return obs


def test_q_learning_s_states_separate_what_the_arm_tells_apart():
    """The table's grid comes from what the arm's world declares: the effector's place, the
    arm's orientation in sectors, each bend in bins of its range, the objects read after the
    joints, the goal. Poses the effector's place alone cannot tell apart are two states; what
    the grid is too coarse to see (a bend within its bin) is one."""
    from hadim_cli.baselines.qlearning import QLearningParams, TabularQ

    env = arm_env("arm-push")
    table = TabularQ(env, QLearningParams(), 100, np.random.default_rng(0))
    obs, _ = env.reset(seed=2)
    objects, goal = [(-1.0, -1.0)], (-0.5, -1.0)

    def key(joints, objects=objects, goal=goal) -> int:
        return table.state(_arm_state(env, obs, joints, objects, goal))

    # The elbow and the wrist bent one way, then mirrored about the line from the base to the
    # effector: the effector at the same place, the arm turned within one sector.
    sector = 2 * np.pi / 16
    pose = np.array([-np.pi + 9 * sector + 0.05, 0.3, -0.3])
    reach = effector_position((0.6, 0.5, 0.4), pose)
    mirrored = np.array([2 * np.arctan2(reach[1], reach[0]) - pose[0], -0.3, 0.3])
    np.testing.assert_allclose(effector_position((0.6, 0.5, 0.4), mirrored), reach, atol=1e-12)
    assert np.floor((mirrored[0] + np.pi) / sector) == np.floor((pose[0] + np.pi) / sector)
    assert key(pose) != key(mirrored)
    assert key(pose) != key(pose + [sector, 0.0, 0.0])  # turned into the next sector
    assert key(pose) != key(pose, objects=[(-1.0, -0.7)])  # the target in another cell
    assert key(pose) != key(pose, goal=(-0.5, -0.7))
    # A bend moved anywhere within one bin of its range (0.25 rad: 16 bins of ±2 rad), all
    # else unmoved: the same state.
    state = _arm_state(env, obs, [0.1, 0.26, 0.5], objects, goal)
    moved = {k: v.copy() for k, v in state.items()}
    moved["observation"][dict((s.prop, c) for s, c in env.observed)[Property.JOINTS]] = (
        0.49, 0.5)
    assert table.state(state) == table.state(moved)


def test_q_learning_s_robot_frame_on_the_arm_turns_with_its_orientation():
    """The fixed variant's grid on the arm: the target and the goal seen in the frame of the
    arm's orientation (bearing sector, distance ring), then each bend's bin."""
    from hadim_cli.baselines.qlearning import Grid, robot_frame_cells

    env = arm_env("arm-push")
    obs, _ = env.reset(seed=2)
    grid = Grid.of(env)
    # The arm straight along +y, the target 0.4 m to its left (−x), the goal 0.25 m ahead
    # of the target (its +y).
    state = _arm_state(env, obs, [np.pi / 2, 0.0, 0.0], [(-0.4, 1.5)], (-0.4, 1.75))
    state["achieved_goal"] = np.array([-0.4, 1.5], np.float32)
    assert robot_frame_cells(state, 16, grid) == [12, 3, 8, 2, 8, 8]


def test_curious_reads_each_module_s_entity_where_the_arm_s_observation_holds_it():
    """CURIOUS's modules on the arm: the effector, the target, the tool — each one's outcome
    read after the arm's joints, for the achieved goal of an episode and for modular HER."""
    from hadim_cli.baselines.curious import ModularGoalEnv, entity_positions

    base = arm_env("arm-push-with-tool")
    env = ModularGoalEnv(base)
    obs, _ = env.reset(seed=3)
    at = base.position_columns(1).start
    assert at == 6  # effector x, y, its orientation's cos, sin, two bends
    for m in range(env.n_modules):
        want = obs["observation"][base.position_columns(m)]
        got = entity_positions(obs["observation"][None], [m], at)[0]
        np.testing.assert_array_equal(got, want)
    seen = set()
    for seed in range(40):  # every module in turn, as the draws give them
        obs, _ = env.reset(seed=seed)
        m = env.module
        seen.add(m)
        world = base.world.observe()
        name = base.world.layout.entities[m]
        true = base.world.layout.get(world, name, Property.POSITION)
        np.testing.assert_allclose(obs["achieved_goal"], env.encode(true, m), atol=1e-6)
    assert seen == set(range(env.n_modules))


def test_modular_her_on_the_arm_relabels_with_the_objects_read_after_the_joints():
    """A CURIOUS agent on the arm: the relabelled goals of modular HER read each object where
    the arm's observation holds it (the first object after the effector and its joints)."""
    from hadim_cli.baselines.agents import make_agent
    from hadim_cli.baselines.config import make_config, task_world
    from hadim_cli.baselines.curious import entity_positions

    cfg = make_config("curious", "arm-push-with-tool", "sparse", "discrete", 1000, 0,
                      task_world("arm-push-with-tool"), episode_length=10)
    agent = make_agent(cfg, 0)
    at = agent.model.replay_buffer.objects_at
    base = agent.envs[0].base
    obs, _ = base.reset(seed=1)
    for m in range(3):
        np.testing.assert_array_equal(entity_positions(obs["observation"][None], [m], at)[0],
                                      obs["observation"][base.position_columns(m)])
    assert at == 6
