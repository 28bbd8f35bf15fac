"""A scripted controller that knows the physics: the upper bound of what a task's budget allows.

It reads the true state (positions, radii), predicts the robot's moves with the differential
drive's exact kinematics (`evaluation.exact.KinematicMotion`) and pushes by geometry: the
robot goes behind the object opposite the way it must move, arriving facing that way, and
drives on while the object moves along the line; with a tool, the tool is first brought in
contact behind the target, round it if needed, then pushed on into it. It never learns and the
learner never uses it: it only scores the task files the learner is scored on, with the same
metric, budget and contact rule, so that a learner's score can be read against what the
budget allows.

    python scripts/scripted_controller.py --task push-with-tool [--json]
"""

from __future__ import annotations

import argparse
import json
import sys
from dataclasses import dataclass

import numpy as np

from hadim_cli.config import PlannerConfig, WorldConfig
from hadim_cli.evaluation.exact import KinematicMotion
from hadim_cli.evaluation.metric import point_error, task_score
from hadim_cli.evaluation.runner import EvalActuator
from hadim_cli.evaluation.tasks import Task, load_task, load_task_file
from hadim_cli.learner.hierarchy import Hierarchy
from hadim_cli.learner.navigation import Keepout, Navigator, Place
from hadim_cli.learner.spaces import SpaceReader
from hadim_cli.world.world import World

CONTACT = 0.01
"""Gap (m) between the robot and the object it is about to push, at the place behind it."""
ALIGNED = 0.35
"""An object is pushed on while the robot stays within this angle (rad) behind it."""
AVOID = 0.05
"""Gap (m) kept from the target while a tool moves it."""


@dataclass(frozen=True)
class PointOutcome:
    point: tuple[float, float]
    error: float
    actions: int
    robot_path: float
    contact_failed: bool


class Scripted:
    def __init__(self, world: World, task: Task):
        self.world = world
        self.task = task
        self.reader = SpaceReader(world.layout)
        config = PlannerConfig()
        motion = KinematicMotion(world.config, self.reader)
        self.nav = Navigator(Hierarchy(), self.reader, config, motion)

    def pos(self, obs: np.ndarray, e: int) -> np.ndarray:
        return self.reader.entity_position(obs, e)

    def radius(self, obs: np.ndarray, e: int) -> float:
        return self.reader.entity_radius(obs, e)

    def push_action(self, obs: np.ndarray, pushed: int, goal: np.ndarray, avoid: int
                    ) -> np.ndarray | None:
        """One action that pushes `pushed` towards `goal` (going behind it first)."""
        p = self.pos(obs, pushed)
        way = goal - p
        dist = float(np.linalg.norm(way))
        if dist < 1e-3:
            return None
        v = way / dist
        contact = self.radius(obs, pushed) + self.radius(obs, 0)
        behind = p - v * (contact + CONTACT)
        robot = self.pos(obs, 0)
        rel = p - robot
        angle = np.arccos(np.clip(rel @ v / max(np.linalg.norm(rel), 1e-9), -1, 1))
        keep = []
        if avoid >= 0:
            c = self.radius(obs, 0) + self.radius(obs, avoid)
            keep.append(Keepout(avoid, c + AVOID, c + 0.02))
        touching = np.linalg.norm(rel) <= contact + 0.03
        if touching and angle <= ALIGNED:
            # Push on: drive to where the robot will be when the object is at the goal.
            return self.nav.choose(obs, Place(goal - v * contact, None, 0.0), keep)
        # Go behind it: round it when the straight way passes through it.
        keep.append(Keepout(pushed, contact + CONTACT - 0.005, contact, 0.0))
        waypoints = detour(robot, behind, p, contact + 0.08)
        for w in waypoints[:-1]:
            action = self.nav.choose(obs, Place(w, None, 0.05), keep)
            if action is not None:
                return action
        return self.nav.choose(obs, Place(behind, v, 0.015), keep)

    def action(self, obs: np.ndarray, point: np.ndarray, target: int, tool: int
               ) -> np.ndarray | None:
        if tool < 0:
            return self.push_action(obs, target, point, -1)
        t, o = self.pos(obs, target), self.pos(obs, tool)
        u = (point - t) / max(float(np.linalg.norm(point - t)), 1e-9)
        contact = self.radius(obs, target) + self.radius(obs, tool)
        rel = t - o
        off = np.arccos(np.clip(rel @ u / max(np.linalg.norm(rel), 1e-9), -1, 1))
        if np.linalg.norm(rel) <= contact + 0.03 and off <= 0.2:
            # The tool is behind the target: push the tool on along the line.
            return self.push_action(obs, tool, o + u * 0.3, target)
        place = t - u * (contact + 0.01)
        waypoints = detour(o, place, t, contact + 0.1)
        return self.push_action(obs, tool, waypoints[0], target)

    def solve(self, point: tuple[float, float]) -> PointOutcome:
        task, world = self.task, self.world
        obs = world.reset(scene=task.scene)
        names = world.layout.entities
        target = names.index(task.target) if task.target else -1
        tool = names.index(task.tool) if task.tool else -1
        entity = 0 if task.entity == "robot" else target
        start = self.pos(obs, entity).copy()
        act = EvalActuator(world, obs, task.budget, task.target if task.tool else None)
        goal = np.asarray(point, dtype=float)
        initial = float(np.linalg.norm(goal - start))
        while not act.exhausted:
            if np.linalg.norm(goal - self.pos(act.obs, entity)) <= 0.03 * initial:
                break
            if entity == 0:
                action = self.nav.choose(act.obs, Place(goal, None, 0.03 * initial), [])
            else:
                action = self.action(act.obs, goal, target, tool)
            if action is None:
                break
            act.act(action)
        final = self.pos(act.obs, entity)
        error = 1.0 if act.touched else point_error(start, final, point)
        return PointOutcome(tuple(point), float(error), act.used, act.path, act.touched)


def detour(start: np.ndarray, goal: np.ndarray, centre: np.ndarray, radius: float
           ) -> list[np.ndarray]:
    """Points round the disc (`centre`, `radius`) when the segment start → goal crosses it."""
    seg = goal - start
    length2 = float(seg @ seg)
    if length2 < 1e-12:
        return [goal]
    s = float(np.clip((centre - start) @ seg / length2, 0.0, 1.0))
    if np.linalg.norm(start + s * seg - centre) >= radius or s >= 0.95:
        return [goal]
    a0 = np.arctan2(*(start - centre)[::-1])
    a1 = np.arctan2(*(goal - centre)[::-1])
    turn = (a1 - a0 + np.pi) % (2 * np.pi) - np.pi
    pts = [centre + radius * np.array([np.cos(a0 + f * turn), np.sin(a0 + f * turn)])
           for f in (1 / 3, 2 / 3)]
    return [*pts, goal]


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--task", help="a task of configs/tasks/ (default: all three)")
    parser.add_argument("--points", help="a task file of your own")
    parser.add_argument("--json", action="store_true", help="print JSON")
    args = parser.parse_args(argv)
    if args.points:
        tasks = [load_task_file(args.points)]
    else:
        names = [args.task] if args.task else ["move-robot", "push-object", "push-with-tool"]
        tasks = [load_task(n) for n in names]
    out = []
    for task in tasks:
        controller = Scripted(World(WorldConfig()), task)
        points = [controller.solve(p) for p in task.points]
        out.append({"task": task.name, "score": task_score([p.error for p in points]),
                    "points": [p.__dict__ for p in points]})
    if args.json:
        print(json.dumps(out, indent=2))
    else:
        for t in out:
            acts = [p["actions"] for p in t["points"]]
            print(f"{t['task']}: {t['score']:.3f}  actions per point {acts}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
