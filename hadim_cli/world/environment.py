"""The contract every body's world keeps, and `make_world`, which builds the configured one.

A world declares what it is — its `body`, its primitive `action_space` and its observation
`layout` (the actor, entity 0, and the objects, each property a named space with bounds) — so
that whoever drives it needs to know nothing of the body. `reset` starts an episode from a
scene (given, or drawn from the passed generator only) in a fresh pymunk space; `step` holds
one primitive action and observes. Same scene and actions, bit-identical observations.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from typing import Any, Generic, Protocol, TypeVar

import numpy as np

from hadim_cli.config import Body, WorldConfig
from hadim_cli.errors import HadimError
from hadim_cli.world.actions import ActionSpace
from hadim_cli.world.layout import ObservationLayout, Property, Shape
from hadim_cli.world.physics import n_settle_substeps, n_substeps, release
from hadim_cli.world.scene import ObjectSpec

SceneT = TypeVar("SceneT")


class _HasSpace(Protocol):
    space: Any
    """The episode's `pymunk.Space`."""


PhysicsT = TypeVar("PhysicsT", bound=_HasSpace)


class Environment(ABC, Generic[SceneT, PhysicsT]):
    """One episode at a time of a body among objects (the room's `World`, the `ArmWorld`)."""

    body: Body
    """What the world is: the body the learner acts through."""
    action_space: ActionSpace
    """The primitive action: its components, each in [-1, 1]."""
    layout: ObservationLayout
    """Where each (entity, property) space lies in an observation, with its bounds."""

    def __init__(self, config: WorldConfig, layout: ObservationLayout):
        if config.body is not self.body:
            raise HadimError(f"world.body = {config.body.value!r}: this part of hadim runs the "
                             f"{self.body.value} only (`hadim world render|info` and `hadim "
                             "bench world` run every body)")
        self.config = config
        self.layout = layout
        self._obs = np.zeros(layout.size)
        """The observation being filled; `observe` returns a copy."""
        self._obj_pos = layout.object_columns(Property.POSITION)
        self._obj_rel = layout.object_columns(Property.RELATIVE)
        self._substeps = n_substeps(config)
        self._settle = n_settle_substeps(config)
        self._dt = config.physics_dt
        self._physics: PhysicsT | None = None
        self._scene: SceneT | None = None
        self._steps = 0
        self.last_contacts: frozenset[tuple[str, str]] = frozenset()
        """Entity pairs (sorted names) that touched at any physics step of the last action."""

    @property
    def action_dim(self) -> int:
        """Components of a primitive action."""
        return self.action_space.dim

    # ------------------------------------------------------------------ episode

    @property
    def scene(self) -> SceneT:
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
              scene: SceneT | None = None) -> np.ndarray:
        """Start an episode from `scene`, or from one drawn with `rng` (or `seed`)."""
        if scene is None:
            if rng is None:
                if seed is None:
                    raise HadimError("reset() needs a scene, a generator or a seed")
                rng = np.random.default_rng(seed)
            scene = self.draw_scene(rng)
        self._check_scene(scene)
        if self._physics is not None:
            release(self._physics.space)  # not left to the garbage collector: see `release`
        self._physics = self._build(scene)
        self._scene = scene
        self._steps = 0
        self.last_contacts = frozenset()
        self._fill_static(scene)
        return self.observe()

    @abstractmethod
    def draw_scene(self, rng: np.random.Generator) -> SceneT:
        """A random scene of this world, drawn from `rng` only (what `reset(rng)` starts)."""

    @abstractmethod
    def _check_scene(self, scene: SceneT) -> None:
        """Refuse a scene this world cannot hold (`HadimError`)."""

    @abstractmethod
    def _build(self, scene: SceneT) -> PhysicsT:
        """A fresh physics space holding `scene`."""

    @abstractmethod
    def _fill_static(self, scene: SceneT) -> None:
        """Write the properties that never change within an episode."""

    def _require_physics(self) -> PhysicsT:
        if self._physics is None:
            raise HadimError("the world has no episode yet: call reset() first")
        return self._physics

    # ------------------------------------------------------------------ acting, observing

    @abstractmethod
    def step(self, action: object) -> np.ndarray:
        """Hold one primitive action (refused with `ActionError` unless in the action box),
        then let the world settle; observe."""

    @abstractmethod
    def observe(self) -> np.ndarray:
        """The current observation (a copy), laid out as `self.layout` says."""

    def poses(self) -> np.ndarray:
        """(x, y, angle) of every body the world reads, the body's first, then the objects
        (scene order), as pymunk holds them."""
        physics: Any = self._require_physics()
        return physics.poses.poses().copy()


def check_objects(layout: ObservationLayout, objects: tuple[ObjectSpec, ...],
                  half_w: float, half_h: float, where: str) -> None:
    """Refuse a scene whose object count is not the layout's, or whose disc leaves the
    half_w × half_h rectangle (`where` names it: "room", "table")."""
    n = len(layout.objects)
    if len(objects) != n:
        raise HadimError(f"the scene has {len(objects)} objects, this world's "
                         f"layout has {n} (world.n_green + world.n_red)")
    for o in objects:
        check_inside(o.x, o.y, o.radius, half_w, half_h, where)


def check_inside(x: float, y: float, r: float, half_w: float, half_h: float,
                 where: str) -> None:
    if abs(x) + r > half_w or abs(y) + r > half_h:
        raise HadimError(f"the scene puts a disc of radius {r} at ({x}, {y}), "
                         f"outside the {2 * half_w}x{2 * half_h} m {where}")


def fill_looks(obs: np.ndarray, layout: ObservationLayout, entity: str, radius: float,
               height: float, color: tuple[float, float, float], shape: Shape) -> None:
    """Write an entity's looks (radius, height, colour, shape) into `obs`."""
    obs[layout.space(entity, Property.RADIUS).slice] = radius
    obs[layout.space(entity, Property.HEIGHT).slice] = height
    obs[layout.space(entity, Property.COLOR).slice] = color
    obs[layout.space(entity, Property.SHAPE).slice] = float(shape)


def fill_object_looks(obs: np.ndarray, layout: ObservationLayout,
                      objects: tuple[ObjectSpec, ...]) -> list[float]:
    """Write every object's looks; returns their radii (scene order)."""
    for name, spec in zip(layout.objects, objects, strict=True):
        fill_looks(obs, layout, name, spec.radius, spec.height, spec.color, spec.shape)
    return [spec.radius for spec in objects]


def make_world(config: WorldConfig) -> Environment[Any, Any]:
    """The world of the configured body: the rover's room or the arm's table."""
    if config.body is Body.ARM:
        from hadim_cli.world.arm import ArmWorld

        return ArmWorld(config)
    from hadim_cli.world.world import World

    return World(config)
