"""Run a task against a learner's current H without changing the learner.

Each point starts from the task's scene in a world of its own. The planner draws no random
numbers and evaluation never writes to D, H or any generator of the learner.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np

from hadim_cli.config import WorldConfig
from hadim_cli.errors import HadimError
from hadim_cli.evaluation.metric import point_error, task_score
from hadim_cli.evaluation.tasks import Task
from hadim_cli.learner.affordance import Affordance
from hadim_cli.learner.explorer import Learner
from hadim_cli.learner.planner import Binding
from hadim_cli.learner.spaces import Property, Role, RoleSpace
from hadim_cli.world.world import World


@dataclass(frozen=True)
class PointResult:
    target: tuple[float, float]
    start: tuple[float, float]
    final: tuple[float, float]
    error: float
    actions: int
    affordance_id: int
    contact_failed: bool = False


@dataclass(frozen=True)
class TaskResult:
    task: str
    score: float
    points: tuple[PointResult, ...]

    def to_dict(self) -> dict:
        return {"task": self.task, "score": self.score, "points": [asdict(p) for p in self.points]}


class EvalActuator:
    """Steps the evaluation world within a budget, watching robot–target contacts."""

    def __init__(self, world: World, obs: np.ndarray, budget: int, watch: str | None):
        self.world = world
        self._obs = obs
        self.budget = budget
        self.used = 0
        self.watch = tuple(sorted(("robot", watch))) if watch else None
        self.touched = False

    @property
    def obs(self) -> np.ndarray:
        return self._obs

    @property
    def exhausted(self) -> bool:
        return self.used >= self.budget or self.touched

    def act(self, action: np.ndarray) -> np.ndarray:
        self._obs = self.world.step(action)
        self.used += 1
        if self.watch is not None and self.watch in self.world.last_contacts:
            self.touched = True
        return self._obs


def choose_affordance(learner: Learner, task: Task) -> Affordance | None:
    """The affordance of H the task evaluates: among those that drive the task's entity and
    property, the most competent with the task's `affordance_input`, else the most competent.

    A model's competence scores its predictions, not how well it controls: `action →
    target.position` predicts about as well as `robot.position → target.position` but, blind
    to the robot's heading, pushes far worse. Hence tasks name the affordance they evaluate,
    as the paper evaluates its A0, A1 and A2."""
    if task.entity == "robot":
        candidates = learner.hierarchy.with_output(RoleSpace(Role.ROBOT, Property.POSITION))
    else:
        candidates = [a for a in learner.hierarchy.with_output(
            RoleSpace(Role.TARGET, Property.POSITION)) if a.has_tool == (task.tool is not None)]
    named = [a for a in candidates if a.input.name == task.affordance_input]
    return max(named or candidates, key=lambda a: a.competence, default=None)


def _entity_index(world: World, name: str | None, task: Task) -> int:
    if name is None:
        return -1
    try:
        return world.layout.entities.index(name)
    except ValueError:
        raise HadimError(f"task {task.name}: no entity '{name}' in its scene") from None


def evaluate(learner: Learner, world_config: WorldConfig, task: Task) -> TaskResult:
    """Attempt every point of `task`; score = 1 − mean(min(1, final / initial distance))."""
    n_objects = world_config.n_green + world_config.n_red
    if len(task.scene.objects) != n_objects:
        raise HadimError(f"task {task.name} has {len(task.scene.objects)} objects in its scene; "
                         f"this run's world has {n_objects}")
    world = World(world_config)
    aff = choose_affordance(learner, task)
    results = []
    for point in task.points:
        obs = world.reset(scene=task.scene)
        target = _entity_index(world, task.target, task)
        tool = _entity_index(world, task.tool, task)
        entity = 0 if task.entity == "robot" else target
        start = learner.reader.entity_position(obs, entity).copy()
        actuator = EvalActuator(world, obs, task.budget, task.target if task.tool else None)
        if aff is not None:
            binding = Binding(target=target, tool=tool) if aff.has_target else Binding()
            learner.planner.reach(aff, binding, np.asarray(point), actuator, task.budget)
        final = learner.reader.entity_position(actuator.obs, entity).copy()
        error = 1.0 if actuator.touched else point_error(start, final, point)
        results.append(PointResult(tuple(point), tuple(map(float, start)),
                                   tuple(map(float, final)), error, actuator.used,
                                   -1 if aff is None else aff.id, actuator.touched))
    return TaskResult(task.name, task_score([r.error for r in results]), tuple(results))
