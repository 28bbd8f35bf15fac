"""The controller through its public contract (`Controller.act`, `Controller.reach`),
on models fitted on rows of the real pymunk World (`handmade.world_learner`): reach a
place, go round a body in the way without touching it, push an object along a line, give
up within a bound when nothing can be reached; and `detour`'s length against the geometry
of tangents and arcs computed here by hand."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from handmade import (
    ROBOT_HEADING,
    ROBOT_LIDAR,
    STEP,
    TARGET_POSITION,
    TARGET_ROBOT,
    TOOL_POSITION,
    Room,
    world_learner,
)

from hadim_cli.config import PlannerConfig, load_config
from hadim_cli.evaluation.exact import exact_levels
from hadim_cli.evaluation.runner import evaluate
from hadim_cli.evaluation.tasks import load_task
from hadim_cli.learner.affordance import typical_step
from hadim_cli.learner.controller import Controller, detour
from hadim_cli.learner.goals import Binding
from hadim_cli.learner.places import needed_context
from hadim_cli.learner.spaces import ACTION, Property, Role, RoleSpace, Rows
from hadim_cli.world.world import World

TASK = load_task("push-line")
ROBOT_POSITION = RoleSpace(Role.ROBOT, Property.POSITION)


@pytest.fixture(scope="module")
def rig():
    config = load_config()
    world = World(config.world)
    learner = world_learner(config, world, TASK.scene)
    assert isinstance(learner.controller, Controller)
    return config, world, learner


def _mover(learner):
    return next(a for a in learner.hierarchy.with_output(ROBOT_POSITION))


def _drive(world, controller, aff, binding, goal, budget):
    """Pursue `goal` from the task's scene through `act`; returns the observations and
    every pair of bodies that touched on the way."""
    obs = world.reset(scene=TASK.scene)
    pursuit = controller.pursue(aff, binding, goal, obs)
    seen, touched = [obs], set()
    for _ in range(budget):
        action = controller.act(obs, pursuit)
        if action is None:
            break
        obs = world.step(action)
        seen.append(obs)
        touched |= set(world.last_contacts)
    return seen, touched


def _push(learner):
    return next(a for a in learner.hierarchy if a.input == ROBOT_POSITION)


def _first_decision(world, controller, aff, binding, goal, scene=TASK.scene):
    """The first action of a pursuit of `goal` from `scene` (the task's), and the
    `Decision` the observer was handed for it; returns (observation, action, decision)."""
    decisions = []
    controller.observer = decisions.append
    try:
        obs = world.reset(scene=scene)
        action = controller.act(obs, controller.pursue(aff, binding, goal, obs))
    finally:
        controller.observer = None
    assert len(decisions) == (action is not None)
    return obs, action, decisions[0] if decisions else None


def _place(config, aff, wanted):
    """`needed_context` of `aff`'s relation for the outcome `wanted`, with the planner's
    constants (as the controller asks it)."""
    return needed_context(aff, wanted, np.zeros(2), np.array([True]),
                          zero_eps=config.learner.zero_eps, k=2 * config.learner.k_inverse,
                          support=config.planner.context_support,
                          agreement=config.planner.agreement)


@pytest.mark.parametrize("goal", [(-0.6, 0.5), (0.0, -0.7), (-0.8, -0.3)])
def test_the_robot_reaches_a_place(rig, goal):
    _, world, learner = rig
    seen, _ = _drive(world, learner.controller, _mover(learner), Binding(), np.array(goal), 30)
    final = learner.reader.entity_position(seen[-1], 0)
    assert np.linalg.norm(final - goal) <= 0.05, final
    # About the distance at full speed plus two turns.
    assert len(seen) - 1 <= 4 + np.hypot(*goal) / 0.15


@pytest.mark.parametrize("avoid", [-1, 1])
def test_the_robot_goes_round_a_body_in_its_way(rig, avoid):
    """Bodies may touch (never overlap); the one a binding forbids is never touched."""
    _, world, learner = rig
    goal = np.array([0.9, 0.05])  # behind obj1, which stands at (0.45, 0) on the way
    seen, touched = _drive(world, learner.controller, _mover(learner), Binding(avoid=avoid),
                           goal, 40)
    final = learner.reader.entity_position(seen[-1], 0)
    assert np.linalg.norm(final - goal) <= 0.06, final
    if avoid == 1:
        assert ("obj1", "robot") not in touched, touched
    for obs in seen:  # no overlap, whatever may touch
        apart = np.linalg.norm(learner.reader.entity_position(obs, 0)
                               - learner.reader.entity_position(obs, 1))
        assert apart >= 0.15 + 0.12 - 0.02


def test_the_robot_pushes_an_object_along_a_line(rig):
    config, _, learner = rig
    task = dataclasses.replace(TASK, points=(TASK.points[0], TASK.points[4]))
    result = evaluate(learner, config.world, task)
    assert result.score >= 0.85, [p.error for p in result.points]
    assert all(p.line_deviation <= 0.15 for p in result.points)


def test_a_place_beyond_the_walls_is_given_up_within_its_budget(rig):
    _, world, learner = rig
    controller = learner.controller
    obs = world.reset(scene=TASK.scene)
    budget = 60
    pursuit = controller.pursue(_mover(learner), Binding(), np.array([-3.0, 0.0]), obs, budget)
    used = 0
    while (action := controller.act(obs, pursuit)) is not None:
        obs = world.step(action)
        used += 1
        assert used <= budget, "the pursuit went on past its budget"
    # The wall is 2 m away (about 14 actions): the robot goes to it, and the pursuit ends
    # with its budget at the latest, the robot against the wall.
    assert 2.0 / 0.15 <= used <= budget
    assert controller.act(obs, pursuit) is None
    assert learner.reader.entity_position(obs, 0)[0] < -1.5


def test_the_same_observation_gives_the_same_action(rig):
    _, world, learner = rig
    obs = world.reset(scene=TASK.scene)
    goal = np.array(TASK.points[2])
    push = _push(learner)
    first = [learner.controller.act(obs, learner.controller.pursue(push, Binding(target=1), goal,
                                                              obs)) for _ in range(2)]
    assert first[0] is not None and np.array_equal(first[0], first[1])


@pytest.mark.parametrize("angle", [0.0, 2.0])
def test_a_push_is_made_from_the_line_of_the_move_whichever_way_it_goes(rig, angle):
    """Discs push alike from either side: the place `needed_context` reads off the real
    pushes lies behind the target on the line of the wanted move (within 1 mm), and the
    robot's input moves along that line."""
    config, _, learner = rig
    u = np.array([np.cos(angle), np.sin(angle)])
    need, x = _place(config, _push(learner), 0.06 * u)
    across = np.array([-u[1], u[0]])
    assert abs(need @ across) <= 1e-3 and need @ u >= 0.27  # target − robot: behind, in contact
    assert abs(x @ across) <= 1e-3 and x @ u > 0.0


def test_a_detour_round_a_disc_is_the_tangents_and_the_arc_between_them():
    frm, to = np.array([[-1.0, 0.0]]), np.array([[1.0, 0.0]])
    r = 0.5
    length, first, last = detour(frm, to, np.zeros((1, 1, 2)), np.full((1, 1), r))
    tangent = np.sqrt(1.0 - r * r)
    touch = np.arccos(r)  # the angle at the centre between the start and its tangent point
    assert length[0] == pytest.approx(2 * tangent + r * (np.pi - 2 * touch))
    # It leaves along the tangent (30° off the straight way here) and arrives along the other.
    assert abs(first[0, 1]) == pytest.approx(0.5)
    assert first[0, 1] == pytest.approx(-last[0, 1])


def test_a_disc_off_the_way_or_holding_its_end_is_no_obstacle():
    frm, to = np.array([[-1.0, 0.0], [-1.0, 0.0]]), np.array([[1.0, 0.0], [0.1, 0.0]])
    centres = np.array([[[0.0, 2.0]], [[0.0, 0.0]]])
    length, _, _ = detour(frm, to, centres, np.array([[0.5], [0.5]]))
    assert length == pytest.approx([2.0, 1.1])


def test_the_robot_reaches_every_pose_of_the_reach_pose_task(rig):
    """Position, then heading (through `act`, by the learned `action → robot.heading`): each
    pose's error — the mean of the position's and the heading's shares — is small."""
    config, _, learner = rig
    result = evaluate(learner, config.world, load_task("reach-pose"))
    assert all(p.error <= 0.15 for p in result.points), [round(p.error, 3) for p in result.points]


def test_a_deeper_search_runs_and_reaches_the_place_too(rig):
    """A horizon of two actions (each depth's best `beam` states imagined one action further)
    runs, and still takes the robot to its place within the same bound as one. (Which first
    action a deeper search prefers is not checked here.)"""
    config, world, learner = rig
    deeper = Controller(learner.hierarchy, learner.reader, config.learner,
                        dataclasses.replace(config.planner, horizon=2))
    goal = np.array([-0.6, 0.5])
    seen, _ = _drive(world, deeper, _mover(learner), Binding(), goal, 30)
    final = learner.reader.entity_position(seen[-1], 0)
    assert np.linalg.norm(final - goal) <= 0.05, final
    assert len(seen) - 1 <= 4 + np.hypot(*goal) / 0.15


def test_a_robot_without_a_turning_affordance_is_driven_as_it_is_headed():
    """H holds `action → robot.position` alone (the robot seen at one heading, along +x):
    the controller acts without a turn to plan, forward towards a goal ahead."""
    room = Room()
    t = room.moves(np.random.default_rng(2), 80, heading=0.0)
    drive = room.affordance(t)
    room.place("robot", [0.0, 0.0])
    room.set("robot", Property.HEADING, [1.0, 0.0])
    controller = room.learner.controller
    goal = np.array([0.4, 0.0])
    pursuit = controller.pursue(drive, Binding(), goal, room.obs)
    action = controller.act(room.obs, pursuit)
    assert action is not None and action.mean() > 0.5  # about full speed forward
    assert drive.model.predict(action[None])[0] @ goal > 0


def test_each_decision_tells_the_observer_its_movers_distance_to_its_place(rig):
    """Pushing obj1, the observer is handed per action one gap (the push level's): the
    robot's way to the place behind obj1 (read off the pushes here), about the straight line
    to it (nothing in between), and the action serves that place."""
    config, world, learner = rig
    push, goal = _push(learner), np.array(TASK.points[2])
    obs, action, decision = _first_decision(world, learner.controller, push, Binding(target=1),
                                            goal)
    assert action is not None
    target = learner.reader.entity_position(obs, 1)
    place, _ = _place(config, push, 0.06 * (goal - target) / np.linalg.norm(goal - target))
    straight = np.linalg.norm(target - place - learner.reader.entity_position(obs, 0))
    (gap,) = decision.gaps
    assert straight - 0.02 <= gap <= straight + 0.1
    assert decision.label == f"place robot for A{push.id}"


@pytest.mark.parametrize("goal_x", [1.25, 0.95])
def test_the_estimate_is_the_targets_way_in_pushes_plus_the_robots_way_to_its_place(rig, goal_x):
    """obj1 ahead of the robot on the line of its goal, the robot facing it: the estimate
    handed to the observer is obj1's way in the push's steps plus the robot's way to
    contact behind obj1 in the drive's steps (each level's step: `step_quantile` of its
    non-null outcome norms), with no turn to pay and whatever the way's length."""
    config, world, learner = rig
    reader, push, drive = learner.reader, _push(learner), _mover(learner)
    q, zero = config.planner.step_quantile, config.learner.zero_eps
    goal = np.array([goal_x, 0.0])
    obs, _, decision = _first_decision(world, learner.controller, push, Binding(target=1), goal)
    target, robot = reader.entity_position(obs, 1), reader.entity_position(obs, 0)
    contact = config.world.robot_radius + TASK.scene.objects[0].radius
    place = target - contact * (goal - target) / np.linalg.norm(goal - target)
    expected = (np.linalg.norm(goal - target) / typical_step(push, q, zero)
                + np.linalg.norm(place - robot) / typical_step(drive, q, zero))
    assert decision.to_go == pytest.approx(expected, rel=1e-3)


def _behind(gap):
    """The task's scene with the robot on the line of obj1's goal (+x), facing it, `gap`
    clear of obj1 — behind it, or in front of it (between it and the goal) when negative."""
    obj = TASK.scene.objects[0]
    contact = load_config().world.robot_radius + obj.radius
    x = obj.x - contact - gap if gap >= 0 else obj.x + contact - gap
    return dataclasses.replace(TASK.scene, robot_x=x, robot_y=obj.y, robot_heading=0.0)


def test_a_robot_a_little_behind_the_target_drives_into_it_at_full_speed(rig):
    """3 cm behind obj1, facing its goal: a full move forward reaches obj1 on the way and
    pushes it (the robot does not stop at contact), and the estimate falls by it."""
    _, world, learner = rig
    _, action, decision = _first_decision(world, learner.controller, _push(learner),
                                          Binding(target=1), np.array([1.25, 0.0]),
                                          _behind(0.03))
    assert action == pytest.approx([1.0, 1.0])
    assert decision.predicted < decision.to_go


def test_a_move_that_stops_short_of_the_target_leaves_it_where_it_is(rig):
    """30–50 cm behind obj1, facing its goal: no move reaches obj1, so the best command's
    estimate is that action, plus obj1's whole way in pushes, plus the robot's way left to
    contact after the drive's predicted move (in the drive's steps)."""
    config, world, learner = rig
    reader, push, drive = learner.reader, _push(learner), _mover(learner)
    q, zero = config.planner.step_quantile, config.learner.zero_eps
    goal = np.array([1.25, 0.0])
    for gap in (0.3, 0.5):
        obs, action, decision = _first_decision(world, learner.controller, push,
                                                Binding(target=1), goal, _behind(gap))
        target, robot = reader.entity_position(obs, 1), reader.entity_position(obs, 0)
        place = target - (config.world.robot_radius + TASK.scene.objects[0].radius) * np.array(
            [1.0, 0.0])
        move = drive.model.predict(action[None], reader.read_each(drive.contexts, obs[None]))[0]
        expected = (1 + np.linalg.norm(goal - target) / typical_step(push, q, zero)
                    + np.linalg.norm(place - robot - move) / typical_step(drive, q, zero))
        assert decision.predicted == pytest.approx(expected, rel=1e-3)


def test_a_robot_between_the_target_and_its_goal_does_not_drive_off_towards_the_goal(rig):
    """In front of obj1 (5 mm clear), facing obj1's goal: driving on moves the robot away
    from obj1, not obj1 — a move away from a body reaches nothing — so the robot does not
    take it; it sets off round obj1."""
    _, world, learner = rig
    _, action, _ = _first_decision(world, learner.controller, _push(learner), Binding(target=1),
                                   np.array([1.25, 0.0]), _behind(-0.005))
    assert action is not None and action.mean() < 0.5


def test_an_exact_level_is_imagined_by_the_rooms_physics_instead_of_its_model():
    """A drive learned facing −x (forward moves the robot −x, whatever the heading seen now)
    sends a robot facing +x backwards to a goal ahead; with the navigation level exact
    (`evaluation.exact`), the controller drives it forwards."""
    room = Room()
    drive = room.affordance(room.moves(np.random.default_rng(2), 80, heading=np.pi))
    learned, exact = _first_actions_learned_and_exact(room, drive, np.array([0.4, 0.0]))
    assert learned.mean() < -0.5 and exact.mean() > 0.5


def _first_actions_learned_and_exact(room: Room, drive, goal: np.ndarray):
    """The first action towards `goal` of a robot at the origin facing +x, with the learned
    levels and with the navigation level exact."""
    room.place("robot", [0.0, 0.0])
    room.set("robot", Property.HEADING, [1.0, 0.0])
    controller = room.learner.controller
    learned = controller.act(room.obs, controller.pursue(drive, Binding(), goal, room.obs))
    with exact_levels(room.learner, load_config().world, ("navigation",)):
        exact = controller.act(room.obs, controller.pursue(drive, Binding(), goal, room.obs))
    return learned, exact


def test_a_search_two_actions_deep_turns_the_robot_towards_a_goal_on_its_right(rig):
    config, world, learner = rig
    deeper = Controller(learner.hierarchy, learner.reader, config.learner,
                        dataclasses.replace(config.planner, horizon=2))
    obs = world.reset(scene=TASK.scene)
    goal = np.array([0.0, -0.7])  # the robot faces +x: a quarter turn first, to the right
    action = deeper.act(obs, deeper.pursue(_mover(learner), Binding(), goal, obs))
    assert action is not None and action[0] > action[1]


def test_a_detour_from_a_discs_rim_leaves_along_its_tangent():
    """From a point on the rim (0.6 of the way left, 0.8 up) to beyond the disc's far side:
    the way starts along the rim — a unit direction square to the radius."""
    radial = np.array([-0.6, 0.8])
    frm, to = 0.5 * radial[None], np.array([[0.9, -0.6]])
    length, first, _ = detour(frm, to, np.zeros((1, 1, 2)), np.full((1, 1), 0.5))
    assert length[0] > np.linalg.norm(to - frm)
    assert np.linalg.norm(first[0]) == pytest.approx(1.0)
    assert first[0] @ radial == pytest.approx(0.0, abs=1e-12)


def test_the_search_tries_an_n_by_n_grid_of_commands_over_the_action_box(rig):
    config, _, learner = rig
    five = Controller(learner.hierarchy, learner.reader, config.learner,
                      dataclasses.replace(config.planner, commands=5))
    assert five.commands.shape == (24, 2)  # 5 × 5, standing still left out
    assert {tuple(c) for c in five.commands} >= {(-1.0, -1.0), (-1.0, 1.0), (1.0, 1.0), (1.0, 0.0)}
    assert np.abs(five.commands).max() == 1.0 and not np.any(np.all(five.commands == 0, axis=1))


def test_a_place_off_the_line_of_the_push_is_turned_with_the_wanted_move():
    """Pushes seen only from 0.6 rad to the left of the line of the move (target − robot
    turned by +0.6 from the move, at contact), with a LIDAR context that has no mirror
    image: the place is off the line. Pushing obj1 towards a goal at 2 rad, the observer's
    gap is the robot's way to that place turned to the goal's direction — not to its mirror
    image, nor to the place unturned."""
    room = Room()
    room.affordance(room.moves(np.random.default_rng(2), 80), contexts=(ROBOT_HEADING,))
    room.set("robot", ROBOT_LIDAR.prop, [1.0] * 4)
    side, contact = 0.6, 0.15 + 0.12
    rng = np.random.default_rng(3)
    room.episode()
    t = []
    for _ in range(40):
        phi, move = rng.uniform(-np.pi, np.pi), rng.uniform(0.03, 0.06)
        along = np.array([np.cos(phi), np.sin(phi)])
        behind = np.array([np.cos(phi + side), np.sin(phi + side)])
        room.place("obj1", [0.0, 0.0])
        room.place("robot", -contact * behind)
        before = room.obs.copy()
        room.place("robot", -contact * behind + move * along)
        room.place("obj1", move * along)
        t.append(room.dataset.append(np.zeros(2), before, room.obs.copy()))
    t = np.array(t, dtype=np.int64)
    rows = Rows(t, np.full(t.size, 1, dtype=np.int64), np.full(t.size, -1, dtype=np.int64))
    push = room.fitter.new_affordance(room.hierarchy.allocate_id(), ROBOT_POSITION,
                                      TARGET_POSITION, (TARGET_ROBOT, ROBOT_LIDAR), rows,
                                      len(room.dataset), np.random.default_rng(0))
    room.hierarchy.add(push, len(room.dataset))
    u = np.array([np.cos(2.0), np.sin(2.0)])
    target = np.array([0.2, -0.4])
    room.place("obj1", target)
    place = target - contact * np.array([np.cos(2.0 + side), np.sin(2.0 + side)])
    robot = place - 0.5 * np.array([np.cos(2.0 + side), np.sin(2.0 + side)])
    room.place("robot", robot)
    room.set("robot", ROBOT_HEADING.prop, [1.0, 0.0])
    decisions = []
    controller = room.learner.controller
    controller.observer = decisions.append
    action = controller.act(room.obs, controller.pursue(push, Binding(target=1),
                                                        target + 0.5 * u, room.obs))
    assert action is not None
    (gap,) = decisions[0].gaps
    assert gap == pytest.approx(0.5, abs=1e-3)


def test_a_detour_round_a_disc_passes_on_the_side_of_the_straight_line():
    """The straight way passes 0.2 above the disc's centre: the way round starts up, over
    the disc, and comes down to the end."""
    frm, to = np.array([[-1.0, 0.2]]), np.array([[1.0, 0.2]])
    _, first, last = detour(frm, to, np.zeros((1, 1, 2)), np.full((1, 1), 0.5))
    assert first[0, 1] > 0.1 and last[0, 1] < -0.1


def test_a_detour_between_points_opposite_across_a_discs_centre_is_its_tangents_and_half_arc():
    """Start and end on one line through the centre, on either side (their directions from
    it, in floating point, just past opposite): the way is two tangents and the arc between."""
    v = np.array([0.1, 0.3])
    frm, to, r = -0.6 * v[None], 0.6 * v[None], 0.1
    length, first, last = detour(frm, to, np.zeros((1, 1, 2)), np.full((1, 1), r))
    d = float(np.linalg.norm(0.6 * v))
    touch = np.arccos(r / d)
    assert length[0] == pytest.approx(2 * np.sqrt(d * d - r * r) + r * (np.pi - 2 * touch))
    assert np.all(np.isfinite(first)) and np.all(np.isfinite(last))


def test_a_robot_facing_its_way_to_its_place_pays_no_turn_whatever_the_push(rig):
    """Behind obj1 but off the line of its goal, facing its place: the estimate is obj1's
    way in pushes plus the robot's way to contact behind obj1 in drive steps — no turn, though
    the push it will make then runs along another line."""
    config, world, learner = rig
    reader, push, drive = learner.reader, _push(learner), _mover(learner)
    q, zero = config.planner.step_quantile, config.learner.zero_eps
    obj = TASK.scene.objects[0]
    goal, target = np.array([1.25, 0.0]), np.array([obj.x, obj.y])
    place = target - (config.world.robot_radius + obj.radius) * np.array([1.0, 0.0])
    robot = place + np.array([-0.3, 0.4])
    toward = np.arctan2(*(place - robot)[::-1])
    scene = dataclasses.replace(TASK.scene, robot_x=robot[0], robot_y=robot[1],
                                robot_heading=toward)
    obs, _, decision = _first_decision(world, learner.controller, push, Binding(target=1), goal,
                                       scene)
    expected = (np.linalg.norm(goal - reader.entity_position(obs, 1)) / typical_step(push, q, zero)
                + np.linalg.norm(place - reader.entity_position(obs, 0))
                / typical_step(drive, q, zero))
    assert decision.to_go == pytest.approx(expected, rel=1e-3)


def test_an_exact_navigation_level_imagines_the_robots_turns_by_the_rooms_physics_too():
    """A turner learned from rows that turn the other way (right wheel faster: a turn to the
    right) turns a robot facing +x the wrong way towards a goal ahead on its left; with the
    navigation level exact, its heading is imagined by the room's physics as well, and the
    controller turns it left."""
    room = Room()
    rng = np.random.default_rng(2)
    drive = room.affordance(room.moves(rng, 80), contexts=(ROBOT_HEADING,))
    t = []
    for _ in range(80):
        theta, action = rng.uniform(-np.pi, np.pi), rng.uniform(-1.0, 1.0, 2)
        room.set("robot", ROBOT_HEADING.prop, [np.cos(theta), np.sin(theta)])
        before = room.obs.copy()
        turned = theta - 0.3 * (action[1] - action[0])
        room.set("robot", ROBOT_HEADING.prop, [np.cos(turned), np.sin(turned)])
        t.append(room.dataset.append(action, before, room.obs.copy()))
    room.affordance(np.array(t, dtype=np.int64), (ROBOT_HEADING,), out=ROBOT_HEADING)
    learned, exact = _first_actions_learned_and_exact(room, drive, np.array([0.3, 0.3]))
    assert learned[0] > learned[1] and exact[1] > exact[0]


def _pushes(room: Room, mover: str, moved: str, n: int, rng: np.random.Generator) -> np.ndarray:
    """`n` rows of `mover` pushing `moved` from straight behind, 3–6 cm in a random direction,
    both at contact (the hand-built room's radii); returns their iterations."""
    contact = sum(room.obs[room.layout.space(e, Property.RADIUS).slice][0] for e in (mover, moved))
    room.episode()
    t = []
    for _ in range(n):
        phi, move = rng.uniform(-np.pi, np.pi), rng.uniform(0.03, 0.06)
        along = np.array([np.cos(phi), np.sin(phi)])
        room.place(moved, [0.0, 0.0])
        room.place(mover, -contact * along)
        before = room.obs.copy()
        room.place(mover, (move - contact) * along)
        room.place(moved, move * along)
        t.append(room.dataset.append(np.zeros(2), before, room.obs.copy()))
    return np.array(t, dtype=np.int64)


def _bound(room: Room, t: np.ndarray, inp, contexts, target: int, tool: int = -1):
    """A(inp → target.position | contexts) fitted on the rows at `t` under a binding, added
    to H."""
    rows = Rows(t, np.full(t.size, target, dtype=np.int64), np.full(t.size, tool, dtype=np.int64))
    aff = room.fitter.new_affordance(room.hierarchy.allocate_id(), inp, TARGET_POSITION,
                                     tuple(contexts), rows, len(room.dataset),
                                     np.random.default_rng(0))
    room.hierarchy.add(aff, len(room.dataset))
    return aff


def test_a_three_level_chains_estimate_pays_the_robots_way_round_the_tool_and_its_turn():
    """A tool chain (obj2 pushes obj1, the robot pushes obj2, the action drives the robot),
    the tool 40 cm below its place behind obj1, the robot 30 cm behind its place behind the
    tool, turned 0.5 rad off its way: the estimate handed to the observer is obj1's way in the
    tool's pushes, plus the tool's way to its place in the robot's pushes, plus the robot's
    way round the tool — the tool arrives square to the push it must make, so the robot must
    go a quarter of the way round it (the sum of their radii times π/2), in drive steps — plus
    the robot's way to its place in drive steps, plus its turn to face that way in turns."""
    room = Room()
    rng = np.random.default_rng(2)
    moves = room.moves(rng, 80)
    drive = room.affordance(moves, contexts=(ROBOT_HEADING,))
    turner = room.affordance(moves, contexts=(ROBOT_HEADING,), out=ROBOT_HEADING)
    push = _bound(room, _pushes(room, "robot", "obj2", 40, rng), ROBOT_POSITION, (TARGET_ROBOT,),
                  target=2)
    target_tool = RoleSpace(Role.TARGET, Property.POSITION, Role.TOOL)
    tool = _bound(room, _pushes(room, "obj2", "obj1", 40, rng), TOOL_POSITION, (target_tool,),
                  target=1, tool=2)
    controller, config, pc = room.learner.controller, room.config, room.learner.controller.pc
    steps = [max(typical_step(a, pc.step_quantile, config.zero_eps), 1e-3)
             for a in (tool, push, drive, turner)]
    # The pushes were seen from straight behind: each place lies on the line of its move.
    for aff, step in zip((tool, push), steps[:2], strict=True):
        place, x = needed_context(aff, np.array([step, 0.0]), np.zeros(2), np.array([True]),
                                  zero_eps=config.zero_eps, k=2 * config.k_inverse,
                                  support=pc.context_support, agreement=pc.agreement)
        assert place[1] == pytest.approx(0.0, abs=1e-9) and place[0] > 0
        assert x[1] == pytest.approx(0.0, abs=1e-9) and x[0] > 0
    target, goal = np.array([0.3, 0.2]), np.array([0.9, 0.2])
    tool_place = target - (0.12 + 0.12) * np.array([1.0, 0.0])
    tool_at = tool_place - np.array([0.0, 0.4])
    robot_place = tool_at - (0.15 + 0.12) * np.array([0.0, 1.0])
    robot_at = robot_place - np.array([0.0, 0.3])
    for name, xy in (("obj1", target), ("obj2", tool_at), ("obj3", [-0.8, 0.9]),
                     ("robot", robot_at)):
        room.place(name, xy)
    heading = np.pi / 2 + 0.5
    room.set("robot", Property.HEADING, [np.cos(heading), np.sin(heading)])
    decisions = []
    controller.observer = decisions.append
    action = controller.act(room.obs, controller.pursue(tool, Binding(target=1, tool=2), goal,
                                                        room.obs))
    assert action is not None
    turn = 2 * np.arcsin(min(steps[3] / 2, 1.0))
    expected = (0.6 / steps[0] + 0.4 / steps[1] + (0.15 + 0.12) * (np.pi / 2) / steps[2]
                + 0.3 / steps[2] + 0.5 / turn)
    assert decisions[0].gaps == pytest.approx((0.4, 0.3))
    assert decisions[0].to_go == pytest.approx(expected, rel=1e-6)


def test_a_driver_that_needs_a_tool_is_passed_over_for_the_next_when_none_is_bound():
    """Two drives of the robot: the more competent reads the tool (its radius), the other,
    learned from noise, does not. Pushing obj1 with no tool bound, the chain passes over the
    first and takes the second, and the controller acts."""
    room = Room()
    rng = np.random.default_rng(2)
    clean, noise = room.moves(rng, 80), room.moves(rng, 80, noise=True)
    plain = room.affordance(noise, contexts=(ROBOT_HEADING,))
    rows = Rows(clean, np.full(clean.size, -1, dtype=np.int64),
                np.full(clean.size, 2, dtype=np.int64))
    with_tool = room.fitter.new_affordance(
        room.hierarchy.allocate_id(), ACTION, ROBOT_POSITION,
        (ROBOT_HEADING, RoleSpace(Role.TOOL, Property.RADIUS)), rows, len(room.dataset),
        np.random.default_rng(0))
    room.hierarchy.add(with_tool, len(room.dataset))
    assert with_tool.has_tool and with_tool.competence > plain.competence
    push = _bound(room, _pushes(room, "robot", "obj1", 40, rng), ROBOT_POSITION, (TARGET_ROBOT,),
                  target=1)
    controller = room.learner.controller
    chain = controller.chain(push, Binding(target=1))
    assert chain is not None and [lv.affordance for lv in chain] == [push, plain]
    room.place("obj1", [0.3, 0.2])
    room.place("robot", [-0.3, 0.2])
    room.set("robot", Property.HEADING, [1.0, 0.0])
    goal = np.array([0.8, 0.2])
    assert controller.act(room.obs, controller.pursue(push, Binding(target=1), goal,
                                                      room.obs)) is not None


def _stuck_forward(room: Room, drive, goal: np.ndarray, actions: int):
    """A pursuit of `goal` by the hand-built drive (accurate: `Room.moves`' law) from the
    origin facing +x, in a world where the robot is held (pressed against something no
    observation holds, as an arm's joint at its limit): every action only slips it 2 mm
    sideways, without turning it. Returns the actions taken."""
    room.place("robot", [0.0, 0.0])
    room.set("robot", Property.HEADING, [1.0, 0.0])
    controller = room.learner.controller
    pursuit = controller.pursue(drive, Binding(), goal, room.obs)
    taken = []
    for _ in range(actions):
        action = controller.act(room.obs, pursuit)
        if action is None:
            break
        taken.append(tuple(action))
        here = room.obs[room.layout.space("robot", Property.POSITION).slice]
        room.place("robot", here + [0.0, 0.002])
    return taken


def test_a_command_that_did_not_do_what_its_model_said_is_not_asked_again_there():
    """The drive's model says full forward moves the robot 5 cm towards its goal; the world
    barely moves it. The pursuit keeps what its commands did: it does not ask a command
    again from within half a step of where it did nothing (without that, the search asks
    full forward at every action), and a new pursuit starts without what the last one
    learned."""
    room = Room()
    drive = room.affordance(room.moves(np.random.default_rng(3), 300),
                            contexts=(ROBOT_HEADING,))
    goal = np.array([0.5, 0.0])
    taken = _stuck_forward(room, drive, goal, 6)
    assert taken and taken[0] == (1.0, 1.0)
    assert len(set(taken)) == len(taken), taken
    assert _stuck_forward(room, drive, goal, 1) == [(1.0, 1.0)]


def test_a_command_that_did_less_than_its_model_said_but_still_the_most_is_asked_again():
    """The world moves the robot a fifth of what the drive's model says (forward 1 cm where
    the model says 5 cm, turns a fifth as far). What the pursuit remembers is what each
    command did, not that it did nothing: full forward, which did less than predicted but
    still brings the robot closest to its goal, is asked again at every action (a
    remembered change of zero turns the robot away instead). The grid is the box's corners."""
    room = Room()
    corners = Controller(room.hierarchy, room.learner.reader, room.config,
                         PlannerConfig(commands=2))
    drive = room.affordance(room.moves(np.random.default_rng(3), 300),
                            contexts=(ROBOT_HEADING,))
    room.place("robot", [0.0, 0.0])
    room.set("robot", Property.HEADING, [1.0, 0.0])
    pursuit = corners.pursue(drive, Binding(), np.array([0.5, 0.0]), room.obs)
    taken = []
    for _ in range(4):
        action = corners.act(room.obs, pursuit)
        taken.append(tuple(action))
        heading = room.obs[room.layout.space("robot", Property.HEADING).slice]
        theta = np.arctan2(heading[1], heading[0]) + 0.2 * 0.3 * (action[1] - action[0])
        here = room.obs[room.layout.space("robot", Property.POSITION).slice]
        room.place("robot", here + 0.2 * STEP * action.mean() * heading)
        room.set("robot", Property.HEADING, [np.cos(theta), np.sin(theta)])
    assert taken == [(1.0, 1.0)] * 4
