"""The World contract: reset/step/observe, determinism, bad actions, layout, episodes."""

from __future__ import annotations

import hashlib
import subprocess
import sys

import numpy as np
import pytest
from worldmade import config, green

from hadim_cli.config import WorldConfig
from hadim_cli.errors import ActionError, HadimError
from hadim_cli.world.scene import Scene
from hadim_cli.world.world import World

_SCRIPT = """
import hashlib, numpy as np
from hadim_cli.config import WorldConfig
from hadim_cli.world.world import World
world = World(WorldConfig())
actions = np.random.default_rng(11).uniform(-1, 1, size=(40, 2))
obs = [world.reset(seed=5)] + [world.step(a) for a in actions]
print(hashlib.sha256(np.array(obs).tobytes()).hexdigest())
"""


def run_episode(world: World, seed: int, n: int = 40) -> np.ndarray:
    actions = np.random.default_rng(11).uniform(-1, 1, size=(n, 2))
    return np.array([world.reset(seed=seed)] + [world.step(a) for a in actions])


def test_same_seed_same_actions_bit_identical_in_process() -> None:
    first = run_episode(World(WorldConfig()), 5)
    world = World(WorldConfig())
    run_episode(world, 9)  # an earlier, different episode must leave no trace
    assert np.array_equal(run_episode(world, 5), first)
    assert not np.array_equal(run_episode(world, 6), first)


@pytest.mark.scenario
def test_same_seed_same_actions_bit_identical_across_processes() -> None:
    digests = {subprocess.run([sys.executable, "-c", _SCRIPT], check=True, capture_output=True,
                              text=True).stdout.strip() for _ in range(2)}
    local = hashlib.sha256(run_episode(World(WorldConfig()), 5).tobytes()).hexdigest()
    assert digests == {local}


def test_reset_builds_a_fresh_space(default_world: World) -> None:
    a = default_world.reset(seed=1)
    space = default_world._physics.space
    b = default_world.reset(seed=1)
    assert default_world._physics.space is not space
    assert np.array_equal(a, b)


def test_reset_needs_a_source_and_a_matching_scene(default_world: World) -> None:
    with pytest.raises(HadimError, match="scene, a generator or a seed"):
        default_world.reset()
    with pytest.raises(HadimError, match="layout has 9"):
        default_world.reset(scene=Scene(objects=(green(1.0, 1.0),)))
    with pytest.raises(HadimError, match="before|reset"):
        World(WorldConfig()).step((0, 0))


def test_reset_from_generator_uses_it(default_world: World) -> None:
    a = default_world.reset(np.random.default_rng(4))
    b = default_world.reset(seed=4)
    assert np.array_equal(a, b)


@pytest.mark.parametrize("action", [
    (np.nan, 0.0), (0.0, np.inf), (-np.inf, 0.0), (1.5, 0.0), (0.0, -1.0001),
    np.zeros(3), [[0.0, 0.0]], 0.5, "ab", ("a", "b"), None, np.array(["1", "0"]), [True, False],
])
def test_bad_actions_are_refused(default_world: World, action: object) -> None:
    default_world.reset(seed=0)
    with pytest.raises(ActionError):
        default_world.step(action)
    assert default_world.steps == 0


@pytest.mark.parametrize(("action", "message"), [
    ([[0.0, 0.0], 1.0], "action must be 2 numbers in [-1, 1], got [[0.0, 0.0], 1.0]"),
    ("ab", "action must be 2 numbers in [-1, 1], got 'ab'"),
    (np.zeros(3), "action must have shape (2,) (left, right), got shape (3,)"),
    ((1.5, 0.0), "action intensities must be finite and in [-1, 1], got (1.5, 0.0)"),
])
def test_a_bad_actions_refusal_says_what_an_action_must_be_and_what_it_got(
        default_world: World, action: object, message: str) -> None:
    default_world.reset(seed=0)
    with pytest.raises(ActionError) as refused:
        default_world.step(action)
    assert str(refused.value) == message


@pytest.mark.parametrize("action", [(-1, 1), [1.0, -1.0], np.array([0.25, 0.5], np.float32)])
def test_good_actions_are_accepted(default_world: World, action: object) -> None:
    default_world.reset(seed=0)
    obs = default_world.step(action)
    assert obs.shape == (default_world.layout.size,) and default_world.steps == 1


def test_observation_is_a_copy_and_matches_the_layout(default_world: World) -> None:
    obs = default_world.reset(seed=2)
    assert obs.dtype == np.float64 and obs.shape == (default_world.layout.size,)
    obs[:] = 123.0
    assert not np.array_equal(default_world.observe(), obs)
    rng = np.random.default_rng(0)
    for _ in range(30):
        obs = default_world.step(rng.uniform(-1, 1, 2))
        for spec in default_world.layout.spaces:
            values = obs[spec.slice]
            assert np.all(values >= np.array(spec.low) - 1e-9), spec.name
            assert np.all(values <= np.array(spec.high) + 1e-9), spec.name


def test_observation_reads_the_bodies(default_world: World) -> None:
    default_world.reset(seed=8)
    for a in np.random.default_rng(1).uniform(-1, 1, (20, 2)):
        obs = default_world.step(a)
    layout, physics = default_world.layout, default_world._physics
    x, y, heading = default_world.robot_pose()
    assert np.array_equal(obs[layout.space("robot", "position").slice], [x, y])
    assert np.allclose(obs[layout.space("robot", "heading").slice],
                       [np.cos(heading), np.sin(heading)])
    green_names = [n for n, s in zip(layout.objects, default_world.scene.objects, strict=True)
                   if s.pushable]
    for name, body in zip(green_names, physics.movable, strict=True):
        assert np.array_equal(obs[layout.space(name, "position").slice], tuple(body.position))
        assert np.array_equal(obs[layout.space(name, "relative").slice],
                              np.array(body.position) - [x, y])


def test_static_properties_and_robot_look(default_world: World) -> None:
    obs = default_world.reset(seed=3)
    lay, scene = default_world.layout, default_world.scene
    assert list(lay.get(obs, "robot", "color")) == [0.2, 0.3, 0.8]
    assert lay.get(obs, "robot", "radius")[0] == 0.15
    for name, spec in zip(lay.objects, scene.objects, strict=True):
        assert list(lay.get(obs, name, "color")) == list(spec.color)
        assert lay.get(obs, name, "height")[0] == spec.height
        assert lay.get(obs, name, "shape")[0] == 0.0


def test_episode_counts_steps() -> None:
    world = World(config(episode_length=3))
    world.reset(seed=0)
    for expected in (1, 2, 3):
        assert not world.episode_over
        world.step((0.0, 0.0))
        assert world.steps == expected
    assert world.episode_over
    world.reset(seed=0)
    assert world.steps == 0 and not world.episode_over and world.last_contacts == frozenset()


def test_the_layout_and_the_scenes_a_world_takes_are_those_of_its_room() -> None:
    """In a room 5 m wide and 3 m high, positions are bounded by half its sides and relative
    positions by its sides; a scene whose robot or object leaves it, by either side, is
    refused, and one that fits in a corner, or whose object touches a wall, is taken."""
    lay = World(config(room_width=5.0, room_height=3.0)).layout
    for entity in ("robot", "obj1"):
        pos = lay.space(entity, "position")
        assert (pos.low, pos.high) == ((-2.5, -1.5), (2.5, 1.5))
    rel = lay.space("obj1", "relative")
    assert (rel.low, rel.high) == ((-5.0, -3.0), (5.0, 3.0))
    world = World(config(room_width=5.0, room_height=3.0, n_green=1, n_red=0))
    world.reset(scene=Scene(objects=(green(2.35, 1.35),), robot_x=-2.3, robot_y=-1.3))
    world.reset(scene=Scene(objects=(green(2.5 - 0.125, 0.0, radius=0.125),)))  # at the wall
    for scene in (Scene(objects=(green(2.45, 0.0),)), Scene(objects=(green(0.0, -1.45),)),
                  Scene(objects=(green(1.0, 1.0),), robot_x=-2.4),
                  Scene(objects=(green(1.0, 1.0),), robot_y=1.4)):
        with pytest.raises(HadimError, match=r"outside the 5\.0x3\.0 m room"):
            world.reset(scene=scene)


def test_a_world_has_no_scene_before_its_first_episode() -> None:
    world = World(config(n_green=1, n_red=0))
    with pytest.raises(HadimError, match=r"^the world has no episode yet: call reset\(\) first$"):
        world.scene  # noqa: B018 — the property refuses
    scene = Scene(objects=(green(1.0, 1.0),))
    world.reset(scene=scene)
    assert world.scene == scene
