"""Algorithm 2 may pick any observed space of the bound objects as a context (the paper's
Algorithm 2). `learner.open_outputs`: the LIDAR may be an affordance's output."""

from __future__ import annotations

import numpy as np
from handmade import ROBOT_LIDAR, Room

from hadim_cli.learner.spaces import Property, Role, actor_contexts, context_candidates

TOOL_TARGET = frozenset({Role.TARGET, Role.TOOL})
ROVER = actor_contexts(Room().layout)


def names(spaces) -> set[str]:
    return {s.name for s in spaces}


def test_the_candidates_hold_every_observed_space_of_the_bound_objects():
    both = names(context_candidates(TOOL_TARGET, ROVER))
    for role in ("target", "tool"):
        for prop in ("position", "radius", "height", "color", "shape"):
            assert f"{role}.{prop}" in both
        assert f"{role}-robot" in both
    assert "target-tool" in both
    # Only the roles an affordance binds, and never the robot's constant properties.
    robot_only = names(context_candidates(frozenset({Role.ROBOT}), ROVER))
    assert robot_only == {"robot.heading", "robot.lidar", "robot.position"}
    target_only = names(context_candidates(frozenset({Role.TARGET}), ROVER))
    assert "tool.color" not in target_only and "target-tool" not in target_only


def test_the_lidar_is_an_output_only_when_outputs_are_open():
    for on in (False, True):
        room = Room(open_outputs=on)
        room.episode()
        t = room.moves(np.random.default_rng(0), 3)
        before = room.obs.copy()
        room.set("robot", Property.LIDAR, [0.5, 0.6, 0.7, 0.8])  # only the LIDAR changes
        room.dataset.append(np.zeros(2), before, room.obs.copy())
        spaces = room.adaptation.non_null_spaces(np.append(t, len(room.dataset) - 1))
        assert (ROBOT_LIDAR in spaces) == on
