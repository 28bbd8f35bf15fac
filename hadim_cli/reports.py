"""Terminal renderings (rich) of H, the affordance timeline and evaluation results."""

from __future__ import annotations

from typing import Any

from rich.console import Console
from rich.table import Table

from hadim_cli.evaluation.runner import TaskResult
from hadim_cli.evaluation.tasks import load_task
from hadim_cli.learner.frames import FramedModel
from hadim_cli.session import Session


def affordance_rows(session: Session) -> list[dict[str, Any]]:
    """H as plain rows; p_A is asked about every entity of the push-object task's scene."""
    learner = session.learner
    from hadim_cli.world.world import World

    world = World(session.config.world)
    obs = world.reset(scene=load_task("push-object").scene)
    rows = []
    for aff in learner.hierarchy:
        accepted: list[str] | None = None
        if aff.classifier is not None:
            entities = world.layout.entities
            feats = [learner.reader.visual_features(obs, i) for i in range(len(entities))]
            import numpy as np

            ok = aff.classifier.accepts(np.stack(feats))
            accepted = [e for e, a in zip(entities, ok, strict=True) if a]
        frame = (aff.contexts[aff.model.frame.axis].name
                 if isinstance(aff.model, FramedModel) else None)
        rows.append({
            "id": aff.id, "input": aff.input.name, "output": aff.output.name,
            "context": [c.name for c in aff.contexts], "frame": frame,
            "created_at": aff.created_at,
            "competence": round(float(aff.competence), 4), "data": len(aff.rows),
            "interest": round(float(aff.interest.interest), 4), "accepts": accepted,
        })
    return rows


def render_h_table(console: Console, rows: list[dict[str, Any]], iteration: int) -> None:
    table = Table(title=f"H at iteration {iteration} ({len(rows)} affordances)")
    for col in ("id", "input → output", "context", "created", "competence", "data",
                "p_A accepts (reference scene)"):
        table.add_column(col)
    for r in rows:
        accepts = "—" if r["accepts"] is None else (", ".join(r["accepts"]) or "nothing")
        table.add_row(f"A{r['id']}", f"{r['input']} → {r['output']}",
                      ", ".join(f"{c} (frame)" if c == r["frame"] else c
                                for c in r["context"]) or "∅", str(r["created_at"]),
                      f"{r['competence']:.3f}", str(r["data"]), accepts)
    console.print(table)


def render_timeline(console: Console, events: list) -> None:
    table = Table(title=f"affordance timeline ({len(events)} events)")
    for col in ("iteration", "affordance", "event", "spaces", "context", "competence"):
        table.add_column(col)
    for e in events:
        comp = "" if e.competence is None else f"{e.competence:.3f}"
        change = ", ".join(f"{k}: {v}" for k, v in e.detail.items())
        table.add_row(str(e.iteration), f"A{e.affordance_id}",
                      e.kind + (f" ({change})" if change else ""),
                      f"{e.input_space} → {e.output_space}", ", ".join(e.context) or "∅", comp)
    console.print(table)


def render_eval(console: Console, result: TaskResult, iteration: int) -> None:
    table = Table(title=f"{result.task} at iteration {iteration}: score {result.score:.3f}")
    for col in ("#", "target", "start", "final", "error", "actions", "note"):
        table.add_column(col)
    for i, p in enumerate(result.points):
        def fmt(v):
            return f"({v[0]:+.2f}, {v[1]:+.2f})"

        note = "robot touched target" if p.contact_failed else (
            "no affordance" if p.affordance_id < 0 else f"A{p.affordance_id}")
        table.add_row(str(i), fmt(p.target), fmt(p.start), fmt(p.final), f"{p.error:.3f}",
                      str(p.actions), note)
    console.print(table)
