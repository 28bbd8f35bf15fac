"""A sweep's runs grouped by config, and their scores as numbers (summary.json)."""

from __future__ import annotations

from typing import Any

import numpy as np

from hadim_cli.errors import HadimError


def sweep_groups(store, sweep: str) -> dict[str, list[str]]:
    """{config label: [run names, seed order]} of a sweep, as it was claimed."""
    settings = store.sweep_settings(sweep)
    if settings is None:
        known = ", ".join(store.sweeps()) or "none"
        raise HadimError(f"no sweep named {sweep!r} in {store.where} (sweeps: {known})")
    groups: dict[str, list[str]] = {}
    stored = {r.name for r in store.list_runs()}
    for entry in settings["entries"]:
        if entry["run"] in stored:
            groups.setdefault(entry["label"], []).append(entry["run"])
    if not groups:
        raise HadimError(f"sweep {sweep!r} has no runs yet: run it first")
    return groups


def score_summary(evaluations: list[list]) -> dict[str, dict[str, dict[str, float]]]:
    """{task: {iteration: {mean, std, n}}} over the runs' evaluations."""
    table: dict[str, dict[int, list[float]]] = {}
    for run_evaluations in evaluations:
        for e in run_evaluations:
            table.setdefault(e.task, {}).setdefault(e.iteration, []).append(e.score)
    return {task: {str(it): {"mean": float(np.mean(v)), "std": float(np.std(v)), "n": len(v)}
                   for it, v in sorted(by_it.items())}
            for task, by_it in table.items()}


def build_summary(store, groups: dict[str, list[str]]) -> dict[str, Any]:
    """Per config the scores by task and iteration; per run its iterations, D's digest, and H
    at the end (as `hadim affordances --json` shows it) and its number of events for a
    learner run, the algorithm, task, reward and actions for a baseline run."""
    from hadim_cli import runs
    from hadim_cli.reports import affordance_rows

    summary: dict[str, Any] = {"configs": {}, "runs": {}}
    for label, names in groups.items():
        summary["configs"][label] = score_summary([store.evaluations(n) for n in names])
        for name in names:
            record = store.get_run(name)
            row = {"config": label, "seed": record.seed, "status": record.status,
                   "iterations": record.iterations,
                   "dataset_sha256": store.dataset_sha256(name)}
            if is_baseline(record.config):
                b = record.config["baseline"]
                row["baseline"] = {k: b[k] for k in ("algorithm", "task", "reward", "actions")}
            else:
                session = runs.restore_session(store, record)
                row.update(affordances=affordance_rows(session),
                           events=len(store.events(name)))
            summary["runs"][name] = row
    return summary


def is_baseline(config: dict[str, Any]) -> bool:
    return config.get("kind") == "baseline"
