"""Evaluation tasks (paper §5.1): a scene, the entity and property to drive, target points.

A task is a TOML file in `configs/tasks/` (or a user's own file passed with `--points`).
A user's task is named `USER_PREFIX + name`, so its scores can never be stored as, or plotted
with, a built-in task's. A task belongs to one body (`body`, the rover's when the file does not
say): its scene places that body (the rover's pose, or the arm's joint angles), and it drives
that body's actor (`robot`, `effector`) or an object; a run of another body refuses it.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from hadim_cli.config import Body, WorldConfig, configs_dir, read_toml
from hadim_cli.errors import HadimError
from hadim_cli.world.kinematics import inner_reach, joint_ranges, outer_reach
from hadim_cli.world.layout import ROBOT, Shape, actor_of
from hadim_cli.world.scene import ArmScene, ObjectSpec, Scene


@dataclass(frozen=True)
class Task:
    """Drive `entity.property` to each point, from the task's scene, within `budget` actions."""

    name: str
    description: str
    entity: str
    """The body's actor ('robot', 'effector': `layout.actor_of`), or 'target' (the object named by
    `target`)."""
    prop: str
    points: tuple[tuple[float, float], ...]
    budget: int
    scene: Scene | ArmScene
    """The rover's `Scene` for a task of the rover, the arm's `ArmScene` for one of the arm."""
    target: str | None = None
    tool: str | None = None
    """With a tool, any robot–target contact during a point's attempt fails the point."""
    headings: tuple[float, ...] | None = None
    """With property 'pose' (robot only): the heading (rad) to face at each point, reached
    after the position; the point's error is the mean of the position's and the heading's."""
    affordance_input: str | None = None
    """The input space (e.g. `robot.position`) of the affordance the task evaluates, as the
    paper evaluates its A0, A1, A2 by name; None, or no such affordance in H: the most
    competent affordance that drives the task's property."""
    body: Body = Body.ROVER
    """The body whose runs can attempt the task."""

    @property
    def drives_actor(self) -> bool:
        """Whether the task drives the body's actor (else an object, its `target`)."""
        return self.entity != "target"


USER_PREFIX = "user:"
"""Prefix of the name of a task read from a user's file (`eval --points`)."""


def task_names() -> list[str]:
    return sorted(p.stem for p in (configs_dir() / "tasks").glob("*.toml"))


def load_task(name: str) -> Task:
    path = configs_dir() / "tasks" / f"{name}.toml"
    if not path.is_file():
        raise HadimError(f"unknown task '{name}' (known: {', '.join(task_names())})")
    return parse_task(read_toml(path, "task file"), str(path))


def load_task_file(path: Path) -> Task:
    """A user's own task, named `user:NAME` (its `name`, else the file's stem)."""
    if not Path(path).is_file():
        raise HadimError(f"task file not found: {path}")
    task = parse_task(read_toml(Path(path), "task file"), str(path))
    return dataclasses.replace(task, name=USER_PREFIX + task.name)


def fits_body(task: Task, world: WorldConfig) -> bool:
    """Whether `task` is one of `world`'s body (its scene places that body)."""
    return task.body is world.body


def body_tasks(body: Body) -> list[str]:
    """The built-in tasks of `body`, by name."""
    return [name for name in task_names() if load_task(name).body is body]


def check_body(task: Task, world: WorldConfig) -> None:
    """Refuse a task of another body than the run's."""
    if not fits_body(task, world):
        raise HadimError(f"task {task.name} is a task of the {task.body.value}; this run's "
                         f"body is the {world.body.value} (its tasks: "
                         f"{', '.join(body_tasks(world.body))})")


def check_task(task: Task, world: WorldConfig) -> None:
    """Refuse a task this run's world cannot attempt: another body's, another number of
    objects, or a target point where the entity cannot be (outside the walls, or inside a
    fixed object)."""
    check_body(task, world)
    if isinstance(task.scene, ArmScene):
        _check_joints(task, task.scene, world)
    n_objects = world.n_green + world.n_red
    if len(task.scene.objects) != n_objects:
        raise HadimError(f"task {task.name} has {len(task.scene.objects)} objects in its scene; "
                         f"this run's world has {n_objects} (list them all, or write "
                         f"scene = \"push-object\" to use a built-in task's scene)")
    radius = _driven_radius(task, world, n_objects)
    for x, y in task.points:
        _check_walls(task, x, y, radius, world)
        if world.body is Body.ARM:
            _check_reach(task, x, y, radius, world)
        for i, obj in enumerate(task.scene.objects):
            if not obj.pushable and math.hypot(x - obj.x, y - obj.y) < radius + obj.radius:
                raise HadimError(f"task {task.name}: target point ({x:g}, {y:g}) is inside "
                                 f"the fixed object obj{i + 1} at ({obj.x:g}, {obj.y:g})")


def check_inside(task: Task, world: WorldConfig) -> None:
    """Refuse a target point outside `world`'s walls for the entity the task drives (a world
    holding only the task's own objects, as a baseline's does)."""
    radius = _driven_radius(task, world, len(task.scene.objects))
    for x, y in task.points:
        _check_walls(task, x, y, radius, world)


def _driven_radius(task: Task, world: WorldConfig, n_objects: int) -> float:
    """The radius of the entity the task drives (its target and tool named in the scene)."""
    if task.drives_actor:
        return world.arm.effector_radius if world.body is Body.ARM else world.robot_radius
    index = _object_index(task.target, n_objects, task)
    _object_index(task.tool, n_objects, task)
    return task.scene.objects[index].radius


def _check_walls(task: Task, x: float, y: float, radius: float, world: WorldConfig) -> None:
    arm = world.body is Body.ARM
    hw, hh = ((world.arm.table_width / 2, world.arm.table_height / 2) if arm
              else (world.room_width / 2, world.room_height / 2))
    if abs(x) + radius > hw or abs(y) + radius > hh:
        raise HadimError(f"task {task.name}: target point ({x:g}, {y:g}) is outside the "
                         f"{2 * hw:g} x {2 * hh:g} m {'table' if arm else 'room'} for a "
                         f"{task.entity} of radius {radius:g} (points must lie within "
                         f"±{hw - radius:g}, ±{hh - radius:g})")


def _check_joints(task: Task, scene: ArmScene, world: WorldConfig) -> None:
    n = len(world.arm.link_lengths)
    if len(scene.joints) != n:
        raise HadimError(f"task {task.name} places {len(scene.joints)} joints in its scene; "
                         f"this run's arm has {n} (world.arm.link_lengths)")
    for i, (q, limit) in enumerate(zip(scene.joints, joint_ranges(world.arm.joint_limits),
                                       strict=True)):
        if not abs(q) <= limit:
            raise HadimError(f"task {task.name} turns joint {i + 1} to {q:g} rad in its "
                             f"scene, beyond this run's limit ±{limit:g}")


def _check_reach(task: Task, x: float, y: float, radius: float, world: WorldConfig) -> None:
    """Refuse a point the arm cannot bring its entity to: for the effector, outside the
    annulus its centre reaches; for an object, inside the base or beyond the effector's
    farthest push (its reach plus both radii)."""
    arm = world.arm
    near, far = inner_reach(arm.link_lengths, arm.joint_limits), outer_reach(arm.link_lengths)
    if not task.drives_actor:
        near, far = arm.base_radius + radius, far + arm.effector_radius + radius
    distance = math.hypot(x, y)
    if not near <= distance <= far:
        raise HadimError(f"task {task.name}: target point ({x:g}, {y:g}) is {distance:.3g} m "
                         f"from the arm's base; the arm brings its {task.entity} only "
                         f"{near:.3g}-{far:.3g} m from it")


def _object_index(name: str | None, n_objects: int, task: Task) -> int:
    known = [f"obj{i + 1}" for i in range(n_objects)]
    if name is not None and name not in known:
        raise HadimError(f"task {task.name}: no object '{name}' in its scene "
                         f"(obj1 … obj{n_objects})")
    return -1 if name is None else known.index(name)


def _need(values: Mapping[str, Any], key: str, where: str) -> Any:
    if key not in values:
        raise HadimError(f"task file {where}: missing key '{key}'")
    return values[key]


def _number(value: Any, key: str, where: str) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
        raise HadimError(f"task file {where}: '{key}' must be a finite number, got {value!r}")
    return float(value)


def _pair(value: Any, key: str, where: str) -> tuple[float, float]:
    if not isinstance(value, list | tuple) or len(value) != 2:
        raise HadimError(f"task file {where}: '{key}' must be a pair [x, y], got {value!r}")
    return (_number(value[0], key, where), _number(value[1], key, where))


def _object(raw: Mapping[str, Any], where: str) -> ObjectSpec:
    color = _need(raw, "color", where)
    if not isinstance(color, list) or len(color) != 3:
        raise HadimError(f"task file {where}: object color must be [r, g, b]")
    radius = _number(_need(raw, "radius", where), "radius", where)
    height = _number(_need(raw, "height", where), "height", where)
    if radius <= 0 or height <= 0:
        raise HadimError(f"task file {where}: object radius and height must be > 0")
    return ObjectSpec(
        x=_number(_need(raw, "x", where), "x", where),
        y=_number(_need(raw, "y", where), "y", where),
        radius=radius, height=height,
        color=tuple(_number(c, "color", where) for c in color),  # type: ignore[arg-type]
        pushable=bool(_need(raw, "pushable", where)), shape=Shape.CYLINDER,
    )


def parse_task(values: Mapping[str, Any], where: str) -> Task:
    known = {"name", "description", "body", "entity", "property", "points", "budget", "scene",
             "target", "tool", "affordance_input"}
    unknown = sorted(set(values) - known)
    if unknown:
        raise HadimError(f"task file {where}: unknown key '{unknown[0]}' "
                         f"(allowed: {', '.join(sorted(known))})")
    body = _body(values.get("body", Body.ROVER.value), where)
    actor = actor_of(body)
    entity = _need(values, "entity", where)
    if entity not in (actor, "target"):
        raise HadimError(f"task file {where}: entity must be '{actor}' (the {body.value}'s "
                         f"actor) or 'target', got {entity!r}")
    prop = _need(values, "property", where)
    if prop not in ("position", "pose") or (prop == "pose" and entity != ROBOT):
        raise HadimError(f"task file {where}: property must be 'position', or 'pose' for the "
                         f"robot (the rover's), got {prop!r}")
    raw_points = _need(values, "points", where)
    if not isinstance(raw_points, list):
        raise HadimError(f"task file {where}: 'points' must be a list")
    headings = None
    if prop == "pose":
        for p in raw_points:
            if not isinstance(p, list | tuple) or len(p) != 3:
                raise HadimError(f"task file {where}: a pose point is [x, y, heading in "
                                 f"degrees], got {p!r}")
        headings = tuple(math.radians(_number(p[2], "points", where)) for p in raw_points)
        raw_points = [p[:2] for p in raw_points]
    points = tuple(_pair(p, "points", where) for p in raw_points)
    if not points:
        raise HadimError(f"task file {where}: 'points' is empty")
    budget = _need(values, "budget", where)
    if isinstance(budget, bool) or not isinstance(budget, int) or budget < 1:
        raise HadimError(f"task file {where}: 'budget' must be an integer >= 1")
    scene = _scene(_need(values, "scene", where), body, where)
    target, tool = values.get("target"), values.get("tool")
    if entity == "target" and not target:
        raise HadimError(f"task file {where}: entity 'target' needs target = \"objN\"")
    return Task(str(values.get("name", Path(where).stem)), str(values.get("description", "")),
                entity, prop, points, budget, scene, target, tool, headings,
                _affordance_input(values.get("affordance_input"), where), body)


def _body(value: Any, where: str) -> Body:
    try:
        return Body(value)
    except ValueError:
        raise HadimError(f"task file {where}: body must be one of "
                         f"{', '.join(repr(b.value) for b in Body)}, got {value!r}") from None


def _scene(raw: Any, body: Body, where: str) -> Scene | ArmScene:
    """A `[scene]` table, or the name of a built-in task (of the same body) whose scene to
    use. The rover's places the robot (`robot = [x, y, heading]`), the arm's its joints
    (`joints = [q1, …]`, rad, base outwards)."""
    if isinstance(raw, str):
        if raw not in task_names():
            raise HadimError(f"task file {where}: scene = {raw!r} names no built-in task "
                             f"(known: {', '.join(task_names())})")
        other = load_task(raw)
        if other.body is not body:
            raise HadimError(f"task file {where}: scene = {raw!r} is a scene of the "
                             f"{other.body.value}; this task's body is the {body.value}")
        return other.scene
    if not isinstance(raw, Mapping):
        raise HadimError(f"task file {where}: 'scene' must be a table or a built-in task's name")
    foreign = "robot" if body is Body.ARM else "joints"
    if foreign in raw:
        raise HadimError(f"task file {where}: scene.{foreign} places another body than the "
                         f"{body.value} (body = {body.value!r})")
    objects = tuple(_object(o, where) for o in raw.get("objects", []))
    if body is Body.ARM:
        joints = _need(raw, "joints", where)
        if not isinstance(joints, list) or not joints:
            raise HadimError(f"task file {where}: scene.joints must be a list of joint "
                             "angles (rad), base outwards")
        return ArmScene(objects, tuple(_number(q, "scene.joints", where) for q in joints))
    robot = raw.get("robot", [0.0, 0.0, 0.0])
    if not isinstance(robot, list) or len(robot) != 3:
        raise HadimError(f"task file {where}: scene.robot must be [x, y, heading]")
    return Scene(objects, *(_number(v, "scene.robot", where) for v in robot))


def _affordance_input(value: Any, where: str) -> str | None:
    from hadim_cli.learner.spaces import parse_space

    if value is None:
        return None
    try:
        return parse_space(str(value)).name
    except (ValueError, KeyError):
        raise HadimError(f"task file {where}: 'affordance_input' must name a space such as "
                         f"'action', 'robot.position' or 'tool.position', got {value!r}") from None
