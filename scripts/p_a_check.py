"""p_A of a run's object-moving affordances: right on the push-object scene, on objects of
shades and sizes the world never draws, and what its replay holds (issue 16, item 6).

    PYTHONPATH=. python scripts/p_a_check.py STORE RUN      # one JSON line
"""
from __future__ import annotations

import json
import sys

import numpy as np

from hadim_cli import runs
from hadim_cli.evaluation.tasks import load_task
from hadim_cli.world.world import World

store_path, run = sys.argv[1], sys.argv[2]
with runs.open_store(store_path, create=False) as st:
    session = runs.restore_session(st, st.get_run(run))
learner = session.learner
world = World(session.config.world)
scene = load_task("push-object").scene
obs = world.reset(scene=scene)
n = len(world.layout.entities)
feats = np.stack([learner.reader.visual_features(obs, i) for i in range(n)])
truth = np.array([False] + [o.pushable for o in scene.objects])


def f(r, h, rgb):
    return [r / 0.25, h / 0.6, *rgb, 0.0]


# Outside the world's ranges: radius 0.08-0.25, height 0.1-0.6, dominant 0.55-1, others 0-0.3.
unseen = {"green-small": (f(0.05, 0.07, (0.1, 0.7, 0.1)), True),
          "green-large": (f(0.30, 0.70, (0.2, 0.9, 0.2)), True),
          "green-dark": (f(0.15, 0.30, (0.1, 0.45, 0.1)), True),
          "green-pale": (f(0.15, 0.30, (0.35, 0.8, 0.35)), True),
          "red-small": (f(0.05, 0.07, (0.8, 0.1, 0.1)), False),
          "red-large": (f(0.30, 0.70, (0.9, 0.2, 0.2)), False),
          "red-dark": (f(0.15, 0.30, (0.45, 0.1, 0.1)), False),
          "red-pale": (f(0.15, 0.30, (0.8, 0.35, 0.35)), False)}
U = np.array([v[0] for v in unseen.values()])
want = np.array([v[1] for v in unseen.values()])
out = []
for aff in learner.hierarchy:
    c = aff.classifier
    if c is None or aff.output.name != "target.position":
        continue
    ok = c.accepts(feats)
    uok = c.accepts(U)
    neg = c._negatives
    robot = np.isclose(neg[:, 3], 0.3) & np.isclose(neg[:, 4], 0.8)  # (0.2, 0.3, 0.8)
    red = (neg[:, 2] > neg[:, 3]) & ~robot
    wrong = [world.layout.entities[i] for i in np.flatnonzero(ok != truth)]
    out.append({"aff": aff.describe(), "scene_right": bool((ok == truth).all()),
                "scene_wrong": wrong,
                "unseen_wrong": [k for k, u, w in zip(unseen, uok, want, strict=True) if u != w],
                "neg_robot": int(robot.sum()), "neg_red": int(red.sum()),
                "neg_green": int((~robot & ~red).sum()), "pos": int(c._positives.shape[0])})
print(json.dumps({"run": store_path, "affordances": out}))
