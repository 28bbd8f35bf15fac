"""Run a task against a learner's current H without changing the learner.

Each point starts from the task's scene in a world of its own. The controller draws no random
numbers and evaluation never writes to D, H or any generator of the learner.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, field

import numpy as np

from hadim_cli.config import WorldConfig
from hadim_cli.errors import HadimError
from hadim_cli.evaluation.metric import (
    heading_error,
    point_error,
    remaining_share,
    task_score,
    zone_count,
)
from hadim_cli.evaluation.tasks import Task, check_task
from hadim_cli.learner.affordance import Affordance
from hadim_cli.learner.controller import Controller, Decision
from hadim_cli.learner.explorer import Learner
from hadim_cli.learner.goals import Binding
from hadim_cli.learner.spaces import ROBOT_HEADING, Property, Role, RoleSpace
from hadim_cli.world.environment import Environment, make_world
from hadim_cli.world.layout import ObservationLayout


@dataclass(frozen=True)
class FirstPush:
    """Angles (degrees, 0-180) of the first action that moved the driven object: how far its
    pusher stood off the line of the object's way to the point, and where the object went.
    A pushed disc moves with its pusher only within a narrow cone (docs/algorithm.md): a
    first push outside it sends the object off its way, and a trip must correct it."""

    pusher_off: float
    """The pusher→object line (the tool's with a tool, else the robot's) off the object's
    way to the point, before the action."""
    move_off: float
    """The object's move off that way."""
    robot_off: float | None = None
    """With a tool: the robot→tool line off the tool→object line (the chain's bend)."""


@dataclass(frozen=True)
class PointResult:
    target: tuple[float, float]
    start: tuple[float, float]
    final: tuple[float, float]
    error: float
    actions: int
    affordance_id: int
    contact_failed: bool = False
    robot_path: float = 0.0
    """Distance (m) the robot drove during the point's attempt."""
    trips: int = 0
    """Trips the controller took to a place: stretches of actions serving a lower level's
    mover on its way to the place its affordance acts from (behind an object, a tool behind
    the target: `Decision.label` "place …")."""
    line_deviation: float = 0.0
    """Largest distance (m) of the driven entity from the straight line start → point: how
    far off the line it was pushed (or drove)."""
    robot_only: int | None = None
    """Actions that moved no object by `MOVED` (the robot driving, turning or blocked): the
    budget spent on getting somewhere rather than on pushing (None: not counted)."""
    trip_starts: tuple[float, ...] = ()
    """For each trip, the driven entity's distance to the point when the trip began, as a
    share of its distance at the start: 1.0 for a trip before it moved (getting behind an
    object, staging a tool), small shares for corrections near the end."""
    first_push: FirstPush | None = None
    """How the first action that moved the driven object was lined up (push tasks)."""
    pursuits: dict[str, int] = field(default_factory=dict)
    """Actions by what the controller served when it chose them (`Decision.label`: the
    lowest level whose mover was off its place, e.g. `place robot for A3`, else the goal's
    own affordance, `A6 target.position`), most actions first. Where the budget went, level
    by level."""
    driven_moves: int = 0
    """Actions that moved the driven entity (the task's object, or the robot) by `MOVED`."""
    driven_path: float = 0.0
    """How far (m) the driven entity moved, summed over those actions: per action that moved
    it, the length of a push. With the same trips, longer pushes leave a larger share of the
    actions moving no object (`robot_only`)."""
    robot_only_after: int = 0
    """Of `robot_only`, the actions after the driven object (a push task's) first moved: the
    corrections once it is on its way, against getting behind it (or staging a tool) before
    its first push."""


@dataclass(frozen=True)
class Step:
    """What the controller served when it chose one primitive action."""

    labels: tuple[str, ...]
    goals: tuple[tuple[float, ...], ...]


@dataclass(frozen=True)
class Recording:
    """One point's attempt, action by action: for drawing it (`evaluation.animate`)."""

    task: str
    point: tuple[float, float]
    observations: np.ndarray
    """(actions + 1, observation size): before the first action, then after each."""
    steps: tuple[Step, ...]
    entity: int
    """The entity the task drives (0: the body's actor)."""
    target: int
    tool: int
    contact_failed: bool


@dataclass(frozen=True)
class TaskResult:
    task: str
    score: float
    points: tuple[PointResult, ...]
    recordings: tuple[Recording, ...] = ()
    """Each point's attempt, when `evaluate(..., record=True)`."""
    budget: int | None = None
    """Actions allowed per point (the task's budget, or `--budget`)."""
    actor: str = "robot"
    """What the world calls the body's actor (`ObservationLayout.actor`): the rover's `robot`,
    the arm's `effector`; reports name it so."""

    @property
    def in_zone(self) -> int:
        """Points whose entity ended inside the goal zone (`metric.GOAL_ZONE`), no contact."""
        return zone_count([asdict(p) for p in self.points])

    def to_dict(self) -> dict:
        return {"task": self.task, "score": self.score, "budget": self.budget,
                "actor": self.actor,
                "in_zone": self.in_zone, "points_total": len(self.points),
                "actions": sum(p.actions for p in self.points),
                "points": [asdict(p) for p in self.points]}


MOVED = 1e-3
"""An object moved by an action when its centre moved this far (m)."""


class EvalActuator:
    """Steps the evaluation world within a budget, watching actor–target contacts (the
    robot's, the effector's)."""

    def __init__(self, world: Environment, obs: np.ndarray, budget: int, watch: str | None,
                 controller: Controller | None = None, record: bool = False):
        self.world = world
        self._obs = obs
        self.budget = budget
        self.used = 0
        self.watch = tuple(sorted((world.layout.actor, watch))) if watch else None
        self._actor = world.layout.space(world.layout.actor, Property.POSITION).slice
        self.touched = False
        self.controller = controller
        """When given, each action is counted by what `controller` served (`pursuits`,
        `trips`), and with `record` kept with the observation after it."""
        self._decision: Decision | None = None
        if controller is not None:
            controller.observer = self._decided
        self.trips = 0
        self.trip_starts: list[float] = []
        """Per trip, the driven entity's remaining share of its way when the trip began."""
        self._last_label = ""
        self.record = record
        self.pursuits: dict[str, int] = {}
        self.observations = [obs.copy()]
        self.steps: list[Step] = []
        self.path = 0.0
        self.line: tuple[slice, np.ndarray, np.ndarray] | None = None
        self.deviation = 0.0
        self._objects = world.layout.object_columns(Property.POSITION)
        self.robot_only = 0
        self.robot_only_after = 0
        self.driven_moves = 0
        self.driven_path = 0.0
        self._pushed: tuple[int, int, np.ndarray] | None = None
        self.first_push: FirstPush | None = None

    def _decided(self, decision: Decision) -> None:
        self._decision = decision

    def follow(self, entity: int, start: np.ndarray, point: np.ndarray) -> None:
        """Measure `entity`'s largest distance from the segment start → point, and the
        actions that move it and how far (`driven_moves`, `driven_path`)."""
        name = self.world.layout.entities[entity]
        self.line = (self.world.layout.space(name, Property.POSITION).slice,
                     np.asarray(start, float), np.asarray(point, float))

    def watch_push(self, target: int, tool: int, point: np.ndarray) -> None:
        """Measure how the first action that moves `target` (toward `point`, with `tool` as
        its pusher when ≥ 0) is lined up (`first_push`)."""
        self._pushed = (target, tool, np.asarray(point, float))

    @property
    def obs(self) -> np.ndarray:
        return self._obs

    @property
    def exhausted(self) -> bool:
        return self.used >= self.budget or self.touched

    def act(self, action: np.ndarray) -> np.ndarray:
        before = self._obs[self._actor]
        objects = self._obs[self._objects]
        last = self._obs
        self._obs = self.world.step(action)
        if self._pushed is not None and self.first_push is None:
            self.first_push = first_push(self.world.layout, last, self._obs, *self._pushed)
        self.used += 1
        still = bool(np.all(np.linalg.norm(self._obs[self._objects] - objects, axis=1) < MOVED))
        self.robot_only += still
        # A push task's object has moved once its first push is measured (`watch_push`).
        self.robot_only_after += still and self.first_push is not None
        self.path += float(np.linalg.norm(self._obs[self._actor] - before))
        if self.line is not None:
            where, a, b = self.line
            pos = self._obs[where]
            self.deviation = max(self.deviation, segment_distance(pos, a, b))
            moved = float(np.linalg.norm(pos - last[where]))
            if moved >= MOVED:
                self.driven_moves += 1
                self.driven_path += moved
        if self.controller is not None:
            label = "" if self._decision is None else self._decision.label
            if label.startswith("place") and not self._last_label.startswith("place"):
                self.trips += 1
                if self.line is not None:
                    where, a, b = self.line
                    self.trip_starts.append(remaining_share(last[where], a, b))
            self._last_label = label
            self.pursuits[label] = self.pursuits.get(label, 0) + 1
            if self.record:
                self.steps.append(Step((label,), ((),)))
                self.observations.append(self._obs.copy())
        if self.watch is not None and self.watch in self.world.last_contacts:
            self.touched = True
        return self._obs


def _heading(world: Environment) -> float:
    """The rover's heading (rad): only a pose task, the rover's only, reads it."""
    return world.robot_pose()[2]  # type: ignore[attr-defined]


def _turn_to(learner: Learner, heading: float, actuator: EvalActuator, budget: int) -> None:
    """Face `heading` (rad) through the most competent `action → robot.heading`."""
    turners = [a for a in learner.hierarchy.with_output(ROBOT_HEADING) if a.input.name == "action"]
    if turners and budget > 0:
        turner = max(turners, key=lambda a: a.competence)
        goal = np.array([np.cos(heading), np.sin(heading)])
        learner.controller.reach(turner, Binding(), goal, actuator, budget)


def angle_between(a: np.ndarray, b: np.ndarray) -> float:
    """Angle (degrees, 0-180) between the vectors `a` and `b` (0 when either is null)."""
    na, nb = float(np.linalg.norm(a)), float(np.linalg.norm(b))
    if na < 1e-12 or nb < 1e-12:
        return 0.0
    return float(np.degrees(np.arccos(np.clip(float(a @ b) / (na * nb), -1.0, 1.0))))


def first_push(layout: ObservationLayout, before: np.ndarray, after: np.ndarray,
               target: int, tool: int, point: np.ndarray) -> FirstPush | None:
    """`FirstPush` of the action from `before` to `after` when it moved `target` by `MOVED`
    (None otherwise): its pusher is `tool` when ≥ 0, else the robot."""
    def at(obs: np.ndarray, entity: int) -> np.ndarray:
        return layout.get(obs, layout.entities[entity], Property.POSITION)

    moved = at(after, target) - at(before, target)
    if float(np.linalg.norm(moved)) < MOVED:
        return None
    pushed = at(before, target)
    way = point - pushed
    pusher = at(before, tool if tool >= 0 else 0)
    robot_off = None
    if tool >= 0:
        robot_off = angle_between(pusher - at(before, 0), pushed - pusher)
    return FirstPush(angle_between(pushed - pusher, way), angle_between(moved, way), robot_off)


def segment_distance(p: np.ndarray, a: np.ndarray, b: np.ndarray) -> float:
    """Distance from point `p` to the segment a → b."""
    ab = b - a
    t = float(np.clip((p - a) @ ab / max(float(ab @ ab), 1e-12), 0.0, 1.0))
    return float(np.linalg.norm(p - (a + t * ab)))


def choose_affordance(learner: Learner, task: Task) -> Affordance | None:
    """The affordance of H the task evaluates: among those that drive the task's entity and
    property, the most competent with the task's `affordance_input`, else the most competent.

    A model's competence scores its predictions, not how well it controls: `action →
    target.position` predicts about as well as `robot.position → target.position` but, blind
    to the robot's heading, pushes far worse. Hence tasks name the affordance they evaluate,
    as the paper evaluates its A0, A1 and A2."""
    if task.drives_actor:
        candidates = learner.hierarchy.with_output(RoleSpace(Role.ROBOT, Property.POSITION))
    else:
        candidates = [a for a in learner.hierarchy.with_output(
            RoleSpace(Role.TARGET, Property.POSITION)) if a.has_tool == (task.tool is not None)]
    named = [a for a in candidates if a.input.name == task.affordance_input]
    return max(named or candidates, key=lambda a: a.competence, default=None)


def _entity_index(world: Environment, name: str | None, task: Task) -> int:
    if name is None:
        return -1
    try:
        return world.layout.entities.index(name)
    except ValueError:
        raise HadimError(f"task {task.name}: no entity '{name}' in its scene") from None


def evaluate(learner: Learner, world_config: WorldConfig, task: Task,
             record: bool = False) -> TaskResult:
    """Attempt every point of `task`; score = 1 − mean(min(1, final / initial distance)).
    `record`: also keep each point's observations and what the controller served."""
    check_task(task, world_config)
    world = make_world(world_config)
    aff = choose_affordance(learner, task)
    results, recordings = [], []
    for i, point in enumerate(task.points):
        obs = world.reset(scene=task.scene)
        target = _entity_index(world, task.target, task)
        tool = _entity_index(world, task.tool, task)
        entity = 0 if task.drives_actor else target
        start = learner.reader.entity_position(obs, entity).copy()
        actuator = EvalActuator(world, obs, task.budget, task.target if task.tool else None,
                                learner.controller, record)
        actuator.follow(entity, start, np.asarray(point))
        if entity > 0:
            actuator.watch_push(entity, tool, np.asarray(point))
        start_heading = _heading(world) if task.headings is not None else 0.0
        if aff is not None:
            binding = Binding(target=target, tool=tool) if aff.has_target else Binding()
            learner.controller.reach(aff, binding, np.asarray(point), actuator, task.budget)
        final = learner.reader.entity_position(actuator.obs, entity).copy()
        error = 1.0 if actuator.touched else point_error(start, final, point)
        if task.headings is not None:
            want = task.headings[i]
            _turn_to(learner, want, actuator, task.budget - actuator.used)
            error = (error + heading_error(start_heading, _heading(world), want)) / 2
        results.append(PointResult(tuple(point), tuple(map(float, start)),
                                   tuple(map(float, final)), error, actuator.used,
                                   -1 if aff is None else aff.id, actuator.touched,
                                   actuator.path, actuator.trips, actuator.deviation,
                                   actuator.robot_only, tuple(actuator.trip_starts),
                                   actuator.first_push,
                                   dict(sorted(actuator.pursuits.items(),
                                               key=lambda kv: (-kv[1], kv[0]))),
                                   actuator.driven_moves, actuator.driven_path,
                                   actuator.robot_only_after))
        if record:
            recordings.append(Recording(task.name, tuple(map(float, point)),
                                        np.stack(actuator.observations), tuple(actuator.steps),
                                        entity, target, tool, actuator.touched))
    return TaskResult(task.name, task_score([r.error for r in results]), tuple(results),
                      tuple(recordings), task.budget, world.layout.actor)
