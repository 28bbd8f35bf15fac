"""Random scenes: cylinders placed without overlap around the robot's start (paper §3.1).

Only numpy: the evaluation and the learner may import this without pulling in pymunk.
"""

from __future__ import annotations

import math

import numpy as np

from hadim_cli.config import WorldConfig
from hadim_cli.errors import HadimError
from hadim_cli.world.layout import ROBOT, object_name
from hadim_cli.world.scene import ObjectSpec, Scene

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


def _fits(x: float, y: float, r: float, placed: list[ObjectSpec], config: WorldConfig) -> bool:
    if math.hypot(x, y) < config.start_clearance + r:
        return False
    gap = config.object_gap
    return all(math.hypot(x - o.x, y - o.y) >= r + o.radius + gap for o in placed)


def _place(rng: np.random.Generator, config: WorldConfig,
           sizes: list[tuple[float, float]], colors: list[tuple[float, float, float]],
           ) -> tuple[ObjectSpec, ...] | None:
    placed: list[ObjectSpec] = []
    for i, (r, h) in enumerate(sizes):
        half_w = config.room_width / 2 - r - config.object_gap
        half_h = config.room_height / 2 - r - config.object_gap
        for _ in range(_TRIES_PER_OBJECT):
            x = float(rng.uniform(-half_w, half_w))
            y = float(rng.uniform(-half_h, half_h))
            if _fits(x, y, r, placed, config):
                placed.append(ObjectSpec(x, y, r, h, colors[i], pushable=i < config.n_green))
                break
        else:
            return None
    return tuple(placed)


def draw_scene(config: WorldConfig, rng: np.random.Generator) -> Scene:
    """A random scene: `n_green` green then `n_red` red cylinders, the robot at the centre.

    Radius and height are uniform in their configured ranges; every object keeps `object_gap`
    from the others and from the walls, and its surface stays at least `start_clearance` from
    the robot's start (the room centre). All randomness comes from `rng`.
    """
    n = config.n_green + config.n_red
    heading = float(rng.uniform(-math.pi, math.pi)) if config.random_heading else 0.0
    for _ in range(_SCENE_TRIES):
        radii = rng.uniform(config.object_radius_min, config.object_radius_max, size=n)
        heights = rng.uniform(config.object_height_min, config.object_height_max, size=n)
        sizes = [(float(r), float(h)) for r, h in zip(radii, heights, strict=True)]
        colors = [shade(rng, 1 if i < config.n_green else 0) for i in range(n)]
        objects = _place(rng, config, sizes, colors)
        if objects is not None:
            return Scene(objects=objects, robot_x=0.0, robot_y=0.0, robot_heading=heading)
    raise SceneError(
        f"could not place {n} objects without overlap in a {config.room_width}x"
        f"{config.room_height} m room after {_SCENE_TRIES} tries; lower world.n_green/n_red, "
        "world.object_radius_max, world.object_gap or world.start_clearance")


def scene_rows(config: WorldConfig, scene: Scene) -> list[dict[str, object]]:
    """One plain row per entity of a scene (robot first): what `hadim world info` shows."""
    rows: list[dict[str, object]] = [{
        "entity": ROBOT, "kind": "robot", "x": scene.robot_x, "y": scene.robot_y,
        "heading": scene.robot_heading, "radius": config.robot_radius,
        "height": config.robot_height, "mass": config.robot_mass, "color": list(ROBOT_COLOR),
    }]
    for i, spec in enumerate(scene.objects):
        rows.append({
            "entity": object_name(i), "kind": "green" if spec.pushable else "red",
            "x": spec.x, "y": spec.y, "radius": spec.radius, "height": spec.height,
            "mass": object_mass(config, spec.radius, spec.height) if spec.pushable else None,
            "color": list(spec.color),
        })
    return rows
