"""Pictures of the arm show its body as the world declares it: `hadim world render` and the
animation of an evaluation (`hadim eval --animate`) draw the base, the links and the joints
where the observed orientation and joints put them, not the effector alone."""

from __future__ import annotations

import numpy as np
import pytest
from matplotlib.colors import to_rgb
from PIL import Image

from hadim_cli.config import Body, WorldConfig
from hadim_cli.evaluation.animate import animate
from hadim_cli.evaluation.runner import Recording
from hadim_cli.world.environment import make_world
from hadim_cli.world.layout import Property
from hadim_cli.world.render import LINK_COLOUR, render_scene

ARM = WorldConfig(body=Body.ARM)
LINK_RGB = np.array([round(255 * c) for c in to_rgb(LINK_COLOUR)])


def _posed(world, obs: np.ndarray, direction: float) -> np.ndarray:
    """`obs` with the arm straight along `direction` (rad), its objects along the table's
    bottom edge, out of the arm's way."""
    lay, actor = world.layout, world.layout.actor
    obs = obs.copy()
    reach = sum(ARM.arm.link_lengths)
    obs[lay.space(actor, Property.ORIENTATION).slice] = (np.cos(direction), np.sin(direction))
    obs[lay.space(actor, Property.JOINTS).slice] = 0.0
    obs[lay.space(actor, Property.POSITION).slice] = (reach * np.cos(direction),
                                                     reach * np.sin(direction))
    for i, name in enumerate(lay.objects):
        obs[lay.space(name, Property.POSITION).slice] = (-1.6 + 0.4 * i, -1.8)
    return obs


def _link_pixels(image: Image.Image) -> np.ndarray:
    """(rows, cols) of the pixels of the links' colour."""
    rgb = np.asarray(image.convert("RGB"), dtype=int)
    return np.argwhere(np.abs(rgb - LINK_RGB).max(axis=2) <= 12)


def _assert_a_straight_arm(pixels: np.ndarray, along: str) -> None:
    """Link-coloured pixels form one long thin band: along x (columns) or y (rows)."""
    assert len(pixels) > 100, "no links drawn"
    rows, cols = np.ptp(pixels[:, 0]), np.ptp(pixels[:, 1])
    long, thin = (cols, rows) if along == "x" else (rows, cols)
    assert long > 60 and thin < long / 5, (rows, cols)


@pytest.fixture(scope="module")
def arm_obs():
    world = make_world(ARM)
    return world, world.reset(seed=3)


def test_world_render_draws_the_arm_s_links_where_its_joints_put_them(arm_obs, tmp_path):
    world, obs = arm_obs
    for direction, along in ((0.0, "x"), (np.pi / 2, "y")):
        path = render_scene(_posed(world, obs, direction), tmp_path / "arm.png",
                            layout=world.layout, arm=ARM.arm, lidar=False)
        _assert_a_straight_arm(_link_pixels(Image.open(path)), along)


def test_the_animation_draws_the_arm_s_links_where_its_joints_put_them(arm_obs, tmp_path):
    world, obs = arm_obs
    observations = np.stack([_posed(world, obs, 0.0), _posed(world, obs, np.pi / 2)])
    rec = Recording("reach", (0.0, 1.2), observations, (), 0, -1, -1, False)
    gif = animate([rec], world.layout, tmp_path / "arm.gif", arm=ARM.arm)
    frames = Image.open(gif)
    for t, along in enumerate(("x", "y")):
        frames.seek(t)
        _assert_a_straight_arm(_link_pixels(frames), along)


def test_an_arm_s_observations_are_not_drawn_without_its_config(arm_obs, tmp_path):
    world, obs = arm_obs
    rec = Recording("reach", (0.0, 1.2), obs[None], (), 0, -1, -1, False)
    with pytest.raises(ValueError, match="arm="):
        animate([rec], world.layout, tmp_path / "arm.gif")
