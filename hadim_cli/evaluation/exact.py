"""Exact stand-ins for levels of the chain — for evaluation only, never for learning.

`hadim eval RUN --task T --exact navigation` replaces the robot's *learned* motion (the lowest
level of the chain) by the differential drive's kinematics, so the difference of the two scores
tells what the learned navigation costs. The stand-in knows the physics the learner does not
(wheel speed, wheel base, action duration); it only ever serves an evaluation.
"""

from __future__ import annotations

import contextlib
import dataclasses
from collections.abc import Iterator

import numpy as np

from hadim_cli.config import WorldConfig
from hadim_cli.errors import HadimError
from hadim_cli.learner.explorer import Learner
from hadim_cli.learner.navigation import ROBOT_HEADING, Navigator
from hadim_cli.learner.spaces import SpaceReader

LEVELS = ("navigation",)
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


@contextlib.contextmanager
def exact_levels(learner: Learner, world: WorldConfig, levels: tuple[str, ...]
                 ) -> Iterator[None]:
    """Within the block, `learner`'s planner uses the exact stand-ins of `levels`; afterwards
    it is as it was (the learner itself is never changed)."""
    unknown = sorted(set(levels) - set(LEVELS))
    if unknown:
        raise HadimError(f"--exact: unknown level '{unknown[0]}' (known: {', '.join(LEVELS)})")
    planner = learner.planner
    saved = planner.pc, planner.navigator
    try:
        if "navigation" in levels:
            planner.pc = dataclasses.replace(planner.pc, navigation=True)
            motion = KinematicMotion(world, learner.reader)
            planner.navigator = Navigator(planner.h, learner.reader, planner.pc, motion)
        yield
    finally:
        planner.pc, planner.navigator = saved
