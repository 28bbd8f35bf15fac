"""The pymunk model of the room: a fresh `Space` built from a `Scene` (paper §3.1).

Top-down, no gravity. Ground friction of every movable body is emulated with the pymunk "tank"
pattern: a `PivotJoint` and a `GearJoint` to a reference body with `max_bias = 0` (velocity
correction only) and a bounded `max_force`. For a green object the reference is the static
body and the bounds are Coulomb friction (μ·m·g, and its torque (2/3)·μ·m·g·r for a disc of
uniform pressure). For the robot the reference is a kinematic *control body* whose velocity is
the one the wheels ask for; the bounds are the drive force and torque, so a heavy load slows the
robot down. Red objects are static circles; walls are thick static segments.

The space, the walls, the objects and the readers here serve the arm's table too
(`arm_physics.py`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pymunk
import pymunk.batch

from hadim_cli.config import WorldConfig
from hadim_cli.world.layout import ROBOT, object_name
from hadim_cli.world.placement import object_mass
from hadim_cli.world.scene import ArmScene, Scene

GRAVITY = 9.81
"""Acceleration of gravity (m/s²), for the ground friction force μ·m·g."""
WALL_THICKNESS = 0.2
"""Half-thickness of the wall segments (m): far more than any body moves in one physics step."""
SHAPE_FRICTION = 0.5
"""Coulomb coefficient between shapes (robot on object, object on object, on walls)."""
COLLISION_SLOP = 0.001
"""Overlap the solver tolerates (m); pymunk's default (0.1) is meant for pixels, not metres."""


def n_substeps(config: WorldConfig) -> int:
    """Physics steps one primitive action lasts (action_duration / physics_dt, rounded)."""
    return max(1, round(config.action_duration / config.physics_dt))


def n_settle_substeps(config: WorldConfig) -> int:
    """Physics steps with the wheels stopped (the arm's joints held) after each action
    (settle_time / physics_dt, rounded)."""
    return round(config.settle_time / config.physics_dt)


def wheel_command(config: WorldConfig, left: float, right: float) -> tuple[float, float]:
    """(forward speed m/s, angular speed rad/s) of a differential drive for wheel intensities."""
    speed = config.max_wheel_speed
    return (left + right) / 2 * speed, (right - left) * speed / config.wheel_base


class ContactLog:
    """Entity pairs touching now, and those that touched at any physics step since `start()`.

    Fed by pymunk's begin/separate callbacks, so it costs nothing while contacts persist.
    One log per space: a discarded space's late `separate` calls cannot reach a new one.
    """

    def __init__(self, names: dict[pymunk.Shape, str]):
        self._names = names
        self.touching: set[tuple[str, str]] = set()
        self.touched: set[tuple[str, str]] = set()

    def _pair(self, arbiter: pymunk.Arbiter) -> tuple[str, str] | None:
        a, b = arbiter.shapes
        name_a, name_b = self._names.get(a), self._names.get(b)
        if name_a is None or name_b is None:
            return None  # a wall: not an entity
        return (name_a, name_b) if name_a < name_b else (name_b, name_a)

    def begin(self, arbiter: pymunk.Arbiter, space: pymunk.Space, data: object) -> None:
        pair = self._pair(arbiter)
        if pair is not None:
            self.touching.add(pair)
            self.touched.add(pair)

    def separate(self, arbiter: pymunk.Arbiter, space: pymunk.Space, data: object) -> None:
        pair = self._pair(arbiter)
        if pair is not None:
            self.touching.discard(pair)

    def start(self) -> None:
        self.touched = set(self.touching)


class PoseReader:
    """(x, y, angle) of the robot and of every object in one batch call per observation.

    `pymunk.batch` copies all bodies' poses in one C call, far cheaper than one `Body.position`
    per body. Its row order is the space's body order: matched to ours once, by body id.
    """

    _FIELDS = pymunk.batch.BodyFields.POSITION | pymunk.batch.BodyFields.ANGLE

    def __init__(self, space: pymunk.Space, bodies: list[pymunk.Body]):
        self._space = space
        self._buffer = pymunk.batch.Buffer()
        pymunk.batch.get_space_bodies(space, pymunk.batch.BodyFields.BODY_ID, self._buffer)
        ids = np.frombuffer(self._buffer.int_buf(), dtype=np.uintp).tolist()
        row = {body_id: i for i, body_id in enumerate(ids)}
        self._rows = np.array([row[b.id] for b in bodies], dtype=np.intp)

    def poses(self) -> np.ndarray:
        """Array (len(bodies), 3) of x, y, angle, in the order the bodies were given."""
        buffer = self._buffer
        buffer.clear()
        pymunk.batch.get_space_bodies(self._space, self._FIELDS, buffer)
        return np.frombuffer(buffer.float_buf(), dtype=np.float64).reshape(-1, 3)[self._rows]


@dataclass
class Physics:
    """One episode's space and the handles the world steps and reads."""

    space: pymunk.Space
    robot: pymunk.Body
    control: pymunk.Body
    """Kinematic body whose velocity is the wheels' command; the robot follows it."""
    movable: list[pymunk.Body]
    """Green objects' bodies, in scene order."""
    contacts: ContactLog
    poses: PoseReader
    """Reads the robot's pose (row 0) and the objects' (rows 1…, scene order)."""


def release(space: pymunk.Space) -> None:
    """Empty `space` while everything in it is alive, before the space is dropped.

    pymunk frees a space, its bodies, shapes and joints through finalizers, and they hold one
    another in cycles (each object and the cffi handle of it), so the garbage collector runs
    those finalizers together, in no set order. Removing a shape that touches another calls
    the contact callbacks, which read both shapes through their handles: in a collection, one
    of them may already be freed (a segfault inside a later `pymunk.Body(...)`, where the
    collection ran). An emptied space leaves its finalizers nothing to remove and nothing to
    call back."""
    space.remove(*space.constraints, *space.shapes, *space.bodies)


def new_space() -> pymunk.Space:
    """An empty top-down space, its collision slop in metres."""
    space = pymunk.Space()
    space.collision_slop = COLLISION_SLOP
    return space


def add_walls(space: pymunk.Space, width: float, height: float) -> None:
    """Four static walls whose inner faces bound a width × height rectangle at the origin."""
    t = WALL_THICKNESS
    hw, hh = width / 2 + t, height / 2 + t
    corners = [(-hw, -hh), (hw, -hh), (hw, hh), (-hw, hh)]
    for a, b in zip(corners, corners[1:] + corners[:1], strict=True):
        wall = pymunk.Segment(space.static_body, a, b, t)
        wall.elasticity, wall.friction = 0.0, SHAPE_FRICTION
        space.add(wall)


def _friction_joints(space: pymunk.Space, ref: pymunk.Body, body: pymunk.Body,
                     force: float, torque: float) -> None:
    pivot = pymunk.PivotJoint(ref, body, (0, 0), (0, 0))
    pivot.max_bias, pivot.max_force = 0.0, force
    gear = pymunk.GearJoint(ref, body, 0.0, 1.0)
    gear.max_bias, gear.max_force = 0.0, torque
    space.add(pivot, gear)


def add_circle(space: pymunk.Space, body: pymunk.Body, radius: float,
               offset: tuple[float, float] = (0.0, 0.0)) -> pymunk.Circle:
    """A disc of `radius` on `body` at `offset` (body frame), friction and elasticity set."""
    shape = pymunk.Circle(body, radius, offset)
    shape.elasticity, shape.friction = 0.0, SHAPE_FRICTION
    space.add(shape)
    return shape


def add_objects(space: pymunk.Space, config: WorldConfig, scene: Scene | ArmScene,
                names: dict[pymunk.Shape, str]) -> tuple[list[pymunk.Body], list[pymunk.Body]]:
    """The scene's cylinders: green ones dynamic, held by ground friction, red ones static.

    Their shapes are named obj1, obj2, … in `names`. Returns every object's body and the
    green ones', both in scene order.
    """
    bodies: list[pymunk.Body] = []
    movable: list[pymunk.Body] = []
    for i, spec in enumerate(scene.objects):
        if spec.pushable:
            mass = object_mass(config, spec.radius, spec.height)
            body = pymunk.Body(mass, pymunk.moment_for_circle(mass, 0, spec.radius))
        else:
            body = pymunk.Body(body_type=pymunk.Body.STATIC)
        body.position = (spec.x, spec.y)
        space.add(body)
        bodies.append(body)
        names[add_circle(space, body, spec.radius)] = object_name(i)
        if spec.pushable:
            friction = config.ground_friction * mass * GRAVITY
            _friction_joints(space, space.static_body, body, friction,
                             friction * spec.radius * 2 / 3)
            movable.append(body)
    return bodies, movable


def build_physics(config: WorldConfig, scene: Scene, *, track_contacts: bool = True) -> Physics:
    """A fresh space holding the walls, the robot at its start pose and the scene's objects.

    Without `track_contacts` no collision callback is installed (the raw benchmark): the
    physics is the same, the contact log stays empty.
    """
    space = new_space()
    names: dict[pymunk.Shape, str] = {}
    add_walls(space, config.room_width, config.room_height)

    robot = pymunk.Body(config.robot_mass,
                        pymunk.moment_for_circle(config.robot_mass, 0, config.robot_radius))
    robot.position = (scene.robot_x, scene.robot_y)
    robot.angle = scene.robot_heading
    space.add(robot)
    names[add_circle(space, robot, config.robot_radius)] = ROBOT
    control = pymunk.Body(body_type=pymunk.Body.KINEMATIC)
    control.position = robot.position
    control.angle = robot.angle
    space.add(control)
    _friction_joints(space, control, robot, config.drive_force, config.drive_torque)

    objects, movable = add_objects(space, config, scene, names)
    return Physics(space, robot, control, movable, contact_log(space, names, track_contacts),
                   PoseReader(space, [robot, *objects]))


def contact_log(space: pymunk.Space, names: dict[pymunk.Shape, str],
                track_contacts: bool) -> ContactLog:
    """The space's contact log, fed by its collision callbacks unless `track_contacts` is off."""
    contacts = ContactLog(names)
    if track_contacts:
        space.on_collision(begin=contacts.begin, separate=contacts.separate)
    return contacts
