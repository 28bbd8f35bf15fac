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


def competence_figure(runs: Mapping[str, Sequence], out: Path, title: str = "") -> None:
    """Score per task over iterations; several runs of one config give mean ± std."""
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


_COLOURS = {"action": "#e6b800", "relative": "#3b7dd8", "absolute": "#3aa655"}


def _space_colour(name: str) -> str:
    if name == "action":
        return _COLOURS["action"]
    return _COLOURS["relative"] if "-" in name else _COLOURS["absolute"]


def timeline_figure(events: Sequence, last_iteration: int, out: Path, title: str = "") -> None:
    """One lane per affordance: its input, output and contexts over time (paper Fig. 4).
    The input space is a solid bar with a dark edge, each context space a lighter hatched one."""
    plt = _plt()
    lanes: dict[int, list] = defaultdict(list)
    for e in events:
        lanes[e.affordance_id].append(e)
    fig, ax = plt.subplots(figsize=(9, 0.8 + 0.9 * max(1, len(lanes))))
    labels = []
    for row, (aid, evs) in enumerate(sorted(lanes.items())):
        evs = sorted(evs, key=lambda e: e.iteration)
        for k, e in enumerate(evs):
            if e.kind == "deleted":
                ax.plot([e.iteration], [row], marker="x", color="k")
                continue
            end = evs[k + 1].iteration if k + 1 < len(evs) else last_iteration
            spaces = [e.input_space, *e.context]
            height = 0.8 / max(1, len(spaces))
            for j, name in enumerate(spaces):
                y = row - 0.4 + j * height
                is_input = j == 0
                ax.barh(y, max(end - e.iteration, 1), left=e.iteration, height=height * 0.9,
                        align="edge", color=_space_colour(name),
                        alpha=1.0 if is_input else 0.45, hatch=None if is_input else "//",
                        edgecolor="black" if is_input else "white",
                        linewidth=0.8 if is_input else 0.5)
                if end - e.iteration > 0.06 * max(last_iteration, 1):
                    label = f"in: {name}" if is_input else f"ctx: {name}"
                    ax.text(e.iteration + 5, y + height * 0.45, label, va="center", fontsize=7)
        labels.append(f"A{aid}: → {evs[0].output_space}")
    ax.set_yticks(range(len(labels)), labels)
    ax.set_xlim(0, max(last_iteration, 1))
    ax.set_xlabel("iteration")
    ax.set_title((f"{title}\n" if title else "") + "input: solid, context: hatched; yellow: "
                 "action, blue: relative, green: absolute spaces", fontsize=9)
    fig.tight_layout()
    _save(plt, fig, out)


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
