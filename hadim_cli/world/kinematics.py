"""The planar arm's forward kinematics and the annulus it reaches (numpy only).

Joint i turns link i from the direction of link i−1 (the first from the table's +x axis), so
link i points at φ_i = q_1 + … + q_i and the effector is at Σ l_i (cos φ_i, sin φ_i) from the
base, at the origin.
"""

from __future__ import annotations

import math
from functools import lru_cache

import numpy as np

_GRID_POINTS = 1_000_000
"""Joint configurations the inner reach is searched over (a regular grid)."""


def joint_points(link_lengths: tuple[float, ...], joints: np.ndarray) -> np.ndarray:
    """(n + 1, 2): the base, every joint after the shoulder, and the effector's centre."""
    phi = np.cumsum(np.asarray(joints, dtype=np.float64))
    steps = np.asarray(link_lengths)[:, None] * np.stack([np.cos(phi), np.sin(phi)], axis=1)
    return np.vstack([np.zeros((1, 2)), np.cumsum(steps, axis=0)])


def effector_position(link_lengths: tuple[float, ...], joints: np.ndarray) -> np.ndarray:
    """(x, y) of the effector's centre for the joint angles `joints` (m)."""
    return joint_points(link_lengths, joints)[-1]


def pose_angles(orientation: np.ndarray, bends: np.ndarray) -> np.ndarray:
    """Every joint's angle (rad), base outwards, from what an arm's observation holds: the
    first link's direction as (cos, sin) (`Property.ORIENTATION`) and the other joints'
    angles (`Property.JOINTS`); one pose (2,), (n − 1,) or many (M, 2), (M, n − 1)."""
    o = np.asarray(orientation, dtype=np.float64)
    return np.concatenate([np.arctan2(o[..., 1:2], o[..., 0:1]),
                           np.asarray(bends, dtype=np.float64)], axis=-1)


def joint_ranges(joint_limits: tuple[float, ...]) -> tuple[float, ...]:
    """How far each joint turns either way from straight (rad): the shoulder ±π, the others
    within their configured limits."""
    return (math.pi, *joint_limits)


def outer_reach(link_lengths: tuple[float, ...]) -> float:
    """Farthest the effector's centre gets from the base: the arm straight (m)."""
    return float(sum(link_lengths))


@lru_cache(maxsize=16)
def inner_reach(link_lengths: tuple[float, ...], joint_limits: tuple[float, ...]) -> float:
    """Nearest the effector's centre gets to the base within the joint limits (m).

    |effector| does not depend on the shoulder, so this is a minimum over the box of the other
    joints, searched on a grid that holds its corners and edges (where the minimum lies unless
    the arm can fold flat; a grid step's error is second order at an interior minimum).
    """
    k = len(joint_limits)
    per_axis = max(3, math.floor(_GRID_POINTS ** (1 / k)))
    axes = [np.linspace(-lim, lim, per_axis) for lim in joint_limits]
    grids = np.meshgrid(*axes, indexing="ij", sparse=True)
    x = np.full((1,) * k, float(link_lengths[0]))
    y = np.zeros((1,) * k)
    phi = np.zeros((1,) * k)
    for length, q in zip(link_lengths[1:], grids, strict=True):
        phi = phi + q
        x = x + length * np.cos(phi)
        y = y + length * np.sin(phi)
    return float(np.sqrt(np.min(x * x + y * y)))
