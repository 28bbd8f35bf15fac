"""`places.needed_context` on hand-written pushes: the place an affordance acts from is the
relation its rows nearest the wanted outcome were seen in, and the input they moved by; an
affordance of the primitive action has no input to give; the relation a level of
`Controller.chain` acts from."""

from __future__ import annotations

import numpy as np
import pytest
from handmade import ROBOT_HEADING, ROBOT_LIDAR, ROBOT_POSITION, TARGET_POSITION, TARGET_ROBOT, Room

from hadim_cli.learner.goals import Binding
from hadim_cli.learner.places import context_slices, needed_context
from hadim_cli.learner.spaces import Rows

WANTED = np.array([0.05, 0.0])
LIDAR = [1.0, 1.0, 1.0, 1.0]


def _pushes(room: Room, pushes) -> tuple[np.ndarray, np.ndarray]:
    """Rows of obj1 pushed along +x by the robot from `gap` behind its centre, by `move`,
    for each (gap, move); returns their iterations and observations before."""
    room.episode()
    t, before = [], []
    for gap, move in pushes:
        room.place("obj1", [0.0, 0.0])
        room.place("robot", [-gap, 0.0])
        before.append(room.obs.copy())
        room.place("robot", [move - gap, 0.0])
        room.place("obj1", [move, 0.0])
        t.append(room.dataset.append(np.zeros(2), before[-1], room.obs.copy()))
    return np.array(t, dtype=np.int64), np.array(before)


@pytest.mark.parametrize("contexts", [(TARGET_ROBOT,), (TARGET_ROBOT, ROBOT_LIDAR)],
                         ids=["mirrored", "with-a-context-that-has-no-mirror-image"])
def test_the_place_is_the_relation_the_k_rows_nearest_the_wanted_outcome_were_seen_in(contexts):
    """Forty pushes along +x by 0.05 ± 0.002·j, j = 1…20; the four nearest the wanted
    0.05 (j ≤ 2) from one gap, the next two (j = 3) from a gap 2 cm further, the rest from
    far off. With k = 4 the place is the four's relation exactly, and the input their move
    — whether the rows are also seen in a mirror (relations only) or not (a LIDAR context):
    one row more would move it."""
    room = Room()
    room.set("robot", ROBOT_LIDAR.prop, LIDAR)
    pushes = [(0.30 if j <= 2 else 0.32 if j == 3 else (0.2 if j % 2 else 0.5),
               WANTED[0] + sign * 0.002 * j) for j in range(1, 21) for sign in (1, -1)]
    t, before = _pushes(room, pushes)
    rows = Rows(t, np.full(t.size, 1, dtype=np.int64), np.full(t.size, -1, dtype=np.int64))
    push = room.fitter.new_affordance(room.hierarchy.allocate_id(), ROBOT_POSITION,
                                      TARGET_POSITION, contexts, rows, len(room.dataset),
                                      np.random.default_rng(0))
    seen = room.learner.reader.read_each((TARGET_ROBOT,), before, 1, -1)
    nearest = seen[:4]  # j = 1, 2, both signs
    assert np.ptp(nearest, axis=0) == pytest.approx([0.0, 0.0])
    c = np.concatenate([[0.25, 0.1], LIDAR[:4 * (len(contexts) - 1)]])
    driven = np.array([True] + [False] * (len(contexts) - 1))
    need, x = needed_context(push, WANTED, c, driven, zero_eps=1e-4, k=4, support=0.1,
                             agreement=0.4)
    assert need[:2] == pytest.approx(nearest[0], abs=1e-9)
    assert np.array_equal(need[2:], c[2:])  # the contexts not driven are kept
    assert x == pytest.approx(WANTED, abs=1e-9)


def test_an_affordance_of_the_primitive_action_gives_a_place_but_no_input():
    room = Room()
    t = room.moves(np.random.default_rng(1), 60)
    drive = room.affordance(t, contexts=(ROBOT_HEADING,))
    need, x = needed_context(drive, WANTED, np.array([1.0, 0.0]), np.array([True]),
                             zero_eps=1e-4, k=8, support=0.1, agreement=0.4)
    assert x is None
    assert need.shape == (2,) and np.all(np.isfinite(need))


def test_the_place_is_read_off_rows_seen_in_the_current_fixed_contexts():
    """Four pushes by exactly the wanted 0.05 seen with a LIDAR 5 mm off the current one,
    four by 0.06 seen with the current LIDAR, the rest far in both: the first four are the
    nearest (their outcome is, and their LIDAR nearly is), and give the place — unless
    the current LIDAR is far from theirs."""
    room = Room()
    rng = np.random.default_rng(4)
    groups = [(0.30, 0.05, 0.105), (0.36, 0.06, 0.1)]
    pushes, lidars = [], []
    for gap, move, lidar in groups:
        for d in (-0.0005, -0.0002, 0.0002, 0.0005):
            pushes.append((gap, move + d))
            lidars.append(lidar)
    for i in range(32):
        pushes.append((0.2 if i % 2 else 0.5, rng.uniform(0.01, 0.03) if i % 4 < 2
                       else rng.uniform(0.08, 0.1)))
        lidars.append(rng.uniform(0.03, 0.06) if i % 3 else rng.uniform(0.15, 0.16))
    room.episode()
    t, before = [], []
    for (gap, move), lidar in zip(pushes, lidars, strict=True):
        room.set("robot", ROBOT_LIDAR.prop, [lidar] * 4)
        ti, bi = _pushes(room, [(gap, move)])
        t.append(ti[0])
        before.append(bi[0])
    t, before = np.array(t), np.array(before)
    rows = Rows(t, np.full(t.size, 1, dtype=np.int64), np.full(t.size, -1, dtype=np.int64))
    push = room.fitter.new_affordance(room.hierarchy.allocate_id(), ROBOT_POSITION,
                                      TARGET_POSITION, (TARGET_ROBOT, ROBOT_LIDAR), rows,
                                      len(room.dataset), np.random.default_rng(0))
    seen = room.learner.reader.read_each((TARGET_ROBOT,), before, 1, -1)
    c = np.array([0.25, 0.1, 0.1, 0.1, 0.1, 0.1])
    need, _ = needed_context(push, WANTED, c, np.array([True, False]), zero_eps=1e-4, k=4,
                             support=0.1, agreement=0.4)
    assert need[:2] == pytest.approx(seen[0], abs=1e-9)
    # Seen from a LIDAR of 0.16, those four (their LIDAR 0.055 off) are no longer the nearest.
    c[2:] = 0.16
    far, _ = needed_context(push, WANTED, c, np.array([True, False]), zero_eps=1e-4, k=4,
                            support=0.1, agreement=0.4)
    assert abs(far[0] - seen[0][0]) > 0.01


def test_the_place_is_fitted_at_the_wanted_outcome_not_averaged_over_the_rows_near_it():
    """Pushes by 0.05 + 0.002·j, j = 1…40 — all longer than the wanted 0.05 — each from a gap
    growing with its move (gap = 0.30 + 0.5·(move − 0.05)): the place is the gap of a push by
    exactly 0.05, which no row holds, read off the k rows nearest by a line through them;
    the input likewise."""
    room = Room()
    moves = WANTED[0] + 0.002 * np.arange(1, 41)
    t, before = _pushes(room, [(0.30 + 0.5 * (m - WANTED[0]), m) for m in moves])
    rows = Rows(t, np.full(t.size, 1, dtype=np.int64), np.full(t.size, -1, dtype=np.int64))
    push = room.fitter.new_affordance(room.hierarchy.allocate_id(), ROBOT_POSITION,
                                      TARGET_POSITION, (TARGET_ROBOT,), rows,
                                      len(room.dataset), np.random.default_rng(0))
    seen = room.learner.reader.read_each((TARGET_ROBOT,), before, 1, -1)
    line = np.polyfit(moves, seen[:, 0], 1)
    need, x = needed_context(push, WANTED, np.array([0.25, 0.1]), np.array([True]),
                             zero_eps=1e-4, k=8, support=0.1, agreement=0.4)
    assert need == pytest.approx([np.polyval(line, WANTED[0]), 0.0], abs=1e-9)
    assert x == pytest.approx(WANTED, abs=1e-9)


def test_a_level_acts_from_the_relation_of_its_mover_to_its_body():
    """A push seen with the target's absolute place as a context before the target-robot
    relation: the level `Controller.chain` gives it acts from the relation (its columns in
    the push's contexts), not from the other context of the target."""
    room = Room()
    drive = room.affordance(room.moves(np.random.default_rng(5), 40))
    t, _ = _pushes(room, [(0.3, 0.04 + 0.001 * j) for j in range(20)])
    rows = Rows(t, np.full(t.size, 1, dtype=np.int64), np.full(t.size, -1, dtype=np.int64))
    push = room.fitter.new_affordance(room.hierarchy.allocate_id(), ROBOT_POSITION,
                                      TARGET_POSITION, (TARGET_POSITION, TARGET_ROBOT), rows,
                                      len(room.dataset), np.random.default_rng(0))
    levels = room.learner.controller.chain(push, Binding(target=1))
    assert [lv.affordance for lv in levels] == [push, drive]
    assert levels[0].relation == context_slices(push)[1] and levels[1].relation is None


def _place_between(second_gap: float) -> tuple[float, float, float]:
    """Forty pushes along +x by 0.05 ± 0.002·j, j = 1…20: j = 1 from a gap of 0.30, j = 2
    from `second_gap`, the rest from far off. Returns the place's distance ahead of the
    target wanted for a push of 0.05 (k = 4: the eight nearest rows and mirror images,
    j = 1 and 2), and the relations j = 1 and j = 2 were seen in."""
    room = Room()
    pushes = [(0.30 if j == 1 else second_gap if j == 2 else (0.2 if j % 2 else 0.5),
               WANTED[0] + sign * 0.002 * j) for j in range(1, 21) for sign in (1, -1)]
    t, before = _pushes(room, pushes)
    rows = Rows(t, np.full(t.size, 1, dtype=np.int64), np.full(t.size, -1, dtype=np.int64))
    push = room.fitter.new_affordance(room.hierarchy.allocate_id(), ROBOT_POSITION,
                                      TARGET_POSITION, (TARGET_ROBOT,), rows, len(room.dataset),
                                      np.random.default_rng(0))
    seen = room.learner.reader.read_each((TARGET_ROBOT,), before, 1, -1)
    need, _ = needed_context(push, WANTED, np.array([0.25, 0.1]), np.array([True]),
                             zero_eps=1e-4, k=4, support=0.1, agreement=0.4)
    assert need[1] == pytest.approx(0.0, abs=1e-9)
    return float(need[0]), float(seen[0, 0]), float(seen[2, 0])


def test_rows_near_the_wanted_outcome_seen_from_a_place_far_from_the_densest_do_not_vote_in():
    """The four rows nearest the wanted push were seen 0.30 m off in the target's scale
    (about two of its units, beyond `agreement`) from the next four: the place is the
    nearest four's relation alone, not a blend of the two."""
    need, first, second = _place_between(0.60)
    assert second - first == pytest.approx(0.30)
    assert need == pytest.approx(first, abs=1e-9)


def test_rows_that_agree_on_the_place_weigh_by_how_near_the_wanted_outcome_they_moved():
    """The nearest four seen from 0.30, the next four from 0.34 (within `agreement`): both
    fit the place, the nearer more (their closeness relative to the median distance of the
    eight): the place lies nearer the first relation than the middle of the two."""
    need, first, second = _place_between(0.34)
    assert second - first == pytest.approx(0.04)
    assert first < need < first + 0.3 * (second - first)
