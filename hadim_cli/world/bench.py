"""How fast the world steps, against the raw pymunk cost of the same physics.

Both loops run the same scenes and the same random actions, episode by episode (interleaved,
so a change of machine load hits both alike). The raw loop builds the same bodies and joints
and only sets the control body's velocity and steps the space: no action checks, no contact
log, no observation. Resets are timed apart: they are not part of a step's cost.
"""

from __future__ import annotations

import math
import time
from dataclasses import asdict, dataclass

import numpy as np

from hadim_cli.config import WorldConfig
from hadim_cli.world.physics import (
    Physics,
    build_physics,
    n_settle_substeps,
    n_substeps,
    wheel_command,
)
from hadim_cli.world.placement import draw_scene
from hadim_cli.world.world import World, wrap_angle


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
    """The raw loop ended every episode with the same robot pose as the world, bit for bit."""

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


def bench_world(config: WorldConfig, actions: int, seed: int = 0) -> WorldBench:
    """Run `actions` uniform random primitive actions, a new scene every episode_length."""
    scene_rng, action_rng = np.random.default_rng(seed).spawn(2)
    all_actions = action_rng.uniform(-1.0, 1.0, size=(actions, 2))
    world = World(config)
    ours = raw = resets = 0.0
    same = True
    episodes = 0
    for begin in range(0, actions, config.episode_length):
        chunk = all_actions[begin:begin + config.episode_length]
        scene = draw_scene(config, scene_rng)
        start = time.perf_counter()
        world.reset(scene=scene)
        resets += time.perf_counter() - start
        start = time.perf_counter()
        for action in chunk:
            world.step(action)
        ours += time.perf_counter() - start
        physics = build_physics(config, scene, track_contacts=False)
        raw += _raw_actions(physics, config, chunk.tolist())
        x, y = physics.robot.position
        same &= (x, y, wrap_angle(physics.robot.angle)) == world.robot_pose()
        episodes += 1
    return WorldBench(actions, episodes, n_substeps(config), ours, raw, resets, same)
