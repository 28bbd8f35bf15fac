"""Scenes: the layout of the world at the start of an episode, as plain frozen records.

A scene is drawn at random by `draw_scene` / `draw_arm_scene` (from a passed-in generator) or
written by hand in a task file; `reset(scene=...)` builds a fresh physics space from it. The
room's `Scene` holds the robot's start pose, the arm's `ArmScene` its joint angles.
"""

from __future__ import annotations

from dataclasses import dataclass

from hadim_cli.world.layout import Shape


@dataclass(frozen=True)
class ObjectSpec:
    """One object of the room."""

    x: float
    y: float
    radius: float
    height: float
    color: tuple[float, float, float]
    """RGB in [0, 1]: a shade of green for pushable objects, of red for fixed ones."""
    pushable: bool
    shape: Shape = Shape.CYLINDER


@dataclass(frozen=True)
class Scene:
    """The robot's start pose and the objects of the room (entity order: obj1, obj2, …)."""

    objects: tuple[ObjectSpec, ...]
    robot_x: float = 0.0
    robot_y: float = 0.0
    robot_heading: float = 0.0
    """Heading angle in radians, 0 facing +x."""


@dataclass(frozen=True)
class ArmScene:
    """The arm's start pose and the objects on the table (entity order: obj1, obj2, …)."""

    objects: tuple[ObjectSpec, ...]
    joints: tuple[float, ...]
    """Start angle of each joint (rad), base outwards, as `Property.JOINTS` reads them."""
