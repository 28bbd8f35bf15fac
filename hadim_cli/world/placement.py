"""Random scenes: cylinders placed without overlap around the robot's start (paper §3.1), or
within the arm's reach.

Only numpy: the evaluation and the learner may import this without pulling in pymunk.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from hadim_cli.config import WorldConfig
from hadim_cli.errors import HadimError
from hadim_cli.world.kinematics import effector_position, inner_reach, outer_reach
from hadim_cli.world.layout import EFFECTOR, ROBOT, object_name
from hadim_cli.world.scene import ArmScene, ObjectSpec, Scene

ROBOT_COLOR: tuple[float, float, float] = (0.2, 0.3, 0.8)
"""The robot's colour: neither green nor red, so no classifier confuses it with an object."""

# Shades: the dominant channel is bright, the two others dark, each drawn independently.
_DOMINANT = (0.55, 1.0)
_OTHERS = (0.0, 0.3)

# A scene that cannot be placed within this many tries per object is drawn again from
# scratch; after `_SCENE_TRIES` whole scenes the configuration is refused.
_TRIES_PER_OBJECT = 500
_SCENE_TRIES = 20


def object_mass(config: WorldConfig, radius: float, height: float) -> float:
    """Mass of a green cylinder (kg): density·π·r²·h."""
    return config.object_density * math.pi * radius * radius * height


class SceneError(HadimError):
    """No scene satisfying the gaps and the start clearance could be drawn."""


def shade(rng: np.random.Generator, channel: int) -> tuple[float, float, float]:
    """A random shade whose `channel` (0 red, 1 green, 2 blue) dominates."""
    rgb = rng.uniform(*_OTHERS, size=3)
    rgb[channel] = rng.uniform(*_DOMINANT)
    return (float(rgb[0]), float(rgb[1]), float(rgb[2]))


Position = Callable[[np.random.Generator, float], tuple[float, float]]
"""Draws a candidate centre for an object of the given radius."""
Fits = Callable[[float, float, float], bool]
"""Whether an object of radius r centred at (x, y) keeps clear of the body and the edges."""


def _clear_of(x: float, y: float, r: float, placed: list[ObjectSpec], gap: float) -> bool:
    return all(math.hypot(x - o.x, y - o.y) >= r + o.radius + gap for o in placed)


def _place(rng: np.random.Generator, config: WorldConfig,
           sizes: list[tuple[float, float]], colors: list[tuple[float, float, float]],
           position: Position, fits: Fits) -> tuple[ObjectSpec, ...] | None:
    placed: list[ObjectSpec] = []
    for i, (r, h) in enumerate(sizes):
        for _ in range(_TRIES_PER_OBJECT):
            x, y = position(rng, r)
            if fits(x, y, r) and _clear_of(x, y, r, placed, config.object_gap):
                placed.append(ObjectSpec(x, y, r, h, colors[i], pushable=i < config.n_green))
                break
        else:
            return None
    return tuple(placed)


def draw_objects(config: WorldConfig, rng: np.random.Generator, position: Position,
                 fits: Fits, where: str, lower: str) -> tuple[ObjectSpec, ...]:
    """`n_green` green then `n_red` red cylinders, none overlapping, each where `fits` allows.

    Radius and height are uniform in their configured ranges, the colour a shade of green or
    red, the centre drawn by `position` until it fits and keeps `object_gap` from the objects
    placed before. All randomness comes from `rng`; `where` and `lower` word the refusal.
    """
    n = config.n_green + config.n_red
    for _ in range(_SCENE_TRIES):
        radii = rng.uniform(config.object_radius_min, config.object_radius_max, size=n)
        heights = rng.uniform(config.object_height_min, config.object_height_max, size=n)
        sizes = [(float(r), float(h)) for r, h in zip(radii, heights, strict=True)]
        colors = [shade(rng, 1 if i < config.n_green else 0) for i in range(n)]
        objects = _place(rng, config, sizes, colors, position, fits)
        if objects is not None:
            return objects
    raise SceneError(f"could not place {n} objects without overlap {where} after "
                     f"{_SCENE_TRIES} tries; lower world.n_green/n_red, {lower}")


def _within(x: float, y: float, r: float, half_w: float, half_h: float, gap: float) -> bool:
    return abs(x) + r + gap <= half_w and abs(y) + r + gap <= half_h


def draw_scene(config: WorldConfig, rng: np.random.Generator) -> Scene:
    """A random room: `n_green` green then `n_red` red cylinders, the robot at the centre.

    The robot's heading is drawn first (if `random_heading`); every object keeps `object_gap`
    from the others and from the walls, and its surface stays at least `start_clearance` from
    the robot's start (the room centre). All randomness comes from `rng`.
    """
    heading = float(rng.uniform(-math.pi, math.pi)) if config.random_heading else 0.0
    gap = config.object_gap

    def position(rng: np.random.Generator, r: float) -> tuple[float, float]:
        half_w = config.room_width / 2 - r - gap
        half_h = config.room_height / 2 - r - gap
        return float(rng.uniform(-half_w, half_w)), float(rng.uniform(-half_h, half_h))

    def fits(x: float, y: float, r: float) -> bool:
        return math.hypot(x, y) >= config.start_clearance + r

    objects = draw_objects(
        config, rng, position, fits, f"in a {config.room_width}x{config.room_height} m room",
        "world.object_radius_max, world.object_gap or world.start_clearance")
    return Scene(objects=objects, robot_x=0.0, robot_y=0.0, robot_heading=heading)


def draw_arm_scene(config: WorldConfig, rng: np.random.Generator) -> ArmScene:
    """A random table: the arm's pose, then the objects, as `draw_objects` says.

    The shoulder's angle is uniform in [-π, π), each other joint's within its limits. Each
    object's centre is uniform (by area) in the annulus the effector's centre reaches, so the
    arm can touch every object; it keeps `object_gap` from the base, from the effector at
    its start, from the table's rim and from the other objects.
    """
    arm, gap = config.arm, config.object_gap
    joints = (float(rng.uniform(-math.pi, math.pi)),
              *(float(rng.uniform(-lim, lim)) for lim in arm.joint_limits))
    ex, ey = effector_position(arm.link_lengths, np.array(joints)).tolist()
    near = inner_reach(arm.link_lengths, arm.joint_limits) ** 2
    far = outer_reach(arm.link_lengths) ** 2
    half_w, half_h = arm.table_width / 2, arm.table_height / 2

    def position(rng: np.random.Generator, r: float) -> tuple[float, float]:
        distance = math.sqrt(rng.uniform(near, far))
        bearing = rng.uniform(-math.pi, math.pi)
        return distance * math.cos(bearing), distance * math.sin(bearing)

    def fits(x: float, y: float, r: float) -> bool:
        return (math.hypot(x, y) >= arm.base_radius + r + gap
                and math.hypot(x - ex, y - ey) >= arm.effector_radius + r + gap
                and _within(x, y, r, half_w, half_h, gap))

    objects = draw_objects(
        config, rng, position, fits, f"within the arm's reach ({math.sqrt(far):g} m)",
        "world.object_radius_max or world.object_gap, or lengthen world.arm.link_lengths")
    return ArmScene(objects=objects, joints=joints)


def scene_rows(config: WorldConfig, scene: Scene) -> list[dict[str, object]]:
    """One plain row per entity of a scene (robot first): what `hadim world info` shows."""
    rows: list[dict[str, object]] = [{
        "entity": ROBOT, "kind": "robot", "x": scene.robot_x, "y": scene.robot_y,
        "heading": scene.robot_heading, "radius": config.robot_radius,
        "height": config.robot_height, "mass": config.robot_mass, "color": list(ROBOT_COLOR),
    }]
    return rows + _object_rows(config, scene.objects)


def _object_rows(config: WorldConfig, objects: tuple[ObjectSpec, ...]
                 ) -> list[dict[str, object]]:
    return [{
        "entity": object_name(i), "kind": "green" if spec.pushable else "red",
        "x": spec.x, "y": spec.y, "radius": spec.radius, "height": spec.height,
        "mass": object_mass(config, spec.radius, spec.height) if spec.pushable else None,
        "color": list(spec.color),
    } for i, spec in enumerate(objects)]


def arm_scene_rows(config: WorldConfig, scene: ArmScene) -> list[dict[str, object]]:
    """One plain row per entity of an arm's scene (the effector first)."""
    arm = config.arm
    x, y = effector_position(arm.link_lengths, np.array(scene.joints)).tolist()
    rows: list[dict[str, object]] = [{
        "entity": EFFECTOR, "kind": "effector", "x": x, "y": y, "joints": list(scene.joints),
        "radius": arm.effector_radius, "height": arm.effector_height, "mass": None,
        "color": list(ROBOT_COLOR),
    }]
    return rows + _object_rows(config, scene.objects)
