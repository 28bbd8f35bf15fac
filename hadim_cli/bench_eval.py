"""`hadim bench eval`: what evaluating a stored learner costs, task by task.

The learner is restored from a run's checkpoint as `hadim eval` restores it, and each task is
evaluated exactly as training's periodic evaluation does (nothing is stored). Both the wall
time and the process's CPU time are reported: on a shared machine the CPU time is the
comparable figure.
"""

from __future__ import annotations

import time
from dataclasses import asdict, dataclass

from hadim_cli.session import Session


@dataclass(frozen=True)
class TaskCost:
    task: str
    score: float
    seconds: float
    cpu_seconds: float
    points: int
    actions: int
    """Primitive actions the planner chose over all points."""


@dataclass(frozen=True)
class EvalBench:
    run: str
    iteration: int
    affordances: int
    tasks: list[TaskCost]
    seconds: float
    cpu_seconds: float

    @property
    def ms_per_action(self) -> float:
        actions = sum(t.actions for t in self.tasks)
        return 1e3 * self.cpu_seconds / max(actions, 1)

    def to_dict(self) -> dict:
        return {**asdict(self), "ms_per_action": round(self.ms_per_action, 3)}


def bench_eval(session: Session, run: str, tasks: tuple[str, ...]) -> EvalBench:
    """Evaluate `session`'s learner on each of `tasks`, timing each."""
    from hadim_cli.evaluation.runner import evaluate
    from hadim_cli.evaluation.tasks import load_task

    chosen = [load_task(name) for name in tasks]
    costs = []
    for task in chosen:
        wall, cpu = time.perf_counter(), time.process_time()
        result = evaluate(session.learner, session.config.world, task)
        cpu, wall = time.process_time() - cpu, time.perf_counter() - wall
        costs.append(TaskCost(task.name, result.score, round(wall, 3), round(cpu, 3),
                              len(result.points), sum(p.actions for p in result.points)))
    return EvalBench(run, session.iteration, len(session.learner.hierarchy), costs,
                     round(sum(c.seconds for c in costs), 3),
                     round(sum(c.cpu_seconds for c in costs), 3))
