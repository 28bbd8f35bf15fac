"""LIDAR ranges against hand-placed layouts and a brute-force reference."""

from __future__ import annotations

import math

import numpy as np
import pytest
from worldmade import green, red, world_with

from hadim_cli.world.layout import Property
from hadim_cli.world.lidar import Lidar


def lidar(world) -> np.ndarray:
    return world.layout.get(world.observe(), "robot", Property.LIDAR)


def test_object_straight_ahead_and_walls() -> None:
    world = world_with(green(1.0, 0.0, radius=0.2), red(-1.5, 1.5), lidar_range=3.0)
    ranges = lidar(world)
    assert ranges[0] == pytest.approx(0.8)  # heading 0: ray 0 hits obj1's surface
    assert ranges[4] == pytest.approx(2.0)  # +y wall
    assert ranges[8] == pytest.approx(2.0)  # -x wall
    assert ranges[12] == pytest.approx(2.0)  # -y wall
    assert ranges[6] == pytest.approx(1.5 * math.sqrt(2) - 0.1)  # red at (-1.5, 1.5), r 0.1


def test_rays_turn_with_the_robot_and_clip_to_range() -> None:
    world = world_with(green(-1.5, -1.5), x=1.0, y=0.5, heading=math.pi / 2)
    ranges = lidar(world)
    assert ranges[0] == pytest.approx(1.5)  # +y wall at 1.5 m: exactly the range
    assert ranges[4] == pytest.approx(1.5)  # -x wall at 3 m, clipped
    assert ranges[12] == pytest.approx(1.0)  # +x wall at 1 m
    assert ranges.max() <= 1.5


def reference(x, y, heading, centers, radii, n, reach, half):
    out = []
    for k in range(n):
        a = heading + 2 * math.pi * k / n
        ts = np.linspace(0, reach, 150001)
        px, py = x + ts * math.cos(a), y + ts * math.sin(a)
        blocked = (np.abs(px) >= half) | (np.abs(py) >= half)
        for (cx, cy), r in zip(centers, radii, strict=True):
            blocked |= (px - cx) ** 2 + (py - cy) ** 2 <= r * r
        out.append(ts[np.argmax(blocked)] if blocked.any() else reach)
    return np.array(out)


@pytest.mark.parametrize("seed", range(4))
def test_ranges_match_brute_force_marching(seed: int) -> None:
    rng = np.random.default_rng(seed)
    centers = rng.uniform(-1.7, 1.7, size=(9, 2))
    radii = rng.uniform(0.08, 0.25, size=9)
    while True:
        x, y = rng.uniform(-1.8, 1.8, size=2)
        if np.all(np.hypot(centers[:, 0] - x, centers[:, 1] - y) > radii + 0.15):
            break
    heading = rng.uniform(-4, 4)
    got = Lidar(16, 1.5, 2.0, 2.0).ranges(x, y, heading, centers.tolist(), radii.tolist())
    want = reference(x, y, heading, centers, radii, 16, 1.5, 2.0)
    assert np.allclose(got, want, atol=2e-5)


def test_a_ray_tangent_to_an_object_stops_where_it_touches_it() -> None:
    """An object is a closed disc, as in the marching reference: ray 0 grazing an object of
    radius 0.5 centred 0.5 m to its side, from either side, stops at the point it touches,
    2 m ahead, not at the wall beyond."""
    lidar = Lidar(16, 3.0, 4.0, 4.0)
    for side in (0.5, -0.5):
        ranges = lidar.ranges(0.0, 0.0, 0.0, [(2.0, side)], [0.5])
        assert ranges[0] == 2.0
    assert lidar.ranges(0.0, 0.0, 0.0, [(2.0, 0.6)], [0.5])[0] == 3.0  # just clear of it
