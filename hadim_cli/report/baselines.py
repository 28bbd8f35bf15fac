"""The reinforcement-learning comparison of a sweep (paper §5.3, Fig. 5), from stored evaluations.

Runs are grouped as the paper's legend: a baseline by algorithm and reward (`dqn (guided)`), a
learner run by its sweep config (`hadim (default)`), so the learner's curve sits on the same
axes. On each task, a group's table row says when its mean score first reached 0.9, how many
of its runs ever did, when 90 % of the points (mean over runs) ended inside the goal zone
(the baselines' `GOAL_RADIUS`, 0.1 m, for every group: a baseline's episode stops as the zone is
entered, so its score stays below 1 even when it reaches every point), its last score, and the
paper's claim. Pure functions over `Evaluation` records.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

THRESHOLD = 0.9
"""The score (and the share of points in the goal zone) a task counts as learned at."""
ZONE_SHARE = 0.9
TASKS = ("move-robot", "push-object", "push-with-tool")


def group_label(config: Mapping[str, Any], sweep_label: str) -> str:
    """A run's curve: a baseline's algorithm and reward, or the learner's sweep config."""
    if config.get("kind") == "baseline":
        b = config["baseline"]
        actions = "" if b.get("actions", "discrete") == "discrete" else f", {b['actions']}"
        variant = "" if b.get("variant", "paper") == "paper" else f", {b['variant']}"
        return f"{b['algorithm']} ({b['reward']}{actions}{variant})"
    return sweep_label if sweep_label.startswith("hadim") else f"hadim ({sweep_label})"


def paper_claim(label: str, task: str) -> str:
    """What the paper's §5.3 says of this group on this task."""
    if label.startswith("hadim"):
        return {"move-robot": "learned by 250", "push-object": "learned by 1000",
                "push-with-tool": "0.96 (CURIOUS's final level) by 2100"}[task]
    if task == "move-robot":
        return "learned in 10k–20k (every algorithm)"
    if task == "push-object":
        return "learned in 12.5k–26k" if "guided" in label else "fails (only guided ones learn)"
    return "0.96 at 32k" if label.startswith("curious") else "fails (only CURIOUS learns)"


def zone_share(points: Sequence[Mapping[str, Any]], radius: float) -> float:
    """Share of an evaluation's points whose entity ended inside the goal zone (no contact)."""
    if not points:
        return 0.0
    inside = [not p.get("contact_failed", False)
              and math.dist(p["final"], p["target"]) <= radius for p in points]
    return float(np.mean(inside))


@dataclass(frozen=True)
class Curve:
    """A group's runs on one task: per iteration every run was evaluated at, every run's score
    and zone share."""

    iterations: tuple[int, ...]
    scores: tuple[tuple[float, ...], ...]
    shares: tuple[tuple[float, ...], ...]
    runs: int
    reached: int
    """Runs whose own score reached the threshold at some evaluation."""


def curve(runs_evaluations: Sequence[Sequence], task: str, radius: float) -> Curve | None:
    by_it: dict[int, list[tuple[float, float]]] = {}
    runs = reached = 0
    for evaluations in runs_evaluations:
        mine = [e for e in evaluations if e.task == task]
        if not mine:
            continue
        runs += 1
        reached += any(e.score >= THRESHOLD for e in mine)
        for e in mine:
            by_it.setdefault(e.iteration, []).append((e.score, zone_share(e.points, radius)))
    # Only iterations every run reached: a sweep still running has runs at different points,
    # and a mean over the front-runners alone is not the group's.
    its = sorted(it for it, values in by_it.items() if len(values) == runs)
    if not its:
        return None
    return Curve(tuple(its), tuple(tuple(s for s, _ in by_it[i]) for i in its),
                 tuple(tuple(z for _, z in by_it[i]) for i in its), runs, reached)


def first_at(iterations: Sequence[int], values: Sequence[Sequence[float]],
             threshold: float) -> int | None:
    """The first iteration whose mean over runs reaches `threshold` (None if none does)."""
    for it, vals in zip(iterations, values, strict=True):
        if float(np.mean(vals)) >= threshold:
            return it
    return None


def _at(it: int | None) -> str:
    return "not reached" if it is None else f"{it}"


def comparison_table(groups: Mapping[str, Sequence[Sequence]], radius: float) -> str:
    """The Fig. 5-like table: per group and task, when it was learned, next to the paper."""
    lines = [f"| algorithm (reward) | task | runs | mean score ≥ {THRESHOLD} at | runs ever ≥ "
             f"{THRESHOLD} | {ZONE_SHARE:.0%} of points in the zone (r = {radius} m) at | last "
             "score (iteration) | paper |", "|---|---|---|---|---|---|---|---|"]
    for task in TASKS:
        for label, runs in groups.items():
            c = curve(runs, task, radius)
            if c is None:
                continue
            last = c.scores[-1]
            score_at = _at(first_at(c.iterations, c.scores, THRESHOLD))
            zone_at = _at(first_at(c.iterations, c.shares, ZONE_SHARE))
            lines.append(
                f"| {label} | {task} | {c.runs} | {score_at} | {c.reached}/{c.runs} | {zone_at} | "
                f"{np.mean(last):.2f} ± {np.std(last):.2f} ({c.iterations[-1]}, n={len(last)}) "
                f"| {paper_claim(label, task)} |")
    return "\n".join(lines)


def comparison_summary(groups: Mapping[str, Sequence[Sequence]], radius: float
                       ) -> dict[str, Any]:
    """The same as numbers (summary.json's `comparison`)."""
    out: dict[str, Any] = {}
    for label, runs in groups.items():
        for task in TASKS:
            c = curve(runs, task, radius)
            if c is None:
                continue
            out.setdefault(label, {})[task] = {
                "runs": c.runs, "reached": c.reached,
                "score_at": first_at(c.iterations, c.scores, THRESHOLD),
                "zone_at": first_at(c.iterations, c.shares, ZONE_SHARE),
                "iterations": list(c.iterations),
                "score_mean": [float(np.mean(s)) for s in c.scores],
                "score_std": [float(np.std(s)) for s in c.scores],
                "zone_mean": [float(np.mean(z)) for z in c.shares],
                "paper": paper_claim(label, task)}
    return out
