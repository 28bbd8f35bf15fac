"""Small hand-built worlds for the physics tests.

Imported by the tests next to it (pytest puts this folder on sys.path) under a name of its own:
`from conftest import …` finds whichever folder's conftest.py was put on sys.path last, which
depends on the order the tests are collected in.
"""

from __future__ import annotations

import dataclasses

from hadim_cli.config import WorldConfig
from hadim_cli.world.scene import ObjectSpec, Scene
from hadim_cli.world.world import World

GREEN = (0.1, 0.8, 0.1)
RED = (0.8, 0.1, 0.1)


def config(**changes: object) -> WorldConfig:
    return dataclasses.replace(WorldConfig(), **changes)


def green(x: float, y: float, radius: float = 0.1, height: float = 0.2) -> ObjectSpec:
    return ObjectSpec(x, y, radius, height, GREEN, pushable=True)


def red(x: float, y: float, radius: float = 0.1, height: float = 0.2) -> ObjectSpec:
    return ObjectSpec(x, y, radius, height, RED, pushable=False)


def world_with(*objects: ObjectSpec, heading: float = 0.0, x: float = 0.0, y: float = 0.0,
               **changes: object) -> World:
    """A world holding exactly `objects` (its config counts them), reset to that scene."""
    n_green = sum(o.pushable for o in objects)
    world = World(config(n_green=n_green, n_red=len(objects) - n_green, **changes))
    world.reset(scene=Scene(objects=tuple(objects), robot_x=x, robot_y=y, robot_heading=heading))
    return world


def assert_drawn_object(o: ObjectSpec, c: WorldConfig) -> None:
    """A drawn object is a shade of green (pushable) or red (fixed), of the configured sizes."""
    r, g, b = o.color
    dominant, others = (g, (r, b)) if o.pushable else (r, (g, b))
    assert dominant >= 0.55 and max(others) <= 0.3
    assert c.object_radius_min <= o.radius <= c.object_radius_max
    assert c.object_height_min <= o.height <= c.object_height_max

