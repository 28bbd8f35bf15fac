"""Terminal renderings (rich) of H, the affordance timeline and evaluation results."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np
from rich.console import Console
from rich.table import Table
from rich.text import Text

if TYPE_CHECKING:  # the learner (and torch) only where H is rendered from a checkpoint
    from hadim_cli.config import WorldConfig
    from hadim_cli.evaluation.runner import FirstPush, TaskResult
    from hadim_cli.session import Session


def _names(names) -> str:
    """Space names one per line: a table may wrap between them, never inside one."""
    return "\n".join(names) or "∅"


def _shown(value: Any, actor: str) -> Any:
    """`value` with every name in it (a string, or strings in lists and tuples) as
    `spaces.shown_as` shows it for the world whose actor is `actor`; anything else as is."""
    from hadim_cli.learner.spaces import shown_as

    if isinstance(value, str):
        return shown_as(value, actor)
    if isinstance(value, list | tuple):
        return type(value)(_shown(v, actor) for v in value)
    return value


def rows_shown(rows: list[dict[str, Any]], actor: str) -> list[dict[str, Any]]:
    """Rows of H (or of its models' errors) with their spaces named for the world whose actor
    is `actor` (`spaces.shown_as`: `effector.position` on the arm); `--json` prints the
    stored names."""
    keys = ("input", "output", "context", "frame")
    return [{k: _shown(v, actor) if k in keys else v for k, v in r.items()} for r in rows]


def events_shown(events: list, actor: str) -> list:
    """Timeline events with their spaces, and the spaces their details name, named for the
    world whose actor is `actor` (as `rows_shown`)."""
    import dataclasses

    return [dataclasses.replace(
        e, input_space=_shown(e.input_space, actor), output_space=_shown(e.output_space, actor),
        context=_shown(e.context, actor),
        detail={k: _shown(v, actor) for k, v in e.detail.items()}) for e in events]


def entity_label(entity: str, scene) -> str:
    """`obj7 (red)`: an object with the colour that says whether it can be pushed."""
    if not entity.startswith("obj"):
        return entity
    spec = scene.objects[int(entity[3:]) - 1]
    return f"{entity} ({'green' if spec.pushable else 'red'})"


def probed_on_task(world: WorldConfig) -> bool:
    """Whether p_A's column of H is asked about the push-object task's scene (the rover's),
    else about the world's scene of seed 0 (a body that task is not of)."""
    from hadim_cli.evaluation.tasks import fits_body, load_task

    return fits_body(load_task("push-object"), world)


def probe_scene(world):
    """The scene p_A is asked about in `world` (`probed_on_task`): the push-object task's,
    or the world's scene of seed 0."""
    from hadim_cli.evaluation.tasks import load_task

    if probed_on_task(world.config):
        return load_task("push-object").scene
    return world.draw_scene(np.random.default_rng(0))


def affordance_rows(session: Session) -> list[dict[str, Any]]:
    """H as plain rows; p_A is asked about every entity of one scene (`probe_scene`)."""
    from hadim_cli.learner.competence import split_zero  # scipy: only where H is computed
    from hadim_cli.learner.frames import FramedModel
    from hadim_cli.world.environment import make_world

    learner = session.learner
    world = make_world(session.config.world)
    scene = probe_scene(world)
    obs = world.reset(scene=scene)
    rows = []
    for aff in learner.hierarchy:
        accepted: list[str] | None = None
        if aff.classifier is not None:
            entities = world.layout.entities
            feats = [learner.reader.visual_features(obs, i) for i in range(len(entities))]
            ok = aff.classifier.accepts(np.stack(feats))
            accepted = [entity_label(e, scene)
                        for e, a in zip(entities, ok, strict=True) if a]
        frame = (aff.contexts[aff.model.frame.axis].name
                 if isinstance(aff.model, FramedModel) else None)
        moved = (~split_zero(aff.model.data()[2], learner.config.zero_eps) if aff.model.n
                 else np.zeros(0))
        rows.append({
            "id": aff.id, "input": aff.input.name, "output": aff.output.name,
            "context": [c.name for c in aff.contexts], "frame": frame,
            "created_at": aff.created_at,
            "competence": round(float(aff.competence), 4), "data": len(aff.rows),
            "effect": int(moved.sum()), "goals": aff.interest.n_goals,
            "interest": round(float(aff.interest.interest), 4), "accepts": accepted,
        })
    return rows


def error_rows(session: Session) -> list[dict[str, Any]]:
    """Each affordance's forward model on its own rows, each left out of its own fit
    (`competence.held_out_errors`): what a planner using it can expect."""
    from hadim_cli.learner.competence import held_out_errors

    return [{"id": aff.id, "input": aff.input.name, "output": aff.output.name,
             "context": [c.name for c in aff.contexts], "rows": aff.model.n,
             "errors": held_out_errors(aff.model)} for aff in session.learner.hierarchy]


def render_errors(console: Console, rows: list[dict[str, Any]], iteration: int) -> None:
    table = Table(title=f"held-out error of each forward model at iteration {iteration}",
                  caption="each row predicted with itself left out; in the output's units "
                          "(m for positions, unit-vector change for a heading)")
    table.add_column("id", no_wrap=True)
    table.add_column("input → output", no_wrap=True)
    table.add_column("context", no_wrap=True)
    table.add_column("rows", justify="right", no_wrap=True)
    for col in ("p50", "p90", "p99", "max"):
        table.add_column(col, justify="right", no_wrap=True)
    for r in rows:
        e = r["errors"]
        cells = ["–"] * 4 if e is None else [f"{e[k]:.3f}" for k in ("p50", "p90", "p99", "max")]
        table.add_row(f"A{r['id']}", f"{r['input']}\n→ {r['output']}", _names(r["context"]),
                      str(r["rows"]), *cells)
    console.print(table)


def render_h_table(console: Console, rows: list[dict[str, Any]], iteration: int,
                   on_task: bool = True) -> None:
    """H's table, then what p_A accepts of the scene it was asked about (`probed_on_task`)."""
    table = Table(title=f"H at iteration {iteration} ({len(rows)} affordances)",
                  caption="born: the iteration it was created; comp.: its competence; "
                          "data: the rows its models are fitted on; moved: those whose output "
                          "changed (where it acts); goals: those its interest map recorded")
    table.add_column("id", no_wrap=True)
    table.add_column("input → output", no_wrap=True)
    table.add_column("context", min_width=13)  # wraps before "(frame)"
    for col in ("born", "comp.", "data", "moved", "goals"):
        table.add_column(col, justify="right", no_wrap=True)
    for r in rows:
        table.add_row(f"A{r['id']}", f"{r['input']}\n→ {r['output']}",
                      _names(f"{c} (frame)" if c == r["frame"] else c for c in r["context"]),
                      str(r["created_at"]), f"{r['competence']:.3f}", str(r["data"]),
                      str(r["effect"]), str(r["goals"]))
    console.print(table)
    scene = "the push-object scene's objects" if on_task else "the objects of the scene of seed 0"
    console.print(f"p_A on {scene} (green: pushable, red: fixed):", markup=False,
                  highlight=False)
    # A grid: a long list of objects wraps under itself, indented past "A3 accepts".
    accepts = Table.grid(padding=(0, 1))
    accepts.add_column(no_wrap=True)
    accepts.add_column()
    for r in rows:
        if r["accepts"] is not None:
            accepts.add_row(Text(f"  A{r['id']} accepts"),
                            Text(", ".join(r["accepts"]) or "nothing"))
    console.print(accepts)


def render_p_a(console: Console, verdicts: list, iteration: int, actor: str = "robot") -> None:
    """p_A of each affordance (a column) on the reference scene and on unseen objects (rows):
    P(accept), ✗ where it is wrong (accepts a fixed object or the actor — the world's name for
    it, `actor` — rejects a pushable one)."""
    if not verdicts:
        console.print(f"no affordance with p_A at iteration {iteration}")
        return
    table = Table(title=f"p_A at iteration {iteration}",
                  caption="P(accept); ✗ wrong. green: pushable, red: fixed; unseen: sizes "
                          "and shades the world never draws")
    table.add_column("entity", no_wrap=True)
    for v in verdicts:
        table.add_column(f"A{v.id}", justify="right")
    for part in ("scene", "unseen"):
        names = list(getattr(verdicts[0], part))
        for i, name in enumerate(names):
            cells = []
            for v in verdicts:
                wrong = name in (v.scene_wrong if part == "scene" else v.unseen_wrong)
                cells.append(f"{getattr(v, part)[name]:.2f}{' ✗' if wrong else ''}")
            table.add_row(name if part == "scene" else f"unseen: {name}", *cells,
                          end_section=i == len(names) - 1)
    console.print(table)
    for v in verdicts:
        r = v.replay
        verdict = "right" if not v.scene_wrong else f"wrong on {', '.join(v.scene_wrong)}"
        unseen = "right" if not v.unseen_wrong else f"wrong on {', '.join(v.unseen_wrong)}"
        console.print(f"  {v.affordance}: scene {verdict}; unseen {unseen}; replay "
                      f"{r['positives']} positives, {r['negatives_robot']} {actor} and "
                      f"{r['negatives_objects']} object negatives", markup=False,
                      highlight=False)


_CHANGE = {"added": "+", "removed": "−"}


def event_text(kind: str, detail: dict[str, Any]) -> str:
    """`context replaced +tool.position −robot.position`; empty parts are left out."""
    parts = []
    for key, value in detail.items():
        if value in (None, "", [], ()):
            continue
        values = list(value) if isinstance(value, list | tuple) else [value]
        if key in _CHANGE:
            parts += [f"{_CHANGE[key]}{v}" for v in values]
        else:
            parts.append(f"{key.replace('_', ' ')}: {', '.join(map(str, values))}")
    return " ".join([kind.replace("_", " "), *parts])


def render_timeline(console: Console, events: list) -> None:
    """Every change of H, a row each. Space names are never cut: a narrow terminal (or a
    pipe, 80 columns) gets the affordance's id inside the event's cell instead of a column
    of its own, and the table keeps its borders."""
    table = _timeline_table(events, own_id_column=True)
    if least_width(table) > console.width:
        table = _timeline_table(events, own_id_column=False)
    console.print(table)


def least_width(table: Table) -> int:
    """The narrowest a bordered table can be drawn without cutting a word (a line, in a
    column that does not wrap): rich's own measure leaves the borders out."""
    from rich.cells import cell_len

    width = len(table.columns) + 1  # the vertical borders
    for column in table.columns:
        cells = [str(column.header), *map(str, column.cells)]
        parts = [p for c in cells for p in (c.splitlines() if column.no_wrap else c.split())]
        width += max(max(map(cell_len, parts), default=0), column.min_width or 0) + 2
    return width


def _timeline_table(events: list, own_id_column: bool) -> Table:
    table = Table(title=f"affordance timeline ({len(events)} events)")
    table.add_column("iter.", justify="right", no_wrap=True)
    if own_id_column:
        table.add_column("aff.", no_wrap=True)
    texts = [event_text(e.kind, e.detail) for e in events]
    if not own_id_column:
        texts = [f"A{e.affordance_id} {t}" for e, t in zip(events, texts, strict=True)]
    # As wide as its longest word: a table may wrap between the changed spaces, not inside one.
    table.add_column("event" if own_id_column else "aff. event",
                     min_width=max((len(w) for t in texts for w in t.split()), default=5))
    table.add_column("input → output", no_wrap=True)
    table.add_column("context", no_wrap=True)
    table.add_column("C", justify="right", no_wrap=True)
    for e, text in zip(events, texts, strict=True):
        comp = "" if e.competence is None else f"{e.competence:.3f}"
        table.add_row(str(e.iteration), *((f"A{e.affordance_id}",) if own_id_column else ()),
                      text, f"{e.input_space}\n→ {e.output_space}", _names(e.context), comp)
    return table


def first_push_summary(pushes: list[FirstPush], actor: str = "robot") -> str:
    """One line of the medians of the points' `FirstPush` angles (`actor`: what the world
    calls the body's actor)."""
    def median(values: list[float]) -> str:
        return f"{float(np.median(values)):.0f}°"

    line = f"first pushes (median): pusher {median([f.pusher_off for f in pushes])} off the way"
    bends = [f.robot_off for f in pushes if f.robot_off is not None]
    if bends:
        line += f", {actor}–tool bend {median(bends)}"
    return line + f", object's move {median([f.move_off for f in pushes])} off"


def render_eval(console: Console, result: TaskResult, iteration: int) -> None:
    """A row per point: where it went, the actions it used, the trips the planner took to a
    place and the actions that moved no object; the caption sums them over the task."""
    points = result.points
    counted = [p for p in points if p.robot_only is not None]
    actions = sum(p.actions for p in counted)
    caption = None
    if counted and actions:
        robot_only = sum(p.robot_only for p in counted)
        caption = (f"{sum(p.trips for p in counted) / len(counted):.1f} trips per point; "
                   f"{100 * robot_only / actions:.0f} % of the "
                   f"{actions} actions moved no object")
        pushed = [p for p in points if p.first_push is not None]  # push tasks' moved objects
        if pushed and robot_only:
            after = sum(p.robot_only_after for p in counted)
            caption += f" ({100 * after / robot_only:.0f} % of those after the object first moved)"
        moves = sum(p.driven_moves for p in pushed)
        if moves:
            path = sum(p.driven_path for p in pushed)
            caption += f"; a push moved the object {100 * path / moves:.1f} cm"
        if pushed:
            caption += "\n" + first_push_summary([p.first_push for p in pushed], result.actor)
    table = _points_table(result, iteration, caption, with_start=True)
    if least_width(table) > console.width:  # 80 columns, or a pipe: the start goes
        table = _points_table(result, iteration, caption, with_start=False)
    console.print(table)


def _points_table(result: TaskResult, iteration: int, caption: str | None,
                  with_start: bool) -> Table:
    table = Table(title=f"{result.task} at iteration {iteration}: score {result.score:.3f}, "
                  f"{result.in_zone}/{len(result.points)} points in the goal zone",
                  caption=caption)
    table.add_column("#", justify="right", no_wrap=True)
    for col in ("target", *(("start",) if with_start else ()), "final"):
        table.add_column(col, no_wrap=True)
    for col in ("error", "actions", "trips"):
        table.add_column(col, justify="right", no_wrap=True)
    table.add_column(f"{result.actor} only", justify="right", min_width=len(result.actor))
    table.add_column("note")
    for i, p in enumerate(result.points):
        def fmt(v):
            return f"{v[0]:+.2f} {v[1]:+.2f}"

        note = f"{result.actor} touched target" if p.contact_failed else (
            "no affordance" if p.affordance_id < 0 else f"A{p.affordance_id}")
        table.add_row(str(i), fmt(p.target), *((fmt(p.start),) if with_start else ()),
                      fmt(p.final), f"{p.error:.3f}", str(p.actions), str(p.trips),
                      "–" if p.robot_only is None else str(p.robot_only), note)
    return table
