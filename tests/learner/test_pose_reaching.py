"""Pose reaching on hand-built models whose answer is known, in the real pymunk World: the
navigator, given the differential drive's exact kinematics (the `motion` override that
`--exact navigation` uses) or forward models fitted on rows of those kinematics (as the
learner's A0 would be), brings the robot to a position *and* heading of the `reach-pose`
task within tolerance, in few actions."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from hadim_cli.config import PlannerConfig, WorldConfig
from hadim_cli.evaluation.exact import KinematicMotion
from hadim_cli.evaluation.tasks import load_task
from hadim_cli.learner.models import LocalLinearModel
from hadim_cli.learner.navigation import ROBOT_HEADING, ROBOT_POSITION, Navigator, Place, line_angle
from hadim_cli.learner.spaces import ACTION, SpaceReader
from hadim_cli.world.world import World

WORLD = WorldConfig()
TASK = load_task("reach-pose")


def _fitted_movers(reader: SpaceReader, obs: np.ndarray, n: int = 600) -> SimpleNamespace:
    """`action → robot.position` and `action → robot.heading`, heading as context, fitted on
    `n` random commands of the exact kinematics from random headings."""
    rng = np.random.default_rng(0)
    exact = KinematicMotion(WORLD, reader)
    heading_slice = reader.layout.space("robot", "heading").slice
    commands = rng.uniform(-1.0, 1.0, (n, 2))
    headings, shifts, turns = [], [], []
    for theta, cmd in zip(rng.uniform(-np.pi, np.pi, n), commands, strict=True):
        h = np.array([np.cos(theta), np.sin(theta)])
        row = obs.copy()
        row[heading_slice] = h
        shift, after = exact(row, cmd[None])
        headings.append(h)
        shifts.append(shift[0])
        turns.append(after[0] - h)
    affs = {}
    for space, out, aff_id in ((ROBOT_POSITION, shifts, 1), (ROBOT_HEADING, turns, 2)):
        model = LocalLinearModel(2, 2, [2])
        model.add(commands, np.array(headings), np.array(out))
        affs[space] = SimpleNamespace(id=aff_id, input=ACTION, output=space, model=model,
                                      competence=0.9, contexts=(ROBOT_HEADING,))
    return SimpleNamespace(with_output=lambda space: [affs[space]] if space in affs else [])


@pytest.mark.parametrize("models", ["exact", "fitted"])
def test_the_navigator_reaches_every_pose_of_the_task_in_the_real_world(models):
    world = World(WORLD)
    obs = world.reset(scene=TASK.scene)
    reader = SpaceReader(world.layout)
    config = PlannerConfig()
    if models == "exact":
        nav = Navigator(SimpleNamespace(with_output=lambda space: []), reader, config,
                        KinematicMotion(WORLD, reader))
    else:
        nav = Navigator(_fitted_movers(reader, obs), reader, config)
    for (x, y), heading in zip(TASK.points, TASK.headings, strict=True):
        obs = world.reset(scene=TASK.scene)
        nav.forget()
        want = np.array([np.cos(heading), np.sin(heading)])
        place = Place(np.array([x, y]), want, 0.03)
        used = 0
        while used < 30 and (action := nav.choose(obs, place, [])) is not None:
            obs = world.step(action)
            used += 1
        position = reader.entity_position(obs, 0)
        facing = reader.value_now(ROBOT_HEADING, obs)
        # The place's 3 cm, plus the real drive's drift of a last turn on the spot.
        assert np.linalg.norm(position - [x, y]) <= 0.05, (x, y, used)
        assert line_angle(facing[None], want[None])[0] <= config.heading_tolerance, (x, y)
        # About the distance at full speed plus two turns.
        assert used <= 8 + np.hypot(x, y) / 0.15, (x, y, used)
