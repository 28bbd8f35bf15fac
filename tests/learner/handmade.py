"""Hand-built data for tests of the algorithm's steps: a learner over a small real layout
whose D is written row by row, so each test knows what the data say.

Imported by the tests next to it (pytest puts this folder on sys.path).
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from hadim_cli.config import Config, LearnerConfig
from hadim_cli.learner.affordance import Affordance
from hadim_cli.learner.explorer import Learner
from hadim_cli.learner.spaces import ACTION, Property, Role, RoleSpace, Rows
from hadim_cli.world.actions import ROVER_ACTIONS
from hadim_cli.world.layout import LayoutBounds, ObservationLayout

ROBOT_POSITION = RoleSpace(Role.ROBOT, Property.POSITION)
ROBOT_HEADING = RoleSpace(Role.ROBOT, Property.HEADING)
ROBOT_LIDAR = RoleSpace(Role.ROBOT, Property.LIDAR)
TARGET_POSITION = RoleSpace(Role.TARGET, Property.POSITION)
TARGET_ROBOT = RoleSpace(Role.TARGET, Property.POSITION, Role.ROBOT)
TOOL_POSITION = RoleSpace(Role.TOOL, Property.POSITION)
GREEN, RED = (0.2, 0.8, 0.2), (0.8, 0.2, 0.2)
STEP = 0.05
"""How far one full-forward action moves the hand-built robot (m)."""


class Room:
    """A learner over a robot and three parked objects; D is filled by the methods below."""

    def __init__(self, config: LearnerConfig | None = None, **overrides):
        self.layout = ObservationLayout.build(3, 4, LayoutBounds(2, 2, 1.5, 0.25, 0.6))
        self.config = replace(config or LearnerConfig(), **overrides)
        self.learner = Learner(self.config, self.layout, ROVER_ACTIONS)
        self.obs = np.zeros(self.layout.size)
        self.set("robot", Property.RADIUS, [0.15])
        self.set("robot", Property.COLOR, [0.2, 0.2, 0.8])
        for i, (name, colour) in enumerate((("obj1", GREEN), ("obj2", RED), ("obj3", GREEN))):
            self.set(name, Property.RADIUS, [0.12 if name != "obj3" else 0.1])
            self.set(name, Property.HEIGHT, [0.2])
            self.set(name, Property.COLOR, colour)
            self.place(name, [-1.5 + i, 1.5])

    @property
    def dataset(self):
        return self.learner.dataset

    @property
    def fitter(self):
        return self.learner.fitter

    @property
    def adaptation(self):
        return self.learner.adaptation

    @property
    def hierarchy(self):
        return self.learner.hierarchy

    def set(self, entity: str, prop: Property, value) -> None:
        self.obs[self.layout.space(entity, prop).slice] = value

    def place(self, entity: str, xy) -> None:
        self.set(entity, Property.POSITION, xy)
        robot = self.obs[self.layout.space("robot", Property.POSITION).slice].copy()
        for name in self.layout.objects:
            pos = self.obs[self.layout.space(name, Property.POSITION).slice]
            self.set(name, Property.RELATIVE, pos - robot)

    def episode(self) -> int:
        """Start an environment episode; returns its first iteration."""
        self.dataset.start_episode()
        return len(self.dataset)

    def moves(self, rng: np.random.Generator, n: int, *, heading: float | None = None,
              noise: bool = False) -> np.ndarray:
        """`n` actions of a differential drive: forward by STEP·mean(action) along the heading,
        turning by 0.3·(right − left). The heading is random per row unless given; with
        `noise`, the displacement is random instead (nothing to learn). The robot stays clear
        of the parked objects (a free move: `Fitter.moved_clear`). Returns iterations."""
        start = len(self.dataset)
        for _ in range(n):
            theta = rng.uniform(-np.pi, np.pi) if heading is None else heading
            self.place("robot", rng.uniform((-1.5, -1.5), (1.5, 1.0)))
            self.set("robot", Property.HEADING, [np.cos(theta), np.sin(theta)])
            self.set("robot", Property.LIDAR, rng.uniform(0.2, 1.5, 4))
            action = rng.uniform(-1.0, 1.0, 2)
            before = self.obs.copy()
            here = self.obs[self.layout.space("robot", Property.POSITION).slice].copy()
            if noise:
                step = rng.uniform(-STEP, STEP, 2)
            else:
                step = STEP * action.mean() * np.array([np.cos(theta), np.sin(theta)])
            turned = theta + 0.3 * (action[1] - action[0])
            self.place("robot", here + step)
            self.set("robot", Property.HEADING, [np.cos(turned), np.sin(turned)])
            self.dataset.append(action, before, self.obs.copy())
        return np.arange(start, len(self.dataset), dtype=np.int64)

    def rows(self, t: np.ndarray) -> Rows:
        return Rows(t, np.full(t.size, -1, dtype=np.int64), np.full(t.size, -1, dtype=np.int64))

    def affordance(self, t: np.ndarray, contexts=(), inp: RoleSpace = ACTION,
                   out: RoleSpace = ROBOT_POSITION, rng=None, add: bool = True) -> Affordance:
        """A(inp → out | contexts) fitted on the rows at iterations `t`, added to H."""
        rng = rng or np.random.default_rng(0)
        aff = self.fitter.new_affordance(self.hierarchy.allocate_id(), inp, out,
                                         tuple(contexts), self.rows(t), len(self.dataset), rng)
        if add:
            self.hierarchy.add(aff, len(self.dataset))
        return aff


# ---------------------------------------------------------------------------- real physics


def world_rows(learner: Learner, world, scene, rng: np.random.Generator, n_free: int,
               n_push: int) -> tuple[np.ndarray, np.ndarray]:
    """Rows of the real World in `scene`: free moves from random poses, and pushes of its
    first object from a random bearing behind it, facing it. Returns the iterations of
    each."""
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
        start = replace(scene, robot_x=x, robot_y=y, robot_heading=heading)
        before = world.reset(scene=start)
        after = world.step(action)
        (free if i < n_free else push).append(learner.dataset.append(action, before, after))
    return np.array(free, dtype=np.int64), np.array(push, dtype=np.int64)


def world_learner(config: Config, world, scene, n_free: int = 300, n_push: int = 400
                  ) -> Learner:
    """A learner whose H holds the robot's motion (`action → robot.position` and
    `action → robot.heading`, the heading as context) and its push of an object
    (`robot.position → target.position | target-robot`), fitted on `world_rows`."""
    learner = Learner(config.learner, world.layout, world.action_space, config.planner)
    rng = np.random.default_rng(0)
    free, push = world_rows(learner, world, scene, rng, n_free, n_push)
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
    return learner
