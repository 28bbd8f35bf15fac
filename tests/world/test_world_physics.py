"""Driving, pushing, fixed objects, walls: the physics the learner relies on."""

from __future__ import annotations

import math

import numpy as np
import pytest
from worldmade import green, red, world_with

from hadim_cli.config import WorldConfig
from hadim_cli.world.layout import Property
from hadim_cli.world.world import World


def position(world: World, entity: str) -> np.ndarray:
    return world.layout.get(world.observe(), entity, Property.POSITION)


@pytest.mark.parametrize("heading", [0.0, 0.7, -2.5])
def test_equal_intensities_drive_straight_along_heading(heading: float) -> None:
    world = world_with(heading=heading)
    world.step((1.0, 1.0))  # the first action includes the short acceleration
    x0, y0, _ = world.robot_pose()
    for _ in range(3):
        world.step((1.0, 1.0))
    x1, y1, h1 = world.robot_pose()
    assert h1 == pytest.approx(heading, abs=1e-9)
    assert math.hypot(x1 - x0, y1 - y0) == pytest.approx(3 * 0.15, abs=1e-3)
    assert math.atan2(y1 - y0, x1 - x0) == pytest.approx(heading, abs=1e-6)


def test_half_intensity_backwards_is_half_speed_reversed() -> None:
    world = world_with()
    world.step((-0.5, -0.5))
    x0 = world.robot_pose()[0]
    world.step((-0.5, -0.5))
    assert world.robot_pose()[0] - x0 == pytest.approx(-0.075, abs=1e-3)


@pytest.mark.parametrize(("action", "sign"), [((-1.0, 1.0), 1.0), ((1.0, -1.0), -1.0)])
def test_opposite_intensities_turn_in_place(action: tuple[float, float], sign: float) -> None:
    world = world_with(heading=0.3)
    world.step(action)
    x0, y0, h0 = world.robot_pose()
    world.step(action)
    x1, y1, h1 = world.robot_pose()
    assert math.hypot(x1, y1) < 1e-6 and math.hypot(x0, y0) < 1e-6
    # ω = 2·0.3 m/s / 0.3 m = 2 rad/s, held 0.5 s.
    assert (h1 - h0) == pytest.approx(sign * 1.0, abs=1e-3)


def test_light_green_object_is_pushed_and_contact_reported() -> None:
    world = world_with(green(0.4, 0.0, radius=0.08, height=0.1), red(-1.5, -1.5))
    for _ in range(3):
        world.step((1.0, 1.0))
    x, y = position(world, "obj1")
    assert x - 0.4 > 0.25 and abs(y) < 1e-6  # 0.45 m driven, 0.17 m of them to reach it
    assert ("obj1", "robot") in world.last_contacts


def pushed_distance(radius: float, height: float, actions: int = 3) -> float:
    world = world_with(green(0.15 + 0.05 + radius, 0.0, radius, height))
    for _ in range(actions):
        world.step((1.0, 1.0))
    return float(position(world, "obj1")[0] - (0.2 + radius))


def test_heavy_green_moves_less_than_light_but_moves() -> None:
    config = WorldConfig()
    light = pushed_distance(config.object_radius_min, config.object_height_min)
    heavy = pushed_distance(config.object_radius_max, config.object_height_max)
    assert heavy < light - 0.03
    assert heavy > 0.15  # the heaviest default object is still pushable (0.197 m in 3 actions)


def test_every_default_green_object_is_pushable_by_the_drive() -> None:
    c = WorldConfig()
    heaviest = c.object_density * math.pi * c.object_radius_max ** 2 * c.object_height_max
    assert c.drive_force > c.ground_friction * heaviest * 9.81


def test_red_object_never_moves_and_blocks_the_robot() -> None:
    world = world_with(red(0.5, 0.0, radius=0.2), green(-1.5, 1.5))
    before = position(world, "obj1").copy()
    for _ in range(6):
        world.step((1.0, 1.0))
    assert np.array_equal(position(world, "obj1"), before)
    assert world.robot_pose()[0] < 0.5 - 0.2 - 0.15 + 0.005
    assert ("obj1", "robot") in world.last_contacts


def test_object_object_contact_is_reported() -> None:
    world = world_with(green(0.3, 0.0), green(0.6, 0.0))
    for _ in range(3):
        world.step((1.0, 1.0))
    assert {("obj1", "robot"), ("obj1", "obj2")} <= world.last_contacts
    world_far = world_with(green(1.5, 1.5), green(-1.5, -1.5))
    world_far.step((1.0, 1.0))
    assert world_far.last_contacts == frozenset()


def test_nothing_leaves_the_room(default_world: World) -> None:
    rng = np.random.default_rng(3)
    config, layout = default_world.config, default_world.layout
    hw, hh = config.room_width / 2, config.room_height / 2
    for _episode in range(3):
        obs = default_world.reset(rng)
        for _ in range(120):
            # Biased forward so the robot reaches and pushes things into the walls.
            obs = default_world.step(np.clip(rng.normal(0.6, 0.5, size=2), -1, 1))
            for entity in layout.entities:
                x, y = layout.get(obs, entity, Property.POSITION)
                r = layout.get(obs, entity, Property.RADIUS)[0]
                assert abs(x) + r <= hw + 0.01 and abs(y) + r <= hh + 0.01, entity


def test_drive_into_wall_stays_inside() -> None:
    world = world_with(heading=0.0, x=1.5)
    for _ in range(10):
        world.step((1.0, 1.0))
    assert world.robot_pose()[0] <= 2.0 - 0.15 + 0.005


@pytest.mark.parametrize("before", [(1.0, 1.0), (-1.0, -1.0), (-1.0, 1.0), (0.3, -0.8)])
def test_every_action_starts_from_standstill_whatever_came_before(before) -> None:
    """`settle_time`: the wheels stop after each action's hold until everything is at rest, so
    a command moves the robot the same way whatever the previous one was (the learner sees no
    speed); without it, a command after its reverse moves the robot ~3 cm less."""
    def move_after(previous, **changes) -> np.ndarray:
        world = world_with(**changes)
        world.step(previous)
        x0, y0, h0 = world.robot_pose()
        world.step((1.0, 1.0))
        x1, y1, h1 = world.robot_pose()
        c, s = math.cos(h0), math.sin(h0)
        return np.array([c * (x1 - x0) + s * (y1 - y0), -s * (x1 - x0) + c * (y1 - y0), h1 - h0])

    assert WorldConfig().settle_time > 0
    np.testing.assert_allclose(move_after(before), [0.15, 0.0, 0.0], atol=1e-4)
    unsettled = move_after(before, settle_time=0.0)
    if before == (-1.0, -1.0):
        assert unsettled[0] < 0.125


def test_a_pushed_object_is_at_rest_when_the_action_is_observed() -> None:
    world = world_with(green(0.4, 0.0, radius=0.08, height=0.1), red(-1.5, -1.5))
    for _ in range(3):
        world.step((1.0, 1.0))
    x = position(world, "obj1")[0]
    world.step((-1.0, 1.0))  # a turn on the spot: nothing pushes the object now
    assert position(world, "obj1")[0] == pytest.approx(x, abs=1e-6)


def test_ground_friction_of_a_green_object_is_coulombs_with_the_torque_of_a_disc():
    """The ground holds a green object back with at most μ·m·g, and its turning with at most
    (2/3)·μ·m·g·r (a disc pressing evenly on the ground); a red object is held by nothing, it
    is static."""
    import pymunk

    from hadim_cli.world.physics import GRAVITY, build_physics
    from hadim_cli.world.placement import object_mass
    from hadim_cli.world.scene import Scene

    cfg = WorldConfig()
    small, big = green(1.0, 0.0, radius=0.08, height=0.1), green(-1.0, 0.0, radius=0.25,
                                                                   height=0.6)
    physics = build_physics(cfg, Scene((small, red(0.0, 1.0), big)))
    assert len(physics.movable) == 2
    for spec, body in zip((small, big), physics.movable, strict=True):
        force = cfg.ground_friction * object_mass(cfg, spec.radius, spec.height) * GRAVITY
        held = {type(c): c for c in physics.space.constraints
                if body in (c.a, c.b) and physics.space.static_body in (c.a, c.b)}
        assert held[pymunk.PivotJoint].max_force == pytest.approx(force)
        assert held[pymunk.GearJoint].max_force == pytest.approx(force * spec.radius * 2 / 3)
        assert held[pymunk.PivotJoint].max_bias == held[pymunk.GearJoint].max_bias == 0.0
