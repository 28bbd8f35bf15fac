"""How fast the world steps, against the raw pymunk cost of the same physics.

Both loops run the same scenes and the same random actions, episode by episode (interleaved,
so a change of machine load hits both alike). The raw loop builds the same bodies and joints
and only sets the drive (the rover's control body velocity, the arm's motor rates) and steps
the space: no action checks, no contact log, no observation. Resets are timed apart: they are
not part of a step's cost. Either body: the configured one (`world.body`).
"""

from __future__ import annotations

import math
import time
from dataclasses import asdict, dataclass
from typing import Any

import numpy as np

from hadim_cli.config import Body, WorldConfig
from hadim_cli.world.arm_physics import ArmPhysics, build_arm_physics
from hadim_cli.world.environment import make_world
from hadim_cli.world.physics import (
    Physics,
    build_physics,
    n_settle_substeps,
    n_substeps,
    wheel_command,
)


@dataclass(frozen=True)
class WorldBench:
    """Measured figures of one benchmark run."""

    actions: int
    episodes: int
    substeps_per_action: int
    seconds: float
    """Time spent in `World.step` (s)."""
    raw_seconds: float
    """Time spent in the raw pymunk loop for the same actions (s)."""
    reset_seconds: float
    """Time spent in `World.reset` with a given scene (s)."""
    same_trajectory: bool
    """The raw loop ended every episode with every body where the world left it, bit for
    bit."""
    body: str
    """The body benchmarked: "rover" or "arm"."""

    @property
    def actions_per_s(self) -> float:
        return self.actions / self.seconds

    @property
    def raw_actions_per_s(self) -> float:
        return self.actions / self.raw_seconds

    @property
    def overhead_ratio(self) -> float:
        """Raw rate ÷ our rate: 1 means no overhead, 2 means the world is twice as slow."""
        return self.raw_actions_per_s / self.actions_per_s

    def to_dict(self) -> dict[str, float | int | bool]:
        out: dict[str, float | int | bool] = {
            "actions_per_s": self.actions_per_s,
            "raw_actions_per_s": self.raw_actions_per_s,
            "overhead_ratio": self.overhead_ratio,
            "step_us": 1e6 * self.seconds / self.actions,
            "raw_step_us": 1e6 * self.raw_seconds / self.actions,
            "reset_ms": 1e3 * self.reset_seconds / self.episodes,
        }
        out.update(asdict(self))
        return out


def _raw_actions(physics: Physics, config: WorldConfig, actions: list[list[float]]) -> float:
    robot, control, space = physics.robot, physics.control, physics.space
    dt, substeps, settle = config.physics_dt, n_substeps(config), n_settle_substeps(config)
    cos, sin = math.cos, math.sin
    start = time.perf_counter()
    for left, right in actions:
        speed, omega = wheel_command(config, left, right)
        control.angular_velocity = omega
        for _ in range(substeps):
            angle = robot.angle
            control.velocity = (speed * cos(angle), speed * sin(angle))
            space.step(dt)
        if settle:
            control.velocity, control.angular_velocity = (0.0, 0.0), 0.0
            for _ in range(settle):
                space.step(dt)
    return time.perf_counter() - start


def _raw_arm_actions(physics: ArmPhysics, config: WorldConfig,
                     actions: list[list[float]]) -> float:
    motors, space = physics.motors, physics.space
    dt, substeps, settle = config.physics_dt, n_substeps(config), n_settle_substeps(config)
    speed = config.arm.max_joint_speed
    start = time.perf_counter()
    for action in actions:
        for motor, c in zip(motors, action, strict=True):
            motor.rate = -c * speed
        for _ in range(substeps):
            space.step(dt)
        if settle:
            for motor in motors:
                motor.rate = 0.0
            for _ in range(settle):
                space.step(dt)
    return time.perf_counter() - start


def _raw_episode(config: WorldConfig, scene: Any, actions: list[list[float]]
                 ) -> tuple[float, np.ndarray]:
    """Seconds the raw loop took on `actions` from `scene`, and every body's pose at the end."""
    if config.body is Body.ARM:
        arm = build_arm_physics(config, scene, track_contacts=False)
        return _raw_arm_actions(arm, config, actions), arm.poses.poses()
    room = build_physics(config, scene, track_contacts=False)
    return _raw_actions(room, config, actions), room.poses.poses()


def bench_world(config: WorldConfig, actions: int, seed: int = 0) -> WorldBench:
    """Run `actions` uniform random primitive actions, a new scene every episode_length."""
    scene_rng, action_rng = np.random.default_rng(seed).spawn(2)
    world = make_world(config)
    all_actions = world.action_space.sample(action_rng, actions)
    ours = raw = resets = 0.0
    same = True
    episodes = 0
    for begin in range(0, actions, config.episode_length):
        chunk = all_actions[begin:begin + config.episode_length]
        scene = world.draw_scene(scene_rng)
        start = time.perf_counter()
        world.reset(scene=scene)
        resets += time.perf_counter() - start
        start = time.perf_counter()
        for action in chunk:
            world.step(action)
        ours += time.perf_counter() - start
        seconds, poses = _raw_episode(config, scene, chunk.tolist())
        raw += seconds
        same &= bool(np.array_equal(poses, world.poses()))
        episodes += 1
    return WorldBench(actions, episodes, n_substeps(config), ours, raw, resets, same,
                      config.body.value)
