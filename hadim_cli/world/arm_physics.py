"""The pymunk model of the arm's table: a fresh `Space` built from an `ArmScene`.

Top-down, no gravity, as the room (`physics.py`, whose walls, objects and readers this
shares). A fixed base at the origin (a static disc); each link a dynamic body whose origin is
its inner joint, its mass spread evenly along it; joint i is a `PivotJoint` to the link before
it (the first to the static body at the base), a `RotaryLimitJoint` holding its angle within
its limit (the shoulder's ±π) and a `SimpleMotor` that drives its speed with a bounded torque,
so an object too heavy, or fixed, stops the arm. The links have no shape: they pass above the
objects, and only the end effector, a disc at the tip of the last link, touches them. A low
rim round the table (the room's walls) keeps pushed objects on it.
"""

from __future__ import annotations

from dataclasses import dataclass

import pymunk

from hadim_cli.config import WorldConfig
from hadim_cli.world.kinematics import joint_points, joint_ranges
from hadim_cli.world.layout import EFFECTOR
from hadim_cli.world.physics import (
    ContactLog,
    PoseReader,
    add_circle,
    add_objects,
    add_walls,
    contact_log,
    new_space,
)
from hadim_cli.world.scene import ArmScene

JOINT_ERROR_BIAS = 0.5 ** 60
"""Share of a joint's error (a pivot's gap, an angle past a limit) left after one second: half
of it corrected at every step of 1/60 s. With pymunk's default (0.9^60, a tenth per step) an
arm pressed against red objects kept its joints up to 1.0 mm apart after an action's settle;
with this, 0.3 mm."""


@dataclass
class ArmPhysics:
    """One episode's space and the handles the arm's world steps and reads."""

    space: pymunk.Space
    links: list[pymunk.Body]
    """The links' bodies, base outwards; each one's origin is its inner joint."""
    motors: list[pymunk.SimpleMotor]
    """One per joint: its `rate` is minus the joint's commanded speed (pymunk drives
    a.angular_velocity − b.angular_velocity towards it; b is the outer link)."""
    movable: list[pymunk.Body]
    """Green objects' bodies, in scene order."""
    contacts: ContactLog
    poses: PoseReader
    """Reads the links' poses (rows 0…n−1) and the objects' (rows n…, scene order)."""


def build_arm_physics(config: WorldConfig, scene: ArmScene, *,
                      track_contacts: bool = True) -> ArmPhysics:
    """A fresh space holding the table's rim, the arm in the scene's pose and its objects.

    Without `track_contacts` no collision callback is installed (the raw benchmark).
    """
    arm = config.arm
    space = new_space()
    names: dict[pymunk.Shape, str] = {}
    add_walls(space, arm.table_width, arm.table_height)
    add_circle(space, space.static_body, arm.base_radius)

    starts = joint_points(arm.link_lengths, scene.joints)[:-1].tolist()
    links: list[pymunk.Body] = []
    motors: list[pymunk.SimpleMotor] = []
    inner, inner_length, angle = space.static_body, 0.0, 0.0
    joints = zip(arm.link_lengths, scene.joints, joint_ranges(arm.joint_limits),
                 arm.motor_torques, starts, strict=True)
    for length, q, limit, torque, start in joints:
        mass = arm.link_mass
        link = pymunk.Body(mass, mass * length * length / 12 + arm.joint_inertia)
        link.center_of_gravity = (length / 2, 0.0)
        angle += q
        link.angle = angle  # before the position: a body turns about its centre of gravity
        link.position = start
        pivot = pymunk.PivotJoint(inner, link, (inner_length, 0.0), (0.0, 0.0))
        stop = pymunk.RotaryLimitJoint(inner, link, -limit, limit)
        pivot.error_bias = stop.error_bias = JOINT_ERROR_BIAS
        motor = pymunk.SimpleMotor(inner, link, 0.0)
        motor.max_force = torque
        space.add(link, pivot, stop, motor)
        links.append(link)
        motors.append(motor)
        inner, inner_length = link, length
    names[add_circle(space, inner, arm.effector_radius, (inner_length, 0.0))] = EFFECTOR

    objects, movable = add_objects(space, config, scene, names)
    return ArmPhysics(space, links, motors, movable, contact_log(space, names, track_contacts),
                      PoseReader(space, [*links, *objects]))
