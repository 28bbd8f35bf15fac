"""Rows of a tool affordance: the target moved through the tool, not by the robot's body."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from hadim_cli.config import LearnerConfig, WorldConfig
from hadim_cli.learner.affordance import Fitter
from hadim_cli.learner.dataset import Dataset
from hadim_cli.learner.spaces import ACTION, Property, Role, RoleSpace, SpaceReader
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
    dataset = Dataset(world.layout.size)
    dataset.start_episode()
    for _ in range(6):
        before, obs = obs, world.step(np.array([1.0, 1.0]))
        dataset.append(np.array([1.0, 1.0]), before, obs)
    return Fitter(dataset, SpaceReader(world.layout), LearnerConfig()), world


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


@pytest.mark.parametrize("relation_frames", [False, True])
def test_the_learner_config_sets_the_robustness_of_every_new_model(relation_frames):
    """`learner.robust_fit` reaches the models of new affordances (a framed model's too)."""
    for robust in (0, 2):
        config = dataclasses.replace(LearnerConfig(), robust_fit=robust,
                                     relation_frames=relation_frames)
        fitter = Fitter(Dataset(World(WorldConfig()).layout.size),
                        SpaceReader(World(WorldConfig()).layout), config)
        for inp, out, contexts in ((ACTION, ROBOT_POS, ()), (ROBOT_POS, TARGET_POS, (REL,))):
            model = fitter.new_model(inp, out, contexts)
            assert getattr(model, "inner", model).robust_iterations == robust
            assert model.params()["robust_iterations"] == robust
