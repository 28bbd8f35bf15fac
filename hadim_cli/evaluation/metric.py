"""The evaluation metric of the paper (§5.1), as pure functions, and the second measure of
the RL comparison (§5.3): how many points end inside the goal zone.

Two measures of one policy on one task (issue 46):
- the budgeted score: 1 − mean(min(1, final / initial distance)) within the task's budget
  (40 / 60 / 80 actions), stored under the task's name;
- episode success: the share of the task's points whose driven entity ends inside the goal
  zone (`GOAL_ZONE`) within an episode's length (`EPISODE_ACTIONS`), the measure the paper's
  RL claims read as; stored as the evaluation of the task with that budget, under
  `measure_name(task, EPISODE_ACTIONS)` ("push-object@1000").

Any evaluation with a budget other than the task's own is stored under `TASK@BUDGET`, so a
task's curve never mixes budgets.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

GOAL_ZONE = 0.1
"""Radius (m) of the goal zone: the RL baselines' episodes end there (`baselines.tasks`), and a
point counts as reached, for every algorithm and for the learner, when its entity ends within
it."""
EPISODE_ACTIONS = 1000
"""The paper's episode length: the budget of the episode-success measure."""
MAX_BUDGET = 10_000
"""The largest budget `hadim eval --budget` accepts (ten episodes' worth)."""
BUDGET_MARK = "@"


def distance_error(initial: float, final: float) -> float:
    """min(1, final / initial distance to a goal): the one goal score (a goal attempt's
    competence is 1 − this). A goal already reached at the start: 0 if still there, else 1."""
    if initial <= 1e-9:
        return 0.0 if final <= 1e-9 else 1.0
    return min(1.0, final / initial)


def point_error(start: Sequence[float], final: Sequence[float], target: Sequence[float]) -> float:
    """min(1, final distance / initial distance): 0 reached, 1 no progress (or worse)."""
    return distance_error(float(np.linalg.norm(np.subtract(target, start))),
                          float(np.linalg.norm(np.subtract(target, final))))


def remaining_share(position: Sequence[float], start: Sequence[float],
                    target: Sequence[float]) -> float:
    """The distance from `position` to `target` as a share of that from `start`: the point's
    error so far, unclipped (an object pushed away reads more than 1)."""
    initial = float(np.linalg.norm(np.subtract(target, start)))
    return float(np.linalg.norm(np.subtract(target, position))) / max(initial, 1e-12)


def task_score(errors: Sequence[float]) -> float:
    """1 − mean(error_i): doing nothing scores 0, reaching every point scores 1."""
    if len(errors) == 0:
        raise ValueError("a task needs at least one point")
    return 1.0 - float(np.mean(errors))


def heading_error(start: float, final: float, target: float) -> float:
    """min(1, final angle to the target heading / initial one), angles in radians."""
    def gap(a: float) -> float:
        return abs((target - a + np.pi) % (2 * np.pi) - np.pi)
    initial, final_gap = gap(start), gap(final)
    if initial <= 1e-6:
        return 0.0 if final_gap <= 0.05 else min(1.0, final_gap / 0.05)
    return min(1.0, final_gap / initial)


def measure_name(task: str, budget: int | None) -> str:
    """The name an evaluation of `task` with another `budget` is stored under (`task@N`);
    the task's own name when `budget` is None."""
    return task if budget is None else f"{task}{BUDGET_MARK}{budget}"


def split_measure(name: str) -> tuple[str, int | None]:
    """(task, budget) of a stored evaluation's name: `push-object@1000` → ("push-object",
    1000); a plain task name → (name, None)."""
    task, mark, budget = name.rpartition(BUDGET_MARK)
    if mark and budget.isdigit():
        return task, int(budget)
    return name, None


def check_budget(budget: int) -> int:
    """`budget` if it is one `hadim eval --budget` accepts; ValueError saying why not."""
    if budget < 1:
        raise ValueError(f"--budget must be at least 1 action, got {budget}")
    if budget > MAX_BUDGET:
        raise ValueError(f"--budget must be at most {MAX_BUDGET} actions (ten episodes), "
                         f"got {budget}")
    return budget


def in_zone(point: Mapping[str, Any], radius: float = GOAL_ZONE) -> bool:
    """Whether a stored point (`PointResult` as a dict) ended inside the goal zone, with no
    forbidden contact."""
    return (not point.get("contact_failed", False)
            and math.dist(point["final"], point["target"]) <= radius)


def zone_count(points: Sequence[Mapping[str, Any]], radius: float = GOAL_ZONE) -> int:
    """How many points ended inside the goal zone."""
    return sum(in_zone(p, radius) for p in points)


def zone_share(points: Sequence[Mapping[str, Any]], radius: float = GOAL_ZONE) -> float:
    """Share of points that ended inside the goal zone (0 for no points)."""
    return zone_count(points, radius) / len(points) if points else 0.0
