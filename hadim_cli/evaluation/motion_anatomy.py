"""What the arm's learned motion costs its tasks, and what a frame of the shoulder would buy.

    python scripts/arm_motion_anatomy.py --store arm.sqlite [--run run-1] [--json]

(`scripts/arm_motion_anatomy.py` runs `main`.)

For an arm run (`hadim train --config configs/arm.toml`), the learner's own `action →
robot.position` (the effector's motion, the paper's A0) is measured three ways, nothing stored:

- its prediction error on fresh (pose, action) pairs of random scenes, against its held-out
  (leave-one-out) error on its own rows: rows of one episode lie close together, so the
  leave-one-out error says little of a pose no episode went near;
- the same rows read in the frame of the arm's first link (the effector's move turned by minus
  the shoulder's angle, the context the other joints' angles): the table turns about the base,
  so a command moves the effector the same way in that frame whatever the shoulder's angle, and
  a pose's neighbours come from every bearing;
- each arm task evaluated with the controller imagining A0 by that framed model (its stand-in,
  as `hadim eval --exact navigation` puts the arm's exact kinematics there): the score the
  frame would buy, from the learner's own rows and nothing it does not know.
"""

from __future__ import annotations

import argparse
import json
import sys

import numpy as np

from hadim_cli import runs
from hadim_cli.evaluation.runner import evaluate
from hadim_cli.evaluation.tasks import body_tasks, load_task
from hadim_cli.learner.models import LocalLinearModel
from hadim_cli.world.layout import Property

FRAMED_K = 30
"""Neighbours of the framed model's local fits."""
FRESH = 300
"""Fresh (pose, action) pairs the errors are measured on."""


def _quantiles(errors: np.ndarray, moves: np.ndarray) -> dict[str, float]:
    return {"p50": float(np.median(errors)), "p90": float(np.quantile(errors, 0.9)),
            "relative_p50": float(np.median(errors / np.maximum(moves, 1e-9)))}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--store", required=True)
    parser.add_argument("--run", default=None)
    parser.add_argument("--json", action="store_true")
    args = parser.parse_args(argv)
    with runs.open_store(args.store, create=False) as st:
        session = runs.restore_session(st, runs.chosen_run(st, args.run), None)
    learner, world = session.learner, session.world
    lay = world.layout
    a0 = max((a for a in learner.hierarchy
              if a.input.name == "action" and a.output.name == "robot.position"),
             key=lambda a: a.competence)
    names = [c.name for c in a0.contexts]
    if "robot.joints" not in names:
        print(f"A{a0.id} reads no joint angles ({', '.join(names)}): nothing to frame",
              file=sys.stderr)
        return 2
    x, c, y = a0.model.data()
    start = sum(a0.model.context_dims[:names.index("robot.joints")])
    n_joints = lay.space(lay.actor, Property.JOINTS).dim
    q = c[:, start:start + n_joints]
    cos, sin = np.cos(q[:, 0]), np.sin(q[:, 0])
    framed = LocalLinearModel(x.shape[1], 2, (n_joints - 1,), k_forward=FRAMED_K)
    framed.add(x, q[:, 1:], np.stack([y[:, 0] * cos + y[:, 1] * sin,
                                      y[:, 1] * cos - y[:, 0] * sin], axis=1))
    joints = lay.space(lay.actor, Property.JOINTS).slice

    def framed_move(commands: np.ndarray, obs: np.ndarray, _: np.ndarray) -> np.ndarray:
        angles = obs[:, joints]
        v = framed.predict(commands, angles[:, 1:])
        co, si = np.cos(angles[:, 0]), np.sin(angles[:, 0])
        return np.stack([v[:, 0] * co - v[:, 1] * si, v[:, 0] * si + v[:, 1] * co], axis=1)

    rng = np.random.default_rng(1)
    errors: dict[str, list[float]] = {"learned": [], "framed": []}
    moves = []
    for _ in range(FRESH):
        obs = world.reset(rng)
        command = world.action_space.sample(rng, 1)
        after = world.step(command[0])
        moved = (lay.get(after, lay.actor, Property.POSITION)
                 - lay.get(obs, lay.actor, Property.POSITION))
        context = np.concatenate([learner.reader.value_now(s, obs) for s in a0.contexts])
        errors["learned"].append(float(np.linalg.norm(
            a0.model.predict(command, context[None])[0] - moved)))
        errors["framed"].append(float(np.linalg.norm(
            framed_move(command, obs[None], np.zeros(0))[0] - moved)))
        moves.append(float(np.linalg.norm(moved)))
    held_out = np.linalg.norm(a0.model.predict_loo() - y, axis=1)
    report: dict = {
        "iteration": session.iteration, "affordance": a0.id, "context": names, "rows": len(y),
        "held_out": _quantiles(held_out, np.linalg.norm(y, axis=1)),
        "fresh_learned": _quantiles(np.array(errors["learned"]), np.array(moves)),
        "fresh_framed": _quantiles(np.array(errors["framed"]), np.array(moves)),
        "tasks": {}}
    tasks = body_tasks(session.config.world.body)
    for name in tasks:
        report["tasks"][name] = {"learned": evaluate(learner, session.config.world,
                                                     load_task(name)).score}
    learner.controller.stand_ins["action"] = framed_move
    for name in tasks:
        report["tasks"][name]["framed"] = evaluate(learner, session.config.world,
                                                   load_task(name)).score
    if args.json:
        print(json.dumps(report, indent=2))
        return 0
    print(f"A{a0.id} action → robot.position, context {', '.join(names)}, {len(y)} rows, "
          f"iteration {session.iteration}")
    for key in ("held_out", "fresh_learned", "fresh_framed"):
        r = report[key]
        print(f"  {key:14s} error p50 {100 * r['p50']:.2f} cm, p90 {100 * r['p90']:.2f} cm, "
              f"{100 * r['relative_p50']:.0f} % of the move")
    for name, scores in report["tasks"].items():
        print(f"  {name:20s} learned {scores['learned']:.3f}  framed {scores['framed']:.3f}")
    return 0
