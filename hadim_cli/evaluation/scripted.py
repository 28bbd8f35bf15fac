"""A scripted controller that knows the physics: the upper bound of what a task's budget allows.

It reads the true state (poses, radii), drives with the differential drive's exact kinematics
(`hadim_cli.world.physics.wheel_command`: each command an arc held for the action's duration)
and pushes by geometry, closed loop: every action it recomputes, from the current state,

- where the *pusher* must be for the pushed object to move toward its goal: on the push
  line, behind the object opposite the way it must go (a disc pushes a disc along the
  contact normal);
- the pusher's aim: a point a look-ahead further along that line from where the pusher is
  (pure pursuit of the line), so that while pushing it steers sideways and turns the contact
  normal back onto the goal instead of letting the object slide off;
- or, when the pusher is too far round the object for steering to help, a waypoint on a
  circle round the object that takes it behind (the only "re-placement").

With a tool the same rule is applied twice: the tool is the target's pusher, and the robot is
the tool's, with the tool's aim as the goal of the robot's push; the robot goes round the tool
on the side away from the target and never moves closer than a safe gap to it. It never learns
and the learner never uses it: it scores the task files the learner is scored on, with the
same metric, budget, actuator and contact rule (`evaluation.runner.EvalActuator`), so that a
learner's score can be read against what the budget allows.

    python scripts/scripted_controller.py                       # every rover task of configs/tasks/
    python scripts/scripted_controller.py --task push-with-tool [--json]

`ObservedPusher` lends its push of one object (the robot behind it, steering) to
`evaluation.exact`, which puts it in place of the learner's own pushing level to measure what
that level costs.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from dataclasses import asdict, dataclass

import numpy as np

from hadim_cli.config import Body, WorldConfig
from hadim_cli.evaluation.metric import heading_error, point_error, task_score
from hadim_cli.evaluation.runner import EvalActuator, segment_distance
from hadim_cli.evaluation.tasks import Task, body_tasks, check_body, load_task, load_task_file
from hadim_cli.learner.spaces import ROBOT_HEADING, SpaceReader
from hadim_cli.world.world import World, wrap_angle

LOOKAHEAD = 0.03
"""How far ahead along the push line (m) a pusher aims from its own projection on it: the
steering gain (shorter turns back onto the line faster)."""
STEERING = True
"""Steer onto the push line while pushing (False: aim straight along the push line from
wherever the pusher is; kept as a switch to show, and test, what the steering buys)."""
ALIGNED = math.radians(25)
"""Largest angle between the contact normal and the push direction at which a pusher in
contact pushes on (steering); beyond it, it slides round the object to its back."""
CONTACT_GAP = 0.02
"""Gap (m, between surfaces) within which a pusher counts as touching."""
CONE = math.tan(math.radians(35))
"""A pusher within this cone behind the contact point pursues the push line directly."""
APPROACH = 0.08
"""How far behind the contact point (m) a re-placement ends, on the push line."""
ROUND_STEP = math.radians(50)
"""Largest step (rad) round an object per waypoint."""
ROUND_GAP = 0.05
"""Gap (m, between surfaces) kept while going round an object."""
TARGET_GAP = 0.04
"""Gap (m, between surfaces) the robot keeps from the target in a tool task."""
STRIKE = math.radians(35)
"""Largest angle between the tool–target line and the push line at which the tool pushes
the target on; beyond it the tool is staged again."""
STAGE = 0.02
"""Gap (m, between surfaces) behind the target where the tool is staged before a strike."""
TOOL_STEP = 0.1
"""Largest move (m) asked of the tool per action (the robot's push of it is slowed by the
load, and shorter tool moves keep the chain robot → tool → target aligned)."""
TOLERANCE = 0.005
"""Distance (m) to the goal at which a point is reached."""
CLOSE_ENOUGH = 0.02
"""A point is also reached within this share of its initial distance (its error then is at
most that share): the last millimetres are not worth the risk of a re-placement."""
NOT_WORTH = 0.02
"""A remainder (m) of a goal not worth going round the object for."""
TURN_FIRST = math.radians(60)
"""Bearing of the aim beyond which the robot turns on the spot before driving an arc."""


GRID = [np.array([a, b]) for a in np.linspace(-1, 1, 9) for b in np.linspace(-1, 1, 9)]
"""Commands tried when the pursued arc would bring the robot too close to the target."""


@dataclass(frozen=True)
class PointOutcome:
    point: tuple[float, ...]
    error: float
    actions: int
    robot_path: float
    trips: int
    line_deviation: float
    contact_failed: bool
    robot_only: int
    """Actions that moved no object (`EvalActuator.robot_only`)."""


@dataclass(frozen=True)
class Pose:
    position: np.ndarray
    heading: float


@dataclass(frozen=True)
class Aim:
    """Where a pusher should go next, and whether that is going round (a re-placement)."""

    point: np.ndarray
    placing: bool
    push: float
    """How far (m) the object may be pushed on by the next action."""


def unit(v: np.ndarray) -> np.ndarray:
    n = float(np.linalg.norm(v))
    return v / n if n > 1e-12 else np.zeros(2)


def angle_of(v: np.ndarray) -> float:
    return math.atan2(float(v[1]), float(v[0]))


class Drive:
    """The differential drive's exact kinematics: the command that follows an arc to a point,
    and where a command takes the robot when nothing is in the way."""

    def __init__(self, config: WorldConfig):
        self.c = config
        self.reach = config.max_wheel_speed * config.action_duration
        """Longest straight move of one action (m)."""

    def command(self, v: float, omega: float) -> np.ndarray:
        """Wheel intensities for forward speed `v` (m/s) and turn rate `omega` (rad/s), scaled
        down together (same curvature) when a wheel would exceed full speed."""
        c = self.c
        left = (v - omega * c.wheel_base / 2) / c.max_wheel_speed
        right = (v + omega * c.wheel_base / 2) / c.max_wheel_speed
        scale = max(1.0, abs(left), abs(right))
        return np.array([left / scale, right / scale])

    def turn(self, pose: Pose, heading: float) -> np.ndarray:
        """Turn on the spot toward `heading` (at most a full-speed action's worth)."""
        return self.command(0.0, wrap_angle(heading - pose.heading) / self.c.action_duration)

    def toward(self, pose: Pose, point: np.ndarray, step: float) -> np.ndarray | None:
        """The arc tangent to the heading (forward or backward, whichever faces the point)
        through `point`, at most `step` m of it; a turn on the spot first when the point is
        far off to the side. None: there."""
        rel = point - pose.position
        dist = float(np.linalg.norm(rel))
        if dist < 1e-4:
            return None
        bearing = wrap_angle(angle_of(rel) - pose.heading)
        sign = 1.0
        if abs(bearing) > math.pi / 2:  # a disc drives (and pushes) backwards as well
            sign, bearing = -1.0, wrap_angle(bearing + math.pi)
        if abs(bearing) > TURN_FIRST:
            return self.turn(pose, pose.heading + bearing)
        length = dist if abs(bearing) < 1e-6 else dist * bearing / math.sin(bearing)
        curvature = 2 * math.sin(bearing) / dist
        move = min(length, step, self.reach)
        v = move / self.c.action_duration
        return self.command(sign * v, v * curvature)

    def predict(self, pose: Pose, command: np.ndarray) -> list[np.ndarray]:
        """Positions half-way and at the end of `command`, with nothing in the way."""
        c = self.c
        v = (command[0] + command[1]) / 2 * c.max_wheel_speed
        omega = (command[1] - command[0]) * c.max_wheel_speed / c.wheel_base
        out = []
        for t in (c.action_duration / 2, c.action_duration):
            if abs(omega) < 1e-9:
                shift = v * t * np.array([math.cos(pose.heading), math.sin(pose.heading)])
            else:
                a, b = pose.heading, pose.heading + omega * t
                shift = v / omega * np.array([math.sin(b) - math.sin(a), math.cos(a) - math.cos(b)])
            out.append(pose.position + shift)
        return out


def push_aim(pusher: np.ndarray, obj: np.ndarray, goal: np.ndarray, contact: float,
             step: float, avoid: tuple[np.ndarray, float] | None = None,
             lookahead: float = LOOKAHEAD) -> Aim:
    """Where a pusher at `pusher` should head next to push the object at `obj` toward `goal`
    (`contact`: the distance between their centres when they touch; `step`: the most the
    object should move per action). `avoid`: a disc (centre, distance) the pusher's way round
    must keep out of, when it can."""
    way = goal - obj
    u = unit(way)
    behind = obj - u * contact  # where the pusher touches to push along u
    rel = pusher - obj
    off = abs(wrap_angle(angle_of(rel) - angle_of(-u)))
    s = float((pusher - behind) @ u)  # along the line: < 0 behind the contact point
    lateral = float(np.linalg.norm(pusher - behind - s * u))
    touching = float(np.linalg.norm(rel)) < contact + CONTACT_GAP
    if touching and off <= ALIGNED or not touching and s < 0 and lateral <= -s * CONE:
        # Push less the further the contact normal is off the way: first turn it, then push.
        push = min(step * max(0.25, 1.0 - off / ALIGNED), float(np.linalg.norm(way)))
        return Aim(_pursue(pusher, behind, u, s, push, lookahead), False, push)
    # Re-place: to a point behind on the line, straight when the way is clear, else round.
    start = behind - u * APPROACH
    if segment_distance(obj, pusher, start) >= contact + 0.01:
        return Aim(start, True, 0.0)
    return Aim(round_waypoint(pusher, obj, -u, contact + ROUND_GAP, avoid), True, 0.0)


def _pursue(pusher: np.ndarray, behind: np.ndarray, u: np.ndarray, s: float, push: float,
            lookahead: float) -> np.ndarray:
    """A point ahead on the push line (pure pursuit): it steers the pusher onto the line,
    which turns the contact normal back onto the way."""
    if not STEERING:
        return pusher + u * lookahead  # straight along the way: no lateral correction
    return behind + u * (min(s, 0.0) + max(push, lookahead))


def round_waypoint(pusher: np.ndarray, obj: np.ndarray, back: np.ndarray, radius: float,
                   avoid: tuple[np.ndarray, float] | None) -> np.ndarray:
    """The next point on the circle (`obj`, `radius`) going round toward the side `back`:
    the short way, unless it passes through `avoid` and the long way does not."""
    start = angle_of(pusher - obj)
    turn = wrap_angle(angle_of(back) - start)
    ways = [turn, turn - math.copysign(2 * math.pi, turn)]

    def clearance(total: float) -> float:
        if avoid is None:
            return math.inf
        angles = start + np.linspace(0.0, total, 12)
        pts = obj + radius * np.stack([np.cos(angles), np.sin(angles)], axis=1)
        return float(np.min(np.linalg.norm(pts - avoid[0], axis=1))) - avoid[1]

    if clearance(ways[0]) < 0 and clearance(ways[1]) > clearance(ways[0]):
        turn = ways[1]
    a = start + math.copysign(min(abs(turn), ROUND_STEP), turn)
    return obj + radius * np.array([math.cos(a), math.sin(a)])


class Scripted:
    """Drives one task's points with the true state and the exact kinematics."""

    def __init__(self, world: World, task: Task):
        self.world = world
        self.task = task
        self.reader = SpaceReader(world.layout)
        self.drive = Drive(world.config)
        self.trips = 0
        self._placing: dict[str, bool] = {}

    def pos(self, obs: np.ndarray, e: int) -> np.ndarray:
        return self.reader.entity_position(obs, e).copy()

    def radius(self, obs: np.ndarray, e: int) -> float:
        return self.reader.entity_radius(obs, e)

    def pose(self, obs: np.ndarray | None = None) -> Pose:
        """The robot's pose: the world's own (`obs` is read by `ObservedPusher`)."""
        x, y, heading = self.world.robot_pose()
        return Pose(np.array([x, y]), heading)

    def _count(self, level: str, aim: Aim) -> None:
        """A trip: a level starts placing its pusher (at the start, or after pushing)."""
        if aim.placing and not self._placing.get(level, False):
            self.trips += 1
        self._placing[level] = aim.placing

    def push(self, obs: np.ndarray, obj: int, goal: np.ndarray, step: float, avoid: int
             ) -> np.ndarray | None:
        """One action of the robot pushing `obj` toward `goal`, never closer than
        `TARGET_GAP` to the entity `avoid` (-1: none)."""
        robot, p = self.pos(obs, 0), self.pos(obs, obj)
        contact = self.radius(obs, obj) + self.radius(obs, 0)
        keep = None
        if avoid >= 0:
            keep = (self.pos(obs, avoid), self.radius(obs, avoid) + self.radius(obs, 0)
                    + TARGET_GAP + ROUND_GAP)
        aim = push_aim(robot, p, goal, contact, step, keep)
        self._count("robot", aim)
        pose = self.pose(obs)
        # Pushing, the aim is no further than the push wanted: the robot slows into contact.
        move = self.drive.reach if aim.placing else float(np.linalg.norm(aim.point - robot))
        command = self.drive.toward(pose, aim.point, move)
        if command is None:
            return None
        if avoid >= 0 and not self._safe(pose, command, obs, avoid):
            command = self._safe_toward(pose, aim.point, obs, avoid)
        return command

    def _safe_toward(self, pose: Pose, point: np.ndarray, obs: np.ndarray, avoid: int
                     ) -> np.ndarray:
        """Of a grid of commands, the safe one that ends nearest `point` (a turn on the spot,
        always safe, when none is)."""
        safe = [c for c in GRID if self._safe(pose, c, obs, avoid)]
        if not safe:
            return self.drive.turn(pose, angle_of(point - pose.position))
        return min(safe, key=lambda c: float(np.linalg.norm(self.drive.predict(pose, c)[1]
                                                             - point)))

    def _safe(self, pose: Pose, command: np.ndarray, obs: np.ndarray, avoid: int) -> bool:
        """The command keeps the robot `TARGET_GAP` clear of `avoid` (or moves it away)."""
        centre = self.pos(obs, avoid)
        limit = self.radius(obs, avoid) + self.radius(obs, 0) + TARGET_GAP
        now = float(np.linalg.norm(pose.position - centre))
        return all(float(np.linalg.norm(q - centre)) >= min(limit, now)
                   for q in self.drive.predict(pose, command))

    def tool_goal(self, obs: np.ndarray, goal: np.ndarray, target: int, tool: int
                  ) -> tuple[np.ndarray, bool]:
        """Where the tool should go next for the target to reach `goal`, and whether that is a
        strike. While the tool lies behind the target (within `STRIKE` of the push line,
        close): where it will be when the target is at `goal` (a strike: tool and target go
        on together); otherwise its staging place `STAGE` behind the target on the push line,
        round the target when the straight way passes through it. The way there is turned so
        that the robot's place behind the tool keeps `TARGET_GAP` clear of the target."""
        t, k = self.pos(obs, target), self.pos(obs, tool)
        contact = self.radius(obs, target) + self.radius(obs, tool)
        u = unit(goal - t)
        off = abs(wrap_angle(angle_of(k - t) - angle_of(-u)))
        striking = off <= STRIKE and np.linalg.norm(k - t) <= contact + STAGE + 0.04
        if striking:
            wanted = goal - u * contact
        else:
            wanted = t - u * (contact + STAGE)
            if segment_distance(t, k, wanted) < contact + 0.02:
                wanted = round_waypoint(k, t, -u, contact + STAGE, None)
        way = wanted - k
        return k + self._pushable_way(obs, k, unit(way), t, tool, target) \
            * float(np.linalg.norm(way)), striking

    def with_tool(self, obs: np.ndarray, goal: np.ndarray, target: int, tool: int
                  ) -> np.ndarray | None:
        """One action moving the target toward `goal` through the tool: the robot pushes the
        tool toward its `tool_goal`, steering, never closer than `TARGET_GAP` to the
        target."""
        wanted, striking = self.tool_goal(obs, goal, target, tool)
        self._count("tool", Aim(self.pos(obs, tool), not striking, 0.0))
        return self.push(obs, tool, wanted, TOOL_STEP, target)

    def _pushable_way(self, obs: np.ndarray, k: np.ndarray, way: np.ndarray, t: np.ndarray,
                      tool: int, target: int) -> np.ndarray:
        """`way` turned (the least) until the robot's place behind the tool to push it that
        way keeps `TARGET_GAP` clear of the target."""
        contact = self.radius(obs, tool) + self.radius(obs, 0)
        limit = self.radius(obs, target) + self.radius(obs, 0) + TARGET_GAP
        base = angle_of(way)
        for turn in np.radians(np.arange(0, 181, 10)):
            for a in (base + turn, base - turn):
                d = np.array([math.cos(a), math.sin(a)])
                if np.linalg.norm(k - d * contact - t) >= limit:
                    return d
        return way

    def action(self, obs: np.ndarray, goal: np.ndarray, target: int, tool: int
               ) -> np.ndarray | None:
        if target < 0:
            return self.drive.toward(self.pose(), goal, self.drive.reach)
        if tool >= 0:
            return self.with_tool(obs, goal, target, tool)
        return self.push(obs, target, goal, self.drive.reach, -1)

    def solve(self, index: int) -> PointOutcome:
        task, world = self.task, self.world
        point = task.points[index]
        obs = world.reset(scene=task.scene)
        names = world.layout.entities
        target = names.index(task.target) if task.target else -1
        tool = names.index(task.tool) if task.tool else -1
        entity = 0 if task.entity == "robot" else target
        start = self.pos(obs, entity)
        start_heading = world.robot_pose()[2]
        act = EvalActuator(world, obs, task.budget, task.target if task.tool else None)
        goal = np.asarray(point, dtype=float)
        act.follow(entity, start, goal)
        self.trips, self._placing = 0, {}
        initial = float(np.linalg.norm(goal - start))
        while not act.exhausted:
            left = float(np.linalg.norm(goal - self.pos(act.obs, entity)))
            if left <= max(TOLERANCE, CLOSE_ENOUGH * initial * (entity != 0)):
                break
            action = self.action(act.obs, goal, target, tool)
            if action is None or (left < NOT_WORTH and self._placing.get("tool" if tool >= 0
                                                                          else "robot")):
                break
            act.act(action)
        final = self.pos(act.obs, entity)
        error = 1.0 if act.touched else point_error(start, final, point)
        if task.headings is not None:
            want = task.headings[index]
            while not act.exhausted and abs(wrap_angle(want - world.robot_pose()[2])) > 1e-3:
                act.act(self.drive.turn(self.pose(), want))
            error = (error + heading_error(start_heading, world.robot_pose()[2], want)) / 2
        return PointOutcome(tuple(float(v) for v in point), float(error), act.used, act.path,
                            self.trips, act.deviation, act.touched, act.robot_only)


class ObservedPusher(Scripted):
    """`Scripted`'s push of one object, reading the robot's pose from the observation (not
    from a world): for `evaluation.exact`, in place of a level of the learner's chain."""

    def __init__(self, config: WorldConfig, reader: SpaceReader):
        self.reader = reader
        self.drive = Drive(config)
        self.trips = 0
        self._placing = {}

    def pose(self, obs: np.ndarray | None = None) -> Pose:
        assert obs is not None
        h = self.reader.value_now(ROBOT_HEADING, obs)
        return Pose(self.pos(obs, 0), math.atan2(float(h[1]), float(h[0])))


def run_task(task: Task, config: WorldConfig | None = None) -> tuple[float, list[PointOutcome]]:
    """The task's score and each point's outcome (the rover's tasks: it drives wheels)."""
    config = config or WorldConfig()
    check_body(task, config)
    controller = Scripted(World(config), task)
    points = [controller.solve(i) for i in range(len(task.points))]
    return task_score([p.error for p in points]), points


def _summary(name: str, score: float, points: list[PointOutcome]) -> str:
    acts = [p.actions for p in points]
    paths = [p.robot_path for p in points]
    trips = [p.trips for p in points]
    touched = sum(p.contact_failed for p in points)
    return (f"{name}: {score:.3f}  actions {min(acts)}-{max(acts)} (mean {np.mean(acts):.1f})"
            f"  robot path {np.mean(paths):.2f} m  trips {np.mean(trips):.1f}"
            f"  robot-only {100 * sum(p.robot_only for p in points) / max(sum(acts), 1):.0f} %"
            f"  line deviation {max(p.line_deviation for p in points):.3f} m"
            + (f"  contact failures {touched}" if touched else ""))


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--task", help="a task of configs/tasks/ (default: every rover task)")
    parser.add_argument("--points", help="a task file of your own")
    parser.add_argument("--json", action="store_true", help="print JSON")
    args = parser.parse_args(argv)
    if args.points:
        tasks = [load_task_file(args.points)]
    else:
        tasks = [load_task(n) for n in ([args.task] if args.task else body_tasks(Body.ROVER))]
    out = []
    for task in tasks:
        score, points = run_task(task)
        out.append((task.name, score, points))
    if args.json:
        print(json.dumps([{"task": n, "score": s, "points": [asdict(p) for p in pts]}
                          for n, s, pts in out], indent=2))
    else:
        for n, s, pts in out:
            print(_summary(n, s, pts))
    return 0


if __name__ == "__main__":
    sys.exit(main())
