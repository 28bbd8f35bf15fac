"""Fig. 5 with both measures of issue 46, and the table that answers the paper's claims.

Per run and task, two curves from the store: the budgeted score (evaluations named as the
task) and episode success (the share of points in the goal zone in evaluations named
`TASK@EPISODE`, EPISODE the run's episode length: 1000). A run "reaches the paper's level" at
its first evaluation with episode success ≥ `LEARNED` (0.9). The long grid stops a run once it
has learned, so a group's mean at a later iteration carries each stopped run's last value
forward (it is marked as such in the table). Pure functions over `Evaluation` records, but
`measures_figure`.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from hadim_cli.evaluation.metric import EPISODE_ACTIONS, measure_name, zone_share
from hadim_cli.report.baselines import TASKS, paper_claim

LEARNED = 0.9
AT = 50_000
"""The paper's run length: the table's first column of both measures."""


@dataclass(frozen=True)
class RunCurve:
    """One run on one task: at each iteration with both measures, the score and the share
    of points in the goal zone within an episode, and that evaluation's actions."""

    run: str
    iterations: tuple[int, ...]
    scores: tuple[float, ...]
    successes: tuple[float, ...]
    actions: tuple[int, ...]
    trained: int
    """The run's iterations (it may have trained past its last evaluation)."""
    carries: bool = True
    """Whether its last value stands for later iterations once it has learned (a baseline of
    the grid, stopped when it learned); not for the learner's runs, which stop at their
    length."""

    @property
    def learned_at(self) -> int | None:
        return next((it for it, s in zip(self.iterations, self.successes, strict=True)
                     if s >= LEARNED), None)

    def at(self, iteration: int) -> tuple[float, float] | None:
        """(score, success) at `iteration`, the last before it carried forward for a run
        that stopped after learning; None if the run has not got there."""
        before = [i for i, it in enumerate(self.iterations) if it <= iteration]
        if not before:
            return None
        i = before[-1]
        if self.iterations[i] < iteration and (self.learned_at is None or not self.carries):
            return None
        return self.scores[i], self.successes[i]


def episode_budget(config: Mapping[str, Any]) -> int:
    """The episode measure's budget: a baseline's episode length, else the paper's 1000."""
    if config.get("kind") == "baseline":
        return int(config["baseline"].get("episode_length", EPISODE_ACTIONS))
    return EPISODE_ACTIONS


def run_curve(name: str, evaluations: Sequence, task: str, budget: int,
              trained: int, carries: bool = True) -> RunCurve | None:
    """The run's two measures on `task` at the iterations that have both (None if none)."""
    score = {e.iteration: e.score for e in evaluations if e.task == task}
    episode = {e.iteration: e for e in evaluations if e.task == measure_name(task, budget)}
    its = sorted(set(score) & set(episode))
    if not its:
        return None
    return RunCurve(name, tuple(its), tuple(score[i] for i in its),
                    tuple(zone_share(episode[i].points) for i in its),
                    tuple(sum(p.get("actions", 0) for p in episode[i].points) for i in its),
                    trained, carries)


def group_curves(store, groups: Mapping[str, Sequence[str]]) -> dict[str, dict[str, list]]:
    """{task: {group label: [RunCurve]}} of the runs that have both measures."""
    out: dict[str, dict[str, list]] = {}
    for label, names in groups.items():
        for name in names:
            record = store.get_run(name)
            evaluations = store.evaluations(name)
            for task in TASKS:
                c = run_curve(name, evaluations, task, episode_budget(record.config),
                              record.iterations, record.config.get("kind") == "baseline")
                if c is not None:
                    out.setdefault(task, {}).setdefault(label, []).append(c)
    return out


def _pair(curves: Sequence[RunCurve], iteration: int) -> str:
    values = [c.at(iteration) for c in curves]
    if any(v is None for v in values):
        return "—"
    scores, successes = zip(*values, strict=True)
    return f"{np.mean(scores):.2f} / {np.mean(successes):.0%}"


def _ours(curves: Sequence[RunCurve]) -> str:
    cells = []
    for c in curves:
        at = c.learned_at
        cells.append(f"{at:,}" if at is not None else f"not by {c.iterations[-1]:,}")
    learned = sum(c.learned_at is not None for c in curves)
    return f"{learned}/{len(curves)}: " + ", ".join(cells)


def _last(curves: Sequence[RunCurve]) -> str:
    scores = [c.scores[-1] for c in curves]
    successes = [c.successes[-1] for c in curves]
    its = sorted({c.iterations[-1] for c in curves})
    span = f"{its[0]:,}" if len(its) == 1 else f"{its[0]:,}–{its[-1]:,}"
    return f"{np.mean(scores):.2f} / {np.mean(successes):.0%} ({span})"


def claims_table(curves: Mapping[str, Mapping[str, Sequence[RunCurve]]]) -> str:
    """Per task and group: the paper's claim, ours (each run's first iteration with ≥ 90 %
    episode success, or "not by N"), both measures (score / success) at 50 000 and at each
    run's last evaluation."""
    lines = ["| task | algorithm (reward) | paper (Fig. 5) | ours: runs learned, first iteration "
             f"with ≥ {LEARNED:.0%} episode success | score / success at {AT:,} | "
             "score / success at the last evaluation (iterations) |",
             "|---|---|---|---|---|---|"]
    for task in TASKS:
        for label, mine in sorted(curves.get(task, {}).items()):
            lines.append(f"| {task} | {label} | {paper_claim(label, task)} | {_ours(mine)} | "
                         f"{_pair(mine, AT)} | {_last(mine)} |")
    return "\n".join(lines)


def claims_summary(curves: Mapping[str, Mapping[str, Sequence[RunCurve]]]) -> dict[str, Any]:
    """The same as numbers (summary.json's `claims`)."""
    return {task: {label: [{"run": c.run, "learned_at": c.learned_at,
                            "iterations": list(c.iterations), "scores": list(c.scores),
                            "successes": list(c.successes), "actions": list(c.actions)}
                           for c in mine]
                   for label, mine in by_label.items()}
            for task, by_label in curves.items()}


def _mean_curve(curves: Sequence[RunCurve], which: str) -> tuple[np.ndarray, np.ndarray]:
    its = sorted({i for c in curves for i in c.iterations})
    xs, ys = [], []
    for it in its:
        values = [c.at(it) for c in curves]
        if any(v is None for v in values):
            continue
        xs.append(it)
        ys.append(np.mean([v[0 if which == "score" else 1] for v in values]))
    return np.array(xs), np.array(ys)


def measures_figure(curves: Mapping[str, Mapping[str, Sequence[RunCurve]]], out: Path) -> None:
    """Fig. 5 with both measures: a panel per task, iterations on a log axis; per group the
    mean score (solid) and the mean episode success (dashed) in one colour."""
    from hadim_cli.plots import _plt, _save

    plt = _plt()
    tasks = [t for t in TASKS if t in curves]
    fig, axes = plt.subplots(1, max(1, len(tasks)), figsize=(5.5 * max(1, len(tasks)), 4.2),
                             squeeze=False)
    labels = sorted({label for by in curves.values() for label in by})
    # paper and fixed of one algorithm in a pair of shades (tab20); the learner in black
    colours = {label: "black" if label.startswith("hadim") else plt.cm.tab20(i % 20)
               for i, label in enumerate(labels)}
    for ax, task in zip(axes[0], tasks, strict=False):
        for label, mine in sorted(curves[task].items()):
            for which, style in (("score", "-"), ("success", "--")):
                xs, ys = _mean_curve(mine, which)
                if len(xs):
                    ax.plot(xs, ys, style, color=colours[label], marker=".",
                            label=f"{label} (n={len(mine)})" if which == "score" else None)
        ax.axhline(LEARNED, color="grey", lw=0.5, ls=":")
        ax.set_title(f"{task}: score (—), episode success (--)", fontsize=9)
        ax.set_xscale("log")
        ax.set_xlabel("iteration")
        ax.set_ylim(-0.02, 1.02)
        ax.grid(alpha=0.3)
        ax.legend(loc="best", fontsize=6)
    fig.tight_layout()
    _save(plt, fig, out)
