"""The simulated room (paper §3.1): `reset` to a scene, `step` one primitive action, observe.

Like a Gymnasium environment, the world knows nothing of who drives it; its randomness comes
only from the generator passed to `reset`. A fresh pymunk space is built at every reset, so a
run is reproduced bit for bit by the same scene and actions, in any process.
"""

from __future__ import annotations

import math

import numpy as np

from hadim_cli.config import WorldConfig
from hadim_cli.errors import ActionError, HadimError
from hadim_cli.world.layout import ROBOT, LayoutBounds, ObservationLayout, Property, Shape
from hadim_cli.world.lidar import Lidar
from hadim_cli.world.physics import (
    Physics,
    build_physics,
    n_settle_substeps,
    n_substeps,
    wheel_command,
)
from hadim_cli.world.placement import ROBOT_COLOR, draw_scene
from hadim_cli.world.scene import Scene

__all__ = ["World", "check_action", "draw_scene", "wrap_angle"]

_NUMERIC_KINDS = frozenset("fiu")


def wrap_angle(angle: float) -> float:
    """The same angle in [-π, π)."""
    return (angle + math.pi) % (2 * math.pi) - math.pi


def check_action(action: object) -> tuple[float, float]:
    """(left, right) wheel intensities of a primitive action, or `ActionError`."""
    arr = action if isinstance(action, np.ndarray) else None
    if arr is None:
        try:
            arr = np.asarray(action)
        except (TypeError, ValueError):
            raise ActionError(f"action must be 2 numbers in [-1, 1], got {action!r}") from None
    if arr.dtype.kind not in _NUMERIC_KINDS:
        raise ActionError(f"action must be 2 numbers in [-1, 1], got {action!r}")
    if arr.shape != (2,):
        raise ActionError(f"action must have shape (2,) (left, right), got shape {arr.shape}")
    left, right = float(arr[0]), float(arr[1])
    # NaN fails every comparison, so this also refuses non-finite values.
    if not (-1.0 <= left <= 1.0 and -1.0 <= right <= 1.0):
        raise ActionError(
            f"action intensities must be finite and in [-1, 1], got ({left!r}, {right!r})")
    return left, right


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


class World:
    """The room, the robot and the objects of one episode at a time."""

    def __init__(self, config: WorldConfig):
        self.config = config
        self.layout = layout_for(config)
        self._lidar = Lidar(config.lidar_rays, config.lidar_range,
                            config.room_width / 2, config.room_height / 2)
        self._substeps = n_substeps(config)
        self._settle = n_settle_substeps(config)
        self._dt = config.physics_dt
        n = len(self.layout.objects)
        self._obs = np.zeros(self.layout.size)
        self._radii: list[float] = [0.0] * n
        self._index_spaces()
        self._physics: Physics | None = None
        self._scene: Scene | None = None
        self._steps = 0
        self.last_contacts: frozenset[tuple[str, str]] = frozenset()
        """Entity pairs (sorted names) that touched at any physics step of the last action."""

    def _index_spaces(self) -> None:
        lay = self.layout
        self._robot_pos = lay.space(ROBOT, Property.POSITION).slice
        self._robot_heading = lay.space(ROBOT, Property.HEADING).slice
        self._robot_lidar = lay.space(ROBOT, Property.LIDAR).slice
        self._obj_pos = lay.object_columns(Property.POSITION)
        self._obj_rel = lay.object_columns(Property.RELATIVE)

    # ------------------------------------------------------------------ episode

    @property
    def scene(self) -> Scene:
        """The scene the current episode started from."""
        if self._scene is None:
            raise HadimError("the world has no episode yet: call reset() first")
        return self._scene

    @property
    def steps(self) -> int:
        """Primitive actions executed since the last reset."""
        return self._steps

    @property
    def episode_over(self) -> bool:
        """True once `episode_length` actions were executed (stepping further is allowed)."""
        return self._steps >= self.config.episode_length

    def reset(self, rng: np.random.Generator | None = None, *, seed: int | None = None,
              scene: Scene | None = None) -> np.ndarray:
        """Start an episode from `scene`, or from one drawn with `rng` (or `seed`)."""
        if scene is None:
            if rng is None:
                if seed is None:
                    raise HadimError("reset() needs a scene, a generator or a seed")
                rng = np.random.default_rng(seed)
            scene = draw_scene(self.config, rng)
        self._check_scene(scene)
        self._physics = build_physics(self.config, scene)
        self._scene = scene
        self._steps = 0
        self.last_contacts = frozenset()
        self._fill_static(scene)
        return self.observe()

    def _check_scene(self, scene: Scene) -> None:
        n = len(self.layout.objects)
        if len(scene.objects) != n:
            raise HadimError(f"the scene has {len(scene.objects)} objects, this world's "
                             f"layout has {n} (world.n_green + world.n_red)")
        hw, hh = self.config.room_width / 2, self.config.room_height / 2
        discs = [(scene.robot_x, scene.robot_y, self.config.robot_radius)]
        discs += [(o.x, o.y, o.radius) for o in scene.objects]
        for x, y, r in discs:
            if abs(x) + r > hw or abs(y) + r > hh:
                raise HadimError(f"the scene puts a disc of radius {r} at ({x}, {y}), "
                                 f"outside the {2 * hw}x{2 * hh} m room")

    def _fill_static(self, scene: Scene) -> None:
        """The properties that never change during an episode, written once per reset."""
        obs, lay, cfg = self._obs, self.layout, self.config
        obs[lay.space(ROBOT, Property.RADIUS).slice] = cfg.robot_radius
        obs[lay.space(ROBOT, Property.HEIGHT).slice] = cfg.robot_height
        obs[lay.space(ROBOT, Property.COLOR).slice] = ROBOT_COLOR
        obs[lay.space(ROBOT, Property.SHAPE).slice] = float(Shape.CYLINDER)
        for i, (name, spec) in enumerate(zip(lay.objects, scene.objects, strict=True)):
            obs[lay.space(name, Property.RADIUS).slice] = spec.radius
            obs[lay.space(name, Property.HEIGHT).slice] = spec.height
            obs[lay.space(name, Property.COLOR).slice] = spec.color
            obs[lay.space(name, Property.SHAPE).slice] = float(spec.shape)
            self._radii[i] = spec.radius

    # ------------------------------------------------------------------ acting

    def _require_physics(self) -> Physics:
        if self._physics is None:
            raise HadimError("the world has no episode yet: call reset() first")
        return self._physics

    def step(self, action: object) -> np.ndarray:
        """Hold the wheel intensities (left, right) ∈ [-1, 1]² for one action, then stop the
        wheels for `settle_time`; observe."""
        physics = self._require_physics()
        left, right = check_action(action)
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
