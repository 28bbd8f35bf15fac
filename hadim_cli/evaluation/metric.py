"""The evaluation metric of the paper (§5.1), as pure functions."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np


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
