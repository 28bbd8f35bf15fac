"""Exact stand-ins for levels of the chain — for evaluation only, never for learning.

`hadim eval RUN --task T --exact LEVEL` has the controller imagine a level of the chain with
the room's physics instead of the learned forward model, so the difference of the two scores
tells what that level's model costs:

- `navigation`: the actor's own motion (`action → robot.position`): the rover's and its
  heading by the differential drive's kinematics (each command an arc held for the action's
  duration), the arm's effector by its forward kinematics (each joint turned by its command
  for the action's duration, within its limits);
- `push`: a body pushed by the robot (`robot.position → object`), `tool`: a body pushed by
  another (`tool.position → target`), by the contact of discs: the pusher moves along its
  move until it touches, and the rest of its move along the line of centres carries the
  pushed disc with it (a disc pushes a disc along the contact normal).

Levels combine (all three: the controller on the room's physics, the upper bound of its
search). The stand-ins know what the learner does not (wheel speed, wheel base, action
duration, radii); they only ever serve an evaluation.
"""

from __future__ import annotations

import contextlib
from collections.abc import Iterator

import numpy as np

from hadim_cli.config import Body, WorldConfig
from hadim_cli.errors import HadimError
from hadim_cli.learner.controller import Controller
from hadim_cli.learner.explorer import Learner
from hadim_cli.learner.spaces import ROBOT_HEADING, Property, SpaceReader
from hadim_cli.world.kinematics import joint_ranges, pose_angles

LEVELS = ("navigation", "push", "tool")
"""Levels of the chain that can be replaced by an exact one."""

PUSHERS = {"push": "robot.position", "tool": "tool.position"}
"""The input space of the level each name replaces."""


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


class ArmMotion:
    """The free arm: each joint turned by its command × `max_joint_speed` for the action's
    duration, held within its limits; the effector's move by the forward kinematics."""

    def __init__(self, world: WorldConfig, reader: SpaceReader):
        arm = world.arm
        self.lengths = np.asarray(arm.link_lengths)
        self.turn = arm.max_joint_speed * world.action_duration
        self.limits = np.asarray(joint_ranges(arm.joint_limits))
        lay = reader.layout
        self.orientation = lay.space(lay.actor, Property.ORIENTATION).slice
        self.joints = lay.space(lay.actor, Property.JOINTS).slice

    def effector(self, joints: np.ndarray) -> np.ndarray:
        phi = np.cumsum(joints, axis=1)
        return np.stack([np.cos(phi) @ self.lengths, np.sin(phi) @ self.lengths], axis=1)

    def __call__(self, commands: np.ndarray, obs: np.ndarray, _: np.ndarray) -> np.ndarray:
        """The effector's move (M, 2) for each command (M, n) from each observation (M, …)."""
        q = pose_angles(obs[:, self.orientation], obs[:, self.joints])
        after = np.clip(q + commands * self.turn, -self.limits, self.limits)
        return self.effector(after) - self.effector(q)


def disc_push(start: np.ndarray, move: np.ndarray, pushed: np.ndarray, radii: np.ndarray
              ) -> np.ndarray:
    """How far discs at `pushed` (M, 2) move when discs at `start` (M, 2) move by `move`
    (M, 2); `radii` (M, 2): the pusher's and the pushed disc's. The pusher goes along its
    move until it touches; the rest of its move along the line of centres there carries the
    pushed disc (none while it moves away or slides by)."""
    touch = radii[:, 0] + radii[:, 1]
    rel = pushed - start
    a = np.sum(move * move, 1)
    b = np.sum(move * rel, 1)
    c = np.sum(rel * rel, 1) - touch ** 2
    disc = b * b - a * c
    # The first s in [0, 1] with |start + s·move − pushed| = touch (already touching: 0).
    s = np.where(c <= 0, 0.0, (b - np.sqrt(np.maximum(disc, 0.0))) / np.maximum(a, 1e-12))
    hits = (disc >= 0) & (s >= 0) & (s <= 1) & (a > 1e-12)
    contact = start + s[:, None] * move
    normal = pushed - contact
    normal = normal / np.maximum(np.linalg.norm(normal, axis=1, keepdims=True), 1e-12)
    along = (1 - s) * np.sum(move * normal, 1)
    return np.where((hits & (along > 0))[:, None], along[:, None] * normal, 0.0)


@contextlib.contextmanager
def exact_levels(learner: Learner, world: WorldConfig, levels: tuple[str, ...]
                 ) -> Iterator[None]:
    """Within the block, `learner`'s controller imagines the levels `levels` names by the
    room's physics; afterwards it is as it was (the learner itself is never changed)."""
    unknown = sorted(set(levels) - set(LEVELS))
    if unknown:
        raise HadimError(f"--exact: unknown level '{unknown[0]}' (known: {', '.join(LEVELS)})")
    controller: Controller = learner.controller
    reader = learner.reader
    lay = reader.layout
    motion = KinematicMotion(world, reader)

    def position(commands: np.ndarray, obs: np.ndarray, _: np.ndarray) -> np.ndarray:
        return np.concatenate([motion(o, c[None])[0] for o, c in zip(obs, commands,
                                                                    strict=True)])

    def heading(commands: np.ndarray, obs: np.ndarray, _: np.ndarray) -> np.ndarray:
        after = np.concatenate([motion(o, c[None])[1] for o, c in zip(obs, commands,
                                                                     strict=True)])
        return after - reader.read_each((ROBOT_HEADING,), obs)

    def push(moves: np.ndarray, obs: np.ndarray, entities: np.ndarray) -> np.ndarray:
        moved, mover = (lay.entities[int(e)] for e in entities)
        where = [lay.get(obs, e, Property.POSITION) for e in (mover, moved)]
        radii = np.stack([lay.get(obs, e, Property.RADIUS)[:, 0] for e in (mover, moved)], 1)
        return disc_push(where[0], moves, where[1], radii)

    stand_ins = {}
    if "navigation" in levels and world.body is Body.ARM:
        stand_ins["action"] = ArmMotion(world, reader)
    elif "navigation" in levels:
        stand_ins.update({"action": position, "heading": heading})
    for name, space in PUSHERS.items():
        if name in levels:
            stand_ins[space] = push
    saved = dict(controller.stand_ins)
    controller.stand_ins.update(stand_ins)
    try:
        yield
    finally:
        controller.stand_ins.clear()
        controller.stand_ins.update(saved)
