"""Random scenes: counts, colours, sizes, gaps, clearance, walls, failures."""

from __future__ import annotations

import math

import numpy as np
import pytest
from worldmade import assert_drawn_object, config

from hadim_cli.config import WorldConfig
from hadim_cli.world.placement import SceneError, draw_scene


@pytest.mark.parametrize("seed", range(15))
def test_draw_scene_respects_the_rules(seed: int) -> None:
    c = WorldConfig()
    scene = draw_scene(c, np.random.default_rng(seed))
    objs = scene.objects
    assert len(objs) == c.n_green + c.n_red
    assert [o.pushable for o in objs] == [True] * c.n_green + [False] * c.n_red
    assert (scene.robot_x, scene.robot_y) == (0.0, 0.0)
    assert -math.pi <= scene.robot_heading < math.pi
    for o in objs:
        assert_drawn_object(o, c)
        assert math.hypot(o.x, o.y) - o.radius >= c.start_clearance
        assert abs(o.x) + o.radius + c.object_gap <= c.room_width / 2
        assert abs(o.y) + o.radius + c.object_gap <= c.room_height / 2
    for i, a in enumerate(objs):
        for b in objs[i + 1:]:
            assert math.hypot(a.x - b.x, a.y - b.y) >= a.radius + b.radius + c.object_gap


def test_draw_scene_is_a_function_of_the_generator() -> None:
    c = WorldConfig()
    assert draw_scene(c, np.random.default_rng(3)) == draw_scene(c, np.random.default_rng(3))
    assert draw_scene(c, np.random.default_rng(3)) != draw_scene(c, np.random.default_rng(4))
    shades = {o.color for o in draw_scene(c, np.random.default_rng(3)).objects}
    assert len(shades) == c.n_green + c.n_red  # shades vary


def test_fixed_heading_when_not_random() -> None:
    scene = draw_scene(config(random_heading=False), np.random.default_rng(0))
    assert scene.robot_heading == 0.0


def test_impossible_scene_is_refused_with_a_clear_error() -> None:
    crowded = config(room_width=1.6, room_height=1.6, n_green=9, n_red=0, object_radius_min=0.2,
                     object_radius_max=0.2)  # not validated: draw_scene must still stop
    with pytest.raises(SceneError, match="could not place 9 objects"):
        draw_scene(crowded, np.random.default_rng(0))
