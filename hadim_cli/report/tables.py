"""The markdown tables of docs/results.md: scores per config, the paper's targets, and per seed
the affordances of H at the end and what p_A of pushing accepts."""

from __future__ import annotations

from typing import Any

import numpy as np

TASKS = ("move-robot", "push-object", "push-with-tool")
# The paper's targets (docs/results.md), checked on the reference config's mean.
TARGETS = {("move-robot", 1000): 0.8, ("move-robot", 4000): 0.85,
           ("push-object", 4000): 0.6, ("push-with-tool", 4000): 0.3}


def score_table(summary: dict[str, Any], iterations: list[int]) -> str:
    lines = ["| config | task | " + " | ".join(str(i) for i in iterations) + " |",
             "|---|---|" + "---|" * len(iterations)]
    for cfg, tasks in summary["configs"].items():
        for task in (t for t in TASKS if t in tasks):  # a baseline is evaluated on its task
            cells = []
            for it in iterations:
                cell = tasks.get(task, {}).get(str(it))
                cells.append("—" if cell is None else f"{cell['mean']:.2f} ± {cell['std']:.2f}")
            lines.append(f"| {cfg} | {task} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def target_table(summary: dict[str, Any], reference: str) -> str:
    scores = summary["configs"][reference]
    lines = [f"| target ({reference}, mean of seeds) | measured | met |", "|---|---|---|"]
    for (task, it), want in TARGETS.items():
        cell = scores.get(task, {}).get(str(it))
        got = None if cell is None else cell["mean"]
        met = "—" if got is None else ("yes" if got >= want else "no")
        shown = "—" if got is None else f"{got:.2f}"
        lines.append(f"| {task} ≥ {want} at {it} | {shown} | {met} |")
    return "\n".join(lines)


def p_a_checks(accepted: list[str] | None, task) -> tuple[bool, bool, bool] | None:
    """(every green object accepted, no red one, not the robot) in `task`'s scene, from the
    entities p_A accepts there as `reports.affordance_rows` labels them (`obj7 (red)`)."""
    from hadim_cli.reports import entity_label

    if accepted is None:
        return None
    labels = [entity_label(f"obj{i + 1}", task.scene) for i in range(len(task.scene.objects))]
    green = [n for n, o in zip(labels, task.scene.objects, strict=True) if o.pushable]
    red = [n for n, o in zip(labels, task.scene.objects, strict=True) if not o.pushable]
    return (all(n in accepted for n in green), not any(n in accepted for n in red),
            entity_label("robot", task.scene) not in accepted)


def _run_row(session, name: str, task, counts: dict[str, Any]) -> str:
    from hadim_cli.evaluation.runner import choose_affordance
    from hadim_cli.learner.spaces import Role
    from hadim_cli.reports import affordance_rows

    h = list(session.learner.hierarchy)
    robot = any(a.input.name == "action" and a.output.name == "robot.position" for a in h)
    pushes = [a for a in h if a.output.name == "target.position" and not a.has_tool
              and a.input.role in (Role.ROBOT, Role.ACTION)
              and any(c.name == "target-robot" for c in a.contexts)]
    tools = [a for a in h if a.has_tool and a.output.name == "target.position"]
    push = choose_affordance(session.learner, task)
    accepted = {r["id"]: r["accepts"] for r in affordance_rows(session)}
    checks = None if push is None else p_a_checks(accepted[push.id], task)
    ok = "no push affordance" if checks is None else (
        f"A{push.id}: " + " / ".join("✓" if c else "✗" for c in checks))
    counts["runs"] += 1
    counts["robot"] += robot
    counts["push"] += bool(pushes)
    counts["tool"] += bool(tools)
    counts["p_A"] += checks is not None and all(checks)
    counts["sizes"].append(len(h))
    push_cell = ", ".join(f"A{a.id} {a.input.name} ({a.created_at})" for a in pushes)
    tool_cell = ", ".join(
        f"A{a.id} ({a.created_at}; {', '.join(c.name for c in a.contexts) or '∅'})"
        for a in tools)
    names_cell = "<br>".join(a.describe().replace("|", "\\|") for a in h)
    return (f"| {name} | {len(h)}: {names_cell} | {'yes' if robot else 'no'} | "
            f"{push_cell or 'no'} | {tool_cell or 'no'} | {ok} |")


def run_table(store, names: list[str]) -> tuple[str, dict[str, Any]]:
    """Per run: H at the end, the three expected affordances, p_A of pushing."""
    from hadim_cli import runs
    from hadim_cli.evaluation.tasks import load_task

    task = load_task("push-object")
    lines = ["| run | affordances | moves robot from actions | push with target-robot "
             "context (created) | through another object (created, contexts) | "
             "p_A of push: green ✓ / red ✗ / robot ✗ |", "|---|---|---|---|---|---|"]
    counts: dict[str, Any] = {"robot": 0, "push": 0, "tool": 0, "p_A": 0, "runs": 0, "sizes": []}
    for name in names:
        session = runs.restore_session(store, store.get_run(name))
        lines.append(_run_row(session, name, task, counts))
    return "\n".join(lines), counts


def counts_line(counts: dict[str, Any]) -> str:
    n = counts["runs"]
    return (f"- moves the robot from actions: {counts['robot']}/{n}; pushes with a target-robot "
            f"context: {counts['push']}/{n}; through another object: {counts['tool']}/{n}; p_A "
            f"of push right on every entity: {counts['p_A']}/{n}; affordances per run: "
            f"{counts['sizes']} (mean {np.mean(counts['sizes']):.1f})")
