"""Top-down picture of a world from an observation: the room (walls, robot, LIDAR) or the
arm's table (base, links, joints, effector, the annulus it reaches), the objects, trajectories.

Everything is read from the observation vector and its layout (the room's or table's size is
the bound of the position spaces), so a stored observation renders as well as a live world;
the arm's link lengths and sizes come from its config. matplotlib is imported here only, and
through `Figure` (no pyplot, no global backend state).
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Protocol

import numpy as np

from hadim_cli.config import ArmConfig, Body, WorldConfig
from hadim_cli.world.kinematics import inner_reach, joint_points, outer_reach, pose_angles
from hadim_cli.world.layout import ObservationLayout, Property

_MOVED = 1e-3  # an object whose path is longer than this (m) gets its trajectory drawn


class Observable(Protocol):
    layout: ObservationLayout
    config: WorldConfig

    def observe(self) -> np.ndarray: ...


def _disc(ax, layout: ObservationLayout, obs: np.ndarray, entity: str,
          label: bool = True) -> tuple[float, float]:
    from matplotlib.patches import Circle

    x, y = layout.get(obs, entity, Property.POSITION)
    radius = float(layout.get(obs, entity, Property.RADIUS)[0])
    color = np.clip(layout.get(obs, entity, Property.COLOR), 0.0, 1.0)
    ax.add_patch(Circle((x, y), radius, facecolor=color, edgecolor="black", lw=0.8, zorder=3))
    if label:
        ax.annotate(entity, (x, y), ha="center", va="center", fontsize=7, zorder=5,
                    color="white" if color.sum() < 1.2 else "black")
    return float(x), float(y)


def _lidar(ax, layout: ObservationLayout, obs: np.ndarray, x: float, y: float) -> None:
    spec = layout.space(layout.actor, Property.LIDAR)
    ranges = obs[spec.slice]
    cos_h, sin_h = layout.get(obs, layout.actor, Property.HEADING)
    heading = math.atan2(sin_h, cos_h)
    angles = heading + 2 * np.pi * np.arange(spec.dim) / spec.dim
    ends_x, ends_y = x + ranges * np.cos(angles), y + ranges * np.sin(angles)
    for ex, ey in zip(ends_x, ends_y, strict=True):
        ax.plot([x, ex], [y, ey], color="orange", lw=0.6, alpha=0.8, zorder=2)
    hit = ranges < spec.high[0] - 1e-9
    ax.scatter(ends_x[hit], ends_y[hit], s=8, color="orange", zorder=4)


def _trajectory(ax, layout: ObservationLayout, trajectory: np.ndarray) -> None:
    for entity in layout.entities:
        path = trajectory[:, layout.space(entity, Property.POSITION).slice]
        actor = entity == layout.actor
        if not actor and np.abs(np.diff(path, axis=0)).sum() <= _MOVED:
            continue
        color = "black" if actor else np.clip(
            layout.get(trajectory[0], entity, Property.COLOR), 0.0, 1.0)
        ax.plot(path[:, 0], path[:, 1], color=color, lw=1.0, ls="-" if actor else "--",
                zorder=2.5)
        ax.scatter(path[:1, 0], path[:1, 1], s=10, color=color, marker="x", zorder=2.5)


LINK_COLOUR = "slategray"
"""The arm's links, drawn opaque so a picture of them reads back as this colour."""


def _heading(ax, layout: ObservationLayout, obs: np.ndarray) -> None:
    """A white line from the actor's centre the way it faces (the rover's heading)."""
    actor = layout.actor
    x, y = layout.get(obs, actor, Property.POSITION)
    radius = float(layout.get(obs, actor, Property.RADIUS)[0])
    cos_h, sin_h = layout.get(obs, actor, Property.HEADING)
    ax.plot([x, x + 1.3 * radius * cos_h], [y, y + 1.3 * radius * sin_h], color="white",
            lw=2, zorder=4)


def arm_points(layout: ObservationLayout, obs: np.ndarray, arm: ArmConfig) -> np.ndarray:
    """(links + 1, 2): the base, every joint after the shoulder and the effector's centre, from
    the pose the observation holds (the orientation and the joints the world declares)."""
    actor = layout.actor
    return joint_points(arm.link_lengths, pose_angles(
        layout.get(obs, actor, Property.ORIENTATION), layout.get(obs, actor, Property.JOINTS)))


def draws_arm(layout: ObservationLayout) -> bool:
    """Whether the actor is an arm's effector: the world declares the joints that place it."""
    return layout.has(layout.actor, Property.JOINTS)


def _table(ax, arm: ArmConfig) -> None:
    """The reach: the annulus the effector's centre covers, dotted."""
    from matplotlib.patches import Circle

    for radius in (inner_reach(arm.link_lengths, arm.joint_limits), outer_reach(arm.link_lengths)):
        ax.add_patch(Circle((0.0, 0.0), radius, fill=False, edgecolor="gray", lw=0.8, ls=":",
                            zorder=1))


def _arm(ax, layout: ObservationLayout, obs: np.ndarray, arm: ArmConfig, label: bool,
         scale: float) -> None:
    """Base, links, joints and the effector, over the objects: the links pass above them."""
    from matplotlib.patches import Circle

    actor = layout.actor
    ax.add_patch(Circle((0.0, 0.0), arm.base_radius, facecolor="dimgray", edgecolor="black",
                        lw=0.8, zorder=4))
    points = arm_points(layout, obs, arm)
    ax.plot(points[:, 0], points[:, 1], color=LINK_COLOUR, lw=5 * scale,
            solid_capstyle="round", zorder=5)
    ax.scatter(points[:-1, 0], points[:-1, 1], s=28 * scale ** 2, color="white",
               edgecolor="black", lw=0.8, zorder=6)
    x, y = layout.get(obs, actor, Property.POSITION)
    color = np.clip(layout.get(obs, actor, Property.COLOR), 0.0, 1.0)
    radius = float(layout.get(obs, actor, Property.RADIUS)[0])
    ax.add_patch(Circle((x, y), radius, facecolor=color, edgecolor="black", lw=0.8, zorder=7))
    if label:
        ax.annotate(actor, (x, y), xytext=(0, 6), textcoords="offset points",
                    ha="center", va="bottom", fontsize=7, zorder=7)


def ground(ax, layout: ObservationLayout, arm: ArmConfig | None = None) -> None:
    """The room's walls, or the arm's table and the annulus its effector reaches (from
    `arm`): the edges are the bounds of the actor's position."""
    from matplotlib.patches import Rectangle

    is_arm = draws_arm(layout)
    half_w, half_h = layout.space(layout.actor, Property.POSITION).high
    ax.add_patch(Rectangle((-half_w, -half_h), 2 * half_w, 2 * half_h, fill=is_arm,
                           facecolor="#f4ecdc", edgecolor="dimgray", lw=4, zorder=0))
    if is_arm and arm is not None:
        _table(ax, arm)


def draw_actor(ax, layout: ObservationLayout, obs: np.ndarray, arm: ArmConfig | None = None,
               *, lidar: bool = False, label: bool = True, scale: float = 1.0) -> None:
    """The body's actor as its world declares it: an arm's base, links, joints and effector
    (its pose from the observed orientation and joints, its link lengths from `arm`), else the
    actor's disc with its LIDAR (if `lidar`) and the way it faces, where it has those.
    `scale` thins the lines of a small picture."""
    actor = layout.actor
    if draws_arm(layout):
        if arm is None:
            raise ValueError("drawing an arm's observation needs its config (arm=)")
        _arm(ax, layout, obs, arm, label, scale)
        return
    x, y = _disc(ax, layout, obs, actor, label)
    if lidar and layout.has(actor, Property.LIDAR):
        _lidar(ax, layout, obs, x, y)
    if layout.has(actor, Property.HEADING):
        _heading(ax, layout, obs)


def render_scene(source: Observable | np.ndarray, path: Path | str, *,
                 layout: ObservationLayout | None = None, trajectory: np.ndarray | None = None,
                 lidar: bool = True, title: str | None = None,
                 arm: ArmConfig | None = None) -> Path:
    """Draw a world (its current observation) or an observation (with `layout`) to `path`.

    `trajectory` is an array of observations (T, layout.size), oldest first: the actor's path
    is drawn, and the path of every object that moved. An arm's observation needs `arm` (a
    live arm world gives its own); `lidar` is the rover's.
    """
    from matplotlib.figure import Figure

    if isinstance(source, np.ndarray):
        if layout is None:
            raise ValueError("rendering an observation needs its layout")
        obs = source
    else:
        obs, layout = source.observe(), source.layout
        if source.config.body is Body.ARM:
            arm = arm or source.config.arm
    half_w, half_h = layout.space(layout.actor, Property.POSITION).high
    fig = Figure(figsize=(6, 6), dpi=120)
    ax = fig.add_subplot()
    ground(ax, layout, arm)
    for entity in layout.objects:
        _disc(ax, layout, obs, entity)
    if trajectory is not None and len(trajectory):
        _trajectory(ax, layout, np.atleast_2d(np.asarray(trajectory)))
    draw_actor(ax, layout, obs, arm, lidar=lidar)
    margin = 0.1
    ax.set_xlim(-half_w - margin, half_w + margin)
    ax.set_ylim(-half_h - margin, half_h + margin)
    ax.set_aspect("equal")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    if title:
        ax.set_title(title)
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path)
    return path
