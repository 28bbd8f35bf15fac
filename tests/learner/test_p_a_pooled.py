"""p_A of every object-moving affordance learns from all of them (pooled), and is then right
on objects of sizes and shades it never saw.

A fixed object stops the robot: pushing it in vain leaves the robot where it was, so the row is
outside the domain of `robot.position → target.position` (its input did not change) and that
affordance's own rows never show a fixed object refuse to move; pooled, its p_A learns the
objects that refused the robot all the same. The data are hand-built (`handmade.Room`),
objects drawn in the world's ranges of size and shade; the probes are `hadim_cli.pa_probes`'s,
read from a real World.
"""

from __future__ import annotations

import numpy as np
import pytest
from handmade import ROBOT_HEADING, ROBOT_POSITION, TARGET_POSITION, TARGET_ROBOT, Room

from hadim_cli.config import load_config
from hadim_cli.learner.spaces import ACTION, Rows, SpaceReader
from hadim_cli.pa_probes import UNSEEN, scene_probes, unseen_probes, unseen_size
from hadim_cli.world.layout import Property
from hadim_cli.world.placement import shade

pytestmark = pytest.mark.usefixtures("one_thread")

ROBOT_RADIUS = 0.15


def push(room: Room, obj: str, angle: float, radius: float, moves: bool) -> None:
    """The robot at the origin, in contact behind `obj`, drives 0.1 m along `angle`; a fixed
    object (`moves` false) stops it: neither moves."""
    u = np.array([np.cos(angle), np.sin(angle)])
    room.place("robot", [0.0, 0.0])
    room.set("robot", Property.HEADING, u)
    parked = room.obs[room.layout.space(obj, Property.POSITION).slice].copy()
    at = (ROBOT_RADIUS + radius) * u
    room.place(obj, at)
    before = room.obs.copy()
    room.place("robot", 0.1 * u if moves else [0.0, 0.0])
    room.place(obj, at + (0.09 * u if moves else 0.0))
    room.dataset.append(np.array([1.0, 1.0]), before, room.obs.copy())
    room.place(obj, parked)


def draw_objects(room: Room, rng: np.random.Generator) -> dict[str, float]:
    """New sizes and shades in the world's ranges: obj1 and obj3 green, obj2 red."""
    w = load_config().world
    radii = {}
    for name, channel in (("obj1", 1), ("obj2", 0), ("obj3", 1)):
        radii[name] = float(rng.uniform(w.object_radius_min, w.object_radius_max))
        room.set(name, Property.RADIUS, [radii[name]])
        room.set(name, Property.HEIGHT, [rng.uniform(w.object_height_min, w.object_height_max)])
        room.set(name, Property.COLOR, shade(rng, channel))
    return radii


def trained_room(episodes: int = 10) -> Room:
    """The robot's motion (from free moves) and two pushing affordances (from the robot's
    position, from the actions), then `episodes` environment episodes of new objects, each
    pushed: the green ones move, the red one stops the robot. Algorithm 2 runs after each."""
    rng = np.random.default_rng(3)
    room = Room()
    room.episode()
    room.affordance(room.moves(rng, 200), contexts=(ROBOT_HEADING,))
    radii = draw_objects(room, rng)
    start = len(room.dataset)
    for a in np.linspace(0, 2 * np.pi, 30, endpoint=False):
        push(room, "obj1", a, radii["obj1"], moves=True)
    t = np.arange(start, len(room.dataset), dtype=np.int64)
    rows = Rows(t, np.full(t.size, 1), np.full(t.size, -1))
    for inp in (ROBOT_POSITION, ACTION):
        aff = room.fitter.new_affordance(room.hierarchy.allocate_id(), inp, TARGET_POSITION,
                                         (TARGET_ROBOT,), rows, len(room.dataset), rng)
        room.hierarchy.add(aff, len(room.dataset))
    for episode in range(episodes):
        start = room.episode()
        radii = draw_objects(room, rng)
        for a in rng.uniform(0, 2 * np.pi, 2):
            push(room, "obj2", a, radii["obj2"], moves=False)
            for green in ("obj1", "obj3"):
                push(room, green, a, radii[green], moves=True)
        room.adaptation.run(start, len(room.dataset), len(room.dataset), episode, rng)
    return room


@pytest.fixture(scope="module")
def pooled() -> Room:
    return trained_room()


def _probes(room: Room):
    from hadim_cli.evaluation.tasks import load_task
    from hadim_cli.world.world import World

    world = World(load_config().world)
    reader = SpaceReader(world.layout)  # the world's layout; the same features as the room's
    return (scene_probes(world, reader, load_task("push-object").scene),
            unseen_probes(world, reader))


def _wrong(room: Room, aff_input: str, probes) -> list[str]:
    aff = next(a for a in room.hierarchy.with_output(TARGET_POSITION)
               if a.input.name == aff_input)
    ok = aff.classifier.accepts(np.stack([p.features for p in probes]))
    return [p.name for p, a in zip(probes, ok, strict=True) if a != p.pushable]


def test_unseen_probes_lie_outside_the_world_s_ranges():
    """The probes are what their names say: sizes below or above the world's ranges, shades
    darker or paler than any it draws, read from a real World's observation."""
    from hadim_cli.world.world import World

    w = load_config().world
    world = World(w)
    probes = unseen_probes(world, SpaceReader(world.layout))
    assert [p.name for p in probes] == [u.name for u in UNSEEN]
    radius, height = w.object_radius_max, w.object_height_max  # features are r / r_max, …
    for p in probes:
        r, h, rgb = p.features[0] * radius, p.features[1] * height, p.features[2:5]
        dominant, others = (rgb[1], rgb[[0, 2]]) if p.pushable else (rgb[0], rgb[1:])
        in_size = w.object_radius_min <= r <= w.object_radius_max \
            and w.object_height_min <= h <= w.object_height_max
        in_shade = dominant >= 0.55 and (others <= 0.3).all()
        assert not (in_size and in_shade), p.name


@pytest.mark.parametrize("u", UNSEEN, ids=lambda u: u.name)
def test_an_unseen_probe_is_pushable_exactly_when_the_robot_can_push_it(u):
    """The probes' labels are the physics': the robot, in contact behind the object, drives
    full forward 5 actions; a pushable probe moves (> 0.2 m), a fixed one does not."""
    from hadim_cli.world.scene import ObjectSpec, Scene
    from hadim_cli.world.world import World

    w = load_config().world
    world = World(w)
    r, h = unseen_size(w, u)
    parked = [ObjectSpec(-1.6 + 0.35 * i, 1.6, 0.1, 0.2, (0.2, 0.8, 0.2), True)
              for i in range(w.n_green + w.n_red - 1)]
    obs = world.reset(scene=Scene((ObjectSpec(w.robot_radius + r + 0.01, 0.0, r, h, u.color,
                                              u.pushable), *parked)))
    where = world.layout.space("obj1", Property.POSITION).slice
    start = obs[where].copy()
    for _ in range(5):
        obs = world.step(np.array([1.0, 1.0]))
    moved = float(np.linalg.norm(obs[where] - start))
    assert (moved > 0.2) == u.pushable, moved


@pytest.mark.parametrize("inp", ["robot.position", "action"])
def test_pooled_p_a_is_right_on_the_scene_and_on_unseen_objects(pooled, inp):
    scene, unseen = _probes(pooled)
    assert _wrong(pooled, inp, scene) == []
    assert _wrong(pooled, inp, unseen) == []


def test_hadim_affordances_pa_shows_each_affordance_s_p_a(pooled):
    """What `hadim affordances RUN --pa` prints: P(accept) per probe and affordance, ✗ where
    wrong, and what each p_A learned from."""
    import io
    from types import SimpleNamespace

    from rich.console import Console

    from hadim_cli.pa_probes import verdicts
    from hadim_cli.reports import render_p_a

    found = verdicts(SimpleNamespace(learner=pooled.learner, config=load_config()))
    assert [v.affordance.split("(")[1].split(" ")[0] for v in found] == ["robot.position",
                                                                       "action"]
    for v in found:
        assert len(v.scene) == 10 and len(v.unseen) == len(UNSEEN)
        assert v.scene["robot"] < 0.5 and v.scene["obj1 (green)"] >= 0.5
        assert v.scene_wrong == () and v.unseen_wrong == ()
        # (the hand-built robot is not the World's: its negatives count as objects here)
        assert v.replay["positives"] > 0 and v.replay["negatives_objects"] > 0
        assert v.as_json()["scene_right"] and v.as_json()["unseen_right"]
    out = io.StringIO()
    render_p_a(Console(file=out, width=200), found, 300)
    text = out.getvalue()
    assert "p_A at iteration 300" in text and "unseen: red-pale" in text
    assert " ✗ │" not in text  # no cell marked wrong
    assert "scene right; unseen right" in text
