"""Animations of evaluation episodes: what the planner did, action by action.

Each frame shows the part of the room (or table) where the point's attempt happens: every
object, the body as its world declares it (`render.draw_actor`: the robot and its heading;
the arm's base, links, joints and effector, posed by the observed orientation and joints),
the paths so far (the actor's solid, moved objects dashed), the point to reach (a star), and
what the planner was pursuing when it chose the action — each level's goal as a marker, and
the chain of affordances as text. Frames are drawn with matplotlib's
`Figure` (no pyplot) and written as one GIF by Pillow; the same recordings give the same bytes.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np

from hadim_cli.config import ArmConfig
from hadim_cli.evaluation.runner import Recording
from hadim_cli.learner.spaces import shown_as
from hadim_cli.world.layout import ObservationLayout, Property
from hadim_cli.world.render import arm_points, draw_actor, draws_arm, ground

_GOAL_COLOURS = ("tab:blue", "tab:purple", "tab:orange", "tab:cyan", "tab:brown")


def _box(layout: ObservationLayout, rec: Recording, arm: ArmConfig | None,
         margin: float = 0.45) -> tuple[float, float, float, float]:
    """A square around everything that moves in `rec` and the point (an arm's every link
    too), within the room."""
    spans = [np.asarray(rec.point)[None]]
    for i, entity in enumerate(layout.entities):
        if i in (0, rec.entity, rec.target, rec.tool):
            spans.append(rec.observations[:, layout.space(entity, Property.POSITION).slice])
    if arm is not None and draws_arm(layout):
        spans += [arm_points(layout, obs, arm) for obs in rec.observations]
    pts = np.concatenate(spans)
    lo, hi = pts.min(0) - margin, pts.max(0) + margin
    size = float(max(hi - lo))
    centre = (lo + hi) / 2
    half_w, half_h = layout.space(layout.actor, Property.POSITION).high
    x0 = float(np.clip(centre[0] - size / 2, -half_w - 0.05, half_w + 0.05 - size))
    y0 = float(np.clip(centre[1] - size / 2, -half_h - 0.05, half_h + 0.05 - size))
    return x0, x0 + size, y0, y0 + size


def _frame(fig, layout: ObservationLayout, rec: Recording, t: int, title: str,
           box: tuple[float, float, float, float], arm: ArmConfig | None) -> np.ndarray:
    from matplotlib.patches import Circle

    fig.clear()
    ax = fig.add_axes((0.08, 0.2, 0.88, 0.72))
    obs = rec.observations[t]
    actor = layout.actor
    ground(ax, layout, arm)
    for entity in layout.entities:
        pos = layout.get(obs, entity, Property.POSITION)
        colour = np.clip(layout.get(obs, entity, Property.COLOR), 0.0, 1.0)
        if entity != actor:
            radius = float(layout.get(obs, entity, Property.RADIUS)[0])
            ax.add_patch(Circle(tuple(pos), radius, facecolor=colour, edgecolor="black",
                                lw=0.8, zorder=3))
        path = rec.observations[:t + 1, layout.space(entity, Property.POSITION).slice]
        if entity == actor or np.abs(np.diff(path, axis=0)).sum() > 1e-3:
            ax.plot(path[:, 0], path[:, 1], color="black" if entity == actor else colour,
                    lw=1.0, ls="-" if entity == actor else "--", zorder=2)
        if entity != actor:
            role = {rec.target: "target", rec.tool: "tool"}.get(layout.entities.index(entity))
            if role:
                ax.annotate(role, tuple(pos), ha="center", va="center", fontsize=7, zorder=5)
    draw_actor(ax, layout, obs, arm, label=False, scale=0.6)
    ax.scatter([rec.point[0]], [rec.point[1]], marker="*", s=180, color="gold",
               edgecolor="black", zorder=6)
    lines = []
    if t > 0 and t - 1 < len(rec.steps):
        step = rec.steps[t - 1]
        for i, (label, goal) in enumerate(zip(step.labels, step.goals, strict=True)):
            colour = _GOAL_COLOURS[i % len(_GOAL_COLOURS)]
            lines.append(("  " * i) + shown_as(label, actor))
            if len(goal) == 2 and "heading" not in label:
                ax.scatter([goal[0]], [goal[1]], marker="x", s=60, color=colour, zorder=7)
    ax.set_xlim(box[0], box[1])
    ax.set_ylim(box[2], box[3])
    ax.set_aspect("equal")
    ax.set_title(title, fontsize=9)
    ax.tick_params(labelsize=7)
    fig.text(0.04, 0.02, "\n".join(lines[-5:]) or "(start)", fontsize=7, family="monospace",
             va="bottom")
    fig.canvas.draw()
    return np.asarray(fig.canvas.buffer_rgba())[:, :, :3].copy()


def animate(recordings: Sequence[Recording], layout: ObservationLayout, path: Path | str, *,
            arm: ArmConfig | None = None, ms_per_frame: int = 250, hold: int = 4) -> Path:
    """Write every recording's attempt, one after another, as a looping GIF at `path`, one
    frame per observation; the last frame of each point is shown `hold` times as long. An
    arm's observations need `arm` (its link lengths and base)."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure
    from PIL import Image

    if not recordings:
        raise ValueError("no recordings to animate")
    if draws_arm(layout) and arm is None:
        raise ValueError("animating an arm's observations needs its config (arm=)")
    fig = Figure(figsize=(4.8, 5.6), dpi=80)
    FigureCanvasAgg(fig)
    frames, durations = [], []
    for i, rec in enumerate(recordings):
        box = _box(layout, rec, arm)
        n = rec.observations.shape[0]
        for t in range(n):
            verdict = " — touched the target: failed" if rec.contact_failed and t == n - 1 else ""
            title = (f"{rec.task} · point {i + 1}/{len(recordings)} {rec.point} · "
                     f"action {t}/{n - 1}{verdict}")
            frames.append(_frame(fig, layout, rec, t, title, box, arm))
            durations.append(ms_per_frame * (hold if t == n - 1 else 1))
    images = [Image.fromarray(f) for f in frames]
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    images[0].save(path, format="GIF", save_all=True, append_images=images[1:],
                   duration=durations, loop=0, optimize=False)
    return path
