"""Exact stand-ins for levels of the chain — for evaluation only, never for learning.

`hadim eval RUN --task T --exact navigation` replaces the robot's *learned* motion (the lowest
level of the chain) by the differential drive's kinematics, so the difference of the two scores
tells what the learned navigation costs. `--exact push` replaces the middle level: whenever a
level above asks for an object to move (the tool, in `push-with-tool`), the scripted
controller's push (`evaluation.scripted`: true state, exact kinematics, pure-pursuit steering)
moves it there instead of the learned `robot.position → object` affordance and the levels
below it; the level above (the tool's effect on the target) stays learned. A task whose top
affordance is itself the robot's push (`push-object`) has no level above it and is unchanged.
`--exact tool` replaces the top level of `push-with-tool`: where the tool should go next for the
target to reach its point (the scripted controller's strike or staging place, one
`TOOL_STEP` at a time), the robot's push of the tool and the levels below it staying learned.
Levels combine (`--exact tool --exact push`: the scripted controller in the planner's loop).
The stand-ins know the physics the learner does not (wheel speed, wheel base, action duration,
radii); they only ever serve an evaluation.
"""

from __future__ import annotations

import contextlib
import dataclasses
from collections.abc import Iterator

import numpy as np

from hadim_cli.config import WorldConfig
from hadim_cli.errors import HadimError
from hadim_cli.learner.controller import Controller
from hadim_cli.learner.explorer import Learner
from hadim_cli.learner.goals import Actuator, Binding
from hadim_cli.learner.navigation import ROBOT_HEADING, Navigator
from hadim_cli.learner.spaces import SpaceReader

LEVELS = ("navigation", "push", "tool")
"""Levels of the chain that can be replaced by an exact one."""


class KinematicMotion:
    """The free differential drive: each command held for the action's duration, no load."""

    def __init__(self, world: WorldConfig, reader: SpaceReader):
        self.world = world
        self.reader = reader

    def __call__(self, obs: np.ndarray, commands: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        w = self.world
        h = self.reader.value_now(ROBOT_HEADING, obs)
        theta = float(np.arctan2(h[1], h[0]))
        v = (commands[:, 0] + commands[:, 1]) / 2 * w.max_wheel_speed
        omega = (commands[:, 1] - commands[:, 0]) * w.max_wheel_speed / w.wheel_base
        t = w.action_duration
        turn = omega * t
        straight = np.abs(omega) < 1e-9
        safe = np.where(straight, 1.0, omega)
        dx = np.where(straight, v * t * np.cos(theta),
                      v / safe * (np.sin(theta + turn) - np.sin(theta)))
        dy = np.where(straight, v * t * np.sin(theta),
                      -v / safe * (np.cos(theta + turn) - np.cos(theta)))
        after = np.stack([np.cos(theta + turn), np.sin(theta + turn)], axis=1)
        return np.stack([dx, dy], axis=1), after


class ExactPush:
    """The scripted controller's push of one object to a point (`evaluation.scripted`), one
    action at a time from the observation, until the object is within `tolerance` of it, the
    push gives up, or the budget is spent."""

    def __init__(self, world: WorldConfig, reader: SpaceReader, tolerance: float = 0.01):
        from hadim_cli.evaluation.scripted import TOOL_STEP, ObservedPusher

        self.pusher = ObservedPusher(world, reader)
        self.step = TOOL_STEP
        self.tolerance = tolerance

    def __call__(self, entity: int, goal: np.ndarray, avoid: int, actuator: Actuator,
                 budget: int) -> int:
        used = 0
        while used < budget and not actuator.exhausted:
            obs = actuator.obs
            if np.linalg.norm(self.pusher.pos(obs, entity) - goal) <= self.tolerance:
                break
            command = self.pusher.push(obs, entity, goal, self.step, avoid)
            if command is None:
                break
            actuator.act(command)
            used += 1
        return used if used > 0 else -1


class ExactTool:
    """The scripted controller's tool goal (`Scripted.tool_goal`), as the tool's next move of
    at most `TOOL_STEP`."""

    def __init__(self, world: WorldConfig, reader: SpaceReader):
        from hadim_cli.evaluation.scripted import TOOL_STEP, ObservedPusher

        self.guide = ObservedPusher(world, reader)
        self.step = TOOL_STEP

    def __call__(self, obs: np.ndarray, goal: np.ndarray, b: Binding) -> np.ndarray:
        wanted, _ = self.guide.tool_goal(obs, goal, b.target, b.tool)
        way = wanted - self.guide.pos(obs, b.tool)
        n = float(np.linalg.norm(way))
        return way if n <= self.step else way * (self.step / n)


@contextlib.contextmanager
def exact_levels(learner: Learner, world: WorldConfig, levels: tuple[str, ...]
                 ) -> Iterator[None]:
    """Within the block, `learner`'s planner uses the exact stand-ins of `levels`; afterwards
    it is as it was (the learner itself is never changed)."""
    unknown = sorted(set(levels) - set(LEVELS))
    if unknown:
        raise HadimError(f"--exact: unknown level '{unknown[0]}' (known: {', '.join(LEVELS)})")
    planner = learner.planner
    if isinstance(planner, Controller):
        with _exact_search(planner, learner, world, levels):
            yield
        return
    saved = planner.pc, planner.navigator, planner.pusher, planner.tool_guide
    try:
        if "navigation" in levels:
            planner.pc = dataclasses.replace(planner.pc, navigation=True)
            motion = KinematicMotion(world, learner.reader)
            planner.navigator = Navigator(planner.h, learner.reader, planner.pc, motion)
        if "push" in levels:
            planner.pusher = ExactPush(world, learner.reader)
        if "tool" in levels:
            planner.tool_guide = ExactTool(world, learner.reader)
        yield
    finally:
        planner.pc, planner.navigator, planner.pusher, planner.tool_guide = saved


@contextlib.contextmanager
def _exact_search(controller: Controller, learner: Learner, world: WorldConfig,
                  levels: tuple[str, ...]) -> Iterator[None]:
    """The search controller's exact levels: `navigation` predicts the robot's own motion
    (its position and heading) by the drive's kinematics instead of the learned models."""
    other = sorted(set(levels) - {"navigation"})
    if other:
        raise HadimError(f"--exact {other[0]}: the search controller replaces only the "
                         f"navigation level (set controller.kind = \"rules\" for the others)")
    motion = KinematicMotion(world, learner.reader)

    def position(commands: np.ndarray, obs: np.ndarray, _: np.ndarray) -> np.ndarray:
        return np.concatenate([motion(o, c[None])[0] for o, c in zip(obs, commands,
                                                                    strict=True)])

    def heading(commands: np.ndarray, obs: np.ndarray, _: np.ndarray) -> np.ndarray:
        after = np.concatenate([motion(o, c[None])[1] for o, c in zip(obs, commands,
                                                                     strict=True)])
        return after - learner.reader.read_each((ROBOT_HEADING,), obs)

    saved = dict(controller.stand_ins)
    controller.stand_ins.update({"action": position, "heading": heading})
    try:
        yield
    finally:
        controller.stand_ins.clear()
        controller.stand_ins.update(saved)
