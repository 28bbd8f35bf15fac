"""Rows of a tool affordance: the target moved through the tool, not by the robot's body."""

from __future__ import annotations

import dataclasses

import numpy as np

from hadim_cli.config import LearnerConfig, WorldConfig
from hadim_cli.learner.affordance import Fitter
from hadim_cli.learner.dataset import Dataset
from hadim_cli.learner.spaces import ACTION, Property, Role, RoleSpace, SpaceReader
from hadim_cli.world.actions import ROVER_ACTIONS
from hadim_cli.world.scene import ObjectSpec, Scene
from hadim_cli.world.world import World

TOOL_POS = RoleSpace(Role.TOOL, Property.POSITION)
TARGET_POS = RoleSpace(Role.TARGET, Property.POSITION)
GREEN = (0.2, 0.8, 0.2)
ROBOT_POS = RoleSpace(Role.ROBOT, Property.POSITION)
REL = RoleSpace(Role.TARGET, Property.POSITION, Role.ROBOT)


def _push_a_chain(world_config: WorldConfig) -> tuple[Fitter, World]:
    """The robot drives into obj1, which drives into obj2; the other objects are far away."""
    far = [ObjectSpec(-1.5 + 0.4 * i, 1.6, 0.1, 0.2, (0.8, 0.2, 0.2), False)
           for i in range(world_config.n_green + world_config.n_red - 2)]
    scene = Scene((ObjectSpec(0.27, 0.0, 0.1, 0.2, GREEN, True),
                   ObjectSpec(0.48, 0.0, 0.1, 0.2, GREEN, True), *far))
    world = World(world_config)
    obs = world.reset(scene=scene)
    dataset = Dataset(world.layout.size, 2)
    dataset.start_episode()
    for _ in range(6):
        before, obs = obs, world.step(np.array([1.0, 1.0]))
        dataset.append(np.array([1.0, 1.0]), before, obs)
    reader = SpaceReader(world.layout, actions=world.action_space)
    return Fitter(dataset, reader, LearnerConfig()), world


def test_tool_rows_drop_targets_the_robot_touches():
    fitter, world = _push_a_chain(WorldConfig())
    t = np.arange(len(fitter.dataset), dtype=np.int64)
    sample = fitter.candidate_rows(TOOL_POS, TARGET_POS, t)
    moved = fitter.nonzero(sample.y)
    pairs = set(zip(sample.rows.target[moved].tolist(), sample.rows.tool[moved].tolist(),
                    strict=True))
    obj1, obj2 = world.layout.entities.index("obj1"), world.layout.entities.index("obj2")
    assert (obj2, obj1) in pairs       # obj2 moved through obj1: a tool row
    assert all(target != obj1 for target, _ in pairs)  # obj1 moved by the robot's body
    # The direct pushing affordance keeps obj1's rows.
    direct = fitter.candidate_rows(RoleSpace(Role.ROBOT, Property.POSITION), TARGET_POS, t)
    assert obj1 in direct.rows.target[fitter.nonzero(direct.y)].tolist()
    assert fitter.touching_robot(direct.rows).any()


def test_the_learner_config_sets_the_robustness_of_every_new_model():
    """`learner.robust_fit` reaches the models of new affordances (a framed model's too)."""
    for robust in (0, 2):
        config = dataclasses.replace(LearnerConfig(), robust_fit=robust)
        fitter = Fitter(Dataset(World(WorldConfig()).layout.size, 2),
                        SpaceReader(World(WorldConfig()).layout, actions=ROVER_ACTIONS), config)
        for inp, out, contexts in ((ACTION, ROBOT_POS, ()), (ROBOT_POS, TARGET_POS, (REL,))):
            model = fitter.new_model(inp, out, contexts)
            assert getattr(model, "inner", model).robust_iterations == robust
            assert model.params()["robust_iterations"] == robust


def _drive_into(world_config: WorldConfig, scene: Scene, action,
                n: int) -> tuple[Fitter, np.ndarray]:
    """`n` times `action` from `scene`; the Fitter over them and the robot's positions."""
    world = World(world_config)
    obs = world.reset(scene=scene)
    dataset = Dataset(world.layout.size, 2)
    dataset.start_episode()
    positions = [world.robot_pose()[:2]]
    for _ in range(n):
        before, obs = obs, world.step(np.asarray(action, dtype=float))
        dataset.append(np.asarray(action, dtype=float), before, obs)
        positions.append(world.robot_pose()[:2])
    reader = SpaceReader(world.layout, actions=world.action_space)
    return Fitter(dataset, reader, LearnerConfig()), np.asarray(positions)


def test_the_robots_motion_is_learned_from_moves_clear_of_everything():
    """The rows of the robot's own motion (action → robot position, heading) are the
    actions taken clear of walls (seen by its one LIDAR ray, ahead) and of objects (from
    their relative positions: the object is behind, where no ray looks); pressed against
    either, the robot does not move as its wheels say."""
    config = dataclasses.replace(WorldConfig(), lidar_rays=1)
    parked = [ObjectSpec(-1.6 + 0.4 * i, 1.7, 0.1, 0.2, (0.8, 0.2, 0.2), False)
              for i in range(config.n_green + config.n_red - 1)]
    reach = config.robot_radius + 0.02  # + affordance.CONTACT_MARGIN
    # Full forward, facing −y from the centre: 0.15 m per action into the wall at y = −2.
    wall = Scene((ObjectSpec(1.5, 0.0, 0.1, 0.2, GREEN, True), *parked), 0.0, -0.5,
                 -np.pi / 2)
    # Full reverse, facing +x, towards a red object 0.6 m behind: pressed against it.
    red = Scene((ObjectSpec(-0.6, 0.0, 0.1, 0.2, (0.8, 0.2, 0.2), False), *parked),
                0.0, 0.0, 0.0)
    for scene, action, gap in ((wall, (1.0, 1.0), lambda p: p[:, 1] + 2.0),
                               (red, (-1.0, -1.0), lambda p: p[:, 0] + 0.6 - 0.1)):
        fitter, pos = _drive_into(config, scene, action, 12)
        t = np.arange(len(fitter.dataset), dtype=np.int64)
        for out in (ROBOT_POS, RoleSpace(Role.ROBOT, Property.HEADING)):
            kept = np.zeros(t.size, dtype=bool)
            kept[fitter.candidate_rows(ACTION, out, t).rows.t] = True
            g = gap(pos)
            clear = (g[:-1] > reach) & (g[1:] > reach)
            stuck = np.linalg.norm(np.diff(pos, axis=0), axis=1) < 0.05
            assert stuck.sum() >= 3 and (~stuck).sum() >= 3  # the scene has both
            assert np.array_equal(kept, clear)
            assert not kept[stuck].any()
