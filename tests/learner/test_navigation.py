"""The navigator: reaching a place (position and heading) through predicted motion.

Known answers first (the differential drive's exact kinematics as the motion), then the same
with forward models fitted on samples of that motion, as the learner's would be."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from hadim_cli.config import PlannerConfig, WorldConfig
from hadim_cli.evaluation.exact import KinematicMotion
from hadim_cli.learner.models import LocalLinearModel
from hadim_cli.learner.navigation import (
    ROBOT_HEADING,
    ROBOT_POSITION,
    Keepout,
    Navigator,
    Place,
    command_grid,
    line_angle,
)
from hadim_cli.learner.routes import Obstacles
from hadim_cli.learner.spaces import ACTION, SpaceReader
from hadim_cli.world.layout import ROBOT, Property
from hadim_cli.world.world import World

WORLD = WorldConfig()


class Kinematic:
    """A robot moved by the exact kinematics, no physics: observations for the navigator."""

    def __init__(self, x: float, y: float, theta: float):
        self.world = World(WORLD)
        self.obs = self.world.reset(seed=0)
        self.layout = self.world.layout
        self.reader = SpaceReader(self.layout)
        self.motion = KinematicMotion(WORLD, self.reader)
        self.set(np.array([x, y]), np.array([np.cos(theta), np.sin(theta)]))
        # Objects far away, out of the way.
        for i, entity in enumerate(self.layout.objects):
            self.obs[self.layout.space(entity, Property.POSITION).slice] = (1.9, -1.9 + 0.3 * i)

    def set(self, position: np.ndarray, heading: np.ndarray) -> None:
        self.obs[self.layout.space(ROBOT, Property.POSITION).slice] = position
        self.obs[self.layout.space(ROBOT, Property.HEADING).slice] = heading

    def act(self, command: np.ndarray) -> None:
        shift, after = self.motion(self.obs, command[None])
        self.set(self.reader.entity_position(self.obs, 0) + shift[0], after[0])

    def place(self, entity: int, position: tuple[float, float]) -> None:
        name = self.layout.entities[entity]
        self.obs[self.layout.space(name, Property.POSITION).slice] = position


def _drive(nav: Navigator, robot: Kinematic, place: Place, keepouts=(), limit: int = 30
           ) -> int:
    for used in range(limit):
        action = nav.choose(robot.obs, place, list(keepouts))
        if action is None:
            return used
        robot.act(action)
    return limit


def _no_h() -> SimpleNamespace:
    return SimpleNamespace(with_output=lambda space: [])


def test_the_grid_is_finer_near_zero_and_never_stands_still():
    grid = command_grid(9)
    assert grid.shape == (80, 2)
    assert not np.any(np.all(grid == 0, axis=1))
    values = np.unique(np.abs(grid))
    assert values[1] < 0.2 and values[-1] == 1.0


def test_line_angle_counts_either_way_along_a_heading():
    a = np.array([[1.0, 0.0]])
    assert line_angle(a, np.array([[-1.0, 0.0]]))[0] == pytest.approx(0.0)
    assert line_angle(a, np.array([[0.0, 1.0]]))[0] == pytest.approx(np.pi / 2)


@pytest.mark.parametrize("goal, heading", [((0.5, 0.3), 90.0), ((-0.4, 0.2), 0.0),
                                           ((0.2, -0.6), 45.0)])
def test_exact_motion_reaches_a_place_facing_the_way_wanted(goal, heading):
    robot = Kinematic(0.0, 0.0, 0.0)
    nav = Navigator(_no_h(), robot.reader, PlannerConfig(), robot.motion)
    want = np.array([np.cos(np.radians(heading)), np.sin(np.radians(heading))])
    place = Place(np.array(goal), want, 0.03)
    used = _drive(nav, robot, place)
    assert nav.reached(robot.obs, place)
    assert used <= 14  # about the distance at full speed plus two turns
    h = robot.reader.value_now(ROBOT_HEADING, robot.obs)
    assert line_angle(h[None], want[None])[0] <= PlannerConfig().heading_tolerance


def test_a_keepout_is_never_entered_and_leaving_it_is_always_allowed():
    robot = Kinematic(0.0, 0.0, 0.0)
    robot.place(1, (0.6, 0.0))  # an object on the straight way to the place
    nav = Navigator(_no_h(), robot.reader, PlannerConfig(), robot.motion)
    keep = [Keepout(1, 0.45, 0.40)]
    for _ in range(30):
        action = nav.choose(robot.obs, Place(np.array([1.2, 0.0])), keep)
        if action is None:
            break
        robot.act(action)
        assert np.linalg.norm(robot.reader.entity_position(robot.obs, 0) - [0.6, 0.0]) >= 0.40
    # Wedged inside the clearance: a way out is still offered.
    robot.set(np.array([0.35, 0.0]), np.array([1.0, 0.0]))
    out = nav.choose(robot.obs, Place(np.array([-0.5, 0.0])), [Keepout(1, 0.45, 0.22)])
    assert out is not None
    robot.act(out)
    assert robot.reader.entity_position(robot.obs, 0)[0] < 0.35


def _learned_movers(rng: np.random.Generator, n: int = 600) -> SimpleNamespace:
    """`action → robot.position` and `action → robot.heading` fitted on `n` random commands
    of the exact kinematics from random headings, with the heading as context."""
    robot = Kinematic(0.0, 0.0, 0.0)
    theta = rng.uniform(-np.pi, np.pi, n)
    commands = rng.uniform(-1.0, 1.0, (n, 2))
    shifts, turns, headings = [], [], []
    for th, cmd in zip(theta, commands, strict=True):
        h = np.array([np.cos(th), np.sin(th)])
        robot.set(np.zeros(2), h)
        shift, after = robot.motion(robot.obs, cmd[None])
        shifts.append(shift[0])
        turns.append(after[0] - h)
        headings.append(h)
    mover = LocalLinearModel(2, 2, [2])
    mover.add(commands, np.array(headings), np.array(shifts))
    turner = LocalLinearModel(2, 2, [2])
    turner.add(commands, np.array(headings), np.array(turns))
    affs = {ROBOT_POSITION: SimpleNamespace(id=1, input=ACTION, output=ROBOT_POSITION,
                                            model=mover, competence=0.9,
                                            contexts=(ROBOT_HEADING,)),
            ROBOT_HEADING: SimpleNamespace(id=2, input=ACTION, output=ROBOT_HEADING,
                                           model=turner, competence=0.9,
                                           contexts=(ROBOT_HEADING,))}
    return SimpleNamespace(with_output=lambda space: [affs[space]] if space in affs else [])


def test_learned_motion_reaches_a_place_facing_the_way_wanted():
    h = _learned_movers(np.random.default_rng(0))
    robot = Kinematic(0.0, 0.0, 0.0)
    nav = Navigator(h, robot.reader, PlannerConfig())
    assert nav.available() and nav.movers()[1] is not None
    place = Place(np.array([0.5, 0.3]), np.array([0.0, 1.0]), 0.03)
    used = _drive(nav, robot, place)
    assert nav.reached(robot.obs, place) and used <= 16


def test_a_place_pursued_without_progress_is_given_up():
    """Predictions that promise progress the moves never bring (the robot does not move):
    the navigator stops after a few actions instead of spending the budget."""
    robot = Kinematic(0.0, 0.0, 0.0)
    nav = Navigator(_no_h(), robot.reader, PlannerConfig(), robot.motion)
    place = Place(np.array([0.8, 0.0]))
    chosen = [nav.choose(robot.obs, place, []) for _ in range(10)]
    assert chosen[0] is not None
    assert sum(c is not None for c in chosen) <= 4
    nav.forget()  # a new goal attempt starts afresh
    assert nav.choose(robot.obs, place, []) is not None


@pytest.mark.parametrize("drifting", [True, False])
def test_a_place_that_drifts_within_its_tolerance_is_still_given_up(drifting):
    """`planner.drifting_places`: a place behind an object is computed afresh every action
    and drifted by a centimetre or two while a robot went to and fro short of it, each time
    a new place to the stall count (26 actions, the rest of a goal). A place within its
    tolerance of the last one is the same pursuit; one further off is a new one. Off, only
    the same place to a tenth of a millimetre counts."""
    robot = Kinematic(0.0, 0.0, 0.0)
    nav = Navigator(_no_h(), robot.reader, PlannerConfig(drifting_places=drifting),
                    robot.motion)

    def place(i: int) -> Place:  # 1.2 cm further each action, tolerance 3 cm
        return Place(np.array([0.8, 0.012 * i]), None, 0.03)

    chosen = [nav.choose(robot.obs, place(i), []) for i in range(10)]
    assert chosen[0] is not None
    if drifting:
        assert sum(c is not None for c in chosen) <= 4
    else:
        assert all(c is not None for c in chosen)
    far = Place(np.array([0.8, 0.5]), None, 0.03)  # a new place altogether
    assert nav.choose(robot.obs, far, []) is not None


def _same(a, b) -> bool:
    return all(np.array_equal(getattr(a, f), getattr(b, f))
               for f in ("commands", "half", "end", "heading", "speed", "turn"))


def test_a_prediction_is_kept_for_the_same_observation_until_the_models_change():
    """The navigator answers a repeated question from what it kept, and what it kept is what
    it would compute afresh; a row added to a motion model makes it compute again."""
    rng = np.random.default_rng(3)
    h = _learned_movers(rng, 300)
    robot = Kinematic(0.2, -0.1, 0.7)
    nav = Navigator(h, robot.reader, PlannerConfig())
    first = nav.predict(robot.obs)
    assert nav.predict(robot.obs.copy()) is first
    assert _same(first, Navigator(h, robot.reader, PlannerConfig()).predict(robot.obs))
    other = robot.obs.copy()
    robot.set(np.array([0.2, -0.1]), np.array([0.0, 1.0]))
    assert not _same(nav.predict(robot.obs), first)      # another observation
    mover = nav.movers()[0].model
    x, c, y = mover.data()
    mover.add(x[:40] * 0.5, c[:40], y[:40] * 3.0)          # the model changed: not kept
    again = nav.predict(other)
    assert again is not first and not _same(again, first)
    assert _same(again, Navigator(h, robot.reader, PlannerConfig()).predict(other))


@pytest.mark.parametrize("exact", [False, True])
def test_motions_from_many_observations_are_each_ones_prediction(exact):
    """`motions` (the convoy's imagined poses, several at once) predicts from each observation
    what `predict` does from it alone — with the heading each holds as the motion models'
    context — and `allowed_many` refuses from each what `allowed` does."""
    h = _learned_movers(np.random.default_rng(5), 300)
    robot = Kinematic(0.2, -0.1, 0.7)
    robot.place(1, (0.5, 0.1))
    nav = Navigator(h, robot.reader, PlannerConfig(), robot.motion if exact else None)
    poses = [((0.2, -0.1), 0.7), ((0.4, 0.3), -2.0), ((0.0, 0.0), 3.0)]
    obs = []
    for position, theta in poses:
        robot.set(np.array(position), np.array([np.cos(theta), np.sin(theta)]))
        obs.append(robot.obs.copy())
    shift, after = nav.motions(np.stack(obs))
    keep = [Keepout(1, 0.45, 0.40)]
    preds = [nav.predict(o) for o in obs]
    for o, pred, s, a in zip(obs, preds, shift, after, strict=True):
        np.testing.assert_allclose(robot.reader.entity_position(o, 0) + s, pred.end, atol=1e-12)
        np.testing.assert_allclose(a, pred.heading, atol=1e-12)
    assert not np.allclose(shift[0], shift[1])
    allowed = nav.allowed_many(np.stack(obs), np.stack([p.half for p in preds]),
                               np.stack([p.end for p in preds]), keep)
    for o, pred, ok in zip(obs, preds, allowed, strict=True):
        np.testing.assert_array_equal(ok, nav.allowed(o, pred, keep))
    assert not allowed.all() and allowed.any()


@pytest.mark.parametrize("bearing", [10.0, -12.0])
def test_a_place_within_its_tolerance_is_still_driven_to_as_near_as_the_grid_allows(bearing):
    """`planner.precise_places`: a push's sub-goal a few degrees off the heading lies within
    the sub-goal's tolerance of many commands (4.5 cm); the navigator takes the command
    ending nearest it (an arc toward it), not the first of those within the tolerance."""
    robot = Kinematic(0.0, 0.0, 0.0)
    a = np.radians(bearing)
    place = Place(0.14 * np.array([np.cos(a), np.sin(a)]), None, 0.045)
    nav = Navigator(_no_h(), robot.reader, PlannerConfig(), robot.motion)
    pred = nav.predict(robot.obs)
    ends = np.linalg.norm(pred.end - place.position, axis=1)
    chosen = nav.choose(robot.obs, place, [])
    i = int(np.flatnonzero(np.all(pred.commands == chosen, axis=1))[0])
    assert ends[i] == pytest.approx(ends.min())
    assert np.sign(chosen[1] - chosen[0]) == np.sign(bearing)  # it turns toward the place
    loose = Navigator(_no_h(), robot.reader, PlannerConfig(precise_places=False), robot.motion)
    chosen = loose.choose(robot.obs, place, [])
    i = int(np.flatnonzero(np.all(pred.commands == chosen, axis=1))[0])
    assert ends[i] > ends.min() + 0.005  # without it, any command within the tolerance


def test_the_way_round_a_disc_goes_along_its_tangents_and_its_arc():
    """`Obstacles.leg`, a known answer: from (-1, 0) to (1, 0) round a disc of radius 0.5 at
    the origin, the way is two tangents of √0.75 and an arc of π/3 (which turns the robot
    by π/3 as well); a disc off the way changes nothing."""
    disc = Obstacles(np.array([[0.0, 0.0]]), np.array([0.5]))
    frm, facing = np.array([[-1.0, 0.0]]), np.array([[1.0, 0.0]])
    cost, arrive = disc.leg(frm, np.array([1.0, 0.0]), facing, speed=0.1, turn=1.0)
    tangents, arc = 2 * np.sqrt(0.75), np.pi / 3
    # The first tangent leaves 30° off the way: that turn is charged too.
    assert cost[0] == pytest.approx((tangents + 0.5 * arc) / 0.1 + arc + np.pi / 6)
    assert abs(arrive[0, 1]) == pytest.approx(0.5)  # it arrives along the last tangent
    aside = Obstacles(np.array([[0.0, 0.8]]), np.array([0.5]))
    cost, _ = aside.leg(frm, np.array([1.0, 0.0]), facing, speed=0.1, turn=1.0)
    assert cost[0] == pytest.approx(2.0 / 0.1)
    # From within the disc (a robot against an object): on the rim at its bearing, along the
    # rim — facing along it costs no turn, facing out from the centre a quarter turn.
    inside = np.array([[-0.4, 0.0], [-0.4, 0.0]])
    cost, _ = disc.leg(inside, np.array([1.0, 0.0]), np.array([[0.0, 1.0], [1.0, 0.0]]),
                       speed=0.1, turn=1.0)
    arc = 2 * np.pi / 3
    assert cost[0] == pytest.approx((np.sqrt(0.75) + 0.5 * arc) / 0.1 + arc)
    assert cost[1] == pytest.approx(cost[0] + np.pi / 2)


def _trip(nav: Navigator, robot: Kinematic, place: Place, discs: Obstacles,
          limit: int = 30) -> tuple[int, float]:
    """Actions of a searched trip, and the nearest its centre came to a disc's rim (half-way
    through each action as well)."""
    nearest = np.inf
    for used in range(limit):
        action = nav.route(robot.obs, place, discs)
        if action is None:
            return used, nearest
        before = robot.reader.entity_position(robot.obs, 0).copy()
        robot.act(action)
        after = robot.reader.entity_position(robot.obs, 0)
        for point in (0.5 * (before + after), after):
            gaps = np.linalg.norm(discs.centres - point, axis=1) - discs.radii
            nearest = min(nearest, float(gaps.min()))
    return limit, nearest


def test_a_trip_goes_round_the_object_to_the_place_behind_it_facing_the_push():
    """`planner.route_search`, on the exact kinematics: the place behind an object (for a push
    back toward the robot) is reached round the object, never into its disc, facing the
    push, in about the actions the way round costs at full speed (not the ten or more of a
    trip by waypoints and turns on the spot)."""
    robot = Kinematic(0.0, 0.0, 0.0)
    nav = Navigator(_no_h(), robot.reader, PlannerConfig(), robot.motion)
    discs = Obstacles(np.array([[0.5, 0.0]]), np.array([0.33]))
    place = Place(np.array([0.85, 0.0]), np.array([-1.0, 0.0]), 0.03)
    around = discs.leg(np.zeros((1, 2)), place.position, np.array([[1.0, 0.0]]),
                       0.15, 1.0)[0][0]
    used, nearest = _trip(nav, robot, place, discs)
    assert nav.reached(robot.obs, place)
    assert nearest >= -1e-9
    assert used <= around + 2


def test_a_trip_leaves_an_object_it_stands_against():
    """A robot within an object's disc (it has just pushed it) may move as long as it does
    not get closer to the object's centre: the trip to the object's other side goes out and
    round, not through it."""
    robot = Kinematic(0.35, 0.0, 0.0)  # against an object at 0.65 (disc 0.33)
    nav = Navigator(_no_h(), robot.reader, PlannerConfig(), robot.motion)
    discs = Obstacles(np.array([[0.65, 0.0]]), np.array([0.33]))
    place = Place(np.array([0.65, 0.34]), np.array([0.0, 1.0]), 0.03)
    trace = []
    for _ in range(30):
        action = nav.route(robot.obs, place, discs)
        if action is None:
            break
        robot.act(action)
        trace.append(float(np.linalg.norm(robot.reader.entity_position(robot.obs, 0)
                                          - discs.centres[0])))
    assert nav.reached(robot.obs, place)
    assert min(trace) >= 0.30 - 1e-9  # never closer than where it stood
