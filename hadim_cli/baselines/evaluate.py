"""Evaluate a baseline's greedy policy on a task file, with the learner's metric (§5.1).

The same task files, target points, budgets and metric as `hadim_cli.evaluation.runner`: each
point starts from the task's scene (reduced to the objects the baseline trains with), the
policy acts greedily for at most the task's budget of actions (stopping early in the goal
zone), error = min(1, final / initial distance), 1 on a robot–target contact with a tool;
score = 1 − mean(error). A fresh environment of its own: evaluation draws nothing from the
training environment or any generator, so it never changes training.
"""

from __future__ import annotations

import numpy as np

from hadim_cli.baselines.agents import environment
from hadim_cli.baselines.config import Algorithm, BaselineConfig, check_fits
from hadim_cli.baselines.curious import ModularGoalEnv
from hadim_cli.baselines.tasks import eval_scene
from hadim_cli.evaluation.metric import point_error, task_score
from hadim_cli.evaluation.runner import PointResult, TaskResult, segment_distance
from hadim_cli.evaluation.tasks import Task

STUCK = 20
"""Actions after which a policy whose observation has not changed at all (pressing against a
wall) is taken to stay so: its point ends there, counted as using the whole budget."""


def evaluate_policy(agent, cfg: BaselineConfig, task: Task) -> TaskResult:
    check_fits(cfg, task)
    base = environment(cfg)
    env = ModularGoalEnv(base) if Algorithm(cfg.algorithm) is Algorithm.CURIOUS else base
    scene = eval_scene(task, base.task)
    entity = base.position_columns(base.task.goal_entity)
    results = []
    for point in task.points:
        obs = env.start_from(scene, point)
        start = obs["observation"][entity].astype(float)
        robot = obs["observation"][:2].astype(float)
        used, contact, path, deviation = 0, False, 0.0, 0.0
        still = 0
        while used < task.budget:
            last = obs["observation"]
            obs, _, terminated, _, info = env.step(agent.act(obs))
            used += 1
            still = still + 1 if np.array_equal(obs["observation"], last) else 0
            if still >= STUCK:  # the same input, the same greedy action: nothing will change
                used = task.budget
                break
            contact = bool(info.get("contact"))
            now = obs["observation"][:2].astype(float)
            path += float(np.linalg.norm(now - robot))
            robot = now
            deviation = max(deviation, segment_distance(
                obs["observation"][entity].astype(float), start, np.asarray(point)))
            if terminated:
                break
        final = obs["observation"][entity].astype(float)
        error = 1.0 if contact else point_error(start, final, np.asarray(point))
        results.append(PointResult(tuple(point), tuple(start.tolist()), tuple(final.tolist()),
                                   error, used, -1, contact, path, 0, deviation))
    return TaskResult(task.name, task_score([r.error for r in results]), tuple(results),
                      budget=task.budget, actor=base.world.layout.actor)
