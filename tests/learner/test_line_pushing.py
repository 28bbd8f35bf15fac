"""Line pushing on hand-built models whose answer is known, in the real pymunk World: the
planner, given A0 (`action → robot.position`, `action → robot.heading`) and A1
(`robot.position → target.position`) fitted on rows recorded from the real physics (free
moves, and pushes from behind the object at every bearing), pushes the `push-line` object to
its points within tolerance and close to the straight line."""

from __future__ import annotations

import dataclasses

import numpy as np

from hadim_cli.config import load_config
from hadim_cli.evaluation.runner import evaluate
from hadim_cli.evaluation.tasks import load_task
from hadim_cli.learner.explorer import Learner
from hadim_cli.learner.navigation import ROBOT_HEADING, ROBOT_POSITION
from hadim_cli.learner.spaces import ACTION, Property, Role, RoleSpace, Rows
from hadim_cli.world.world import World

TARGET_POSITION = RoleSpace(Role.TARGET, Property.POSITION)
TARGET_ROBOT = RoleSpace(Role.TARGET, Property.POSITION, Role.ROBOT)
TASK = load_task("push-line")


def _record(learner: Learner, world: World, rng: np.random.Generator, n_free: int,
            n_push: int) -> tuple[np.ndarray, np.ndarray]:
    """Rows of the real World: free moves from random poses, and pushes of obj1 from a
    random bearing behind it, facing it. Returns the iterations of each."""
    scene = TASK.scene
    obj = scene.objects[0]
    contact = obj.radius + world.config.robot_radius
    free, push = [], []
    learner.dataset.start_episode()
    for i in range(n_free + n_push):
        if i < n_free:
            x, y = rng.uniform(-0.6, -0.1), rng.uniform(-0.5, 0.5)
            heading = rng.uniform(-np.pi, np.pi)
            action = rng.uniform(-1, 1, 2)
        else:
            bearing = rng.uniform(-np.pi, np.pi)
            x = obj.x + (contact + rng.uniform(0.0, 0.03)) * np.cos(bearing)
            y = obj.y + (contact + rng.uniform(0.0, 0.03)) * np.sin(bearing)
            heading = bearing + np.pi + rng.uniform(-0.3, 0.3)
            action = np.clip(rng.uniform(0.2, 1.0) + rng.uniform(-0.2, 0.2, 2), -1, 1)
        start = dataclasses.replace(scene, robot_x=x, robot_y=y, robot_heading=heading)
        before = world.reset(scene=start)
        after = world.step(action)
        (free if i < n_free else push).append(learner.dataset.append(action, before, after))
    return np.array(free, dtype=np.int64), np.array(push, dtype=np.int64)


def test_the_planner_pushes_an_object_along_a_line_in_the_real_world():
    config = load_config()
    world = World(config.world)
    learner = Learner(config.learner, world.layout, config.planner)
    rng = np.random.default_rng(0)
    free, push = _record(learner, world, rng, 300, 400)
    unbound = np.full(free.size, -1, dtype=np.int64)
    bound = np.full(push.size, 1, dtype=np.int64)
    specs = ((ACTION, ROBOT_POSITION, (ROBOT_HEADING,), Rows(free, unbound, unbound)),
             (ACTION, ROBOT_HEADING, (ROBOT_HEADING,), Rows(free, unbound, unbound)),
             (ROBOT_POSITION, TARGET_POSITION, (TARGET_ROBOT,),
              Rows(push, bound, np.full(push.size, -1, dtype=np.int64))))
    h = learner.hierarchy
    for inp, out, contexts, rows in specs:
        aff = learner.fitter.new_affordance(h.allocate_id(), inp, out, contexts, rows,
                                            len(learner.dataset), rng)
        h.add(aff, len(learner.dataset))
    task = dataclasses.replace(TASK, points=(TASK.points[0], TASK.points[4]))
    result = evaluate(learner, config.world, task)
    assert result.score >= 0.9
    assert all(p.line_deviation <= 0.15 for p in result.points)
