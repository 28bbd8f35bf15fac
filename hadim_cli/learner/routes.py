"""Trips of the robot planned as sequences of primitive actions (`planner.route_search`).

A trip takes the robot to a place beside an object — behind it, facing the push — often
round that object or another. One action at a time with an estimate that ignores what lies
between (`Navigator.actions_to_go`) and waypoints round the objects, a trip took about ten
actions: out to a waypoint, a turn on the spot, the next waypoint, another turn, back in to
contact (path 2.5 times the trip's displacement, turns four times its change of heading).

Here the navigator searches over *sequences* of the commands it scores (a beam search, a few
actions deep) and takes the first action of the best one; it replans after every action. The
motion of each command is the learned models' prediction from the current observation, read
in the robot's frame (where the robot's motion does not depend on where it stands or faces)
and carried along each sequence. Every object is a disc no sequence may enter (or, already
within it, get closer to the centre of); the estimate of the actions left from where a
sequence ends goes round the discs in its way along the tangents and the arc between them
(`Obstacles.leg`), so the search is not drawn into the side of the object it must go round.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

_CELL = (0.02, 0.02, 0.15)
"""Poses nearer than this (m, m, rad) count as the same in the beam (the cheaper is kept)."""


def unit(v: np.ndarray) -> np.ndarray:
    """`v` (row-wise) at unit length; null rows stay null."""
    n = np.linalg.norm(v, axis=-1, keepdims=True)
    return np.where(n > 1e-9, v / np.maximum(n, 1e-12), 0.0)


def _rotate(v: np.ndarray, angle: np.ndarray) -> np.ndarray:
    c, s = np.cos(angle)[..., None], np.sin(angle)[..., None]
    return np.concatenate([c * v[..., :1] - s * v[..., 1:], s * v[..., :1] + c * v[..., 1:]],
                          axis=-1)


def cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]


@dataclass(frozen=True)
class Obstacles:
    """Discs (centres (K, 2), radii (K,): distances between the robot's centre and theirs)
    the robot's centre stays out of."""

    centres: np.ndarray
    radii: np.ndarray

    def within(self, start: np.ndarray, to: np.ndarray, reach: float) -> Obstacles:
        """The discs that come within `reach` (m) of the segment `start` → `to`: the only
        ones a search from `start` whose sequences move at most `reach` can meet, or whose
        way on to `to` can pass."""
        way = to - start
        s = np.clip((self.centres - start) @ way / max(float(way @ way), 1e-12), 0.0, 1.0)
        gap = np.linalg.norm(start + s[:, None] * way - self.centres, axis=1)
        keep = gap < self.radii + reach
        return Obstacles(self.centres[keep], self.radii[keep])

    def holds(self, point: np.ndarray) -> bool:
        """Whether `point` lies within a disc."""
        return bool(np.any(np.linalg.norm(self.centres - point, axis=1) < self.radii))

    def refused(self, before: np.ndarray, after: np.ndarray) -> np.ndarray:
        """Mask of moves from `before` to `after` (each (M, 2)) that end within a disc closer
        to its centre than they started (moving away from within one is how a robot next to
        an object leaves it)."""
        out = np.zeros(after.shape[0], dtype=bool)
        for c, r in zip(self.centres, self.radii, strict=True):
            d = np.linalg.norm(after - c, axis=1)
            out |= (d < r) & (d < np.linalg.norm(before - c, axis=1) - 1e-4)
        return out

    def leg(self, frm: np.ndarray, to: np.ndarray, facing: np.ndarray, speed: float,
            turn: float) -> tuple[np.ndarray, np.ndarray]:
        """Estimated actions from poses (`frm`, `facing`: (M, 2) each) to the point `to`, and
        the direction they arrive in: turn to the way, drive. Where the straight way crosses
        a disc it goes along the tangent to the disc, round its arc and along the tangent
        from it (the disc whose detour costs most; a start within a disc counts as on its
        rim at the same bearing, facing along it), and the turn along the arc is charged as
        well. Either way along a direction counts (the robot drives backwards as well)."""
        way = to - frm
        dist = np.sqrt(np.einsum("ij,ij->i", way, way))
        first = way / np.maximum(dist, 1e-12)[:, None]
        arrive = np.where(dist[:, None] > 1e-6, first, facing)
        length, bend = dist.copy(), np.zeros_like(dist)
        extra = np.zeros_like(dist)
        for c, r in zip(self.centres, self.radii, strict=True):
            end = float(np.linalg.norm(to - c))
            if end <= r:
                continue  # the place itself lies within: no way round to it
            rel = frm - c
            s = np.clip(-np.einsum("ij,ij->i", rel, way) / np.maximum(dist ** 2, 1e-12),
                        0.0, 1.0)
            near = rel + s[:, None] * way
            hit = np.flatnonzero(np.einsum("ij,ij->i", near, near) < r * r)
            if not hit.size:
                continue
            rel, d = rel[hit], dist[hit]
            d0 = np.sqrt(np.einsum("ij,ij->i", rel, rel))
            u0, u1 = rel / np.maximum(d0, 1e-12)[:, None], (to - c) / end
            d0 = np.maximum(d0, r)  # within: as if on the rim at the same bearing
            side = np.where(cross(u0, u1) >= 0, 1.0, -1.0)
            apart = np.arccos(np.clip(u0 @ u1, -1.0, 1.0))
            a0, a1 = np.arccos(np.minimum(r / d0, 1.0)), np.arccos(r / end)
            arc = np.maximum(apart - a0 - a1, 0.0)
            around = np.sqrt(d0 ** 2 - r ** 2) + np.sqrt(end ** 2 - r ** 2) + r * arc
            cost = (around - d) / speed + arc / turn
            better = cost > extra[hit]
            if not better.any():
                continue
            rows = hit[better]
            u0, side, a0 = u0[better], side[better], a0[better]
            extra[rows], length[rows], bend[rows] = cost[better], around[better], arc[better]
            touch0 = c + r * _rotate(u0, side * a0)
            touch1 = c + r * _rotate(np.broadcast_to(u1, u0.shape), -side * a1)
            # From the rim (or within: on it at the same bearing), along the rim.
            on_rim = (d0[better] <= r * (1 + 1e-9))[:, None]
            first[rows] = np.where(on_rim, _rotate(u0, side * (np.pi / 2)),
                                   unit(touch0 - frm[rows]))
            arrive[rows] = unit(to - touch1)
        facing_way = np.arccos(np.minimum(np.abs(np.einsum("ij,ij->i", facing, first)), 1.0))
        facing_way = np.where(dist > 1e-6, facing_way, 0.0)
        return length / speed + (facing_way + bend) / turn, arrive


@dataclass(frozen=True)
class Motion:
    """What each command does, in the robot's frame (x ahead, y to its left)."""

    commands: np.ndarray
    """(N, 2) wheel commands."""
    shift: np.ndarray
    """(N, 2) the robot's displacement after each command."""
    half: np.ndarray
    """(N, 2) its displacement half-way through."""
    turn: np.ndarray
    """(N,) its change of heading (rad, counter-clockwise)."""


def search(position: np.ndarray, heading: np.ndarray, motion: Motion, obstacles: Obstacles,
           to_go, reached, depth: int, beam: int,
           later: np.ndarray | None = None) -> int | None:
    """The first command (its index in `motion.commands`) of the best sequence of at most
    `depth` commands from the pose (`position`, unit `heading`). The best: the shortest that
    `reached` says arrives; else the least estimated cost in actions (its length plus `to_go`
    where it ends). `to_go(positions, headings)`
    and `reached(positions, headings)` take (M, 2) arrays each. `later`: the indices of the
    commands tried after the first (all by default; the finest are for the next action,
    and the plan is made again after it). None when every first command is refused by the
    obstacles."""
    angle0 = float(np.arctan2(heading[1], heading[0]))
    pos = position[None].astype(float)
    ang = np.array([angle0])
    origin = np.zeros(1, dtype=int)  # the first command of each kept sequence
    best: tuple[float, int] | None = None
    every = np.arange(motion.commands.shape[0])
    later = every if later is None else later
    for d in range(1, depth + 1):
        tried = every if d == 1 else later
        n = tried.size
        shift, mid = motion.shift[tried], motion.half[tried]
        end = (pos[:, None, :] + _rotate(shift[None], ang[:, None])).reshape(-1, 2)
        half = (pos[:, None, :] + _rotate(mid[None], ang[:, None])).reshape(-1, 2)
        after = (ang[:, None] + motion.turn[tried][None]).reshape(-1)
        parent = np.repeat(np.arange(pos.shape[0]), n)
        first = np.tile(tried, pos.shape[0]) if d == 1 else origin[parent]
        before = pos[parent]
        ok = ~(obstacles.refused(before, half) | obstacles.refused(before, end))
        if not ok.any():
            break
        end, after, first = end[ok], after[ok], first[ok]
        facing = np.stack([np.cos(after), np.sin(after)], axis=1)
        there = reached(end, facing)
        if there.any():
            # The shortest sequence that arrives, the one ending nearest the place first.
            rest = to_go(end[there], facing[there])
            return int(first[there][int(np.argmin(rest))])
        cost = d + to_go(end, facing)
        i = int(np.argmin(cost))
        if best is None or cost[i] < best[0]:
            best = (float(cost[i]), int(first[i]))
        order = np.argsort(cost, kind="stable")
        cell = (np.floor(end[order, 0] / _CELL[0]).astype(np.int64) * 4096
                + np.floor(end[order, 1] / _CELL[1]).astype(np.int64)) * 64 \
            + np.floor(np.mod(after[order], 2 * np.pi) / _CELL[2]).astype(np.int64)
        _, keep = np.unique(cell, return_index=True)
        kept = order[np.sort(keep)[:beam]]
        pos, ang, origin = end[kept], after[kept], first[kept]
    return None if best is None else best[1]
