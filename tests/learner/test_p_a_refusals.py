"""p_A's negatives are the objects that refused the robot (`Adaptation._refused`).

A fixed object stops the robot: its push in vain changes nothing, so it is no row of the
pushing affordance (its input did not change), and often comes in a learning episode where
nothing moved at all. A pushable object the robot only grazes (moves along it) or backs away
from does not move either, and is no negative. Hand-built data (`handmade.Room`): the robot's
motion model is fitted on free moves, each push is written row by row.
"""

from __future__ import annotations

import numpy as np
import pytest
from handmade import ROBOT_HEADING, ROBOT_POSITION, STEP, TARGET_POSITION, TARGET_ROBOT, Room

from hadim_cli.learner.spaces import Property, Rows

pytestmark = pytest.mark.usefixtures("one_thread")

ROBOT_RADIUS = 0.15
FORWARD = np.array([1.0, 1.0])


def drive(room: Room, obj: str, bearing: float, heading: float, action=FORWARD, *,
          robot_moves: bool, obj_moves: bool) -> int:
    """The robot at the origin facing `heading`, `obj` touching it at `bearing`; one action.
    The robot moves by its free step unless stopped; the object by 0.9 of it if it moves.
    Returns the iteration."""
    h = np.array([np.cos(heading), np.sin(heading)])
    b = np.array([np.cos(bearing), np.sin(bearing)])
    radius = float(room.obs[room.layout.space(obj, Property.RADIUS).slice][0])
    parked = room.obs[room.layout.space(obj, Property.POSITION).slice].copy()
    room.place("robot", [0.0, 0.0])
    room.set("robot", Property.HEADING, h)
    at = (ROBOT_RADIUS + radius) * b
    room.place(obj, at)
    before = room.obs.copy()
    step = STEP * float(np.mean(action)) * h
    room.place("robot", step if robot_moves else [0.0, 0.0])
    room.place(obj, at + (0.9 * step if obj_moves else 0.0))
    t = room.dataset.append(np.asarray(action, dtype=float), before, room.obs.copy())
    room.place(obj, parked)
    return t


def pushing_room(young: bool = False) -> Room:
    """A motion affordance (action → robot.position | robot.heading) from free moves and a
    pushing affordance (robot.position → target.position | target-robot) from pushes of the
    green obj1 in every direction. `young`: the motion affordance has no context yet and has
    only seen the robot facing east (it takes every forward move for a move east)."""
    rng = np.random.default_rng(0)
    room = Room()
    room.episode()
    if young:
        room.affordance(room.moves(rng, 200, heading=0.0))
    else:
        room.affordance(room.moves(rng, 200), contexts=(ROBOT_HEADING,))
    start = len(room.dataset)
    for a in np.linspace(0, 2 * np.pi, 24, endpoint=False):
        drive(room, "obj1", a, a, robot_moves=True, obj_moves=True)
    t = np.arange(start, len(room.dataset), dtype=np.int64)
    rows = Rows(t, np.full(t.size, 1), np.full(t.size, -1))
    aff = room.fitter.new_affordance(room.hierarchy.allocate_id(), ROBOT_POSITION,
                                     TARGET_POSITION, (TARGET_ROBOT,), rows,
                                     len(room.dataset), rng)
    room.hierarchy.add(aff, len(room.dataset))
    return room


def pusher(room: Room):
    return next(a for a in room.hierarchy if a.output == TARGET_POSITION)


def negatives(room: Room) -> np.ndarray:
    return pusher(room).classifier.state()["replay.negative"]


def features(room: Room, entity: int) -> np.ndarray:
    t = np.zeros(1, dtype=np.int64)
    return room.fitter.target_features(Rows(t, np.array([entity]), t - 1))[0]


def holds(replay: np.ndarray, x: np.ndarray) -> bool:
    return bool(np.all(np.isclose(replay, x), axis=1).any())


def test_an_object_that_stops_the_robot_refused_it_a_graze_or_backing_away_did_not():
    """Nor an object alongside when something else (a wall) stops the robot."""
    room = pushing_room()
    start = room.episode()
    drive(room, "obj2", 0.3, 0.3, robot_moves=False, obj_moves=False)  # red, head-on: stopped
    drive(room, "obj3", np.pi / 2, 0.0, robot_moves=True, obj_moves=False)  # green, alongside
    drive(room, "obj3", 0.0, 0.0, -FORWARD, robot_moves=True, obj_moves=False)  # backing away
    drive(room, "obj3", np.pi / 2, 0.0, robot_moves=False, obj_moves=False)  # a wall ahead
    refused = room.adaptation._refused(np.arange(start, len(room.dataset), dtype=np.int64))
    assert set(refused.target.tolist()) == {2}


def test_a_move_a_young_motion_model_misplaces_is_no_refusal():
    """Facing north, touching obj3 on its east side, the robot drives forward and goes north
    (a graze); its young motion model meant a move east, into obj3. The robot was not
    stopped: it moved as far as it meant to. The red obj2 head-on does stop it."""
    room = pushing_room(young=True)
    start = room.episode()
    drive(room, "obj3", 0.0, np.pi / 2, robot_moves=True, obj_moves=False)
    drive(room, "obj2", 0.0, 0.0, robot_moves=False, obj_moves=False)
    refused = room.adaptation._refused(np.arange(start, len(room.dataset), dtype=np.int64))
    assert set(refused.target.tolist()) == {2}


def test_refusals_teach_p_a_in_a_learning_episode_where_nothing_moved():
    """Driving into a fixed object moves nothing: no space is non-null, no affordance is
    updated, and still the object is a negative of p_A (with the robot)."""
    room = pushing_room()
    start = room.episode()
    for _ in range(3):
        drive(room, "obj2", 0.3, 0.3, robot_moves=False, obj_moves=False)
    assert not room.adaptation.non_null_spaces(np.arange(start, len(room.dataset)))
    room.adaptation.run(start, len(room.dataset), len(room.dataset), 1,
                        np.random.default_rng(1))
    assert holds(negatives(room), features(room, 2))


def test_a_pushable_object_is_no_negative_even_where_the_pushing_model_expects_a_push():
    """In one learning episode: the green obj3 is grazed (the robot slides along it, nothing
    moves; the pushing model, fitted on head-on pushes, expects a push), the red obj2 stops
    the robot, the green obj1 is pushed. p_A of the pushing affordance, whose rows never hold
    obj2, learns obj2 as a negative, obj1 as a positive, and nothing of obj3."""
    room = pushing_room()
    start = room.episode()
    drive(room, "obj3", np.radians(80), 0.0, robot_moves=True, obj_moves=False)
    drive(room, "obj2", 1.0, 1.0, robot_moves=False, obj_moves=False)
    drive(room, "obj1", 2.0, 2.0, robot_moves=True, obj_moves=True)
    room.adaptation.run(start, len(room.dataset), len(room.dataset), 1,
                        np.random.default_rng(1))
    c = pusher(room).classifier.state()
    assert holds(c["replay.negative"], features(room, 2))
    assert not holds(c["replay.negative"], features(room, 3))
    assert holds(c["replay.positive"], features(room, 1))


def test_an_object_that_moved_earlier_in_the_episode_is_no_refusal():
    """Stuck once (against something the robot cannot see), moved before: it is pushable."""
    room = pushing_room()
    room.episode()
    drive(room, "obj3", 2.0, 2.0, robot_moves=True, obj_moves=True)
    later = len(room.dataset)  # a later learning episode of the same environment episode
    drive(room, "obj3", 0.5, 0.5, robot_moves=False, obj_moves=False)
    drive(room, "obj2", 0.5, 0.5, robot_moves=False, obj_moves=False)
    t = np.arange(later, len(room.dataset), dtype=np.int64)
    assert set(room.adaptation._refused(t).target.tolist()) == {2}


def draw_objects(room: Room, rng: np.random.Generator) -> None:
    """New sizes and shades in the world's ranges: obj1 and obj3 green, obj2 red."""
    from hadim_cli.config import load_config
    from hadim_cli.world.placement import shade

    w = load_config().world
    for name, channel in (("obj1", 1), ("obj2", 0), ("obj3", 1)):
        room.set(name, Property.RADIUS, [rng.uniform(w.object_radius_min, w.object_radius_max)])
        room.set(name, Property.HEIGHT, [rng.uniform(w.object_height_min, w.object_height_max)])
        room.set(name, Property.COLOR, shade(rng, channel))


def test_p_a_from_refusals_is_right_on_the_scene_and_on_unseen_objects():
    """Ten environment episodes of new objects: each green one is grazed (the robot slides
    along it, it does not move: the trap of a pushing model's expectations) and pushed, the
    red one stops the robot. Both pushing affordances' p_A are then right on the reference
    scene and on objects of sizes and shades the world never draws."""
    from hadim_cli.config import load_config
    from hadim_cli.evaluation.tasks import load_task
    from hadim_cli.learner.spaces import ACTION, SpaceReader
    from hadim_cli.pa_probes import scene_probes, unseen_probes
    from hadim_cli.world.world import World

    rng = np.random.default_rng(3)
    room = pushing_room()
    t = np.array([a.rows.t for a in room.hierarchy if a.output == TARGET_POSITION][0])
    room.hierarchy.add(room.fitter.new_affordance(
        room.hierarchy.allocate_id(), ACTION, TARGET_POSITION, (TARGET_ROBOT, ROBOT_HEADING),
        Rows(t, np.full(t.size, 1), np.full(t.size, -1)), len(room.dataset), rng),
        len(room.dataset))
    for episode in range(10):
        start = room.episode()
        draw_objects(room, rng)
        for a in rng.uniform(0, 2 * np.pi, 2):
            drive(room, "obj2", a, a, robot_moves=False, obj_moves=False)
            for green in ("obj1", "obj3"):
                drive(room, green, a + np.radians(80), a, robot_moves=True, obj_moves=False)
                drive(room, green, a, a, robot_moves=True, obj_moves=True)
        room.adaptation.run(start, len(room.dataset), len(room.dataset), episode, rng)
    world = World(load_config().world)
    reader = SpaceReader(world.layout)
    probes = (scene_probes(world, reader, load_task("push-object").scene)
              + unseen_probes(world, reader))
    x = np.stack([p.features for p in probes])
    for aff in room.hierarchy:
        if aff.output != TARGET_POSITION:
            continue
        ok = aff.classifier.accepts(x)
        assert [p.name for p, a in zip(probes, ok, strict=True) if a != p.pushable] == [], \
            aff.describe()
