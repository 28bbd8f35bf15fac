"""The rewards of the paper's comparison (§5.3, its table), as vectorised pure functions.

Every function takes arrays whose last axis is (x, y), with any leading batch shape, so one
transition and a batch of relabelled ones go through the same code.

- sparse ("non-guided"): +1000 when the goal entity is inside the goal zone, −5 otherwise;
- guided: +1000 in the goal zone; otherwise up to +20 for moving or pushing in the right
  direction, −5 when nothing moved the right way. "Right direction" is read along the task's
  chain (robot → tool → target → goal): the goal entity's progress towards the goal if it
  moved; else the progress of the entity before it in the chain towards the one it must push
  (the robot towards the target on `push-object`, the tool towards the target, or else the
  robot towards the tool, on `push-with-tool`). The bonus is 20 · progress / STEP, capped at
  20, STEP being the robot's largest displacement in one action (0.15 m).

Like the paper's table, the guided reward is not potential-based: going back and forth in
front of an object earns +20 − 5 per pair of actions. It is reproduced as the paper states it.
"""

from __future__ import annotations

import enum
import math

import numpy as np

GOAL_REWARD = 1000.0
STEP_PENALTY = -5.0
GUIDE_MAX = 20.0
STEP = 0.15
"""The robot's largest displacement in one action (m): 0.3 m/s for 0.5 s."""
MOVED = 1e-3
"""An entity moved when it was displaced by more than this (m)."""


class Reward(enum.StrEnum):
    SPARSE = "sparse"
    GUIDED = "guided"


def distance(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Euclidean distance over the last axis, as sqrt(dx² + dy²) in float64: the same
    operations as `distance_1`, so one transition and a batch give identical rewards."""
    d = np.asarray(a, dtype=np.float64) - np.asarray(b, dtype=np.float64)
    return np.sqrt(d[..., 0] * d[..., 0] + d[..., 1] * d[..., 1])


def distance_1(ax: float, ay: float, bx: float, by: float) -> float:
    dx, dy = ax - bx, ay - by
    return math.sqrt(dx * dx + dy * dy)


def reached(achieved: np.ndarray, desired: np.ndarray, radius: float) -> np.ndarray:
    """True where the achieved goal lies inside the goal zone (distance ≤ radius)."""
    return distance(achieved, desired) <= radius


def sparse_reward(achieved: np.ndarray, desired: np.ndarray, radius: float) -> np.ndarray:
    return np.where(reached(achieved, desired, radius), GOAL_REWARD, STEP_PENALTY)


def progress(before: np.ndarray, after: np.ndarray, towards: np.ndarray) -> np.ndarray:
    """How much closer (m) `after` is to `towards` than `before` was."""
    return distance(before, towards) - distance(after, towards)


def guide_bonus(chain_before: np.ndarray, chain_after: np.ndarray,
                desired: np.ndarray) -> np.ndarray:
    """The guided part (0 … 20) for chains of positions, shape (..., n, 2): entity 0 is the
    robot, the last the goal entity; each entity is to be pushed by the one before it."""
    before = np.asarray(chain_before, dtype=float)
    after = np.asarray(chain_after, dtype=float)
    n = before.shape[-2]
    gain = progress(before[..., -1, :], after[..., -1, :], np.asarray(desired, dtype=float))
    decided = distance(after[..., -1, :], before[..., -1, :]) > MOVED
    for i in range(n - 2, -1, -1):  # back along the chain: who moved first, the right way
        moved = distance(after[..., i, :], before[..., i, :]) > MOVED
        here = progress(before[..., i, :], after[..., i, :], after[..., i + 1, :])
        take = ~decided & moved
        gain = np.where(take, here, gain)
        decided = decided | take
    return np.where(decided, GUIDE_MAX * np.clip(gain / STEP, 0.0, 1.0), 0.0)


def guided_reward(chain_before: np.ndarray, chain_after: np.ndarray, desired: np.ndarray,
                  radius: float) -> np.ndarray:
    after = np.asarray(chain_after, dtype=float)
    at_goal = reached(after[..., -1, :], desired, radius)
    bonus = guide_bonus(chain_before, chain_after, desired)
    return np.where(at_goal, GOAL_REWARD, np.where(bonus > 0, bonus, STEP_PENALTY))


def reward_1(kind: Reward, chain_before: list[list[float]], chain_after: list[list[float]],
             desired: tuple[float, float], radius: float) -> float:
    """The reward of one transition with Python floats: the step loop's fast path, equal to
    the vectorised functions above (same operations; a test checks it on random batches)."""
    gx, gy = desired
    ax, ay = chain_after[-1]
    if distance_1(ax, ay, gx, gy) <= radius:
        return GOAL_REWARD
    if kind is Reward.SPARSE:
        return STEP_PENALTY
    bx, by = chain_before[-1]
    gain: float | None = None
    if distance_1(ax, ay, bx, by) > MOVED:
        gain = distance_1(bx, by, gx, gy) - distance_1(ax, ay, gx, gy)
    else:
        for i in range(len(chain_after) - 2, -1, -1):
            (px, py), (qx, qy) = chain_before[i], chain_after[i]
            if distance_1(qx, qy, px, py) > MOVED:
                tx, ty = chain_after[i + 1]
                gain = distance_1(px, py, tx, ty) - distance_1(qx, qy, tx, ty)
                break
    bonus = 0.0 if gain is None else GUIDE_MAX * min(max(gain / STEP, 0.0), 1.0)
    return bonus if bonus > 0 else STEP_PENALTY
