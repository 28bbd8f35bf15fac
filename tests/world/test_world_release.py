"""A world drops an episode's pymunk space only once it is empty: pymunk's finalizers, run by
the garbage collector in no set order, would otherwise remove touching shapes and call the
contact callbacks on shapes already freed (`physics.release`)."""

from __future__ import annotations

import numpy as np
import pymunk

from hadim_cli.world.physics import ContactLog, release


def test_a_released_space_is_empty_and_its_contacts_ended_while_alive():
    space = pymunk.Space()
    a, b = pymunk.Body(1, 1), pymunk.Body(1, 1)
    b.position = (0.19, 0.0)
    shapes = pymunk.Circle(a, 0.1), pymunk.Circle(b, 0.1)
    pin = pymunk.PivotJoint(space.static_body, a, (0, 0), (0, 0))
    wall = pymunk.Segment(space.static_body, (-1, -1), (1, -1), 0.01)
    space.add(a, b, *shapes, pin, wall)
    contacts = ContactLog(dict(zip(shapes, ("robot", "obj1"), strict=True)))
    space.on_collision(begin=contacts.begin, separate=contacts.separate)
    space.step(0.01)
    assert contacts.touching == {("obj1", "robot")}
    release(space)
    assert not space.bodies and not space.shapes and not space.constraints
    assert contacts.touching == set()  # the separation was seen, with both shapes alive


def test_a_reset_leaves_the_episode_as_a_fresh_world_would():
    from hadim_cli.config import load_config
    from hadim_cli.world.world import World

    config = load_config().world
    once, twice = World(config), World(config)
    rng = np.random.default_rng(3)
    actions = rng.uniform(-1, 1, (20, 2))
    once.reset(seed=1)
    for action in actions[:10]:
        once.step(action)
    first = once.reset(seed=2)
    assert np.array_equal(first, twice.reset(seed=2))
    assert all(np.array_equal(once.step(a), twice.step(a)) for a in actions)
