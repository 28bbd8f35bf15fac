"""`learner.open_contexts`: Algorithm 2 may pick any observed space of the bound objects as a
context (the paper's Algorithm 2); off, the fixed list. `learner.open_outputs`: the LIDAR may be an
affordance's output (item 2)."""

from __future__ import annotations

import numpy as np
from handmade import ROBOT_LIDAR, ROBOT_POSITION, TARGET_POSITION, TARGET_ROBOT, Room

from hadim_cli.learner.spaces import Property, Role, RoleSpace, actor_contexts, context_candidates

TOOL_TARGET = frozenset({Role.TARGET, Role.TOOL})
ROVER = actor_contexts(Room().layout)


def names(spaces) -> set[str]:
    return {s.name for s in spaces}


def test_open_candidates_hold_every_observed_space_of_the_bound_objects():
    closed = names(context_candidates(TOOL_TARGET, ROVER))
    opened = names(context_candidates(TOOL_TARGET, ROVER, open_all=True))
    assert closed < opened
    for role in ("target", "tool"):
        for prop in ("position", "radius", "height", "color", "shape"):
            assert f"{role}.{prop}" in opened
        assert f"{role}-robot" in opened
        assert f"{role}.color" not in closed and f"{role}.position" not in closed
    assert "target-tool" in opened
    # Only the roles an affordance binds, and never the robot's constant properties.
    robot_only = names(context_candidates(frozenset({Role.ROBOT}), ROVER, open_all=True))
    assert robot_only == {"robot.heading", "robot.lidar", "robot.position"}


def test_the_context_search_tries_the_open_spaces_when_asked():
    colour = RoleSpace(Role.TARGET, Property.COLOR)
    for on in (False, True):
        room = Room(open_contexts=on)
        push = room.affordance(room.moves(np.random.default_rng(0), 10),
                               (TARGET_ROBOT,), inp=ROBOT_POSITION, out=TARGET_POSITION)
        tried = {c for _, contexts, _ in room.adaptation._context_options(push) for c in contexts}
        assert (colour in tried) == on


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
