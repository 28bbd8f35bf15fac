"""Observation layout: named per-entity property spaces laid out in one flat float vector.

An observation is a 1-D float64 array; `ObservationLayout` says which slice holds which
(entity, property) space, with its dimension and bounds. The world fills the vector; the
learner reads spaces by name. Entity 0 is always the body's *actor* — the entity that acts on
the objects: the rover's `robot`, the arm's `effector` — and entities 1..n the objects.
"""

from __future__ import annotations

import enum
from dataclasses import dataclass
from functools import cached_property

import numpy as np

ROBOT = "robot"
"""The rover's actor."""
EFFECTOR = "effector"
"""The arm's actor: its end effector."""


def actor_of(body: str) -> str:
    """What the world of `body` (a `config.Body` value) calls its actor, entity 0 of its
    layout, for a reader that builds no world (a stored run's tables); each world's layout
    names it so (tested)."""
    return {"rover": ROBOT, "arm": EFFECTOR}[str(body)]


def object_name(index: int) -> str:
    """Name of the object entity `index` (0-based): obj1, obj2, …"""
    return f"obj{index + 1}"


class Property(enum.StrEnum):
    """Observable properties of an entity (paper §3.1)."""

    POSITION = "position"
    """Absolute (x, y) in the world frame, origin at the room's (or the table's) centre (m)."""
    RELATIVE = "relative"
    """Object position minus the actor's position, world frame (m); objects only."""
    HEADING = "heading"
    """(cos θ, sin θ) of the robot's heading; the rover's robot only."""
    LIDAR = "lidar"
    """Ranges of the LIDAR rays from the robot's centre (m), robot frame; the rover's robot
    only."""
    ORIENTATION = "orientation"
    """(cos φ, sin φ) of the direction the actor's body points from its fixed base (the arm's
    first link, from the table's +x axis): how the whole pose is turned about the base, apart
    from its shape (`JOINTS`). What a command does turns with it, so the actor's motion is
    read in its frame (`frames.relation_frame`) — but, unlike the rover's `HEADING`, it is no
    way the actor must face to move. The arm's effector only."""
    JOINTS = "joints"
    """Angle of each joint after the first (rad), base outwards: each link's from the link
    before it, counter-clockwise, 0 straight, within the joint's limits — the pose's shape
    (the first link's direction is `ORIENTATION`). The arm's effector only."""
    RADIUS = "radius"
    HEIGHT = "height"
    COLOR = "color"
    """RGB in [0, 1]."""
    SHAPE = "shape"
    """Shape code (see `Shape`)."""


class Shape(enum.IntEnum):
    """Shape codes; kept a property so boxes can come later."""

    CYLINDER = 0


# Properties that describe what an entity *is* (inputs of the visual classifier p_A).
VISUAL_PROPERTIES: tuple[Property, ...] = (
    Property.RADIUS, Property.HEIGHT, Property.COLOR, Property.SHAPE,
)


@dataclass(frozen=True)
class SpaceSpec:
    """One (entity, property) space of the observation vector."""

    entity: str
    prop: Property
    start: int
    dim: int
    low: tuple[float, ...]
    high: tuple[float, ...]

    @property
    def name(self) -> str:
        return f"{self.entity}.{self.prop.value}"

    @property
    def slice(self) -> slice:
        return slice(self.start, self.start + self.dim)


@dataclass(frozen=True)
class LayoutBounds:
    """The bounds the layout needs (taken from the world config)."""

    half_width: float
    half_height: float
    lidar_range: float
    radius_max: float
    height_max: float
    joint_limits: tuple[float, ...] = ()
    """The arm's joint limits (rad), one per joint; empty for the rover."""


OBJECT_SPACES: tuple[tuple[Property, int], ...] = (
    (Property.POSITION, 2), (Property.RELATIVE, 2), (Property.RADIUS, 1),
    (Property.HEIGHT, 1), (Property.COLOR, 3), (Property.SHAPE, 1),
)
"""The spaces of every object, whatever the body: (property, dimension)."""

_LOOKS: tuple[tuple[Property, int], ...] = (
    (Property.RADIUS, 1), (Property.HEIGHT, 1), (Property.COLOR, 3), (Property.SHAPE, 1),
)


def rover_spaces(lidar_rays: int) -> tuple[tuple[Property, int], ...]:
    """The robot's spaces: position, heading, LIDAR and its looks."""
    return ((Property.POSITION, 2), (Property.HEADING, 2), (Property.LIDAR, lidar_rays),
            *_LOOKS)


def arm_spaces(n_joints: int) -> tuple[tuple[Property, int], ...]:
    """The arm's effector's spaces: position, the first link's direction, the other joints'
    angles and its looks."""
    return ((Property.POSITION, 2), (Property.ORIENTATION, 2), (Property.JOINTS, n_joints - 1),
            *_LOOKS)


def _bounds(prop: Property, dim: int, b: LayoutBounds) -> tuple[tuple[float, ...], ...]:
    if prop is Property.POSITION:
        return (-b.half_width, -b.half_height), (b.half_width, b.half_height)
    if prop is Property.RELATIVE:
        return (-2 * b.half_width, -2 * b.half_height), (2 * b.half_width, 2 * b.half_height)
    if prop in (Property.HEADING, Property.ORIENTATION):
        return (-1.0, -1.0), (1.0, 1.0)
    if prop is Property.LIDAR:
        return (0.0,) * dim, (b.lidar_range,) * dim
    if prop is Property.JOINTS:
        return tuple(-v for v in b.joint_limits), tuple(b.joint_limits)
    if prop is Property.RADIUS:
        return (0.0,), (b.radius_max,)
    if prop is Property.HEIGHT:
        return (0.0,), (b.height_max,)
    if prop is Property.COLOR:
        return (0.0,) * 3, (1.0,) * 3
    return (0.0,), (float(max(Shape)),)


@dataclass(frozen=True)
class ObservationLayout:
    """Where each (entity, property) space lives in the flat observation vector."""

    entities: tuple[str, ...]
    spaces: tuple[SpaceSpec, ...]

    @classmethod
    def build(cls, n_objects: int, lidar_rays: int, bounds: LayoutBounds) -> ObservationLayout:
        """The rover's layout: the robot, then `n_objects` objects."""
        return cls.for_actor(ROBOT, rover_spaces(lidar_rays), n_objects, bounds)

    @classmethod
    def for_actor(cls, actor: str, actor_spaces: tuple[tuple[Property, int], ...],
                  n_objects: int, bounds: LayoutBounds) -> ObservationLayout:
        """The actor with its (property, dimension) spaces, then `n_objects` objects."""
        entities = (actor, *(object_name(i) for i in range(n_objects)))
        spaces: list[SpaceSpec] = []
        start = 0
        for entity in entities:
            for prop, dim in actor_spaces if entity == actor else OBJECT_SPACES:
                low, high = _bounds(prop, dim, bounds)
                spaces.append(SpaceSpec(entity, prop, start, dim, low, high))
                start += dim
        return cls(entities, tuple(spaces))

    @property
    def actor(self) -> str:
        """The entity the body acts with (entity 0): `robot` or `effector`."""
        return self.entities[0]

    @property
    def size(self) -> int:
        last = self.spaces[-1]
        return last.start + last.dim

    @property
    def objects(self) -> tuple[str, ...]:
        return self.entities[1:]

    @cached_property
    def _index(self) -> dict[tuple[str, Property], SpaceSpec]:
        return {(s.entity, s.prop): s for s in self.spaces}

    def space(self, entity: str, prop: Property) -> SpaceSpec:
        try:
            return self._index[(entity, Property(prop))]
        except KeyError:
            raise KeyError(f"no space {entity}.{prop}") from None

    def has(self, entity: str, prop: Property) -> bool:
        return (entity, Property(prop)) in self._index

    def object_columns(self, prop: Property) -> np.ndarray:
        """(objects, dim) indices of `prop` of every object: `obs[cols]` reads them all."""
        dim = dict(OBJECT_SPACES)[Property(prop)]
        starts = [self.space(o, prop).start for o in self.objects]
        return (np.asarray(starts, dtype=np.intp)[:, None] + np.arange(dim, dtype=np.intp)
                ).reshape(-1, dim)

    def get(self, obs: np.ndarray, entity: str, prop: Property) -> np.ndarray:
        """The values of one space in one observation (or the rows of a batch)."""
        return obs[..., self.space(entity, prop).slice]
