"""The simulated room (paper §3.1): `reset` to a scene, `step` one primitive action, observe.

Like a Gymnasium environment, the world knows nothing of who drives it; its randomness comes
only from the generator passed to `reset`. A fresh pymunk space is built at every reset, so a
run is reproduced bit for bit by the same scene and actions, in any process. The arm's world
(`arm.py`) keeps the same contract (`environment.Environment`).
"""

from __future__ import annotations

import math

import numpy as np

from hadim_cli.config import Body, WorldConfig
from hadim_cli.world.actions import ROVER_ACTIONS
from hadim_cli.world.environment import (
    Environment,
    check_inside,
    check_objects,
    fill_looks,
    fill_object_looks,
)
from hadim_cli.world.layout import ROBOT, LayoutBounds, ObservationLayout, Property, Shape
from hadim_cli.world.lidar import Lidar
from hadim_cli.world.physics import (
    Physics,
    build_physics,
    wheel_command,
)
from hadim_cli.world.placement import ROBOT_COLOR, draw_scene
from hadim_cli.world.scene import Scene

__all__ = ["World", "draw_scene", "wrap_angle"]


def wrap_angle(angle: float) -> float:
    """The same angle in [-π, π)."""
    return (angle + math.pi) % (2 * math.pi) - math.pi


def layout_for(config: WorldConfig) -> ObservationLayout:
    """The observation layout of worlds built from `config`."""
    bounds = LayoutBounds(
        half_width=config.room_width / 2,
        half_height=config.room_height / 2,
        lidar_range=config.lidar_range,
        radius_max=max(config.object_radius_max, config.robot_radius),
        height_max=max(config.object_height_max, config.robot_height),
    )
    return ObservationLayout.build(config.n_green + config.n_red, config.lidar_rays, bounds)


class World(Environment[Scene, Physics]):
    """The room, the robot and the objects of one episode at a time."""

    body = Body.ROVER
    action_space = ROVER_ACTIONS
    """(left, right) wheel intensities, each in [-1, 1]."""

    def __init__(self, config: WorldConfig):
        super().__init__(config, layout_for(config))
        self._lidar = Lidar(config.lidar_rays, config.lidar_range,
                            config.room_width / 2, config.room_height / 2)
        self._radii: list[float] = [0.0] * len(self.layout.objects)
        lay = self.layout
        self._robot_pos = lay.space(ROBOT, Property.POSITION).slice
        self._robot_heading = lay.space(ROBOT, Property.HEADING).slice
        self._robot_lidar = lay.space(ROBOT, Property.LIDAR).slice

    # ------------------------------------------------------------------ episode

    def draw_scene(self, rng: np.random.Generator) -> Scene:
        return draw_scene(self.config, rng)

    def _check_scene(self, scene: Scene) -> None:
        hw, hh = self.config.room_width / 2, self.config.room_height / 2
        check_objects(self.layout, scene.objects, hw, hh, "room")
        check_inside(scene.robot_x, scene.robot_y, self.config.robot_radius, hw, hh, "room")

    def _build(self, scene: Scene) -> Physics:
        return build_physics(self.config, scene)

    def _fill_static(self, scene: Scene) -> None:
        cfg = self.config
        fill_looks(self._obs, self.layout, ROBOT, cfg.robot_radius, cfg.robot_height,
                   ROBOT_COLOR, Shape.CYLINDER)
        self._radii = fill_object_looks(self._obs, self.layout, scene.objects)

    # ------------------------------------------------------------------ acting

    def step(self, action: object) -> np.ndarray:
        """Hold the wheel intensities (left, right) ∈ [-1, 1]² for one action, then stop the
        wheels for `settle_time`; observe."""
        physics = self._require_physics()
        left, right = self.action_space.check(action)
        speed, omega = wheel_command(self.config, left, right)
        robot, control, space, dt = physics.robot, physics.control, physics.space, self._dt
        control.angular_velocity = omega
        physics.contacts.start()
        cos, sin = math.cos, math.sin
        for _ in range(self._substeps):
            angle = robot.angle
            control.velocity = (speed * cos(angle), speed * sin(angle))
            space.step(dt)
        if self._settle:
            control.velocity, control.angular_velocity = (0.0, 0.0), 0.0
            for _ in range(self._settle):
                space.step(dt)
        self._steps += 1
        self.last_contacts = frozenset(physics.contacts.touched)
        return self.observe()

    # ------------------------------------------------------------------ observing

    def robot_pose(self) -> tuple[float, float, float]:
        """(x, y, heading) of the robot, heading in [-π, π)."""
        robot = self._require_physics().robot
        x, y = robot.position
        return float(x), float(y), wrap_angle(robot.angle)

    def observe(self) -> np.ndarray:
        """The current observation (a copy), laid out as `self.layout` says."""
        physics = self._require_physics()
        obs = self._obs
        poses = physics.poses.poses()
        x, y, angle = poses[0].tolist()
        robot_xy, centers = poses[0, :2], poses[1:, :2]
        obs[self._robot_pos] = robot_xy
        obs[self._robot_heading] = (math.cos(angle), math.sin(angle))
        obs[self._robot_lidar] = self._lidar.ranges(x, y, angle, centers.tolist(), self._radii)
        obs[self._obj_pos] = centers
        obs[self._obj_rel] = centers - robot_xy
        return obs.copy()
