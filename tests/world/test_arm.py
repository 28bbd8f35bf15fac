"""The arm's world: what it declares, its kinematics, joint limits, reach, scenes, determinism."""

from __future__ import annotations

import dataclasses
import hashlib
import itertools
import math
import subprocess
import sys

import numpy as np
import pytest
from worldmade import GREEN, RED, assert_drawn_object

from hadim_cli.config import Body, WorldConfig, configs_dir, load_config
from hadim_cli.errors import ActionError, HadimError
from hadim_cli.world.arm import ArmWorld
from hadim_cli.world.environment import make_world
from hadim_cli.world.kinematics import (
    effector_position,
    inner_reach,
    joint_points,
    joint_ranges,
    outer_reach,
    pose_angles,
)
from hadim_cli.world.layout import EFFECTOR, OBJECT_SPACES, Property
from hadim_cli.world.scene import ArmScene, ObjectSpec
from hadim_cli.world.world import World

ARM = load_config(configs_dir() / "arm.toml").world
LIMIT_SLACK = 1e-3
"""How far past a joint's limit pymunk's solver may leave it (rad): measured, 2e-4."""

_SCRIPT = """
import hadim_cli, hashlib, numpy as np
from hadim_cli.config import configs_dir, load_config
from hadim_cli.world.environment import make_world
world = make_world(load_config(configs_dir() / "arm.toml").world)
actions = np.random.default_rng(11).uniform(-1, 1, size=(40, 3))
obs = [world.reset(seed=5)] + [world.step(a) for a in actions]
print(hashlib.sha256(np.array(obs).tobytes()).hexdigest())
"""



def angles(lay, obs: np.ndarray) -> np.ndarray:
    """Every joint's angle, base outwards, from the observation: the first link's direction
    (`Property.ORIENTATION`) and the other joints' bends (`Property.JOINTS`)."""
    return pose_angles(lay.get(obs, EFFECTOR, Property.ORIENTATION),
                       lay.get(obs, EFFECTOR, Property.JOINTS))

def arm_config(**changes: object) -> WorldConfig:
    return dataclasses.replace(ARM, **changes)


def arm_with(*objects: ObjectSpec, joints: tuple[float, ...] = (0.0, 0.0, 0.0)) -> ArmWorld:
    """An arm world holding exactly `objects`, reset to the pose `joints`."""
    n_green = sum(o.pushable for o in objects)
    world = ArmWorld(arm_config(n_green=n_green, n_red=len(objects) - n_green))
    world.reset(scene=ArmScene(tuple(objects), joints))
    return world


def run_episode(world: ArmWorld, seed: int, n: int = 40) -> np.ndarray:
    actions = np.random.default_rng(11).uniform(-1, 1, size=(n, 3))
    return np.array([world.reset(seed=seed)] + [world.step(a) for a in actions])


def test_the_world_declares_its_body_action_and_observation():
    """What a learner that knows no body reads: the body, the action's components and box,
    the actor (entity 0) and every space with its bounds; the objects' spaces are the room's."""
    world = make_world(ARM)
    assert isinstance(world, ArmWorld) and world.body is Body.ARM
    assert world.action_dim == 3
    assert world.action_space.names == ("joint1", "joint2", "joint3")
    lay = world.layout
    assert lay.actor == EFFECTOR and lay.objects == tuple(f"obj{i}" for i in range(1, 10))
    assert [s.prop for s in lay.spaces if s.entity == EFFECTOR] == [
        Property.POSITION, Property.ORIENTATION, Property.JOINTS, Property.RADIUS,
        Property.HEIGHT, Property.COLOR, Property.SHAPE]
    # The pose: the first link's direction about the base apart from the other joints' bends.
    orientation = lay.space(EFFECTOR, Property.ORIENTATION)
    assert orientation.dim == 2 and orientation.low == (-1.0, -1.0)
    joints = lay.space(EFFECTOR, Property.JOINTS)
    assert joints.low == (-2.0, -2.0) and joints.high == (2.0, 2.0)
    assert lay.space(EFFECTOR, Property.POSITION).high == (2.0, 2.0)
    assert [(s.prop, s.dim) for s in lay.spaces if s.entity == "obj1"] == list(OBJECT_SPACES)
    rover = make_world(WorldConfig())
    assert isinstance(rover, World) and rover.body is Body.ROVER and rover.action_dim == 2
    assert rover.layout.actor == "robot" and not rover.layout.has("robot", Property.JOINTS)


def test_a_world_refuses_another_body_s_config():
    """The rover's world (all that training, evaluation and the baselines build) refuses an
    arm config in one sentence, and the arm's a rover config."""
    with pytest.raises(HadimError) as refused:
        World(ARM)
    assert str(refused.value) == ("world.body = 'arm': this part of hadim runs the rover only "
                                  "(`hadim world render|info` and `hadim bench world` run every "
                                  "body)")
    with pytest.raises(HadimError, match="world.body = 'rover'"):
        ArmWorld(WorldConfig())


@pytest.mark.parametrize("action", [
    (0.0, 0.0), np.zeros(4), (np.nan, 0.0, 0.0), (0.0, 1.5, 0.0), (0.0, 0.0, -np.inf),
    "abc", [True, False, True],
])
def test_bad_actions_are_refused(action: object) -> None:
    world = make_world(ARM)
    world.reset(seed=0)
    with pytest.raises(ActionError):
        world.step(action)
    assert world.steps == 0


def test_the_effector_is_where_the_joint_angles_put_it():
    """Over many random commands, with the arm pushing objects and pressed against red ones,
    the effector read from the physics stays within 1 mm of the forward kinematics of the
    joint angles read with it (measured: 0.25 mm at most)."""
    world = make_world(ARM)
    lay = world.layout
    rng = np.random.default_rng(7)
    worst = 0.0
    for seed in range(6):
        obs = world.reset(seed=100 + seed)
        for action in [None, *rng.uniform(-1, 1, (80, 3))]:
            if action is not None:
                obs = world.step(action)
            at = effector_position(ARM.arm.link_lengths, angles(lay, obs))
            worst = max(worst, float(np.hypot(*(at - lay.get(obs, EFFECTOR, Property.POSITION)))))
    assert worst < 1e-3


def test_a_joint_command_turns_its_joint_by_speed_times_duration():
    """Clear of everything and of the limits, command c turns the joint by c × max_joint_speed
    × action_duration (the settle holds it still): the action means the same in every pose."""
    world = arm_with(joints=(0.3, 0.5, -0.5))
    start = world.joint_angles()
    world.step((1.0, -1.0, 0.5))
    turned = world.joint_angles() - start
    np.testing.assert_allclose(turned, np.array([1.0, -1.0, 0.5]) * 0.12 * 0.5, atol=1e-3)


def test_each_link_is_a_uniform_rod_turned_with_its_joints_inertia():
    """A link's mass is spread evenly along it: its centre of gravity halfway, its moment of
    inertia about that centre m·l²/12, plus what its joint's motor and gearbox add
    (`joint_inertia`); each link starts where the scene's joint angles put it."""
    from hadim_cli.world.arm_physics import build_arm_physics

    arm, q = ARM.arm, (0.4, -0.7, 1.1)
    physics = build_arm_physics(arm_config(n_green=0, n_red=0), ArmScene((), q))
    starts = joint_points(arm.link_lengths, np.array(q))[:-1]
    rows = zip(physics.links, arm.link_lengths, starts, np.cumsum(q), strict=True)
    for link, length, start, angle in rows:
        assert link.mass == arm.link_mass
        assert tuple(link.center_of_gravity) == (length / 2, 0.0)
        assert link.moment == pytest.approx(arm.link_mass * length**2 / 12 + arm.joint_inertia,
                                            rel=1e-12)
        np.testing.assert_allclose(tuple(link.position), start, atol=1e-12)
        assert link.angle == pytest.approx(angle, abs=1e-12)


def test_every_action_ends_at_rest():
    """After the hold, the joints are held still for `settle_time`: the arm, and the object it
    pushed, are at rest when observed, so an action's outcome depends only on what the
    observation holds."""
    q0 = (0.0, 0.6, 0.6)
    tip = effector_position(ARM.arm.link_lengths, np.array(q0))
    ahead = effector_position(ARM.arm.link_lengths, np.array(q0) + 0.05) - tip
    c = tip + ahead / np.linalg.norm(ahead) * (0.1 + ARM.arm.effector_radius + 0.01)
    world = arm_with(ObjectSpec(float(c[0]), float(c[1]), 0.1, 0.2, GREEN, True), joints=q0)
    for command in ((1.0, 1.0, 1.0), (1.0, -0.5, 1.0)):
        before = world.observe()
        after = world.step(command)
        assert not np.array_equal(before[world.layout.object_columns(Property.POSITION)],
                                  after[world.layout.object_columns(Property.POSITION)])
        physics = world._physics
        assert max(abs(link.angular_velocity) for link in physics.links) < 5e-3  # of 0.36
        assert max(abs(body.velocity) for body in physics.movable) < 5e-3


def test_joint_limits_hold_under_any_command():
    """Every extreme command held until the joints are pressed against their stops, then
    uniform random ones: no joint passes its limit (the shoulder's ±π), and a joint pressed
    against its stop rests on it."""
    world = arm_with(joints=(0.0, 1.0, -1.0))
    lay = world.layout
    limits = np.array(joint_ranges(ARM.arm.joint_limits))
    rng = np.random.default_rng(3)
    corners = [np.array(c) for c in itertools.product((-1.0, 1.0), repeat=3)]
    commands = [c for c in corners for _ in range(40)] + list(rng.uniform(-1, 1, (60, 3)))
    worst = -np.inf
    for command in commands:
        joints = angles(lay, world.step(command))
        worst = max(worst, float(np.max(np.abs(joints) - limits)))
    assert worst <= LIMIT_SLACK
    for command in corners:  # 110 actions of 0.06 rad reach every stop from anywhere
        for _ in range(110):
            world.step(command)
        np.testing.assert_allclose(world.joint_angles(), command * limits, atol=LIMIT_SLACK)


def test_an_object_beyond_reach_is_never_touched():
    """Objects whose surface lies beyond the effector's farthest reach (1 cm beyond) stay where
    they were, bit for bit, whatever the arm does — even swept round at full stretch — and the
    effector never leaves its reach."""
    reach = outer_reach(ARM.arm.link_lengths) + ARM.arm.effector_radius
    far = []
    for k, (r, pushable) in enumerate([(0.08, True), (0.25, True), (0.15, False)] * 2):
        bearing = math.pi / 4 + math.pi / 2 * (k // 2) + (0.35 if k % 2 else -0.35)
        d = reach + r + 0.01  # on the table's diagonals, where it is widest
        far.append(ObjectSpec(d * math.cos(bearing), d * math.sin(bearing), r, 0.1,
                              GREEN if pushable else RED, pushable))
    world = arm_with(*far, joints=(0.0, 0.0, 0.0))
    lay = world.layout
    start = world.observe()
    rng = np.random.default_rng(5)
    sweep = np.array([1.0, 0.0, 0.0])  # the arm straight, round its whole reach both ways
    commands = [sweep] * 110 + [-sweep] * 110 + list(rng.uniform(-1, 1, (60, 3)))
    for command in commands:
        obs = world.step(command)
        assert not any(EFFECTOR in pair for pair in world.last_contacts)
        assert np.hypot(*lay.get(obs, EFFECTOR, Property.POSITION)) <= outer_reach(
            ARM.arm.link_lengths) + 1e-3
    cols = lay.object_columns(Property.POSITION)
    assert np.array_equal(obs[cols], start[cols])


def test_a_pushed_object_moves_and_a_red_one_stops_the_arm():
    """The effector moving into a green object (even the heaviest) pushes it along; into a
    red one, the effector stops at its surface (it sinks in by 2 mm at most)."""
    q0 = (0.0, 0.6, 0.6)
    tip = effector_position(ARM.arm.link_lengths, np.array(q0))
    ahead = effector_position(ARM.arm.link_lengths, np.array(q0) + 0.05) - tip
    ahead /= np.linalg.norm(ahead)
    for spec, pushable in ((GREEN, True), (RED, False)):
        c = tip + ahead * (0.25 + ARM.arm.effector_radius + 0.01)
        obj = ObjectSpec(float(c[0]), float(c[1]), 0.25, 0.6, spec, pushable)
        world = arm_with(obj, joints=q0)
        for _ in range(3):
            obs = world.step((1.0, 1.0, 1.0))
        moved = np.hypot(*(world.layout.get(obs, "obj1", Property.POSITION) - c))
        gap = np.hypot(*(world.layout.get(obs, "obj1", Property.RELATIVE))) - 0.25 - 0.05
        if pushable:
            assert moved > 0.15, moved
        else:
            assert moved == 0.0 and gap > -0.002, gap


def test_inner_reach_is_the_nearest_the_effector_gets_to_its_base():
    arm = ARM.arm
    inner = inner_reach(arm.link_lengths, arm.joint_limits)
    q = np.random.default_rng(0).uniform(-1, 1, (20000, 3)) * joint_ranges(arm.joint_limits)
    phi = np.cumsum(q, axis=1)
    lengths = np.asarray(arm.link_lengths)
    d = np.hypot((lengths * np.cos(phi)).sum(axis=1), (lengths * np.sin(phi)).sum(axis=1))
    assert d.min() >= inner - 1e-9 and d.min() < inner + 0.02
    assert 0.19 < inner < 0.21 and outer_reach(arm.link_lengths) == 1.5
    two = inner_reach((0.6, 0.5), (2.5,))  # two links: the law of cosines
    assert two == pytest.approx(math.sqrt(0.6**2 + 0.5**2 + 2 * 0.6 * 0.5 * math.cos(2.5)))
    points = joint_points((0.6, 0.5, 0.4), np.array([math.pi / 2, -math.pi / 2, 0.0]))
    np.testing.assert_allclose(points, [[0, 0], [0, 0.6], [0.5, 0.6], [0.9, 0.6]], atol=1e-12)


def test_pose_angles_reads_one_pose_or_many_in_double_precision():
    """The joint angles of a batch of observed poses (what exact navigation reads) are each
    pose's, and a float32 observation's (the goal environments') are worked out in float64
    from the values it holds."""
    q = np.random.default_rng(4).uniform(-1, 1, (5, 3)) * joint_ranges(ARM.arm.joint_limits)
    orientation = np.stack([np.cos(q[:, 0]), np.sin(q[:, 0])], axis=1)
    batch = pose_angles(orientation, q[:, 1:])
    assert batch.shape == (5, 3)
    np.testing.assert_allclose(batch, q, atol=1e-12)
    for row, o, bends in zip(batch, orientation, q[:, 1:], strict=True):
        np.testing.assert_array_equal(row, pose_angles(o, bends))
    o32, bends32 = orientation.astype(np.float32), q[:, 1:].astype(np.float32)
    read = pose_angles(o32, bends32)
    assert read.dtype == np.float64
    o64 = o32.astype(np.float64)
    np.testing.assert_array_equal(read[:, 0], np.arctan2(o64[:, 1], o64[:, 0]))
    np.testing.assert_array_equal(read[:, 1:], bends32.astype(np.float64))


@pytest.mark.parametrize("seed", range(12))
def test_reset_draws_a_pose_within_limits_and_objects_the_arm_reaches(seed: int) -> None:
    """Joints within their limits; every object green then red, of the room's sizes and
    shades, its centre in the annulus the effector's centre reaches (so the arm can touch
    it), clear of the base, of the effector, of the rim and of every other object."""
    world = make_world(ARM)
    obs = world.reset(seed=seed)
    arm, gap, scene = ARM.arm, ARM.object_gap, world.scene
    assert np.all(np.abs(scene.joints) <= joint_ranges(arm.joint_limits))
    effector = world.layout.get(obs, EFFECTOR, Property.POSITION)
    inner, outer = inner_reach(arm.link_lengths, arm.joint_limits), outer_reach(arm.link_lengths)
    objs = scene.objects
    assert [o.pushable for o in objs] == [True] * ARM.n_green + [False] * ARM.n_red
    for o in objs:
        assert_drawn_object(o, ARM)
        assert inner <= math.hypot(o.x, o.y) <= outer
        assert math.hypot(o.x, o.y) >= arm.base_radius + o.radius + gap
        assert math.hypot(o.x - effector[0], o.y - effector[1]) >= (
            arm.effector_radius + o.radius + gap - 1e-9)
        assert abs(o.x) + o.radius + gap <= arm.table_width / 2
    for a, b in itertools.combinations(objs, 2):
        assert math.hypot(a.x - b.x, a.y - b.y) >= a.radius + b.radius + gap


def test_scenes_spread_over_the_annulus():
    """Centres are uniform by area in the annulus: as many beyond the median radius as
    within it, and every bearing."""
    world = make_world(ARM)
    arm = ARM.arm
    inner, outer = inner_reach(arm.link_lengths, arm.joint_limits), outer_reach(arm.link_lengths)
    rng = np.random.default_rng(1)
    centres = np.array([(o.x, o.y) for _ in range(60) for o in world.draw_scene(rng).objects])
    d = np.hypot(*centres.T)
    median = math.sqrt((inner**2 + outer**2) / 2)
    assert 0.4 < np.mean(d > median) < 0.6
    bearing = np.arctan2(centres[:, 1], centres[:, 0])
    assert np.all(np.histogram(bearing, bins=8, range=(-math.pi, math.pi))[0] > 40)


def test_drawn_poses_spread_over_every_joints_range():
    """The shoulder's angle is uniform in [-π, π), each other joint's within its limits: over
    200 drawn scenes every quarter of every joint's range holds a share near a quarter."""
    world = make_world(ARM)
    rng = np.random.default_rng(2)
    poses = np.array([world.draw_scene(rng).joints for _ in range(200)])
    for q, limit in zip(poses.T, joint_ranges(ARM.arm.joint_limits), strict=True):
        counts = np.histogram(q, bins=4, range=(-limit, limit))[0]
        assert counts.sum() == 200 and np.all(counts > 30), counts


def test_a_scene_the_arm_cannot_hold_is_refused():
    world = make_world(ARM)
    with pytest.raises(HadimError, match="layout has 9"):
        world.reset(scene=ArmScene((), (0.0, 0.0, 0.0)))
    lone = arm_config(n_green=1, n_red=0)
    inside = ObjectSpec(1.0, 0.0, 0.1, 0.2, GREEN, True)
    with pytest.raises(HadimError, match="joint 2 to 2.5 rad, beyond its limit"):
        ArmWorld(lone).reset(scene=ArmScene((inside,), (0.0, 2.5, 0.0)))
    with pytest.raises(HadimError, match="2 joint angles, the arm has 3"):
        ArmWorld(lone).reset(scene=ArmScene((inside,), (0.0, 0.0)))
    with pytest.raises(HadimError, match="outside the 4.0x4.0 m table"):
        ArmWorld(lone).reset(scene=ArmScene((ObjectSpec(1.95, 0, 0.1, 0.2, GREEN, True),),
                                            (0.0, 0.0, 0.0)))


def test_same_seed_same_actions_bit_identical_in_process() -> None:
    first = run_episode(ArmWorld(ARM), 5)
    world = ArmWorld(ARM)
    run_episode(world, 9)  # an earlier, different episode must leave no trace
    assert np.array_equal(run_episode(world, 5), first)
    assert not np.array_equal(run_episode(world, 6), first)
    space = world._physics.space
    world.reset(seed=5)
    assert world._physics.space is not space


@pytest.mark.scenario
def test_same_seed_same_actions_bit_identical_across_processes() -> None:
    digests = {subprocess.run([sys.executable, "-c", _SCRIPT], check=True, capture_output=True,
                              text=True).stdout.strip() for _ in range(2)}
    local = hashlib.sha256(run_episode(ArmWorld(ARM), 5).tobytes()).hexdigest()
    assert digests == {local}


def test_observation_matches_its_layout_and_the_scene():
    world = make_world(ARM)
    obs = world.reset(seed=2)
    lay, scene = world.layout, world.scene
    assert obs.dtype == np.float64 and obs.shape == (lay.size,)
    np.testing.assert_allclose(angles(lay, obs), scene.joints, atol=1e-12)
    np.testing.assert_allclose(world.joint_angles(), scene.joints, atol=1e-12)
    first = lay.get(obs, EFFECTOR, Property.ORIENTATION)
    np.testing.assert_allclose(first, [math.cos(scene.joints[0]), math.sin(scene.joints[0])],
                               atol=1e-12)
    assert lay.get(obs, EFFECTOR, Property.RADIUS)[0] == ARM.arm.effector_radius
    for name, spec in zip(lay.objects, scene.objects, strict=True):
        assert list(lay.get(obs, name, Property.POSITION)) == [spec.x, spec.y]
        np.testing.assert_allclose(lay.get(obs, name, Property.RELATIVE),
                                   np.array([spec.x, spec.y])
                                   - lay.get(obs, EFFECTOR, Property.POSITION))
        assert list(lay.get(obs, name, Property.COLOR)) == list(spec.color)
    obs[:] = 0.0
    assert not np.array_equal(world.observe(), obs)
    for action in np.random.default_rng(0).uniform(-1, 1, (30, 3)):
        obs = world.step(action)
        for spec in lay.spaces:
            slack = LIMIT_SLACK if spec.prop is Property.JOINTS else 1e-9
            assert np.all(obs[spec.slice] >= np.array(spec.low) - slack), spec.name
            assert np.all(obs[spec.slice] <= np.array(spec.high) + slack), spec.name
    assert world.steps == 30
