"""Figures (matplotlib, Agg): competence curves (paper Fig. 2) and affordance timelines (Fig. 4)."""

from __future__ import annotations

from collections import defaultdict
from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np

from hadim_cli.errors import HadimError


def _plt():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def _save(plt, fig, out: Path) -> None:
    """Write `fig` as a PNG; an unwritable path is the user's mistake, not a crash."""
    try:
        fig.savefig(out, dpi=120)
    except OSError as exc:
        raise HadimError(f"cannot write {out}: {exc.strerror or exc}") from None
    finally:
        plt.close(fig)


def competence_figure(runs: Mapping[str, Sequence], out: Path, title: str = ""):
    """Score per task over iterations; several runs of one config give mean ± std. Writes
    `out` and returns the (closed) figure."""
    plt = _plt()
    by_task: dict[str, dict[int, list[float]]] = defaultdict(lambda: defaultdict(list))
    for evaluations in runs.values():
        for e in evaluations:
            by_task[e.task][e.iteration].append(e.score)
    fig, ax = plt.subplots(figsize=(7, 4))
    for task, points in sorted(by_task.items()):
        its = np.array(sorted(points))
        mean = np.array([np.mean(points[i]) for i in its])
        std = np.array([np.std(points[i]) for i in its])
        ax.plot(its, mean, marker="o", label=task)
        ax.fill_between(its, mean - std, mean + std, alpha=0.2)
    ax.set_xlabel("iteration")
    ax.set_ylabel("evaluation score")
    ax.set_ylim(-0.02, 1.02)
    ax.grid(alpha=0.3)
    ax.legend()
    ax.set_title(title or f"competence ({len(runs)} run{'s' if len(runs) != 1 else ''})")
    fig.tight_layout()
    _save(plt, fig, out)
    return fig


def _space_colours(events: Sequence) -> dict[str, tuple]:
    """One colour per space named in the timeline, the same in every lane and the legend."""
    import matplotlib

    names = sorted({n for e in events for n in (e.input_space, *e.context)})
    palette = [*matplotlib.colormaps["tab20"].colors, *matplotlib.colormaps["tab20b"].colors]
    return {name: palette[i % len(palette)] for i, name in enumerate(names)}


def timeline_figure(events: Sequence, last_iteration: int, out: Path, title: str = ""):
    """One lane per affordance (paper Fig. 4): its input space on the lane's first line, a
    solid bar; its contexts on the lines above, hatched. Each space has one colour, named in
    the legend: no text is drawn on the bars, so nothing overlaps however many changes H
    goes through. Writes `out` and returns the (closed) figure."""
    from matplotlib.patches import Patch

    plt = _plt()
    lanes: dict[int, list] = defaultdict(list)
    for e in events:
        lanes[e.affordance_id].append(e)
    colours = _space_colours(events)
    fig, ax = plt.subplots(figsize=(11, 1.4 + 0.7 * max(1, len(lanes))))
    labels = []
    deleted = False
    for row, (aid, evs) in enumerate(sorted(lanes.items())):
        evs = sorted(evs, key=lambda e: e.iteration)
        lines = 1 + max(len(e.context) for e in evs)
        height = 0.8 / lines
        for k, e in enumerate(evs):
            if e.kind == "deleted":
                ax.plot([e.iteration], [row], marker="x", color="k", markersize=8)
                deleted = True
                continue
            end = evs[k + 1].iteration if k + 1 < len(evs) else last_iteration
            for j, name in enumerate([e.input_space, *e.context]):
                is_input = j == 0
                ax.barh(row - 0.4 + j * height, max(end - e.iteration, 1), left=e.iteration,
                        height=height * 0.9, align="edge", color=colours[name],
                        hatch=None if is_input else "//",
                        edgecolor="black" if is_input else "white",
                        linewidth=0.8 if is_input else 0.5)
        labels.append(f"A{aid} → {evs[0].output_space}")
    ax.set_yticks(range(len(labels)), labels)
    ax.set_ylim(-0.6, max(len(labels), 1) - 0.4)
    ax.set_xlim(0, max(last_iteration, 1))
    ax.set_xlabel("iteration")
    ax.set_ylabel("affordance (→ its output space)")
    ax.grid(axis="x", alpha=0.3)
    handles = [Patch(facecolor="white", edgecolor="black", label="input space (solid)"),
               Patch(facecolor="white", edgecolor="grey", hatch="//",
                     label="context space (hatched)")]
    if deleted:
        handles.append(ax.plot([], [], "x", color="k", label="deleted")[0])
    handles += [Patch(facecolor=c, edgecolor="black", label=n) for n, c in colours.items()]
    ax.legend(handles=handles, loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=8,
              title="spaces", title_fontsize=9, frameon=False)
    ax.set_title(title or "affordance timeline")
    fig.tight_layout()
    _save(plt, fig, out)
    return fig


def comparison_figure(groups: Mapping[str, Sequence[Sequence]], out: Path,
                      tasks: Sequence[str] = (), *, log_x: bool = False) -> None:
    """One panel per task, one curve (mean ± std over its runs) per group (paper Fig. 2)."""
    plt = _plt()
    found = sorted({e.task for runs in groups.values() for evs in runs for e in evs})
    tasks = [t for t in tasks if t in found] or found
    fig, axes = plt.subplots(1, len(tasks), figsize=(4.5 * len(tasks), 3.6), squeeze=False)
    for ax, task in zip(axes[0], tasks, strict=True):
        for label, runs in groups.items():
            by_it: dict[int, list[float]] = defaultdict(list)
            for evs in runs:
                for e in evs:
                    if e.task == task:
                        by_it[e.iteration].append(e.score)
            if not by_it:
                continue
            its = np.array(sorted(by_it))
            mean = np.array([np.mean(by_it[i]) for i in its])
            std = np.array([np.std(by_it[i]) for i in its])
            n = sum(1 for evs in runs if any(e.task == task for e in evs))
            ax.plot(its, mean, label=f"{label} (n={n})")
            ax.fill_between(its, mean - std, mean + std, alpha=0.15)
        ax.set_title(task)
        ax.set_xlabel("iteration")
        if log_x:
            ax.set_xscale("log")
        ax.set_ylim(-0.02, 1.02)
        ax.grid(alpha=0.3)
    axes[0][0].set_ylabel("evaluation score")
    axes[0][-1].legend(loc="best", fontsize=8)
    fig.tight_layout()
    _save(plt, fig, out)
