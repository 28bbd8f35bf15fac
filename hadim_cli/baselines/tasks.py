"""The three tasks of the comparison as goal-conditioned problems: who is in the room, where
the robot, the objects and the goals are drawn, and which entity must reach the goal.

One object at a time, as the paper (§5.3): no object on `move-robot`, the target on
`push-object`, the target and a tool on `push-with-tool`. Objects have the size and colour of
the same task's evaluation file (`configs/tasks/<task>.toml`), so evaluating on that file asks
the policy about the objects it trained with.

The arm's three (`reach`, `arm-push`, `arm-push-with-tool`, `ARM_TASKS`) are the same problems
on its table: the arm starts in any pose, the target anywhere in the annulus its effector
reaches (`draw_arm_scene`'s rule), the tool beside it, every goal where the arm can bring the
goal entity (`evaluation.tasks.check_task`'s rule).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from hadim_cli.config import Body, WorldConfig
from hadim_cli.errors import HadimError
from hadim_cli.evaluation.metric import GOAL_ZONE
from hadim_cli.evaluation.tasks import Task, load_task
from hadim_cli.world.kinematics import effector_position, inner_reach, outer_reach
from hadim_cli.world.scene import ArmScene, ObjectSpec, Scene

GOAL_RADIUS = GOAL_ZONE
"""Radius of the goal zone (m): its diameter (0.2 m) exceeds one action's largest step
(0.15 m), so driving straight through the zone cannot jump over it. The same for every
algorithm."""
ROBOT_BOX = 1.6
"""The robot starts uniformly in [-1.6, 1.6]² with a uniform heading."""
OBJECT_BOX = 1.2
"""The target starts uniformly in [-1.2, 1.2]², clear of the robot."""
GOAL_BOX = 1.5
"""Every goal lies in [-1.5, 1.5]²."""
GOAL_RING = (0.2, 0.8)
"""On the pushing tasks, goals lie 0.2–0.8 m from the target's start (the evaluation points
lie 0.35–0.68 m from it); on move-robot, uniformly in the goal box."""
TOOL_RING = (0.3, 0.5)
"""On push-with-tool, the tool starts 0.3–0.5 m (centre to centre) from the target."""
CLEARANCE = 0.05
"""Gap kept between drawn bodies (m)."""

TASKS = ("move-robot", "push-object", "push-with-tool")
ARM_TASKS = ("reach", "arm-push", "arm-push-with-tool")
"""The same three problems for the arm (`world.body = "arm"`)."""
HALF_ROOM = 2.0
"""Half the side of the room the baselines train in (m): observations and goals lie in
[-HALF_ROOM, HALF_ROOM]²."""


@dataclass(frozen=True)
class RLTask:
    """One task of the comparison."""

    name: str
    objects: tuple[ObjectSpec, ...]
    """Entity order obj1 (target), obj2 (tool); empty on move-robot."""
    robot_radius: float
    """The radius of the body's actor (the robot's, the effector's)."""
    world: WorldConfig = WorldConfig()
    """The world the task is drawn in: its body decides the scene's kind."""

    @property
    def goal_entity(self) -> int:
        """Index of the goal entity among (robot, obj1, obj2)."""
        return 0 if not self.objects else 1

    @property
    def chain(self) -> tuple[int, ...]:
        """Entities from the robot to the goal entity, each pushing the next."""
        return {0: (0,), 1: (0, 1), 2: (0, 2, 1)}[len(self.objects)]

    def forbidden_contact(self, actor: str) -> tuple[str, str] | None:
        """An actor–target contact ends a push-with-tool episode as failed (as in evaluation);
        `actor`: what the world calls its actor."""
        return tuple(sorted(("obj1", actor))) if len(self.objects) == 2 else None  # type: ignore[return-value]


def _spec(task: Task, entity: str | None) -> ObjectSpec:
    index = int(str(entity).removeprefix("obj")) - 1
    return task.scene.objects[index]


def body_tasks(world: WorldConfig) -> tuple[str, ...]:
    """The comparison's tasks of `world`'s body."""
    return ARM_TASKS if world.body is Body.ARM else TASKS


def rl_task(name: str, world: WorldConfig) -> RLTask:
    known = body_tasks(world)
    if name not in known:
        raise HadimError(f"unknown task '{name}' for the {world.body.value} "
                         f"(known: {', '.join(known)})")
    task = load_task(name)
    objects: tuple[ObjectSpec, ...] = ()
    if task.target is not None:
        objects = (_spec(task, task.target),)
        if task.tool is not None:
            objects += (_spec(task, task.tool),)
    radius = world.arm.effector_radius if world.body is Body.ARM else world.robot_radius
    return RLTask(name, objects, radius, world)


def eval_scene(task: Task, rl: RLTask) -> Scene | ArmScene:
    """The evaluation task's scene reduced to the entities this task trains with."""
    keep = [task.target, task.tool][: len(rl.objects)]
    objects = tuple(_spec(task, name) for name in keep)
    scene = task.scene
    if isinstance(scene, ArmScene):
        return ArmScene(objects, scene.joints)
    return Scene(objects, scene.robot_x, scene.robot_y, scene.robot_heading)


def _clear(x: float, y: float, r: float, placed: list[tuple[float, float, float]]) -> bool:
    return all(math.hypot(x - px, y - py) >= r + pr + CLEARANCE for px, py, pr in placed)


def draw_start(task: RLTask, rng: np.random.Generator) -> Scene | ArmScene:
    """A random start: the robot anywhere, the target clear of it, the tool near the target
    (the arm: `_draw_arm_start`)."""
    if task.world.body is Body.ARM:
        return _draw_arm_start(task, rng)
    for _ in range(1000):
        rx, ry = rng.uniform(-ROBOT_BOX, ROBOT_BOX, size=2)
        heading = float(rng.uniform(-math.pi, math.pi))
        placed = [(float(rx), float(ry), task.robot_radius)]
        objects = []
        for i, spec in enumerate(task.objects):
            if i == 0:
                x, y = rng.uniform(-OBJECT_BOX, OBJECT_BOX, size=2)
            else:
                d, a = rng.uniform(*TOOL_RING), rng.uniform(-math.pi, math.pi)
                x, y = placed[1][0] + d * math.cos(a), placed[1][1] + d * math.sin(a)
            x, y = float(x), float(y)
            limit = 2.0 - spec.radius - CLEARANCE
            if abs(x) > limit or abs(y) > limit or not _clear(x, y, spec.radius, placed):
                break
            placed.append((x, y, spec.radius))
            objects.append(ObjectSpec(x, y, spec.radius, spec.height, spec.color,
                                      spec.pushable, spec.shape))
        else:
            return Scene(tuple(objects), float(rx), float(ry), heading)
    raise HadimError(f"task {task.name}: could not draw a start scene")


def draw_goal(task: RLTask, scene: Scene | ArmScene, rng: np.random.Generator) -> np.ndarray:
    """A goal outside the goal zone of the goal entity's start, inside the goal box (the
    arm's: `_draw_arm_goal`)."""
    if isinstance(scene, ArmScene):
        return _draw_arm_goal(task, scene, rng)
    start = np.array([scene.robot_x, scene.robot_y] if not scene.objects
                     else [scene.objects[0].x, scene.objects[0].y])
    for _ in range(1000):
        if scene.objects:
            d, a = rng.uniform(*GOAL_RING), rng.uniform(-math.pi, math.pi)
            goal = start + d * np.array([math.cos(a), math.sin(a)])
        else:
            goal = rng.uniform(-GOAL_BOX, GOAL_BOX, size=2)
        if np.all(np.abs(goal) <= GOAL_BOX) and np.linalg.norm(goal - start) > 2 * GOAL_RADIUS:
            return goal
    raise HadimError(f"task {task.name}: could not draw a goal")


def _annulus(task: RLTask) -> tuple[float, float]:
    """The nearest and farthest the effector's centre gets from the base (m)."""
    arm = task.world.arm
    return inner_reach(arm.link_lengths, arm.joint_limits), outer_reach(arm.link_lengths)


def _in_annulus(rng: np.random.Generator, near: float, far: float) -> tuple[float, float]:
    """A point uniform by area in the annulus near-far round the base."""
    d = math.sqrt(rng.uniform(near * near, far * far))
    a = rng.uniform(-math.pi, math.pi)
    return d * math.cos(a), d * math.sin(a)


def _draw_arm_start(task: RLTask, rng: np.random.Generator) -> ArmScene:
    """The arm in any pose (as `draw_arm_scene`), the target in the annulus its effector
    reaches, clear of the effector and the base, the tool 0.3-0.5 m from the target."""
    arm = task.world.arm
    near, far = _annulus(task)
    for _ in range(1000):
        joints = (float(rng.uniform(-math.pi, math.pi)),
                  *(float(rng.uniform(-lim, lim)) for lim in arm.joint_limits))
        ex, ey = effector_position(arm.link_lengths, np.array(joints)).tolist()
        placed = [(ex, ey, task.robot_radius), (0.0, 0.0, arm.base_radius)]
        objects = []
        for i, spec in enumerate(task.objects):
            if i == 0:
                x, y = _in_annulus(rng, near, far)
            else:
                d, a = rng.uniform(*TOOL_RING), rng.uniform(-math.pi, math.pi)
                x, y = objects[0].x + d * math.cos(a), objects[0].y + d * math.sin(a)
            if math.hypot(x, y) > far or not _clear(x, y, spec.radius, placed):
                break
            placed.append((x, y, spec.radius))
            objects.append(ObjectSpec(x, y, spec.radius, spec.height, spec.color,
                                      spec.pushable, spec.shape))
        else:
            return ArmScene(tuple(objects), joints)
    raise HadimError(f"task {task.name}: could not draw a start scene")


def _draw_arm_goal(task: RLTask, scene: ArmScene, rng: np.random.Generator) -> np.ndarray:
    """A goal outside the goal zone of the goal entity's start, where the arm brings it: in
    the effector's annulus (reach), 0.2-0.8 m from the target and within the effector's
    push of it (the pushing tasks)."""
    arm = task.world.arm
    near, far = _annulus(task)
    if scene.objects:
        start = np.array([scene.objects[0].x, scene.objects[0].y])
        r = scene.objects[0].radius
        near, far = arm.base_radius + r + CLEARANCE, far + arm.effector_radius + r
    else:
        start = effector_position(arm.link_lengths, np.array(scene.joints))
    for _ in range(1000):
        if scene.objects:
            d, a = rng.uniform(*GOAL_RING), rng.uniform(-math.pi, math.pi)
            goal = start + d * np.array([math.cos(a), math.sin(a)])
        else:
            goal = np.array(_in_annulus(rng, near, far))
        if near <= np.linalg.norm(goal) <= far and np.linalg.norm(goal - start) > 2 * GOAL_RADIUS:
            return goal
    raise HadimError(f"task {task.name}: could not draw a goal")
