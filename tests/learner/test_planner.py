"""Planner pieces at small sizes: the context to reach first, and the rules around it."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from hadim_cli.config import load_config
from hadim_cli.learner.adaptation import required_gain
from hadim_cli.learner.frames import FramedModel, relation_frame
from hadim_cli.learner.hierarchy import Hierarchy
from hadim_cli.learner.models import LocalLinearModel
from hadim_cli.learner.navigation import Place
from hadim_cli.learner.planner import (
    CONVOY_PURSUIT,
    LINE_STEP,
    ROBOT_POSITION,
    Binding,
    Planner,
    Pursuit,
    _at_own_lengths,
)
from hadim_cli.learner.spaces import ACTION, Property, Role, RoleSpace

TARGET_ROBOT = RoleSpace(Role.TARGET, Property.POSITION, Role.ROBOT)
TARGET_POSITION = RoleSpace(Role.TARGET, Property.POSITION)
TARGET_TOOL = RoleSpace(Role.TARGET, Property.POSITION, Role.TOOL)
RADIUS = RoleSpace(Role.TARGET, Property.RADIUS)


def _planner(mirrored: bool = True) -> Planner:
    # Relations read centre to centre (no contact places); the reader is otherwise unused.
    config = load_config(overrides=[f"planner.mirrored_relations={str(mirrored).lower()}"])
    return Planner(Hierarchy(), reader=SimpleNamespace(relation_offset=None),
                   config=config.learner, planner=config.planner)


def _push_aff(model) -> SimpleNamespace:
    """A pushing affordance around `model` (contexts: the object's radius, the relation)."""
    return SimpleNamespace(model=model, output=TARGET_POSITION, contexts=(RADIUS, TARGET_ROBOT))


def _push_like_model(rng: np.random.Generator, outliers: int, n: int = 300) -> LocalLinearModel:
    """`n` rows of a push: the object moves along the contact direction (robot behind it), plus
    `outliers` rows with the same outcome from a far, odd place (a bounce)."""
    model = LocalLinearModel(2, 2, [1, 2])  # input; contexts: radius, relation
    angles = rng.uniform(-np.pi, np.pi, n)
    radius = rng.uniform(0.08, 0.25, n)
    direction = np.stack([np.cos(angles), np.sin(angles)], axis=1)
    relation = direction * (radius + 0.15)[:, None]
    step = rng.uniform(0.02, 0.12, n)[:, None]
    model.add(direction * step, np.concatenate([radius[:, None], relation], axis=1),
              direction * step * 0.9)
    odd = np.tile([[0.6, -0.6]], (outliers, 1))
    model.add(np.tile([[0.1, 0.0]], (outliers, 1)),
              np.concatenate([np.full((outliers, 1), 0.12), odd], axis=1),
              np.tile([[0.1, 0.0]], (outliers, 1)))
    return model


def test_the_context_to_reach_is_where_such_outcomes_usually_come_from():
    rng = np.random.default_rng(0)
    planner = _planner()
    aff = _push_aff(_push_like_model(rng, outliers=3))
    relations = np.array([False, True])  # the radius is fixed, the relation reachable
    current = np.array([0.12, -0.5, 0.4])  # an object of radius 0.12, robot far away
    needed = planner.needed_context(aff, np.array([0.1, 0.0]), current, relations)
    assert needed[0] == 0.12  # what cannot be changed stays as it is
    # Behind the object along the push (+x), at contact distance 0.27 — not the odd rows.
    assert abs(needed[1] - 0.27) < 0.05 and abs(needed[2]) < 0.05
    # Pushing along +y needs the robot below the object.
    needed = planner.needed_context(aff, np.array([0.0, 0.1]), current, relations)
    assert abs(needed[1]) < 0.05 and abs(needed[2] - 0.27) < 0.05


def test_the_relation_to_reach_is_fitted_through_the_outcomes_around_the_push():
    # 150 pushes in random directions: no row's outcome is exactly the wanted one, and one
    # row's relation (the densest) was ~11 degrees off the push on average; the weighted
    # linear fit of relation on outcome around it is ~3 degrees off.
    model = _push_like_model(np.random.default_rng(0), outliers=0, n=150)
    planner = _planner()
    errors = []
    for theta in np.linspace(0.0, 2 * np.pi, 32, endpoint=False):
        u = np.array([np.cos(theta), np.sin(theta)])
        needed = planner.needed_context(_push_aff(model), 0.1 * u,
                                        np.array([0.12, *(-0.5 * u)]), np.array([False, True]))
        off = np.degrees(np.arctan2(needed[2], needed[1]) - theta)
        errors.append(abs((off + 180.0) % 360.0 - 180.0))
    assert np.mean(errors) < 5.0


def test_a_framed_model_knows_where_to_push_from_at_bearings_it_never_saw():
    """Pushes seen only towards the first quadrant: a model in the relation's frame still
    places the robot behind the object for a push towards the third (its rows, turned along
    the wanted outcome, all vote for the same place); in room coordinates the rows vote for
    where they were, ~180 degrees off."""
    rng = np.random.default_rng(2)
    room = _push_like_model(rng, outliers=0, n=150)
    x, c, y = room.data()
    keep = (c[:, 1] > 0) & (c[:, 2] > 0)
    framed = FramedModel(2, 2, [1, 2], relation_frame(ROBOT_POSITION, TARGET_POSITION,
                                                      (RADIUS, TARGET_ROBOT)))
    framed.add(x[keep], c[keep], y[keep])
    planner = _planner()
    u = np.array([-1.0, -1.0]) / np.sqrt(2)
    current = np.array([0.12, *(-0.5 * u)])
    off = {}
    for name, model in (("framed", framed), ("room", room_model(x[keep], c[keep], y[keep]))):
        needed = planner.needed_context(_push_aff(model), 0.1 * u, current,
                                        np.array([False, True]))
        cos = float(needed[1:] @ u) / np.linalg.norm(needed[1:])
        off[name] = np.degrees(np.arccos(np.clip(cos, -1.0, 1.0)))
        if name == "framed":
            assert abs(np.linalg.norm(needed[1:]) - 0.27) < 0.05
    assert off["framed"] < 10.0 and off["room"] > 90.0, off


def room_model(x: np.ndarray, c: np.ndarray, y: np.ndarray) -> LocalLinearModel:
    model = LocalLinearModel(2, 2, [1, 2])
    model.add(x, c, y)
    return model


def test_a_context_change_must_earn_its_complexity():
    assert required_gain(1, 2, 0.1) == 0.1  # adding
    assert required_gain(1, 1, 0.1) == 0.05  # replacing
    assert required_gain(2, 1, 0.1) == 0.0  # removing: as good and simpler is enough


def test_the_planner_refuses_an_action_that_would_touch_what_it_must_avoid():
    """While a tool moves the target, the robot's own motion model screens each action: one
    predicted to bring the robot into contact with the target is not executed."""
    from hadim_cli.learner.planner import Binding

    planner, obs, layout = _avoid_scene()
    obs[layout.space("obj1", Property.POSITION).slice] = [0.4, 0.0]
    towards, away = np.array([1.0, 0.0]), np.array([-1.0, 0.0])
    assert planner.foresees_contact(Binding(target=2, avoid=1), towards, obs)
    assert not planner.foresees_contact(Binding(target=2, avoid=1), away, obs)
    assert not planner.foresees_contact(Binding(target=1), towards, obs)  # nothing to avoid
    # Ending 0.04 m short of touching is still too close: the motion model errs by ~0.03 m.
    obs[layout.space("obj1", Property.POSITION).slice] = [0.15 + 0.27 + 0.04, 0.0]
    assert planner.foresees_contact(Binding(target=2, avoid=1), towards, obs)
    obs[layout.space("obj1", Property.POSITION).slice] = [0.15 + 0.27 + 0.07, 0.0]
    assert not planner.foresees_contact(Binding(target=2, avoid=1), towards, obs)


def _drive_like_model(rng: np.random.Generator) -> LocalLinearModel:
    """A differential drive: action (left, right) moves the robot along ±its heading, so one
    displacement is reached driving forwards with one heading or backwards with the opposite."""
    model = LocalLinearModel(2, 2, [2])
    angles = rng.uniform(-np.pi, np.pi, 400)
    heading = np.stack([np.cos(angles), np.sin(angles)], axis=1)
    action = rng.uniform(-1.0, 1.0, (400, 2))
    forward = 0.05 * (action[:, 0] + action[:, 1])  # turning part left out: not needed here
    model.add(action, heading, heading * forward[:, None])
    return model


def test_the_pose_to_take_is_the_nearest_one_that_produces_the_move():
    """To move 0.08 m along +x the robot can face +x and drive forwards or face -x and drive
    backwards. Facing almost -x already, it keeps that pose instead of turning round."""
    rng = np.random.default_rng(1)
    planner = _planner()
    aff = SimpleNamespace(model=_drive_like_model(rng))
    delta = np.array([0.08, 0.0])
    facing_back = np.array([np.cos(3.0), np.sin(3.0)])
    pose = planner.nearest_pose(aff, delta, facing_back)
    assert pose @ facing_back > 0.9
    facing_ahead = np.array([np.cos(0.2), np.sin(0.2)])
    pose = planner.nearest_pose(aff, delta, facing_ahead)
    assert pose @ facing_ahead > 0.9


def test_a_relation_is_measured_against_where_the_affordance_acts():
    """Spreads of a push's relation come from the rows with an effect (the robot near the
    object), not from all rows (the robot anywhere in the room): 0.14 m off the side of an
    object is not 'behind' it."""
    rng = np.random.default_rng(2)
    planner = _planner()
    model = _push_like_model(rng, outliers=0)
    far = rng.uniform(-1.5, 1.5, (600, 2))  # rows where nothing moved: the robot far away
    model.add(np.zeros((600, 2)), np.concatenate([np.full((600, 1), 0.12), far], axis=1),
              np.zeros((600, 2)))
    aff = _push_aff(model)
    spread = planner._spreads(aff)[1]
    assert spread < 0.35  # contact distances 0.23-0.4 in every direction: about 0.27
    all_rows = np.linalg.norm(model.data()[1][:, 1:].std(axis=0))
    assert all_rows > 1.0


def test_rows_where_nothing_moved_do_not_support_a_push():
    """A robot 0.45 m behind an object has stood there before without moving it: those rows
    are near in (input, context) but show no push, so the step is unsupported and the robot
    first gets to contact."""
    rng = np.random.default_rng(3)
    planner = _planner()
    model = _push_like_model(rng, outliers=0)
    n = 200
    far = np.stack([rng.uniform(0.4, 0.5, n), rng.uniform(-0.05, 0.05, n)], axis=1)
    model.add(rng.uniform(-0.1, 0.1, (n, 2)), np.concatenate([np.full((n, 1), 0.12), far], 1),
              np.zeros((n, 2)))
    aff = _push_aff(model)
    relations = np.array([False, True])
    away = np.array([0.12, 0.45, 0.0])
    assert planner.support_gap(aff, np.array([0.1, 0.0]), away, relations) > 0.5
    at_contact = np.array([0.12, 0.27, 0.0])
    assert planner.support_gap(aff, np.array([0.1, 0.0]), at_contact, relations) < 0.3


def test_a_surface_relation_is_reached_at_the_current_pair_s_contact():
    """With surface relations, the place to push from is computed from the sizes of the
    bodies at hand: a reading of `relation_offset` towards the object puts the robot in
    contact with it (0.15 + 0.12 m from its centre), not at the learned centre distance of
    other objects."""
    from hadim_cli.learner.planner import Binding
    from hadim_cli.learner.spaces import SpaceReader
    from hadim_cli.world.layout import LayoutBounds, ObservationLayout

    layout = ObservationLayout.build(2, 4, LayoutBounds(2, 2, 1.5, 0.25, 0.6))
    obs = np.zeros(layout.size)
    obs[layout.space("robot", Property.RADIUS).slice] = 0.15
    obs[layout.space("obj1", Property.RADIUS).slice] = 0.12
    obs[layout.space("obj1", Property.POSITION).slice] = [0.4, 0.2]
    hierarchy = SimpleNamespace(controllers=lambda space: [])
    planner = Planner(hierarchy, SpaceReader(layout, relation_offset=0.3),
                      load_config().learner)
    u = np.array([0.0, 1.0])
    driven, goal, _ = planner._context_goal(TARGET_ROBOT, 0.3 * u, obs, Binding(target=1))
    assert driven == ROBOT_POSITION
    assert np.allclose(goal, np.array([0.4, 0.2]) - 0.27 * u)
    obs[layout.space("robot", Property.POSITION).slice] = goal  # there: it reads as wanted
    assert np.allclose(planner.value(TARGET_ROBOT, obs, Binding(target=1)), 0.3 * u)


def test_a_trip_is_taken_only_when_it_costs_less_than_pushing_on():
    """`planner.replace_by_cost`: re-place when trip + remaining steps < remaining / rate."""
    from dataclasses import replace

    planner = _planner()
    planner.pc = replace(planner.pc, replace_by_cost=True)
    planner._trip_cost = lambda *args: 5.0  # actions to the better place

    def worth(rate: float, remaining: float, off: float = 0.2) -> bool:
        return planner._worth_replacing(None, None, None, None, None, rate, off, remaining)

    assert worth(0.0, 1.0)  # nothing can be pushed from here
    assert worth(0.5, 10.0)  # 5 + 10 < 20
    assert not worth(0.8, 10.0)  # 5 + 10 > 12.5
    assert not worth(0.5, 2.0)  # near the goal the trip never pays: 5 + 2 > 4
    planner.pc = replace(planner.pc, replace_by_cost=False)
    # The fixed rule: progress < 0.3, or drifted more than `realign` spreads.
    assert worth(0.2, 2.0) and not worth(0.8, 10.0) and worth(0.8, 10.0, off=0.5)


def _avoid_scene():
    """A robot (radius 0.15) at the origin that moves 0.15 m per unit of action, a target
    (obj1, radius 0.12) at (0.6, 0) it must not touch, and a planner over that motion."""
    from hadim_cli.learner.spaces import SpaceReader
    from hadim_cli.world.layout import LayoutBounds, ObservationLayout, Property

    layout = ObservationLayout.build(2, 4, LayoutBounds(2, 2, 1.5, 0.25, 0.6))
    obs = np.zeros(layout.size)
    obs[layout.space("robot", Property.RADIUS).slice] = 0.15
    obs[layout.space("robot", Property.HEADING).slice] = [1.0, 0.0]
    obs[layout.space("obj1", Property.RADIUS).slice] = 0.12
    obs[layout.space("obj1", Property.POSITION).slice] = [0.6, 0.0]
    obs[layout.space("obj2", Property.RADIUS).slice] = 0.1
    obs[layout.space("obj2", Property.POSITION).slice] = [0.3, 0.5]
    actions = np.random.default_rng(1).uniform(-1, 1, (200, 2))
    model = LocalLinearModel(2, 2)
    model.add(actions, None, 0.15 * actions)
    mover = SimpleNamespace(id=0, input=ACTION, output=ROBOT_POSITION, contexts=(),
                            model=model, has_target=False, has_tool=False, competence=1.0)
    hierarchy = SimpleNamespace(
        controllers=lambda space: [mover] if space == ROBOT_POSITION else [],
        with_output=lambda space: [mover] if space == ROBOT_POSITION else [])
    return Planner(hierarchy, SpaceReader(layout), load_config().learner), obs, layout


class _World:
    """An actuator that moves the robot as the motion model says (exactly)."""

    def __init__(self, obs, layout):
        self._obs = obs.copy()
        self.position = layout.space("robot", Property.POSITION).slice
        self.acted = 0

    @property
    def obs(self):
        return self._obs

    @property
    def exhausted(self):
        return self.acted >= 100

    def act(self, action):
        self._obs[self.position] += 0.15 * np.asarray(action)
        self.acted += 1
        return self._obs


class _Wall(_World):
    """An actuator whose robot is against a fixed object: no action moves anything."""

    def act(self, action):
        self.acted += 1
        return self._obs


def test_an_action_that_moved_nothing_is_not_repeated_from_where_it_left():
    """`planner.skip_idle_repeats`: a robot backing into a fixed object did so 28 times, the
    rest of a goal's budget (the planner decides from the observation alone). An action
    that moved nothing is refused from the observation it left; another action, or the same
    one once the world has changed, is not. Off, the attempt spends its whole budget."""
    from dataclasses import replace

    planner, obs, layout = _avoid_scene()
    mover = planner.h.controllers(ROBOT_POSITION)[0]
    world = _Wall(obs, layout)
    back = np.array([-1.0, 0.0])
    assert planner.execute(ACTION, back, Binding(), world, 1, 0) == 1
    assert planner.execute(ACTION, back, Binding(), world, 1, 0) == -1
    assert world.acted == 1
    assert planner.execute(ACTION, np.array([0.0, 1.0]), Binding(), world, 1, 0) == 1
    assert planner.execute(ACTION, np.array([0.0, 1.0]), Binding(), world, 1, 0) == -1
    world._obs[world.position] += 0.01  # something else moved the robot
    assert planner.execute(ACTION, np.array([0.0, 1.0]), Binding(), world, 1, 0) == 1
    # A moving action is never refused.
    free = _World(obs, layout)
    for _ in range(3):
        assert planner.execute(ACTION, back, Binding(), free, 1, 0) == 1

    def attempt(skip: bool) -> int:
        # Off after an idle action from this very observation (the first attempt's): the
        # switch, not a forgotten action, must decide.
        planner.pc = replace(planner.pc, skip_idle_repeats=skip, navigation=False)
        wall = _Wall(obs, layout)
        return planner.reach(mover, Binding(), np.array([-0.5, 0.0]), wall, 40).actions

    assert attempt(skip=True) == 1
    assert attempt(skip=False) == 40


def test_a_robot_place_where_it_would_touch_what_it_must_avoid_is_refused():
    """Pushing a tool that lies against the target can ask for a robot place inside the
    target: going for it touched the target (a failed tool point). The planner refuses such
    a place before moving; a place clear of the target is driven to."""
    from hadim_cli.learner.planner import Binding

    planner, obs, layout = _avoid_scene()
    pushing_tool = SimpleNamespace(id=3, input=ROBOT_POSITION, contexts=(TARGET_ROBOT,))
    b = Binding(target=2, avoid=1)

    def place(goal):
        world = _World(obs, layout)
        done = planner._place(pushing_tool, b, 0, ROBOT_POSITION, np.array(goal), b,
                              planner.h.controllers(ROBOT_POSITION)[0], [0.2], world, 40, 1,
                              None)
        return done, world

    # 0.6 - 0.15 - 0.12 - 0.05 = 0.28: any place closer to the target's centre touches it.
    done, world = place([0.45, 0.05])
    assert done == -1 and world.acted == 0
    done, world = place([0.2, 0.3])
    assert done > 0 and world.acted == done
    assert np.linalg.norm(world.obs[world.position] - [0.2, 0.3]) < 0.05


def test_a_small_remainder_of_an_approached_goal_is_not_worth_a_trip():
    """A target pushed 3 cm past its goal was chased round the tool for 50 actions (and
    touched). A remainder shorter than `small_correction` steps that needs a trip ends the
    attempt: a sub-goal's, or, once the output has moved towards the goal, a goal's whose
    binding has an entity to avoid. The first step of a goal still takes the trip, and so does
    the remainder of a plain push (a trip there risks nothing)."""
    from hadim_cli.learner.planner import Binding

    planner = _planner()
    aff = SimpleNamespace(id=6, model=SimpleNamespace(n=100, context_dims=[2]),
                          contexts=(TARGET_ROBOT,), input=ROBOT_POSITION, output=TARGET_POSITION)
    answer = SimpleNamespace(x=np.array([0.03, 0.0]), y_predicted=np.zeros(2))
    aff.model.infer = lambda delta, c=None: answer
    planner.context = lambda *args: np.array([0.3, 0.0])
    planner.reachable_relations = lambda a: np.array([True])
    planner._spreads = lambda a: [0.1]
    planner.support_gap = lambda *args: 1.0
    planner.needed_context = lambda *args: np.array([-0.3, 0.0])
    planner.step_size = lambda a: 0.1
    trips = []
    planner._reach_context = lambda *args, **kw: trips.append(1) or 7
    actuator = SimpleNamespace(obs=np.zeros(4))
    small = np.array([-0.03, 0.0])
    assert planner._one_step(aff, None, small, actuator, 80, 0, spare_trips=True) == -1
    assert not trips
    assert planner._one_step(aff, None, small, actuator, 80, 0, spare_trips=False) == 7
    assert trips == [1]
    # The loop says which: moved towards the goal, or not yet.
    seen = []
    planner.value = lambda *args: np.array([0.17 if seen else 0.0, 0.0])  # moved by a step

    def flags(b: Binding, depth: int = 0) -> list[bool]:
        seen.clear()
        planner.reach(aff, b, np.array([0.2, 0.0]),
                      SimpleNamespace(obs=None, exhausted=False), 10, depth)
        return list(seen)

    # One step that moves the output, then nothing more can be done.
    planner._one_step = lambda *a, **kw: seen.append(kw["spare_trips"]) or (
        1 if len(seen) == 1 else -1)
    assert flags(Binding(target=2, tool=1, avoid=2)) == [False, True]
    assert flags(Binding(target=1)) == [False, False]
    assert flags(Binding(target=1), depth=1) == [True]  # then within its tolerance


def test_the_tool_level_spares_a_staging_for_a_small_remainder():
    """A target 2.4 cm from its goal: the tool staged round it for that last correction
    shoved it 20 cm off. A level whose input is another object (the tool level) spares such a
    trip once its output has moved towards the goal, with no entity to avoid in its binding
    too (`spare_stagings`); off, or for a level the robot pushes, the remainder is chased."""
    from dataclasses import replace

    planner = _planner()
    tool_position = RoleSpace(Role.TOOL, Property.POSITION)
    tool_level = SimpleNamespace(id=6, model=SimpleNamespace(n=100), contexts=(),
                                 input=tool_position, output=TARGET_POSITION)
    pusher = SimpleNamespace(id=3, model=SimpleNamespace(n=100), contexts=(),
                             input=ROBOT_POSITION, output=TARGET_POSITION)
    seen: list[bool] = []
    planner.value = lambda *args: np.array([0.17 if seen else 0.0, 0.0])  # moved by a step
    planner.step_size = lambda a: 0.17
    planner._one_step = lambda *a, **kw: seen.append(kw["spare_trips"]) or (
        1 if len(seen) == 1 else -1)

    def flags(aff: SimpleNamespace) -> list[bool]:
        seen.clear()
        planner.reach(aff, Binding(target=1, tool=2), np.array([0.2, 0.0]),
                      SimpleNamespace(obs=None, exhausted=False), 10)
        return list(seen)

    assert flags(tool_level) == [False, True]
    assert flags(pusher) == [False, False]
    planner.pc = replace(planner.pc, spare_stagings=False)
    assert flags(tool_level) == [False, False]


def test_a_roughly_aligned_level_pushes_on_and_steers_back_to_the_needed_relation():
    """A tool that slid along the target's side is pushed on and back behind it in one move
    (`planner.steer`): the step asked from the needed relation plus the way back to it.
    Further off than `realign` spreads, the level takes a trip to the needed place."""
    from dataclasses import replace

    from hadim_cli.learner.planner import Binding

    planner, obs, layout = _avoid_scene()  # obj2 (the tool here) at (0.3, 0.5)
    tool_position = RoleSpace(Role.TOOL, Property.POSITION)
    target_tool = RoleSpace(Role.TARGET, Property.POSITION, Role.TOOL)
    aff = SimpleNamespace(id=6, model=SimpleNamespace(n=100, context_dims=[2]),
                          contexts=(target_tool,), input=tool_position, output=TARGET_POSITION)
    b = Binding(target=1, tool=2, avoid=1)
    # The needed relation puts the tool 0.22 m behind the target at (0.6, 0): at (0.38, 0).
    needed_tool = np.array([0.38, 0.0])
    planner._context_plans = lambda *args: iter(
        [(0, target_tool, TARGET_POSITION, needed_tool, Binding(target=2, avoid=1), [aff])])
    steer = planner._steering(aff, b, np.zeros(2), obs)
    assert np.allclose(steer, needed_tool - [0.3, 0.5])
    # A relation held by another entity than the one the input moves: nothing to steer.
    robot_moves = SimpleNamespace(**{**vars(aff), "input": ROBOT_POSITION})
    assert planner._steering(robot_moves, b, np.zeros(2), obs) is None

    step = np.array([0.1, 0.0])
    aff.model.infer = lambda delta, c=None: SimpleNamespace(x=step, y_predicted=np.zeros(2))
    planner.context = lambda *args: np.zeros(2)
    planner.reachable_relations = lambda a: np.array([True])
    planner._spreads = lambda a: [0.1]
    planner.support_gap = lambda *args: 1.0
    planner.needed_context = lambda *args: np.zeros(2)
    planner.step_size = lambda a: 0.1
    calls = []
    planner.execute = lambda space, x, *args, **kw: calls.append(("push", x)) or 1
    planner._reach_context = lambda *args, **kw: calls.append(("trip", None)) or 5
    actuator = SimpleNamespace(obs=obs)
    planner._steer_by_model = lambda *args: None  # no forward model here: the way back
    for off, expected in ((0.3, "push"), (0.6, "trip")):
        calls.clear()
        planner._gap = lambda *args, off=off: off  # spreads from the needed relation
        planner._one_step(aff, b, np.array([0.1, 0.0]), actuator, 80, 0)
        assert calls[0][0] == expected
    calls.clear()
    planner._gap = lambda *args: 0.3
    planner._one_step(aff, b, np.array([0.1, 0.0]), actuator, 80, 0)
    assert np.allclose(calls[0][1], step + steer)
    # With a forward model of the relation, its move (`_steer_by_model`) is the one pushed.
    planner._steer_by_model = lambda *args: np.array([0.05, -0.02])
    calls.clear()
    planner._one_step(aff, b, np.array([0.1, 0.0]), actuator, 80, 0)
    assert np.allclose(calls[0][1], [0.05, -0.02])
    planner.pc = replace(planner.pc, steer=False)
    calls.clear()
    planner._one_step(aff, b, np.array([0.1, 0.0]), actuator, 80, 0)
    assert calls[0][0] == "trip"


def test_a_detour_goes_round_objects_that_leave_no_way_between_them():
    """A tool lying against the target: the way from one side of the pair to the other goes
    round both. Round the target alone, a waypoint fell inside the tool (the robot turned
    back and forth at it, every way there refused)."""
    planner, obs, layout = _avoid_scene()
    obs[layout.space("obj2", Property.POSITION).slice] = [0.38, 0.0]  # against obj1 (0.6, 0)
    obs[layout.space("robot", Property.POSITION).slice] = [0.5, 0.45]
    goal = np.array([0.2, -0.15])
    points = planner._waypoints(ROBOT_POSITION, goal, obs, Binding(target=2, avoid=1), -1)
    assert len(points) > 1
    robot_r = 0.15
    for entity, radius in ((1, 0.12), (2, 0.1)):
        centre = obs[layout.space(f"obj{entity}", Property.POSITION).slice]
        for w in points[:-1]:
            assert np.linalg.norm(w - centre) >= radius + robot_r + planner.pc.approach_margin


def _across(v: np.ndarray, u: np.ndarray) -> float:
    """How far `v` lies off the line along the unit vector `u`."""
    return float(v[0] * u[1] - v[1] * u[0])


def _segment_distance(a: np.ndarray, b: np.ndarray, c: np.ndarray) -> float:
    """Distance from `c` to the segment a → b."""
    s = float(np.clip((c - a) @ (b - a) / ((b - a) @ (b - a)), 0.0, 1.0))
    return float(np.linalg.norm(a + s * (b - a) - c))


@pytest.mark.parametrize("on_line", [True, False])
def test_a_tool_staged_round_the_target_goes_to_the_push_line_in_one_leg(on_line):
    """`line_stagings`: the tool left of the target must stand below-left of it to push it up
    and to the right (the bearing 252° from the target, as for the tool task's 72° points).
    In one leg it goes to the nearest point further back on that push's line whose straight
    way clears the target, then along the line: two legs, the second the push's own
    direction. Off: round the target on an arc, three legs, none along the line."""
    from dataclasses import replace

    planner, obs, layout = _avoid_scene()  # target obj1 (radius 0.12) at (0.6, 0)
    planner.pc = replace(planner.pc, line_stagings=on_line)
    tool = layout.space("obj2", Property.POSITION).slice
    obs[tool] = [0.2, 0.0]
    centre = np.array([0.6, 0.0])
    u = np.array([np.cos(np.deg2rad(252)), np.sin(np.deg2rad(252))])
    goal = centre + 0.23 * u  # the tool against the target, behind it for the push
    tool_as_target = RoleSpace(Role.TARGET, Property.POSITION)
    points = planner._waypoints(tool_as_target, goal, obs, Binding(target=1, tool=2), 2)
    clearance = 0.12 + 0.1 + planner.pc.approach_margin
    np.testing.assert_allclose(points[-1], goal)
    if not on_line:
        assert len(points) == 3
        for w in points[:-1]:
            assert abs(_across(w - centre, u)) > 0.05  # off the line
        return
    assert len(points) == 2
    point = points[0]
    back = (point - centre) @ u
    assert abs(_across(point - centre, u)) < 1e-9 and back > 0.23  # on the line, behind
    # The nearest such point: its straight way from the tool clears the target, and one
    # step nearer along the line it would not.
    assert _segment_distance(np.array([0.2, 0.0]), point, centre) >= clearance
    nearer = centre + (back - LINE_STEP) * u
    assert (np.linalg.norm(nearer - centre) < clearance
            or _segment_distance(np.array([0.2, 0.0]), nearer, centre) < clearance)
    # Nothing in the way: straight there, either way.
    obs[tool] = centre + 0.6 * u
    assert len(planner._waypoints(tool_as_target, goal, obs, Binding(target=1, tool=2), 2)) == 1


def test_a_staging_whose_push_line_leaves_the_room_goes_round_on_the_arc():
    """`line_stagings` needs room behind the place for the tool and for its pusher behind
    it: with the target 0.6 m from a wall, the nearest point further back on the line that
    clears the target leaves room for the tool, not for the robot behind it, so the tool goes
    round the target on the arc's waypoints instead. Away from the wall, the line."""
    from dataclasses import replace

    planner, obs, layout = _avoid_scene()
    planner.pc = replace(planner.pc, line_stagings=True)
    target = layout.space("obj1", Property.POSITION).slice
    centre = np.array([0.6, -1.4])  # the wall at y = -2
    obs[target] = centre
    obs[layout.space("obj2", Property.POSITION).slice] = [0.2, -1.4]
    u = np.array([np.cos(np.deg2rad(252)), np.sin(np.deg2rad(252))])
    goal = centre + 0.23 * u
    points = planner._waypoints(RoleSpace(Role.TARGET, Property.POSITION), goal, obs,
                                Binding(target=1, tool=2), 2)
    assert len(points) == 3
    obs[target] = centre + [0.0, 0.3]
    obs[layout.space("obj2", Property.POSITION).slice] = [0.2, -1.1]
    points = planner._waypoints(RoleSpace(Role.TARGET, Property.POSITION), goal + [0.0, 0.3],
                                obs, Binding(target=1, tool=2), 2)
    assert len(points) == 2


def _disc_push_model(rng: np.random.Generator, n: int = 1500) -> LocalLinearModel:
    """Pushes of a disc by a disc: the object moves along the line of centres by the robot's
    move onto that line (the relation: object minus robot, 0.25 m, any bearing)."""
    model = LocalLinearModel(2, 2, [2])
    bearing = rng.uniform(-np.pi, np.pi, n)
    line = np.stack([np.cos(bearing), np.sin(bearing)], axis=1)
    moves = rng.uniform(-0.1, 0.1, (n, 2))
    along = np.maximum(np.sum(moves * line, axis=1), 0.0)
    model.add(moves, 0.25 * line, along[:, None] * line)
    return model


def test_steering_keeps_the_contact_where_the_push_needs_it():
    """Robot behind an object but 18° off the line of the wanted push: the move asked of the
    robot is the one the level's forward model predicts to push the object the wanted way
    *and* bring the contact back towards the needed relation. Pushing straight along the
    wanted way turns a disc's contact further off."""
    planner = _planner()
    model = _disc_push_model(np.random.default_rng(4))
    aff = SimpleNamespace(id=3, input=ROBOT_POSITION, output=TARGET_POSITION,
                          contexts=(TARGET_ROBOT,), model=model)
    def at(deg):
        return 0.25 * np.array([np.cos(np.radians(deg)), np.sin(np.radians(deg))])

    c, needed = at(-30.0), at(-48.0)
    delta = 0.06 * at(-45.0) / 0.25
    then = model.infer(delta, needed).x
    relations = np.array([True])
    move = planner._steer_by_model(aff, delta, c, needed, then, relations, [0.1])
    assert move is not None

    def after(x):
        return c + model.predict(x[None], c[None])[0] - x

    def angle_off(rel):
        return abs(np.degrees(np.arctan2(rel[1], rel[0])) + 48.0)

    assert angle_off(after(move)) < angle_off(c) < angle_off(after(then))
    assert model.predict(move[None], c[None])[0] @ delta > 0  # and it still pushes the way
    # A level whose contexts hold no relation to its input entity is left to the old rule.
    other = SimpleNamespace(id=4, input=ROBOT_POSITION, output=TARGET_POSITION,
                            contexts=(RADIUS,), model=LocalLinearModel(2, 2, [1]))
    assert planner._steer_by_model(other, delta, np.zeros(1), np.zeros(1), then,
                                   np.array([False]), [0.1]) is None


def _asked_in_a_step(planner: Planner, aff, b: Binding, delta: np.ndarray, want: np.ndarray,
                     goal: np.ndarray, obs: np.ndarray, support_gap: float) -> np.ndarray:
    """The input move one step of the tool level `aff` asks for, its relation 0.2 spreads off
    `want` (within `realign`) and the inverse answer `support_gap` from the data."""
    planner.context = lambda *args: np.zeros(2)
    planner.reachable_relations = lambda a: np.array([True])
    planner._spreads = lambda a: [0.1]
    planner.support_gap = lambda *args: support_gap
    planner.needed_context = lambda *args: want
    planner._gap = lambda *args: 0.2
    calls = []
    planner.execute = lambda space, x, *args, **kw: calls.append(x) or 1
    planner._one_step(aff, b, delta, SimpleNamespace(obs=obs), 80, 0, goal=goal)
    return calls[0]


def test_an_object_input_heads_for_where_it_must_be_when_the_output_is_at_its_goal():
    """`hold_relation`: while the tool's relation to the target is within `realign` of the
    needed one, the tool's move heads for its final place — the target's goal less the needed
    relation — at the inverse model's step, not along the step asked of the target from here.
    Further off, or for the robot (which turns at will), the level's other rules decide."""
    from dataclasses import replace

    planner, obs, _ = _avoid_scene()  # target obj1 at (0.6, 0), tool obj2 at (0.3, 0.5)
    planner.step_size = lambda a: 0.1  # the steps asked are no remainder (0.05)
    # The final place itself, not the pursuit of the line nor the convoy's move along the step.
    planner.pc = replace(planner.pc, pursue_line=False, convoy=False)
    tool_position = RoleSpace(Role.TOOL, Property.POSITION)
    target_tool = RoleSpace(Role.TARGET, Property.POSITION, Role.TOOL)
    step = np.array([0.08, 0.0])
    model = SimpleNamespace(n=100, context_dims=[2],
                            infer=lambda delta, c=None: SimpleNamespace(
                                x=step, y_predicted=np.zeros(2)))
    aff = SimpleNamespace(id=6, model=model, contexts=(target_tool,), input=tool_position,
                          output=TARGET_POSITION)
    b = Binding(target=1, tool=2, avoid=1)
    goal = np.array([1.2, 0.5])
    # The needed relation, read as stored: the tool pressed against the target from behind.
    want = np.array([0.3, 0.0])
    behind = planner.reader.offset_now(target_tool, want, obs, 1, 2)
    assert behind[0] > 0.15 and abs(behind[1]) < 1e-9
    delta = np.array([0.06, 0.05])  # the target's step toward its goal from (0.6, 0)
    way = planner._way_to_final_place(aff, b, delta, want, 0.2, goal, obs)
    final = goal - behind
    assert np.isclose(np.linalg.norm(way), 0.08)
    assert np.allclose(way / 0.08, (final - [0.3, 0.5]) / np.linalg.norm(final - [0.3, 0.5]))
    # Not the place behind the target where it stands now (the step's own direction).
    now = np.array([0.6, 0.0]) - behind - [0.3, 0.5]
    assert abs(way @ now) / (0.08 * np.linalg.norm(now)) < 0.9
    # Off by more than `realign`, the robot as the input, or the switch off: no such move.
    assert planner._way_to_final_place(aff, b, delta, want, 0.6, goal, obs) is None
    robot = SimpleNamespace(**{**vars(aff), "input": ROBOT_POSITION})
    assert planner._way_to_final_place(robot, b, delta, want, 0.2, goal, obs) is None
    assert planner._way_to_final_place(aff, b, delta, want, 0.2, None, obs) is None
    off_switch = replace(planner.pc, hold_relation=False)
    planner.pc, saved = off_switch, planner.pc
    assert planner._way_to_final_place(aff, b, delta, want, 0.2, goal, obs) is None
    planner.pc = saved
    # In a step of the level, that move is what the tool is asked for.
    assert np.allclose(_asked_in_a_step(planner, aff, b, delta, want, goal, obs, 1.0), way)


def test_an_object_input_off_its_line_pursues_a_point_one_step_ahead_on_it():
    """`pursue_line`: the tool heads for the point one inverse-model step ahead of its
    projection on the line it must push along (from its place in the needed relation to the
    target now, along the target's step): off that line it comes back within a step, where
    heading for its final place corrected the offset only as the distance left allowed. On the
    line, both are the step along it."""
    from dataclasses import replace

    planner, obs, layout = _avoid_scene()  # target obj1 at (0.6, 0)
    planner.step_size = lambda a: 0.1  # the steps asked are no remainder (0.05)
    tool_position = RoleSpace(Role.TOOL, Property.POSITION)
    target_tool = RoleSpace(Role.TARGET, Property.POSITION, Role.TOOL)
    model = SimpleNamespace(n=100, context_dims=[2],
                            infer=lambda delta, c=None: SimpleNamespace(
                                x=np.array([0.08, 0.0]), y_predicted=np.zeros(2)))
    aff = SimpleNamespace(id=6, model=model, contexts=(target_tool,), input=tool_position,
                          output=TARGET_POSITION)
    b = Binding(target=1, tool=2, avoid=1)
    want, goal, delta = np.array([0.3, 0.0]), np.array([1.2, 0.0]), np.array([0.06, 0.0])
    behind = np.array([0.6, 0.0]) - planner.reader.offset_now(target_tool, want, obs, 1, 2)
    tool = layout.space("obj2", Property.POSITION).slice

    def ways(at):
        obs[tool] = at
        pursued = planner._way_to_final_place(aff, b, delta, want, 0.2, goal, obs)
        planner.pc, saved = replace(planner.pc, pursue_line=False), planner.pc
        final = planner._way_to_final_place(aff, b, delta, want, 0.2, goal, obs)
        planner.pc = saved
        return pursued, final

    # 6 cm off the line, 3 cm behind its place: a step straight back onto the line ahead.
    at = behind + np.array([-0.03, 0.06])
    pursued, final = ways(at)
    assert np.isclose(np.linalg.norm(pursued), 0.08) and np.isclose(np.linalg.norm(final), 0.08)
    aim = behind + [0.05, 0.0] - at  # 0.1 m: cut to the step
    np.testing.assert_allclose(pursued, 0.08 * aim / np.linalg.norm(aim), atol=1e-9)
    assert abs((at + pursued)[1]) < 0.015 and (at + final)[1] > 0.05  # 1.2 cm off, not 5.4
    # On the line: the step along it, either way.
    pursued, final = ways(behind - [0.05, 0.0])
    np.testing.assert_allclose(pursued, [0.08, 0.0], atol=1e-9)
    np.testing.assert_allclose(final, [0.08, 0.0], atol=1e-9)


def test_an_object_input_nearer_than_needed_pursues_its_line_from_where_it_stands():
    """`near_pursuit`: a tool on the push line but nearer the target than the needed relation
    (which, with `closer_places`, counts as at its place) is asked the inverse model's step
    along the line. Pursuing from the needed place behind it asked 1 cm: less than its
    pusher's sub-goal tolerance, so nothing moved and the point stalled."""
    from dataclasses import replace

    planner, obs, layout = _avoid_scene()  # target obj1 at (0.6, 0)
    planner.step_size = lambda a: 0.1  # the steps asked are no remainder (0.05)
    tool_position = RoleSpace(Role.TOOL, Property.POSITION)
    target_tool = RoleSpace(Role.TARGET, Property.POSITION, Role.TOOL)
    model = SimpleNamespace(n=100, context_dims=[2],
                            infer=lambda delta, c=None: SimpleNamespace(
                                x=np.array([0.08, 0.0]), y_predicted=np.array([0.06, 0.0])))
    aff = SimpleNamespace(id=6, model=model, contexts=(target_tool,), input=tool_position,
                          output=TARGET_POSITION)
    b = Binding(target=1, tool=2, avoid=1)
    want, goal, delta = np.array([0.4, 0.0]), np.array([1.2, 0.0]), np.array([0.06, 0.0])
    behind = np.array([0.6, 0.0]) - planner.reader.offset_now(target_tool, want, obs, 1, 2)
    obs[layout.space("obj2", Property.POSITION).slice] = behind + [0.07, 0.0]
    c = planner.value(target_tool, obs, b)
    assert c[0] < want[0] - 0.05 and abs(c[1]) < 1e-9  # nearer, on the needed bearing
    planner.context = lambda *args: c
    planner.reachable_relations = lambda a: np.array([True])
    planner._spreads = lambda a: [0.1]
    planner.support_gap = lambda *args: 1.0
    planner.needed_context = lambda *args: want
    planner.pc = replace(planner.pc, convoy=False)  # the pursuit, not the convoy's move

    def asked() -> np.ndarray:
        calls = []
        planner.execute = lambda space, x, *args, **kw: calls.append(x) or 1
        planner._one_step(aff, b, delta, SimpleNamespace(obs=obs), 80, 0, goal=goal)
        return calls[0]

    np.testing.assert_allclose(asked(), [0.08, 0.0], atol=1e-9)
    planner.pc = replace(planner.pc, near_pursuit=False)
    np.testing.assert_allclose(asked(), [0.01, 0.0], atol=1e-9)


@pytest.mark.parametrize("direct", [True, False])
def test_the_last_stretch_of_an_object_input_is_pushed_by_the_inverse_answer(direct):
    """`direct_remainders`: 3 cm from its goal, with the tool 6 cm off the line behind the
    target, pursuit of the line asked the tool for a move as far sideways as forward, which
    its pusher refused as a small remainder (the goal ended 5-6 cm short). Shorter than
    `small_correction` steps, the remainder is pushed by the inverse model's answer from
    where the tool stands; off, the pursuit goes on to the end. A longer step still pursues
    the line either way."""
    from dataclasses import replace

    planner, obs, layout = _avoid_scene()  # target obj1 at (0.6, 0)
    planner.pc = replace(planner.pc, direct_remainders=direct, convoy=False)
    planner.step_size = lambda a: 0.1  # small_correction 0.5: remainders under 5 cm
    tool_position = RoleSpace(Role.TOOL, Property.POSITION)
    target_tool = RoleSpace(Role.TARGET, Property.POSITION, Role.TOOL)
    answer = np.array([0.03, -0.005])
    model = SimpleNamespace(n=100, context_dims=[2],
                            infer=lambda delta, c=None: SimpleNamespace(
                                x=answer, y_predicted=delta.copy()))
    aff = SimpleNamespace(id=6, model=model, contexts=(target_tool,), input=tool_position,
                          output=TARGET_POSITION)
    b = Binding(target=1, tool=2, avoid=1)
    want, goal = np.array([0.3, 0.0]), np.array([0.63, 0.0])
    behind = np.array([0.6, 0.0]) - planner.reader.offset_now(target_tool, want, obs, 1, 2)
    obs[layout.space("obj2", Property.POSITION).slice] = behind + [0.0, 0.06]
    small, long = np.array([0.03, 0.0]), np.array([0.08, 0.0])
    assert planner._way_to_final_place(aff, b, long, want, 0.2, goal, obs) is not None
    pursued = planner._way_to_final_place(aff, b, small, want, 0.2, goal, obs)
    assert (pursued is None) == direct
    # In a step of the level: the inverse answer, or the pursuit's move mostly sideways.
    asked = _asked_in_a_step(planner, aff, b, small, want, goal, obs, 0.0)
    if direct:
        np.testing.assert_allclose(asked, answer)
    else:
        np.testing.assert_allclose(asked, pursued)
        assert abs(pursued[1]) > abs(pursued[0])


def _action_pusher(pose_places: bool) -> tuple[Planner, SimpleNamespace]:
    """An affordance pushing the target by wheel commands, with the target-robot relation and
    the robot's heading as contexts: in its rows the robot always faced the object and drove
    forward into it, from every bearing."""
    from hadim_cli.learner.navigation import ROBOT_HEADING
    from hadim_cli.learner.spaces import ACTION

    rng = np.random.default_rng(3)
    n = 300
    angles = rng.uniform(-np.pi, np.pi, n)
    u = np.stack([np.cos(angles), np.sin(angles)], axis=1)
    speed = rng.uniform(0.3, 1.0, n)[:, None]
    model = LocalLinearModel(2, 2, [2, 2])  # wheels; contexts: relation, heading
    model.add(np.repeat(speed, 2, axis=1), np.concatenate([0.27 * u, u], axis=1),
              0.1 * speed * u)
    aff = SimpleNamespace(id=3, input=ACTION, output=TARGET_POSITION, model=model,
                          contexts=(TARGET_ROBOT, ROBOT_HEADING))
    config = load_config(overrides=[f"planner.pose_places={str(pose_places).lower()}"])
    return Planner(Hierarchy(), None, config.learner, config.planner), aff


def test_an_action_pusher_is_placed_with_the_heading_its_pushes_were_made_facing():
    """`pose_places`: the place a push by wheel commands is made from includes the robot's
    heading (the data's, facing the push), not the one the robot has before the trip (it
    turned back to that after driving there, and pushed sideways)."""
    delta = np.array([0.06, 0.0])
    current = np.array([-0.2, 0.4, 0.0, 1.0])  # far off, facing +y
    planner, aff = _action_pusher(True)
    free = np.array([True, False]) | planner._poses(aff)
    needed = planner.needed_context(aff, delta, current, free)
    assert abs(needed[0] - 0.27) < 0.05 and abs(needed[1]) < 0.05
    assert needed[2] > 0.95
    np.testing.assert_allclose(planner._needed_heading(aff, needed),
                               needed[2:] / np.linalg.norm(needed[2:]))
    off, aff_off = _action_pusher(False)
    assert not off._poses(aff_off).any() and off._needed_heading(aff_off, needed) is None
    kept = off.needed_context(aff_off, delta, current, np.array([True, False]))
    np.testing.assert_array_equal(kept[2:], current[2:])


@pytest.mark.parametrize("route_search", [True, False])
def test_the_place_of_an_action_pusher_is_driven_to_facing_its_heading(route_search):
    """The robot's place for such a pusher is one navigation target with the heading needed;
    the heading is not then placed again once the robot faces it. With `route_search` the
    trip is searched whole (the search goes round the objects), without the waypoints
    round them; without it, through the waypoints."""
    from dataclasses import replace

    from hadim_cli.learner.navigation import ROBOT_HEADING

    planner, aff = _action_pusher(True)
    # (this reader has no room: `room_places` is tested on its own)
    planner.pc = replace(planner.pc, route_search=route_search, room_places=False)
    places, searched = [], []
    obs_heading = np.array([0.0, 1.0])

    def navigate(route, b, actuator, budget, near=-1, search=False):
        places.extend(route)
        searched.append(search)
        obs_heading[:] = route[-1].heading  # arrives facing it
        return 3

    planner.navigate = navigate
    planner._navigating = lambda: True
    planner._spreads = lambda a: [0.3, 1.0]
    planner.step_size = lambda a: 0.1
    planner._waypoints = lambda driven, goal, obs, b, mover: [goal + [0.0, 0.4], goal]
    planner.value = lambda space, obs, b: (obs_heading.copy() if space == ROBOT_HEADING
                                           else np.zeros(2))
    planner.reader = SimpleNamespace(offset_now=lambda space, want, *a: want,
                                     relation_offset=None)  # centre to centre
    placed_headings = []
    orig = planner._place

    def place(aff_, b, i, driven, goal, *args):
        if driven == ROBOT_HEADING:
            placed_headings.append(goal)
        return orig(aff_, b, i, driven, goal, *args)

    planner._place = place
    planner._drivers = lambda a, driven, sub_b, b: [aff]
    world = SimpleNamespace(obs=np.zeros(4), exhausted=False)
    needed = np.array([0.27, 0.0, 1.0, 0.0])
    used = planner._reach_context(aff, Binding(target=1), needed, world, 40, 1)
    assert used == 3 and searched == [route_search]
    assert len(places) == (1 if route_search else 2)
    np.testing.assert_allclose(places[-1].heading, [1.0, 0.0])
    assert placed_headings == []  # facing it already: no turn on the spot after the trip


def _push_level(relation_now, needed) -> tuple[Planner, SimpleNamespace]:
    """A push level (`robot.position → target.position | target-robot`, spread 0.1, step 0.1)
    whose relation reads `relation_now` and whose step asks for `needed`; its inverse answer
    for a step is the step itself, predicted whole and supported where it stands."""
    planner = _planner()
    aff = SimpleNamespace(id=3, model=SimpleNamespace(n=100, context_dims=[2]),
                          contexts=(TARGET_ROBOT,), input=ROBOT_POSITION, output=TARGET_POSITION)
    aff.model.infer = lambda delta, c=None: SimpleNamespace(x=delta.copy(),
                                                            y_predicted=delta.copy())
    planner.context = lambda *args: np.array(relation_now, dtype=float)
    planner.reachable_relations = lambda a: np.array([True])
    planner._spreads = lambda a: [0.1]
    planner.support_gap = lambda *args: 0.0
    planner.needed_context = lambda *args: np.array(needed, dtype=float)
    planner.step_size = lambda a: 0.1
    return planner, aff


def _step_after(planner: Planner, aff, trip_of: tuple[int, ...]) -> int:
    """`_one_step` of a 5 cm push of `aff` after an action that served the trips of the
    affordances `trip_of`."""
    planner._placed_for = frozenset(trip_of)
    return planner._one_step(aff, Binding(target=1), np.array([0.05, 0.0]),
                             SimpleNamespace(obs=np.zeros(4)), 80, 1)


def test_a_trip_under_way_goes_on_until_it_arrives():
    """`finish_trips`: a level whose last action served the trip to its needed context keeps
    going there while the relation is off by more than `place_support`, even back within
    `realign` with a push predicted to work; deciding afresh, the same level pushes on (the
    robot went to and fro across `realign`: a trip, a push, a trip again)."""
    from dataclasses import replace

    # The push from here is supported, its relation 0.3 spreads off the needed one.
    planner, aff = _push_level([-0.3, 0.03], [-0.3, 0.0])
    planner.pc = replace(planner.pc, finish_trips=True)
    done = []
    planner._reach_context = lambda *args, **kw: done.append("trip") or 2
    planner._steer = lambda *args, **kw: done.append("steer") or 1
    planner.execute = lambda *args, **kw: done.append("push") or 1
    assert _step_after(planner, aff, trip_of=()) == 1
    assert done == ["push"]
    assert _step_after(planner, aff, trip_of=(3,)) == 2  # the last action was its trip
    assert done == ["push", "trip"]
    _step_after(planner, aff, trip_of=(5,))  # another level's trip: no matter here
    assert done[-1] == "push"
    planner.pc = replace(planner.pc, finish_trips=False)
    _step_after(planner, aff, trip_of=(3,))
    assert done[-1] == "push"


@pytest.mark.parametrize("heading_now", [90.0, -40.0, 10.0, 170.0])
def test_a_trip_at_its_place_goes_on_until_the_robot_faces_its_push(heading_now):
    """`face_places`: a level whose last action served its own trip, now at its place (the
    relation as needed), goes on with the trip while the robot's heading is off the one the
    place was taken with by more than `heading_tolerance` (either way along it counts):
    otherwise the push from there turned first, and a robot that the trip had turned 57° one
    way turned 57° back. Facing it, another level's trip, or the switch off: it pushes."""
    from dataclasses import replace

    from hadim_cli.learner.navigation import ROBOT_HEADING

    planner, aff = _push_level([-0.3, 0.0], [-0.3, 0.0])  # at its place
    planner.pc = replace(planner.pc, face_places=True)
    planner._navigating = lambda: True
    planner.heading_for = lambda then, obs, b: then / np.linalg.norm(then)  # facing +x
    angle = np.deg2rad(heading_now)
    planner.value = lambda space, obs, b: (np.array([np.cos(angle), np.sin(angle)])
                                           if space == ROBOT_HEADING else np.zeros(2))
    done = []
    planner._reach_context = lambda *args, **kw: done.append(
        "trip" if kw.get("facing") is None else "face") or 1
    planner.execute = lambda *args, **kw: done.append("push") or 1
    facing = abs(np.cos(angle)) >= np.cos(planner.pc.heading_tolerance)
    _step_after(planner, aff, trip_of=(3,))  # the last action was this level's trip
    assert done == ["push" if facing else "face"]
    _step_after(planner, aff, trip_of=(5,))  # another level's trip: no matter here
    assert done[-1] == "push"
    planner.pc = replace(planner.pc, face_places=False)
    _step_after(planner, aff, trip_of=(3,))
    assert done[-1] == "push"


def test_a_trip_that_only_turns_is_driven_with_its_heading():
    """What `face_places` asks of `_reach_context`: a place the robot already stands at
    (within a quarter step) is skipped, unless the trip goes on for its heading; then the
    navigator is given the place with that heading."""
    from dataclasses import replace

    from hadim_cli.learner.navigation import ROBOT_HEADING

    planner, aff = _action_pusher(False)  # the heading is not in the needed context
    planner.pc = replace(planner.pc, route_search=True, room_places=False)  # (no room here)
    aff.input = ROBOT_POSITION
    places = []

    def navigate(route, b, actuator, budget, near=-1, search=False):
        places.extend(route)
        return 1

    planner.navigate = navigate
    planner._navigating = lambda: True
    planner._spreads = lambda a: [0.3, 1.0]
    planner.step_size = lambda a: 0.1
    planner._waypoints = lambda driven, goal, obs, b, mover: [goal]
    planner.value = lambda space, obs, b: (np.array([0.0, 1.0]) if space == ROBOT_HEADING
                                           else np.zeros(2))
    planner.reader = SimpleNamespace(offset_now=lambda space, want, *a: want,
                                     relation_offset=None)
    planner.heading_for = lambda then, obs, b: np.array([1.0, 0.0])
    planner._drivers = lambda a, driven, sub_b, b: [aff]
    world = SimpleNamespace(obs=np.zeros(4), exhausted=False)
    needed = np.array([0.01, 0.0, 0.0, 1.0])  # the robot stands 1 cm from its place
    then = np.array([0.05, 0.0])
    assert planner._reach_context(aff, Binding(target=1), needed, world, 40, 1,
                                  then=then) == 0
    assert places == []
    assert planner._reach_context(aff, Binding(target=1), needed, world, 40, 1, then=then,
                                  facing=np.array([1.0, 0.0])) == 1
    assert len(places) == 1
    np.testing.assert_allclose(places[0].position, -needed[:2])
    np.testing.assert_allclose(places[0].heading, [1.0, 0.0])


def test_the_actions_of_a_trip_say_whose_trip_it_is():
    """What `finish_trips` reads: after an action taken while placing the context of an
    affordance, `_placed_for` names that affordance; after a plain push, none."""
    from hadim_cli.learner.planner import Pursuit

    planner = _planner()
    world = SimpleNamespace(act=lambda action: None, obs=np.zeros(4))
    planner.stack.append(Pursuit("A6 target.position", np.zeros(2), Binding(target=1)))
    planner.stack.append(Pursuit("place target-robot for A4", np.zeros(2), Binding(), 4))
    planner._act(world, np.zeros(2))
    assert planner._placed_for == frozenset({4})
    planner.stack.pop()
    planner._act(world, np.zeros(2))
    assert planner._placed_for == frozenset()


def _pusher_at(relation_now, needed, closer: bool):
    """A push level (`robot.position → target.position | target-robot`, spread 0.1) whose
    relation reads `relation_now` and whose step asks for `needed`; what `_one_step` does:
    'trip' (a re-placement) or 'push' (the inverse answer executed)."""
    from dataclasses import replace

    planner, aff = _push_level(relation_now, needed)
    planner.pc = replace(planner.pc, closer_places=closer, steer=False, hold_relation=False)
    done = []
    planner._reach_context = lambda *args, **kw: done.append("trip") or 3
    planner.execute = lambda *args, **kw: done.append("push") or 1
    planner._one_step(aff, Binding(target=1), np.array([0.05, 0.0]),
                      SimpleNamespace(obs=np.zeros(4)), 80, 0, spare_trips=False)
    return done[0]


def test_a_pusher_nearer_on_the_needed_bearing_stands_at_its_place():
    """`planner.closer_places`: the rows a small push is chosen from began up to 9 cm short of
    contact; the push that closed that gap read as a pusher 9 cm off its place, and the next
    step sent it back there. On the needed bearing and nearer, it pushes; off the bearing, or
    further than needed, it still re-places."""
    contact, gap = [0.3, 0.0], [0.39, 0.0]
    assert _pusher_at(contact, gap, closer=False) == "trip"
    assert _pusher_at(contact, gap, closer=True) == "push"
    turned = 0.3 * np.array([np.cos(0.5), np.sin(0.5)])  # in contact, 29° off the bearing
    assert _pusher_at(turned, gap, closer=True) == "trip"
    assert _pusher_at([0.49, 0.0], gap, closer=True) == "trip"  # 10 cm further than needed


def test_a_trip_drives_to_contact_on_the_needed_bearing():
    """`planner.contact_places` (with `closer_places`): the place a trip drives to is the
    needed relation brought to contact (plus the contact margin) on its bearing; a relation
    already within that, and a context that is not a relation the planner drives, stay."""
    from dataclasses import replace

    from hadim_cli.learner.affordance import CONTACT_MARGIN

    planner = Planner(Hierarchy(), SimpleNamespace(relation_offset=0.3),
                      load_config().learner)
    aff = SimpleNamespace(id=3, model=SimpleNamespace(n=100, context_dims=(2, 1)),
                          contexts=(TARGET_ROBOT, RADIUS), input=ROBOT_POSITION,
                          output=TARGET_POSITION)
    answer = SimpleNamespace(x=np.array([0.05, 0.0]), y_predicted=np.zeros(2))
    aff.model.infer = lambda delta, c=None: answer
    planner.context = lambda *args: np.array([0.6, 0.0, 0.9])  # far off: a trip
    planner.reachable_relations = lambda a: np.array([True, False])
    planner._spreads = lambda a: [0.1, 0.1]
    planner.support_gap = lambda *args: 0.0
    planner.step_size = lambda a: 0.1
    seen = []
    planner._reach_context = lambda a, b, needed, *args, **kw: seen.append(needed.copy()) or 3

    def trip_to(needed: np.ndarray) -> np.ndarray:
        planner.needed_context = lambda *args: needed
        planner._one_step(aff, Binding(target=1), np.array([0.05, 0.0]),
                          SimpleNamespace(obs=np.zeros(4)), 80, 0, spare_trips=False)
        return seen[-1]

    needed = np.array([0.0, 0.42, 0.9])
    for contact, closer, want in (
            (False, True, needed),
            (True, False, needed),
            (True, True, np.array([0.0, 0.3 + CONTACT_MARGIN, 0.9]))):
        planner.pc = replace(planner.pc, contact_places=contact, closer_places=closer,
                             steer=False, hold_relation=False)
        assert np.allclose(trip_to(needed), want)
    near = np.array([0.0, 0.31, 0.9])
    assert np.allclose(trip_to(near), near)


def test_only_the_pushers_relation_is_brought_to_contact():
    """`planner.pusher_contacts`: a tool affordance whose context is the robot's relation to
    the target (one learner's was, until 2280) must not drive the robot against the target;
    its tool's relation still goes to contact. Off, both did."""
    from dataclasses import replace

    from hadim_cli.learner.affordance import CONTACT_MARGIN

    planner = Planner(Hierarchy(), SimpleNamespace(relation_offset=0.3),
                      load_config().learner)
    target_tool = RoleSpace(Role.TARGET, Property.POSITION, Role.TOOL)
    tool_level = SimpleNamespace(contexts=(TARGET_ROBOT, target_tool),
                                 model=SimpleNamespace(context_dims=(2, 2)),
                                 input=RoleSpace(Role.TOOL, Property.POSITION))
    pusher = SimpleNamespace(contexts=(TARGET_ROBOT,), model=SimpleNamespace(context_dims=(2,)),
                             input=ROBOT_POSITION)
    driven = np.array([True, True])
    needed = np.array([0.0, 0.45, 0.42, 0.0])
    contact = 0.3 + CONTACT_MARGIN
    out = planner._at_contact(tool_level, needed, driven)
    assert np.allclose(out, [0.0, 0.45, contact, 0.0])
    assert np.allclose(planner._at_contact(pusher, needed[:2], driven[:1]), [0.0, contact])
    planner.pc = replace(planner.pc, pusher_contacts=False)
    assert np.allclose(planner._at_contact(tool_level, needed, driven),
                       [0.0, contact, contact, 0.0])


def test_a_needed_relation_inside_the_object_gives_way_to_the_rows_own():
    """`planner.relations_seen`: rows agreeing on a push from both sides of an object fit a
    relation inside it (0.087 from rows of 0.30-0.63, traced on a learner whose every tool
    placement then shoved the target). Such a fit gives way to the relation of the row most
    rows agree with; a fit within the rows' lengths (less their spread) stands, and so does
    any context that is not a relative position."""
    planner = _planner()
    aff = SimpleNamespace(contexts=(TARGET_ROBOT, RADIUS),
                          model=SimpleNamespace(context_dims=(2, 1)))
    rows = np.array([[0.30, 0.00, 0.1], [-0.30, 0.05, 0.1], [0.00, 0.35, 0.1],
                     [0.63, 0.00, 0.1]])
    best = rows[2]
    inside = np.array([0.087, 0.007, 0.02])
    assert np.allclose(planner._seen_relation(aff, inside, rows, best), [0.0, 0.35, 0.02])
    near = np.array([0.25, 0.0, 0.02])  # 5 cm short of the shortest row: within the spread
    assert np.allclose(planner._seen_relation(aff, near, rows, best), near)


def test_the_needed_context_checks_its_relation_against_the_rows_when_asked():
    """`needed_context` hands its fit to `_seen_relation` with `relations_seen` on: a fit
    inside the object (stood in for here) comes back as a relation of the rows."""
    from dataclasses import replace

    rng = np.random.default_rng(0)
    model = _push_like_model(rng, outliers=0)
    aff = SimpleNamespace(model=model, contexts=(RADIUS, TARGET_ROBOT), id=1,
                          output=TARGET_POSITION)
    planner = _planner()
    planner._relation_at = lambda dy, rel, w: np.array([0.01, 0.0])  # a fit inside
    c = np.array([0.12, 0.3, 0.0])
    relations = np.array([False, True])
    delta = np.array([0.05, 0.0])
    assert np.allclose(planner.needed_context(aff, delta, c, relations)[1:], [0.01, 0.0])
    planner.pc = replace(planner.pc, relations_seen=True)
    needed = planner.needed_context(aff, delta, c, relations)
    assert np.linalg.norm(needed[1:]) > 0.2  # a row's: radius + 0.15 from the centre


def test_a_needed_relation_that_stages_an_object_inside_another_is_brought_out_to_contact():
    """`planner.solid_bodies`: a relative position shorter than the reading at contact (the
    relation offset, 0.3 here) asks for one body inside the other. An object (the tool) can
    be staged there only by shoving the other (a young tool affordance asked for a tool 14 cm
    inside its target): brought to contact on its own bearing. The robot's place pressed
    into the object it pushes stands (its trip ends pushing), and so do a relation at or
    beyond contact, one the planner does not drive, and a context that is not a relative
    position."""
    planner = _planner()
    planner.reader = SimpleNamespace(relation_offset=0.3)
    aff = SimpleNamespace(contexts=(TARGET_TOOL, TARGET_TOOL, RADIUS, TARGET_ROBOT),
                          model=SimpleNamespace(context_dims=(2, 2, 1, 2)))
    needed = np.array([-0.06, -0.08, 0.0, 0.1, 0.05, -0.1, 0.0])
    driven = np.array([True, False, True, True])
    out = planner._out_of_bodies(aff, needed, driven)
    assert np.allclose(out[:2], [-0.18, -0.24])  # 0.3 on the bearing of (-0.06, -0.08)
    assert np.allclose(out[2:], needed[2:])
    apart = np.array([0.0, 0.31, 0.0, 0.1, 0.05, -0.1, 0.0])
    assert np.allclose(planner._out_of_bodies(aff, apart, driven), apart)


def test_the_needed_context_keeps_bodies_apart_when_asked():
    """`needed_context` hands its fit to `_out_of_bodies` with `solid_bodies` on: a tool's
    place fitted inside the target (stood in for here) comes back at contact on its bearing;
    off, the fit stands."""
    from dataclasses import replace

    rng = np.random.default_rng(0)
    model = _push_like_model(rng, outliers=0)
    aff = SimpleNamespace(model=model, contexts=(RADIUS, TARGET_TOOL), id=1,
                          output=TARGET_POSITION)
    planner = _planner()
    planner.reader = SimpleNamespace(relation_offset=0.3)  # relations read from surfaces
    planner._relation_at = lambda dy, rel, w: np.array([-0.05, 0.0])  # a fit inside
    c = np.array([0.12, 0.3, 0.0])
    relations = np.array([False, True])
    delta = np.array([0.05, 0.0])
    planner.pc = replace(planner.pc, solid_bodies=False)
    assert np.allclose(planner.needed_context(aff, delta, c, relations)[1:], [-0.05, 0.0])
    planner.pc = replace(planner.pc, solid_bodies=True)
    assert np.allclose(planner.needed_context(aff, delta, c, relations)[1:], [-0.3, 0.0])


def test_a_trip_keeps_out_of_every_object_and_reaches_the_one_it_is_taken_next_to():
    """`Planner._obstacles`: every object is a disc of contact plus the contact margin round
    it, the entity to avoid one of its avoid distance, and the object the place is next to
    one that ends just short of the place (else the place itself would lie within it and
    no way would lead there)."""
    planner = _planner()
    centres = {1: np.array([1.0, 0.0]), 2: np.array([0.5, 0.0]), 3: np.array([-1.0, 1.0])}
    radii = {0: 0.15, 1: 0.12, 2: 0.1, 3: 0.2}
    planner.reader = SimpleNamespace(
        layout=SimpleNamespace(entities=("robot", "a", "b", "c")),
        entity_position=lambda obs, e: centres[e], entity_radius=lambda obs, e: radii[e])
    place = Place(np.array([0.25, 0.0]), np.array([1.0, 0.0]))  # 0.25 behind object 2
    discs = planner._obstacles(Binding(target=2, avoid=1), np.zeros(4), 2, place)
    np.testing.assert_allclose(discs.centres, [centres[1], centres[2], centres[3]])
    assert discs.radii[0] == pytest.approx(0.15 + 0.12 + planner.pc.avoid_margin)
    assert discs.radii[1] == pytest.approx(0.25 - 0.005)
    assert discs.radii[2] == pytest.approx(0.15 + 0.2 + 0.02)
    assert not discs.holds(place.position)


def _one_sided_pushes(bias_deg: float, n: int = 300) -> LocalLinearModel:
    """`n` pushes each made from a relation `bias_deg` to one side of the push's line: the
    rows a learner holds when most of its pushes struck their object off its centre."""
    rng = np.random.default_rng(4)
    angles = rng.uniform(-np.pi, np.pi, n)
    bias = np.deg2rad(bias_deg)
    direction = np.stack([np.cos(angles), np.sin(angles)], axis=1)
    side = np.stack([np.cos(angles + bias), np.sin(angles + bias)], axis=1)
    radius = rng.uniform(0.08, 0.25, n)
    step = rng.uniform(0.02, 0.12, n)[:, None]
    model = LocalLinearModel(2, 2, [1, 2])  # input; contexts: radius, relation
    model.add(direction * step, np.concatenate([radius[:, None],
                                                side * (radius + 0.15)[:, None]], axis=1),
              direction * step * 0.9)
    return model


def _bearing(v: np.ndarray) -> float:
    return float(np.degrees(np.arctan2(v[1], v[0])))


@pytest.mark.parametrize("theta", [0.0, 50.0, -140.0])
def test_a_place_fitted_with_its_mirror_images_lies_on_the_line_of_its_push(theta):
    """`mirrored_relations` (on by default): pushes all made from 9° to one side of their
    line put the place 9° off the line when fitted over the rows as stored; with each row's
    mirror image across the wanted push the place lies on the line, as far from the object
    as the rows' (radius + 0.15)."""
    model = _one_sided_pushes(9.0)
    u = np.array([np.cos(np.deg2rad(theta)), np.sin(np.deg2rad(theta))])
    aff = _push_aff(model)
    current = np.array([0.12, *(-0.5 * u)])
    relations = np.array([False, True])
    stored = _planner(mirrored=False).needed_context(aff, 0.08 * u, current, relations)
    needed = _planner().needed_context(aff, 0.08 * u, current, relations)
    assert needed[0] == 0.12
    off = (_bearing(needed[1:]) - theta + 180.0) % 360.0 - 180.0
    off_stored = (_bearing(stored[1:]) - theta + 180.0) % 360.0 - 180.0
    assert abs(off) < 1.0 and off_stored > 6.0, (off, off_stored)
    assert abs(np.linalg.norm(needed[1:]) - 0.27) < 0.04


def test_mirror_images_reflect_outcomes_relations_and_headings_and_keep_sizes():
    """`Planner._mirrored` across the line of a push along +x: every 2-D vector of a row
    (its outcome, its relation, the robot's heading) is reflected, its radius is kept; an
    affordance with an absolute position among its contexts has no mirror image."""
    from hadim_cli.learner.navigation import ROBOT_HEADING

    model = SimpleNamespace(context_dims=[1, 2, 2])
    aff = SimpleNamespace(model=model, output=TARGET_POSITION,
                          contexts=(RADIUS, TARGET_ROBOT, ROBOT_HEADING))
    heading = np.array([np.cos(0.5), np.sin(0.5)])
    ctx = np.array([[0.12, 0.25, 0.04, *heading]])
    y = np.array([[0.1, 0.02]])
    out = Planner._mirrored(aff, ctx, y, np.array([0.3, 0.0]))
    assert out is not None
    both_ctx, both_y = out
    np.testing.assert_array_equal(both_ctx[0], ctx[0])
    np.testing.assert_allclose(both_ctx[1], [0.12, 0.25, -0.04, heading[0], -heading[1]])
    np.testing.assert_allclose(both_y, [[0.1, 0.02], [0.1, -0.02]])
    # Along another line: reflected across it, the push along it is its own image.
    u = np.array([0.6, 0.8])
    _, image = Planner._mirrored(aff, ctx, 0.1 * u[None], u)
    np.testing.assert_allclose(image[1], 0.1 * u)
    absolute = SimpleNamespace(model=SimpleNamespace(context_dims=[1, 2]), output=TARGET_POSITION,
                               contexts=(RADIUS, TARGET_POSITION))
    assert Planner._mirrored(absolute, ctx[:, :3], y, np.array([0.3, 0.0])) is None


def _tool_level(answer: np.ndarray, predict) -> SimpleNamespace:
    """A tool level (`tool.position → target.position | target-tool`) whose inverse model
    answers `answer` for any outcome (predicting it exactly) and whose forward model is
    `predict(moves, contexts)`."""
    target_tool = RoleSpace(Role.TARGET, Property.POSITION, Role.TOOL)
    model = SimpleNamespace(n=100, context_dims=[2], predict=predict,
                            infer=lambda delta, c=None: SimpleNamespace(
                                x=answer.copy(), y_predicted=delta.copy()))
    return SimpleNamespace(id=6, model=model, contexts=(target_tool,),
                           input=RoleSpace(Role.TOOL, Property.POSITION), output=TARGET_POSITION)


def test_a_convoy_moves_the_tool_along_the_targets_way_and_tells_its_pusher():
    """`convoy`: a tool 6 cm off the line behind the target, within `realign`, is asked to
    move along the target's step — not back onto the line, as the pursuit asks — at the length
    whose outcome its forward model predicts nearest the step (the target moves 0.6 of the
    tool's move: 0.1 m for a 6 cm step, not the inverse answer's 8 cm). While that move is
    executed, the planner knows the entity the tool pushes (its pusher pushes straight);
    after it, no longer. Off: the pursuit's move, 14° and more off the target's way."""
    from dataclasses import replace

    planner, obs, layout = _avoid_scene()  # target obj1 at (0.6, 0), radius 0.12
    planner.step_size = lambda a: 0.1  # the steps asked are no remainder
    aff = _tool_level(np.array([0.08, 0.0]), lambda x, c: 0.6 * x)
    b = Binding(target=1, tool=2, avoid=1)
    want, goal = np.array([0.3, 0.0]), np.array([1.2, 0.3])
    way = (goal - [0.6, 0.0]) / np.linalg.norm(goal - [0.6, 0.0])
    behind = [0.6, 0.0] - planner.reader.offset_now(aff.contexts[0], want, obs, 1, 2)
    obs[layout.space("obj2", Property.POSITION).slice] = behind + [0.0, -0.06]
    planner.context = lambda *args: np.zeros(2)
    planner.reachable_relations = lambda a: np.array([True])
    planner._spreads = lambda a: [0.1]
    planner.support_gap = lambda *args: 1.0
    planner.needed_context = lambda *args: want
    planner._gap = lambda *args: 0.2

    def asked() -> tuple[np.ndarray, int]:
        calls = []
        planner.execute = lambda space, x, *args, **kw: calls.append(
            (x, planner._convoy_output)) or 1
        planner._one_step(aff, b, 0.06 * way, SimpleNamespace(obs=obs), 80, 0, goal=goal)
        return calls[0]

    move, pushed = asked()
    np.testing.assert_allclose(move, 0.1 * way, atol=1e-12)
    assert pushed == 1 and planner._convoy_output == -1
    planner.pc = replace(planner.pc, convoy=False)
    move, pushed = asked()
    assert pushed == -1
    assert np.degrees(np.arccos(move @ way / np.linalg.norm(move))) > 14.0


def test_a_relation_trailing_on_its_bearing_is_taken_at_its_own_length():
    """`_trailing`: a driven relation longer than its place (the tool behind the target, not
    yet touching it) is brought to its own length on the place's bearing; a shorter one, and
    one the planner does not drive, stay the place's."""
    aff = SimpleNamespace(model=SimpleNamespace(context_dims=[2, 2, 1]))
    near = np.array([0.05, 0.0, 0.05, 0.0, 0.3])
    c = np.array([0.0, 0.2, 0.0, 0.02, 0.9])
    out = _at_own_lengths(aff, c, near, np.array([True, True, False]), further=True)
    np.testing.assert_allclose(out[:2], [0.2, 0.0])   # trailing: its length, the place's bearing
    np.testing.assert_allclose(out[2:4], near[2:4])   # nearer than the place: the place
    np.testing.assert_allclose(out[4:], near[4:])     # not driven
    np.testing.assert_allclose(near, [0.05, 0.0, 0.05, 0.0, 0.3])  # not changed in place


def test_a_tool_trailing_behind_the_target_on_its_bearing_holds_the_convoy():
    """`convoy_trailing`: the tool 15 cm short of its place at contact, on the place's bearing,
    holds the relation for a convoy (its first push closes the distance); off, the 15 cm count
    as drift past `realign` and a trip to the place would follow. Off its bearing by 30°, the
    tool holds nothing either way."""
    from dataclasses import replace

    planner, obs, layout = _avoid_scene()
    planner.step_size = lambda a: 0.1
    aff = _tool_level(np.array([0.08, 0.0]), lambda x, c: 0.6 * x)
    b = Binding(target=1, tool=2, avoid=1)
    spreads, relations, goal = [0.1], np.array([True]), np.array([1.2, 0.0])
    near = np.array([0.05, 0.0])
    behind = np.array([0.2, 0.0])
    turned = 0.2 * np.array([np.cos(np.radians(30)), np.sin(np.radians(30))])

    def held(c: np.ndarray) -> tuple[int, slice] | None:
        return planner._convoy_hold(aff, b, np.array([0.1, 0.0]), c, near, relations,
                                    spreads, goal)

    assert held(behind) == (0, slice(0, 2))
    assert held(turned) is None
    planner.pc = replace(planner.pc, convoy_trailing=False)
    assert held(behind) is None
    assert held(near + [0.01, 0.0]) == (0, slice(0, 2))
    planner.pc = replace(planner.pc, convoy=False)
    assert held(near) is None


def _goes_on_scene(rem: float, off_deg: float):
    """The tool level bound to push the target (obj1, at (0.6, 0)) with the tool (obj2) 0.22 m
    behind it on a line `off_deg` off the target's way to a goal `rem` ahead (+x); a step of
    0.1, so `small_correction` (0.5) of a step is 5 cm."""
    planner, obs, layout = _avoid_scene()
    planner.step_size = lambda a: 0.1
    a = np.radians(off_deg)
    obs[layout.space("obj2", Property.POSITION).slice] = [0.6, 0.0] - 0.22 * np.array(
        [np.cos(a), np.sin(a)])
    aff = _tool_level(np.array([0.08, 0.0]), lambda x, c: x)
    return planner, obs, aff, Binding(target=1, tool=2, avoid=1), np.array([0.6 + rem, 0.0])


def test_a_convoy_past_realign_goes_on_near_its_goal_right_after_a_convoy_action():
    """`convoy_goes_on`: the tool–target line 20° off the way, the goal 10 cm ahead — pushed on
    along the line the target passes 3.4 cm from it, within a small correction — and the last
    action the convoy's: the convoy goes on. Not 30 cm ahead (10 cm off), not after another
    action (a trip, a staging: any action resets it), not with the option off, and not with
    the line pointing away from the goal while further than a small correction."""
    from dataclasses import replace

    planner, obs, aff, b, goal = _goes_on_scene(0.10, 20.0)
    planner._convoy_acted = True
    assert planner._goes_on(aff, b, goal, obs)
    far = _goes_on_scene(0.30, 20.0)
    far[0]._convoy_acted = True
    assert not far[0]._goes_on(far[2], far[3], far[4], far[1])
    away = _goes_on_scene(0.10, 170.0)  # the line 1.7 cm from the goal, but pointing away
    away[0]._convoy_acted = True
    assert not away[0]._goes_on(away[2], away[3], away[4], away[1])
    planner.pc = replace(planner.pc, convoy_goes_on=False)
    assert not planner._goes_on(aff, b, goal, obs)
    planner.pc = replace(planner.pc, convoy_goes_on=True)
    planner._act(SimpleNamespace(obs=obs, act=lambda action: None), np.array([0.5, 0.5]))
    assert not planner._goes_on(aff, b, goal, obs)
    planner.stack.append(Pursuit(CONVOY_PURSUIT, goal, b))  # an action of the convoy's
    planner._act(SimpleNamespace(obs=obs, act=lambda action: None), np.array([0.4, 0.4]))
    planner.stack.pop()
    assert planner._goes_on(aff, b, goal, obs)


def test_a_convoy_that_goes_on_takes_only_the_chains_command():
    """`_convoy` past `realign` (no held relation) where the convoy goes on: the chain's command
    (`_convoy_plan`), and when the chain has none, no convoy at all (None: the correction
    follows), never the straight step; where the relation holds, the chain's command or else
    the straight step; where neither, None."""
    planner, obs, aff, b, goal = _goes_on_scene(0.10, 20.0)
    answer, straight = [], []
    planner._convoy_plan = lambda *args: answer[0] if answer else None
    planner._convoy_step = lambda *args: straight.append(1) or 3
    planner.straight_move = lambda aff, delta, c, x: x
    hold = [None]
    planner._convoy_hold = lambda *args: hold[0]
    planner._goes_on = lambda *args: (0, slice(0, 2))

    def convoy() -> int | None:
        return planner._convoy(aff, b, np.array([0.05, 0.0]), np.zeros(2), np.zeros(2),
                               np.zeros(2), np.array([True]), [0.1], SimpleNamespace(obs=obs),
                               80, 0, goal)

    answer.append(1)
    assert convoy() == 1
    answer.clear()
    assert convoy() is None and not straight
    planner._goes_on = lambda *args: None
    assert convoy() is None and not straight
    hold[0] = (0, slice(0, 2))
    assert convoy() == 3 and straight == [1]
    answer.append(1)
    assert convoy() == 1


def _robot_pushing_the_tool(planner: Planner, answer: np.ndarray
                            ) -> tuple[SimpleNamespace, Binding]:
    """The robot's push level (`robot.position → target.position | target-robot`) bound to
    push the tool (entity 2) clear of the target (entity 1), standing at its place: its
    inverse model answers `answer` for any outcome, its forward model predicts half the
    robot's move. `planner` is stubbed to push from here."""
    model = SimpleNamespace(n=100, context_dims=[2], predict=lambda x, c: 0.5 * x,
                            infer=lambda delta, c=None: SimpleNamespace(
                                x=answer.copy(), y_predicted=delta.copy()))
    aff = SimpleNamespace(id=3, input=ROBOT_POSITION, output=TARGET_POSITION,
                          contexts=(TARGET_ROBOT,), model=model)
    planner.context = lambda *args: np.zeros(2)
    planner.reachable_relations = lambda a: np.array([True])
    planner._from_needed = lambda *args: None  # at its place: it pushes from here
    return aff, Binding(target=2, avoid=1)


def test_the_robot_pushes_straight_in_a_convoy_and_by_the_inverse_answer_elsewhere():
    """`convoy`: the robot at its place behind the tool, asked to move it 3 cm along +x for a
    convoy move of the tool into the target, pushes along +x at the length its forward model
    predicts best (the tool moves half the robot's move: 5.3 cm, the nearest of the lengths it
    weighs to 6) — not the inverse answer, a drive 0.14 m diagonally past the tool's back that
    the model rates as good. Staging the tool round the same target (no convoy move), or a
    convoy through another entity, keeps the inverse answer."""
    from hadim_cli.learner.planner import STRAIGHT_LENGTHS

    planner = _planner()
    answer = np.array([0.1, 0.1])
    aff, b = _robot_pushing_the_tool(planner, answer)

    def pushed(convoy_output: int) -> np.ndarray:
        planner._convoy_output = convoy_output
        calls = []
        planner.execute = lambda space, x, *args, **kw: calls.append(x) or 1
        planner._one_step(aff, b, np.array([0.03, 0.0]), SimpleNamespace(obs=None), 80, 1)
        return calls[0]

    length = np.hypot(0.1, 0.1) * STRAIGHT_LENGTHS
    best = length[int(np.argmin(np.abs(0.5 * length - 0.03)))]
    assert np.isclose(best, 0.375 * np.hypot(0.1, 0.1))
    np.testing.assert_allclose(pushed(1), [best, 0.0], atol=1e-12)
    np.testing.assert_allclose(pushed(-1), answer)
    np.testing.assert_allclose(pushed(3), answer)


def test_the_robots_convoy_push_is_a_pose_facing_the_push_and_elsewhere_a_place():
    """`convoy_facing`: the robot's straight push in a convoy step goes to the navigator as a
    pose — its place and a heading along the push — so it drives straight along the move
    instead of reaching the place by an arc; a push that is no convoy (staging), or with the
    option off, asks for the place alone."""
    from dataclasses import replace

    planner, obs, _ = _avoid_scene()
    answer = np.array([0.1, 0.1])
    aff, b = _robot_pushing_the_tool(planner, answer)

    def place(convoy_output: int) -> Place:
        planner._convoy_output = convoy_output
        asked = []
        planner.navigate = lambda places, *args, **kw: asked.extend(places) or 1
        planner._one_step(aff, b, np.array([0.0, 0.03]), SimpleNamespace(obs=obs), 80, 1)
        assert len(asked) == 1
        return asked[0]

    pose = place(1)
    assert pose.heading is not None
    np.testing.assert_allclose(pose.heading, [0.0, 1.0], atol=1e-12)
    assert pose.position[0] == 0.0 and pose.position[1] > 0.0  # straight along +y
    assert place(-1).heading is None  # staging: the inverse answer, a place alone
    planner.pc = replace(planner.pc, convoy_facing=False)
    assert place(1).heading is None


def test_a_subgoal_shorter_than_a_step_is_held_to_a_share_of_its_own_length():
    """`short_subgoals`: a sub-goal 3 cm away, for a robot whose typical step is ~0.2 m, is
    reached (an action taken, the robot within a tenth of it) — not read as reached before
    any action because it lies within 30 % of a step (the convoy's last 3.7 cm were asked of
    the tool and never pushed). A goal of the top level (depth 0) is unchanged; off, the
    sub-goal takes no action."""
    from dataclasses import replace

    planner, obs, layout = _avoid_scene()
    planner.pc = replace(planner.pc, navigation=False)  # the motion model's inverse answer
    mover = planner.h.controllers(ROBOT_POSITION)[0]
    assert planner.step_size(mover) > 0.15
    goal = np.array([0.03, 0.0])

    def attempt(short: bool, depth: int = 1) -> tuple[int, float]:
        planner.pc = replace(planner.pc, short_subgoals=short)
        world = _World(obs, layout)
        used = planner.reach(mover, Binding(), goal, world, 10, depth).actions
        return used, float(np.linalg.norm(world.obs[world.position] - goal))

    used, left = attempt(True)
    assert used >= 1 and left <= 0.3 * 0.03
    assert attempt(False) == (0, 0.03)
    used, left = attempt(False, depth=0)
    assert used >= 1 and left <= 0.3 * 0.03


def _chain(planner: Planner, commands: np.ndarray, shifts: np.ndarray, turns_deg: np.ndarray,
           relation_deg: float):
    """`_chain_command`'s world on hand-made models whose answer is known: the robot (at the
    origin, heading +x) moves by `shifts` for `commands` (its heading turned by `turns_deg`),
    the tool (obj2, 0.3 m ahead of it) moves with it, and the target (obj1, 0.3 m from the
    tool, `relation_deg` off its way: +x, to the goal 1 m ahead) moves along the tool–target
    line of centres by the tool's move projected on that line (a disc pushes a disc along
    their centres). Relations are read centre to centre from every observation, imagined or
    not; their spread 0.3, a step 0.1. `planner` must be `_avoid_scene`'s."""
    from hadim_cli.learner.navigation import Prediction

    obs, layout = planner._test_obs, planner.reader.layout
    n = np.array([np.cos(np.radians(relation_deg)), np.sin(np.radians(relation_deg))])
    obs[layout.space("obj2", Property.POSITION).slice] = [0.3, 0.0]
    obs[layout.space("obj1", Property.POSITION).slice] = [0.3, 0.0] + 0.3 * n
    turns = np.radians(turns_deg)
    headings = np.stack([np.cos(turns), np.sin(turns)], 1)
    pred = Prediction(commands, 0.5 * shifts, shifts, headings, 0.15, 1.0)
    planner.navigator = SimpleNamespace(
        commands=commands, predict=lambda *args: pred,
        allowed_many=lambda obs, *args: np.ones((len(obs), len(commands)), bool),
        motions=lambda arr, *args: (np.repeat(shifts[None], len(arr), 0),
                                    np.repeat(headings[None], len(arr), 0)))
    planner._spreads = lambda a: [0.3]
    planner.step_size = lambda a: 0.1
    aff = SimpleNamespace(contexts=(TARGET_TOOL,), input=RoleSpace(Role.TOOL, Property.POSITION),
                          output=TARGET_POSITION, model=SimpleNamespace(
                              predict=lambda moved, c: np.sum(moved * c, 1, keepdims=True) * c
                              / np.sum(c * c, 1, keepdims=True)))
    push = SimpleNamespace(contexts=(TARGET_ROBOT,),
                           model=SimpleNamespace(predict=lambda shift, c: shift.copy()))
    goal, near = np.array([1.0, 0.0]), np.array([0.3, 0.0])

    def command() -> np.ndarray | None:
        return planner._chain_command(aff, push, Binding(target=1, tool=2, avoid=1),
                                      Binding(target=2, avoid=1), near, near.copy(),
                                      (0, slice(0, 2)), (0, slice(0, 2)), goal, [], obs)
    command.aff, command.push, command.goal = aff, push, goal
    return command


def test_a_convoy_planned_through_the_chain_pushes_on_the_side_that_lines_the_tool_up():
    """`convoy_plan`: the tool–target line 20° off the target's way. A push 10° off the way
    moves the target furthest (0.0985 m along the line of centres) but slides the tool further
    round it (the line 23° off after it); a push 40° off moves it 0.094 m and turns the line
    back to 14°. With the drift costed the second is taken; without, the first. A command
    that would go further still but turns the robot 20° is never taken (`convoy_turn`): the
    push's model cannot tell its arc from a straight push. Nor one that does not drive the
    robot into the tool (backing off, a turn on the spot), whatever the models predict of it,
    nor the last command again from the observation it left unchanged: the next best then."""
    from dataclasses import replace

    planner, planner._test_obs, _ = _avoid_scene()
    planner.pc = replace(planner.pc, convoy_plan=True)
    angles = np.radians([-10.0, -40.0, -10.0])
    shifts = np.array([0.1, 0.1, 0.2])[:, None] * np.stack([np.cos(angles), np.sin(angles)], 1)
    commands = np.array([[1.0, 0.9], [1.0, 0.8], [1.0, 0.2]])
    command = _chain(planner, commands, shifts, np.array([0.0, 0.0, 20.0]), -20.0)
    np.testing.assert_array_equal(command(), commands[1])
    planner._idle = (commands[1].copy(), planner._test_obs.copy())  # it left this unchanged
    np.testing.assert_array_equal(command(), commands[0])  # the next best, not a repeat
    planner._idle = None
    planner.pc = replace(planner.pc, convoy_drift_cost=0.0)
    np.testing.assert_array_equal(command(), commands[0])
    planner.pc = replace(planner.pc, convoy_turn=30.0)
    np.testing.assert_array_equal(command(), commands[2])
    planner.pc = replace(planner.pc, convoy_turn=8.0, convoy_drift_cost=3.0)
    shifts[:2] *= -1  # backing away: no command it may take brings the target nearer
    assert command() is None
    shifts[:2] *= -1
    shifts[1] = 0.0  # a turn on the spot: the models asked about a null move must not count
    # The models predict the null move pushes the target furthest (traced: one such command
    # taken 58 times); chosen by progress alone (no drift cost: a null move drifts the
    # robot's relation to the tool, which the drift cost would weigh anyway), it would win.
    command.aff.model.predict = lambda moved, c: np.where(
        np.linalg.norm(moved, axis=1, keepdims=True) < 1e-9, [[0.09, 0.0]], [[0.05, 0.0]])
    planner.pc = replace(planner.pc, convoy_drift_cost=0.0)
    np.testing.assert_array_equal(command(), commands[0])


def test_a_convoy_command_costs_the_targets_way_left_and_each_relations_drift():
    """`_chain`, by hand: after each command the robot has moved by its shift, the tool with
    it, the target by the tool's move along their line of centres; the command's cost is the
    target's distance to its goal in steps plus `convoy_drift_cost` × (gap / `realign`)⁴ for
    the target–tool and the tool–robot relations, each read from that command's imagined
    observation against a relation of its length (0.3) along the target's new way."""
    from dataclasses import replace

    planner, planner._test_obs, _ = _avoid_scene()
    planner.pc = replace(planner.pc, convoy_plan=True)
    angles = np.radians([-10.0, -40.0, 25.0])
    shifts = np.array([0.1, 0.1, 0.05])[:, None] * np.stack([np.cos(angles), np.sin(angles)], 1)
    commands = np.array([[1.0, 0.9], [1.0, 0.8], [0.9, 1.0]])
    command = _chain(planner, commands, shifts, np.zeros(3), -20.0)
    n = np.array([np.cos(np.radians(-20.0)), np.sin(np.radians(-20.0))])
    tool = np.array([0.3, 0.0]) + shifts
    target = np.array([0.3, 0.0]) + 0.3 * n + (shifts @ n)[:, None] * n
    rem = np.linalg.norm(command.goal - target, axis=1)
    way = (command.goal - target) / rem[:, None]
    pc = planner.pc
    want = rem / 0.1
    for rel in (target - tool, tool - shifts):
        gap = np.linalg.norm(rel - 0.3 * way, axis=1) / 0.3
        want = want + pc.convoy_drift_cost * (gap / pc.realign) ** 4
    imagined, cost, fits = planner._chain(
        command.aff, command.push, Binding(target=1, tool=2, avoid=1), Binding(target=2, avoid=1),
        planner._test_obs[None], (0.3, 0.3), (0, slice(0, 2)), (0, slice(0, 2)), command.goal)
    np.testing.assert_allclose(cost[0], want, rtol=1e-9)
    assert fits[0].all() and imagined.shape == (1, 3, planner._test_obs.size)


def test_a_deeper_convoy_takes_the_first_command_whose_follow_up_ends_best():
    """`convoy_depth`: three first commands end at costs 1.0, 1.2 and 2.0; the best command
    after each ends at 0.9, 0.3 and — after the third, none fits — nothing. One action ahead
    the first is taken; two ahead the second (0.3), the third valued at its own end (2.0),
    not at a follow-up that does not fit. The first command must itself fit: refused by the
    keep-outs, the second is not taken however good its follow-up."""
    from dataclasses import replace

    from hadim_cli.learner.navigation import Prediction

    planner, obs, _ = _avoid_scene()
    commands = np.array([[1.0, 1.0], [1.0, 0.8], [0.8, 1.0]])
    pred = Prediction(commands, np.zeros((3, 2)), np.zeros((3, 2)), np.tile([1.0, 0.0], (3, 1)),
                      0.15, 1.0)
    allowed = np.ones(3, bool)
    planner.navigator = SimpleNamespace(commands=commands, predict=lambda *args: pred,
                                        allowed_many=lambda *args: allowed[None])
    first = (np.array([1.0, 1.2, 2.0]), np.ones(3, bool))
    follow = {0.0: ([0.9, 5.0, 5.0], [True, True, True]),
              1.0: ([0.3, 5.0, 5.0], [True, True, True]),
              2.0: ([0.1, 0.1, 0.1], [False, False, False])}

    def chain(aff, push, b, sub_b, arr, *args):  # an imagined observation's [0]: which it is
        if arr.shape[0] == 1 and arr[0, 0] == obs[0]:
            ends = np.stack([np.full_like(obs, k) for k in range(3)])[None]
            return ends, first[0][None], first[1][None]
        costs = np.array([follow[float(a[0])][0] for a in arr])
        fits = np.array([follow[float(a[0])][1] for a in arr])
        return np.repeat(arr[:, None], 3, 1), costs, fits

    obs[0] = -1.0
    planner._chain = chain

    def command(depth: int) -> np.ndarray | None:
        planner.pc = replace(planner.pc, convoy_depth=depth)
        near = np.array([0.3, 0.0])
        return planner._chain_command(None, None, Binding(), Binding(), near, near,
                                      (0, slice(0, 2)), (0, slice(0, 2)), np.zeros(2), [], obs)

    np.testing.assert_array_equal(command(1), commands[0])
    np.testing.assert_array_equal(command(2), commands[1])
    allowed[1] = False
    np.testing.assert_array_equal(command(2), commands[0])


def test_a_convoy_planned_through_the_chain_first_closes_on_the_object_behind_it():
    """`convoy_plan`: the robot 5 cm short of the tool behind it (more than `CONTACT_MARGIN`)
    drives to the contact place behind the tool facing the target's way (the navigator's
    choice, one action, under the pursuit "convoy through the chain"); a robot in front of the
    tool, one whose relation to it is past `realign`, or a command that already left this very
    observation unchanged (`_idle_repeat`), leaves the step to the straight convoy (None)."""
    from dataclasses import replace

    planner, obs, layout = _avoid_scene()  # target obj1 at (0.6, 0), radius 0.12
    planner.pc = replace(planner.pc, convoy_plan=True)
    obs[layout.space("obj2", Property.POSITION).slice] = [0.3, 0.0]  # tool, radius 0.1
    obs[layout.space("robot", Property.POSITION).slice] = [0.0, 0.0]  # 5 cm short of it
    tool_aff = _tool_level(np.array([0.08, 0.0]), lambda x, c: x)
    push = SimpleNamespace(id=3, input=ROBOT_POSITION, output=TARGET_POSITION,
                           contexts=(TARGET_ROBOT,), model=SimpleNamespace(
                               n=100, context_dims=[2], predict=lambda x, c: x))
    planner.h = SimpleNamespace(controllers=lambda space: [push])
    planner.context = lambda aff, o, b: np.array([0.3, 0.0])
    planner.needed_context = lambda *args: np.array([0.3, 0.0])
    planner.reachable_relations = lambda a: np.array([True])
    planner._spreads = lambda a: [0.3]
    planner.step_size = lambda a: 0.1
    places, labels, acted = [], [], []
    planner.navigator.choose = lambda o, place, keep, *args: places.append(place) or np.array(
        [1.0, 1.0])
    planner._act = lambda actuator, command: (labels.append([p.label for p in planner.stack]),
                                              acted.append(command))
    b = Binding(target=1, tool=2)
    actuator = SimpleNamespace(obs=obs)

    def plan() -> int | None:
        return planner._convoy_plan(tool_aff, b, np.array([0.05, 0.0]), np.zeros(2),
                                    np.array([0.3, 0.0]), (0, slice(0, 2)), actuator,
                                    np.array([1.2, 0.0]))

    assert plan() == 1
    np.testing.assert_allclose(places[0].position, [0.05, 0.0], atol=1e-12)
    np.testing.assert_allclose(places[0].heading, [1.0, 0.0])
    assert labels == [["convoy through the chain"]] and len(acted) == 1
    assert planner.stack == []
    obs[layout.space("robot", Property.POSITION).slice] = [0.45, -0.3]  # ahead of the tool
    assert plan() is None
    obs[layout.space("robot", Property.POSITION).slice] = [0.0, 0.0]
    planner.context = lambda aff, o, b: np.array([0.0, 0.3])  # round its side: past realign
    assert plan() is None
    assert len(acted) == 1
    planner.context = lambda aff, o, b: np.array([0.3, 0.0])
    planner._idle = (np.array([1.0, 1.0]), obs.copy())  # that command left this obs unchanged
    assert plan() is None
    assert len(acted) == 1


def test_a_convoy_step_is_planned_through_the_chain_only_with_convoy_plan():
    """`convoy_plan`: where the convoy holds (`_held_relation`), the step is the chain's
    (`_convoy_plan`) when it answers, the straight convoy step when it does not or the option
    is off."""
    from dataclasses import replace

    planner = _planner()
    aff = _tool_level(np.array([0.08, 0.0]), lambda x, c: x)
    planner._spreads = lambda a: [0.3]
    planner.support_gap = lambda *args: 0.0
    planner.needed_context = lambda *args: np.array([0.3, 0.0])
    planner._as_near = lambda aff, c, needed, relations: needed
    planner._gap = lambda *args: 0.1
    planner._held_relation = lambda *args: (0, slice(0, 2))
    planner.straight_move = lambda aff, delta, c, x: x
    planner._convoy_step = lambda *args: 3
    answer = []
    planner._convoy_plan = lambda *args: answer[0] if answer else None

    def step() -> int | None:
        return planner._from_needed(aff, Binding(target=1, tool=2), np.array([0.05, 0.0]),
                                    np.array([0.3, 0.0]), np.array([0.05, 0.0]), 1.0,
                                    np.array([True]), SimpleNamespace(obs=None), 80, 0, 1.0,
                                    False, np.array([1.2, 0.0]))

    assert planner.pc.convoy_plan
    answer.append(7)
    assert step() == 7
    answer.clear()
    assert step() == 3  # the chain has no command: the straight step
    answer.append(7)
    planner.pc = replace(planner.pc, convoy_plan=False)
    assert step() == 3


@pytest.mark.parametrize("room_places", [True, False])
def test_a_place_nearer_a_wall_than_the_body_is_not_taken(room_places):
    """`room_places`: the robot's place 0.1 m from a wall (its radius is 0.15 m) and the tool's
    place beyond the wall are refused (-1, nothing driven); places a body fits are driven
    to. Off, every place is driven to (a tool goal sent the tool toward a place beyond the
    wall for its whole budget)."""
    from dataclasses import replace

    from hadim_cli.learner.planner import Attempt, Binding
    from hadim_cli.learner.spaces import SpaceReader
    from hadim_cli.world.layout import LayoutBounds, ObservationLayout

    layout = ObservationLayout.build(2, 4, LayoutBounds(2, 2, 1.5, 0.25, 0.6))  # ±2 m
    obs = np.zeros(layout.size)
    obs[layout.space("robot", Property.RADIUS).slice] = 0.15
    obs[layout.space("obj1", Property.RADIUS).slice] = 0.1
    config = load_config()
    planner = Planner(SimpleNamespace(controllers=lambda space: []),
                      SpaceReader(layout, relation_offset=0.3), config.learner,
                      replace(config.planner, room_places=room_places))
    planner._navigating = lambda: False
    planner._waypoints = lambda driven, goal, obs, b, mover: [goal]
    driven_to = []

    def reach(sub, b, goal, actuator, budget, depth=0):
        driven_to.append((b.target, tuple(goal)))
        return Attempt(0.1, 0.0, 2)

    planner.reach = reach
    world = SimpleNamespace(obs=obs, exhausted=False)
    aff = SimpleNamespace(id=6, contexts=(RoleSpace(Role.TARGET, Property.POSITION, Role.TOOL),))
    tool = Binding(target=1)  # the tool, driven as its pusher's target
    sub = SimpleNamespace(id=3)

    def place(driven, goal, b):
        return planner._place(aff, Binding(target=2, tool=1), 0, driven, np.array(goal), b,
                              sub, [1.0], world, 40, 1, None)

    refused = -1 if room_places else 2
    assert place(ROBOT_POSITION, [1.9, 0.0], Binding()) == refused  # 0.10 m from the wall
    assert place(ROBOT_POSITION, [0.0, -1.9], Binding()) == refused
    assert place(TARGET_POSITION, [0.3, 2.05], tool) == refused  # beyond the wall
    assert place(ROBOT_POSITION, [1.84, -1.84], Binding()) == 2  # 0.16 m from both: fits
    assert place(TARGET_POSITION, [-1.89, 0.5], tool) == 2  # the tool's 0.1 m fits
    assert len(driven_to) == (2 if room_places else 5)


def _stalling_chain(stall_trips: bool, start: float):
    """A goal 0.1 m steps away whose every step is a sub-goal of 2 cm (a small correction for
    the sub-affordance's 0.1 m step); the sub-level refuses a trip whenever it is told to
    spare one, and else makes it, moving the output 2 cm. Returns (actions used, the
    `spare_trips` each sub-step was given)."""
    from dataclasses import replace

    from hadim_cli.learner.planner import Binding

    config = load_config()
    planner = Planner(Hierarchy(), None, config.learner,
                      replace(config.planner, stall_trips=stall_trips))
    planner.step_size = lambda a: 0.1
    planner.value = lambda space, obs, b: obs.copy()
    world = SimpleNamespace(obs=np.array([start, 0.0]), exhausted=False)
    top = SimpleNamespace(id=6, input=ROBOT_POSITION, output=TARGET_POSITION)
    sub = SimpleNamespace(id=3, input=ROBOT_POSITION, output=TARGET_POSITION)
    spared = []

    def one_step(aff, b, delta, actuator, budget, depth, remaining=1.0, spare_trips=True,
                 goal=None):
        if aff is top:  # its step: a sub-goal 2 cm along the way
            return planner.reach(sub, b, actuator.obs + 0.02 * np.sign(delta), actuator,
                                 budget, depth + 1).actions
        spared.append(spare_trips)
        if spare_trips:
            return -1
        actuator.obs = actuator.obs + np.clip(delta, -0.02, 0.02)
        return 1

    planner._one_step = one_step
    used = planner.reach(top, Binding(target=1), np.zeros(2), world, 40).actions
    return used, spared


def test_a_small_correction_is_made_once_the_goal_it_serves_stalled_far_from_its_end():
    """`stall_trips`: a sub-goal's small correction is spared a trip at first; when the goal it
    serves then stalls (its step moved nothing) while more than `small_correction` of its
    steps from its end, the next one is made, and the goal goes on. Off (and near the goal's
    end either way): spared every time, and the goal stalls twice and gives up unmoved."""
    used, spared = _stalling_chain(True, 0.3)
    assert spared[:2] == [True, False] and used > 0
    used, spared = _stalling_chain(False, 0.3)
    assert spared == [True, True] and used == 0
    used, spared = _stalling_chain(True, 0.04)  # within 0.5 × its 0.1 m step: spared
    assert spared == [True, True] and used == 0
