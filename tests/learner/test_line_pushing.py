"""Line pushing on hand-built models whose answer is known, in the real pymunk World: the
planner, given A0 (`action → robot.position`, `action → robot.heading`) and A1
(`robot.position → target.position`) fitted on rows recorded from the real physics (free
moves, and pushes from behind the object at every bearing), pushes the `push-line` object to
its points within tolerance and close to the straight line."""

from __future__ import annotations

import dataclasses

from handmade import world_learner

from hadim_cli.config import load_config
from hadim_cli.evaluation.runner import evaluate
from hadim_cli.evaluation.tasks import load_task
from hadim_cli.world.world import World

TASK = load_task("push-line")


def test_the_planner_pushes_an_object_along_a_line_in_the_real_world():
    config = load_config()
    world = World(config.world)
    learner = world_learner(config, world, TASK.scene)
    task = dataclasses.replace(TASK, points=(TASK.points[0], TASK.points[4]))
    result = evaluate(learner, config.world, task)
    assert result.score >= 0.9
    assert all(p.line_deviation <= 0.15 for p in result.points)
