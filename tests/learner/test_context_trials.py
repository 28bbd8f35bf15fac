"""A context is tried on rows of other moments: `Fitter.trial` scores each row by a model that
has not seen the actions just before and after it (h-block leave-one-out), so a context that
only tells one moment from another (a reading constant through a pursuit) does not win over
the one the outcome depends on."""

from __future__ import annotations

import numpy as np
from handmade import ROBOT_HEADING, ROBOT_LIDAR, ROBOT_POSITION, STEP, Room

from hadim_cli.learner.spaces import ACTION
from hadim_cli.world.layout import Property


def _pursuits(room: Room, rng: np.random.Generator, runs: int, length: int) -> np.ndarray:
    """`runs` pursuits of `length` actions: each holds one command (a little noise) from one
    heading, its LIDAR reading the same throughout, and slips by an offset of its own (what no
    observation holds). Returns the iterations."""
    start = len(room.dataset)
    room.episode()
    for _ in range(runs):
        theta = rng.uniform(-np.pi, np.pi)
        lidar = rng.uniform(0.2, 1.5, 4)
        command = rng.uniform(-1.0, 1.0, 2)
        slip = rng.normal(0.0, 0.05 * STEP, 2)
        here = rng.uniform((-1.5, -1.5), (1.5, 1.0))
        for _ in range(length):
            room.place("robot", here)
            room.set("robot", Property.HEADING, [np.cos(theta), np.sin(theta)])
            room.set("robot", Property.LIDAR, lidar)
            action = np.clip(command + rng.normal(0.0, 0.02, 2), -1.0, 1.0)
            before = room.obs.copy()
            here = here + STEP * action.mean() * np.array([np.cos(theta), np.sin(theta)]) + slip
            room.place("robot", here)
            room.dataset.append(action, before, room.obs.copy())
    return np.arange(start, len(room.dataset), dtype=np.int64)


def test_a_context_that_only_tells_the_moment_loses_to_the_one_the_outcome_depends_on():
    room = Room()
    t = _pursuits(room, np.random.default_rng(6), 60, 8)
    rows = room.rows(t)

    def trial(contexts):
        return room.fitter.trial(ACTION, ROBOT_POSITION, contexts, rows,
                                 np.random.default_rng(0))

    heading, lidar = trial((ROBOT_HEADING,)), trial((ROBOT_LIDAR,))
    assert heading > lidar + 0.1, (heading, lidar)
