"""Reaching a place of the robot through its learned motion: the lowest level of the chain.

The robot's own affordances (`action → robot.position`, `action → robot.heading`) are forward
models of one primitive action. To reach a place — a position, and for a push the way it must
then face — the navigator scores a grid of wheel commands with those models from the current
observation and takes the one whose predicted pose has the least *estimated actions to go*:
turning to face the way, driving, and (for a place with a heading) a last straight stretch
along it. The speeds in that estimate are read off the same predictions (the longest predicted
move and turn of one action), so nothing of the robot's kinematics is given. A command the
models predict would bring the robot closer to an entity it must keep clear of is never
chosen; moving away from one always may be, which is how a robot wedged beside an object gets
out. Either way along a heading counts: the learned motion shows the robot drives backwards as
well as forwards, and a disc pushes with its back as well as with its front.

A trip to the place a push is made from (`planner.route_search`) is instead planned as a
sequence of those commands round the objects (`Navigator.route`, `routes.search`), and
replanned after every action; a push's sub-goals are still reached one action at a time.

The navigator draws no random numbers and changes nothing in the learner.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol

import numpy as np

from hadim_cli.config import PlannerConfig
from hadim_cli.learner.affordance import Affordance
from hadim_cli.learner.hierarchy import Hierarchy
from hadim_cli.learner.routes import Motion as BodyMotion
from hadim_cli.learner.routes import Obstacles, cross, search, unit
from hadim_cli.learner.spaces import ACTION, Property, Role, RoleSpace, SpaceReader

ROBOT_POSITION = RoleSpace(Role.ROBOT, Property.POSITION)
ROBOT_HEADING = RoleSpace(Role.ROBOT, Property.HEADING)
STALL_ACTIONS = 3
"""Actions a place is pursued without getting closer than ever before it is given up."""
_KEPT_PREDICTIONS = 8
"""Predictions the navigator keeps for observations it may be asked about again."""


@dataclass(frozen=True)
class Place:
    """Where the robot should be: a position and, optionally, a heading (a unit vector; either
    way along it counts) with the tolerances that count as there."""

    position: np.ndarray
    heading: np.ndarray | None = None
    tolerance: float = 0.03
    """Distance (m) within which the position is reached."""


@dataclass(frozen=True)
class Keepout:
    """An entity the robot keeps `clearance` (m, between centres) from. Within the clearance
    it may still go round the entity, never closer than `floor` and never more than
    `slack` (m) closer per action."""

    entity: int
    clearance: float
    floor: float = 0.0
    slack: float = 0.01


@dataclass(frozen=True)
class Prediction:
    """Predicted outcomes of every candidate command from one observation."""

    commands: np.ndarray
    """(N, 2) wheel commands."""
    half: np.ndarray
    """(N, 2) robot positions half-way through each command."""
    end: np.ndarray
    """(N, 2) robot positions after each command."""
    heading: np.ndarray
    """(N, 2) unit headings after each command."""
    speed: float
    """Longest predicted move of one command (m)."""
    turn: float
    """Largest predicted turn of one command (rad)."""


def command_grid(n: int) -> np.ndarray:
    """The n × n wheel commands over [-1, 1]², denser near zero (fine moves close to a
    place), without standing still."""
    axis = np.linspace(-1.0, 1.0, n)
    axis = np.sign(axis) * np.abs(axis) ** 1.5
    grid = np.stack(np.meshgrid(axis, axis, indexing="ij"), axis=-1).reshape(-1, 2)
    return grid[np.linalg.norm(grid, axis=1) > 1e-9]


def line_angle(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Angle (rad, 0..π/2) between the lines along unit vectors `a` and `b` (row-wise); 0 where
    either is null."""
    cos = np.abs(np.sum(a * b, axis=-1))
    return np.arccos(np.clip(cos, 0.0, 1.0))


class Motion(Protocol):
    """Predicts, for each wheel command, the robot's displacement and heading after it."""

    def __call__(self, obs: np.ndarray, commands: np.ndarray
                 ) -> tuple[np.ndarray, np.ndarray]: ...


class Navigator:
    """Chooses primitive actions that bring the robot to a `Place` (see the module doc).

    `motion`: predictions to use instead of the learned models — only for evaluation, to
    measure what the learned motion costs (`evaluation.exact`)."""

    def __init__(self, hierarchy: Hierarchy, reader: SpaceReader, config: PlannerConfig,
                 motion: Motion | None = None):
        self.h = hierarchy
        self.reader = reader
        self.config = config
        self.commands = command_grid(config.navigation_grid)
        axis = np.unique(self.commands)
        coarse = axis[::2]
        self._coarse = np.flatnonzero(np.isin(self.commands, coarse).all(axis=1))
        """The commands a trip search tries after its first action: every other value of
        each wheel's (`routes.search`)."""
        self.motion = motion
        self._predictions: dict[tuple, tuple[tuple, Prediction]] = {}
        """Recent predictions by (observation, target, tool), each with the motion models it
        came from: the planner often asks again from the same observation (a place given
        up, the next one tried), and the models do not change between two of the learner's
        adds (never during an evaluation)."""
        self._pursuits: dict[tuple, list[float]] = {}
        """Per place pursued lately: [fewest actions to go seen, actions since]."""

    def forget(self) -> None:
        """Drop the memory of places pursued (each goal attempt starts afresh, so that an
        evaluation can never change what training does next)."""
        self._pursuits.clear()

    def movers(self) -> tuple[Affordance | None, Affordance | None]:
        """The most competent `action → robot.position` and `action → robot.heading`."""
        def best(space: RoleSpace) -> Affordance | None:
            found = [a for a in self.h.with_output(space) if a.input is ACTION and a.model.n >= 2]
            return max(found, key=lambda a: a.competence, default=None)
        return best(ROBOT_POSITION), best(ROBOT_HEADING)

    def available(self) -> bool:
        return self.motion is not None or self.movers()[0] is not None

    def _context(self, aff: Affordance, obs: np.ndarray, target: int, tool: int) -> np.ndarray:
        if not aff.contexts:
            return np.zeros(0)
        return np.concatenate([self.reader.value_now(c, obs, target, tool)
                               for c in aff.contexts])

    def predict(self, obs: np.ndarray, target: int = -1, tool: int = -1) -> Prediction | None:
        """Every candidate command's predicted pose, from the learned forward models."""
        if self.motion is not None:
            shift, after = self.motion(obs, self.commands)
            return self._prediction(self.reader.entity_position(obs, 0),
                                    self.reader.value_now(ROBOT_HEADING, obs), shift, after)
        mover, turner = self.movers()
        if mover is None:
            return None
        key = (obs.tobytes(), target, tool)
        models = tuple((a.model, a.model.n, a.contexts) if a is not None else None
                       for a in (mover, turner))
        known = self._predictions.get(key)
        if known is not None and known[0] == models:
            return known[1]
        pred = self._predict(obs, target, tool, mover, turner)
        if len(self._predictions) >= _KEPT_PREDICTIONS:
            self._predictions.pop(next(iter(self._predictions)))
        self._predictions[key] = (models, pred)
        return pred

    def _predict(self, obs: np.ndarray, target: int, tool: int, mover: Affordance,
                 turner: Affordance | None) -> Prediction:
        shift, after = self._motions(obs[None], target, tool, mover, turner)
        return self._prediction(self.reader.entity_position(obs, 0),
                                self.reader.value_now(ROBOT_HEADING, obs), shift[0], after[0])

    def motions(self, obs: np.ndarray, target: int = -1, tool: int = -1
                ) -> tuple[np.ndarray, np.ndarray] | None:
        """Every candidate command's predicted displacement and heading after it (each
        (B, N, 2)) from each of the observations `obs` (B, D) — poses the planner imagines
        as well as the one observed (None: no motion model yet)."""
        if self.motion is not None:
            out = [self.motion(o, self.commands) for o in obs]
            return np.stack([s for s, _ in out]), np.stack([a for _, a in out])
        mover, turner = self.movers()
        if mover is None:
            return None
        return self._motions(obs, target, tool, mover, turner)

    def _motions(self, obs: np.ndarray, target: int, tool: int, mover: Affordance,
                 turner: Affordance | None) -> tuple[np.ndarray, np.ndarray]:
        b, n = obs.shape[0], self.commands.shape[0]
        heading = np.repeat(self.reader.read_each((ROBOT_HEADING,), obs), n, 0)
        commands = np.tile(self.commands, (b, 1))
        c = self._contexts(mover, obs, target, tool, n)
        shift = mover.model.predict(commands, c)
        if turner is not None:
            turned = turner.model.predict(commands, self._contexts(turner, obs, target, tool, n))
            after = unit(heading + turned)
            still = np.linalg.norm(after, axis=1) < 1e-9
            after[still] = heading[still]
        else:
            # No heading model yet: the robot is taken to face the way it moved.
            after = np.where(np.linalg.norm(shift, axis=1, keepdims=True) > 1e-6, unit(shift),
                             heading)
        return shift.reshape(b, n, 2), after.reshape(b, n, 2)

    def _contexts(self, aff: Affordance, obs: np.ndarray, target: int, tool: int,
                  n: int) -> np.ndarray | None:
        """`aff`'s context in each observation of `obs`, each repeated for `n` commands."""
        if not aff.contexts:
            return None
        return np.repeat(self.reader.read_each(aff.contexts, obs, target, tool), n, 0)

    def _prediction(self, position: np.ndarray, heading: np.ndarray, shift: np.ndarray,
                    after: np.ndarray) -> Prediction:
        turn = float(np.max(np.arccos(np.clip(after @ heading, -1.0, 1.0))))
        speed = float(np.max(np.linalg.norm(shift, axis=1)))
        return Prediction(self.commands, position + 0.5 * shift, position + shift, after,
                          max(speed, 1e-3), max(turn, 1e-2))

    def actions_to_go(self, position: np.ndarray, heading: np.ndarray, place: Place,
                      speed: float, turn: float, obstacles: Obstacles | None = None
                      ) -> np.ndarray:
        """Estimated primitive actions from poses (position, heading), each (N, 2), to `place`:
        turn to face the way, drive, and with a heading, the last `approach_distance` straight
        along it (the cheaper of going there first or heading straight for the place). A pose
        within the place's tolerance only turns to its heading. With `obstacles`, each leg goes
        round the discs in its way (`Obstacles.leg`)."""
        position, heading = np.atleast_2d(position), np.atleast_2d(heading)

        def leg(frm: np.ndarray, to: np.ndarray, facing: np.ndarray
                ) -> tuple[np.ndarray, np.ndarray]:
            if obstacles is not None:
                return obstacles.leg(frm, to[0], facing, speed, turn)
            way = to - frm
            dist = np.linalg.norm(way, axis=1)
            direction = unit(way)
            cost = dist / speed + line_angle(facing, direction) / turn
            arrive = np.where(dist[:, None] > 1e-6, direction, facing)
            return cost, arrive

        direct, arrive = leg(position, place.position[None], heading)
        # Within the place's tolerance the position is reached: what is left is the heading
        # (a pose 2 cm off, charged a turn to face that 2 cm and back, never turned on).
        apart = np.linalg.norm(position - place.position, axis=1)
        inside = apart <= place.tolerance
        # With `precise_places`, nearer is still better there (a push's steering is finer
        # than its sub-goal's tolerance).
        direct = np.where(inside, apart / speed if self.config.precise_places else 0.0, direct)
        arrive = np.where(inside[:, None], heading, arrive)
        if place.heading is None:
            return direct
        want = np.broadcast_to(place.heading, position.shape)
        best = direct + line_angle(arrive, want) / turn
        # The last stretch is driven along the heading, from behind the place; with
        # obstacles, from either side of it that lies outside them (from behind a place
        # next to an object, the stretch would start within the object).
        sides = (-1.0,) if obstacles is None else (-1.0, 1.0)
        for side in sides:
            start = place.position + side * self.config.approach_distance * place.heading
            if obstacles is not None and obstacles.holds(start):
                continue
            to_start, arrive = leg(position, start[None], heading)
            best = np.minimum(best, to_start + line_angle(arrive, want) / turn
                              + self.config.approach_distance / speed)
        return best

    def reached(self, obs: np.ndarray, place: Place) -> bool:
        position = self.reader.entity_position(obs, 0)
        if np.linalg.norm(place.position - position) > place.tolerance:
            return False
        if place.heading is None:
            return True
        heading = self.reader.value_now(ROBOT_HEADING, obs)
        return float(line_angle(heading[None], place.heading[None])[0]) \
            <= self.config.heading_tolerance

    def allowed(self, obs: np.ndarray, pred: Prediction, keepouts: list[Keepout]) -> np.ndarray:
        """Mask of the commands that, half-way or at the end, keep the robot out of every
        keep-out entity's clearance, or within it neither below its floor nor more than its
        slack closer (going round it); moving away is always allowed."""
        return self.allowed_many(obs[None], pred.half[None], pred.end[None], keepouts)[0]

    def allowed_many(self, obs: np.ndarray, half: np.ndarray, end: np.ndarray,
                     keepouts: list[Keepout]) -> np.ndarray:
        """`allowed` from each of the observations `obs` (B, D), for the robot positions
        half-way through and after each command, `half` and `end` (B, N, 2): a (B, N) mask."""
        ok = np.ones(end.shape[:2], dtype=bool)
        robot = self.reader.entity_position(obs, 0)[:, None]
        for k in keepouts:
            centre = self.reader.entity_position(obs, k.entity)[:, None]
            now = np.linalg.norm(robot - centre, axis=-1)
            for pts in (half, end):
                d = np.linalg.norm(pts - centre, axis=-1)
                closer = d < now - 1e-4
                ok &= ~((d < k.clearance) & closer & ((d < k.floor) | (d < now - k.slack)))
        return ok

    def choose(self, obs: np.ndarray, place: Place, keepouts: list[Keepout],
               target: int = -1, tool: int = -1) -> np.ndarray | None:
        """The command that most reduces the estimated actions to `place` (None: there, no
        command allowed, or none predicted to get closer)."""
        if self.reached(obs, place):
            return None
        pred = self.predict(obs, target, tool)
        if pred is None:
            return None
        ok = self.allowed(obs, pred, keepouts)
        if not ok.any():
            return None
        here = self.actions_to_go(self.reader.entity_position(obs, 0),
                                  self.reader.value_now(ROBOT_HEADING, obs), place,
                                  pred.speed, pred.turn)[0]
        cost = self.actions_to_go(pred.end, pred.heading, place, pred.speed, pred.turn)
        cost = np.where(ok, cost, np.inf)
        best = int(np.argmin(cost))
        # One action must buy a fair share of the way left, else the models see no way
        # forward from here (a wall, a corner) and the caller replans.
        if not cost[best] < here - min(0.25, 0.5 * here):
            return None
        if self._stalled(place, here):
            return None
        return pred.commands[best].copy()

    def route(self, obs: np.ndarray, place: Place, obstacles: Obstacles, target: int = -1,
              tool: int = -1) -> np.ndarray | None:
        """The first command of the best sequence of commands to `place` that keeps out of
        the `obstacles` (`routes.search`, `route_depth` deep): a trip planned whole, replanned
        after every action. None: there, no command allowed, or the pursuit stalled."""
        if self.reached(obs, place):
            return None
        pred = self.predict(obs, target, tool)
        if pred is None:
            return None
        position = self.reader.entity_position(obs, 0)
        heading = self.reader.value_now(ROBOT_HEADING, obs)
        obstacles = obstacles.within(position, place.position,
                                     self.config.route_depth * pred.speed)

        def to_go(p: np.ndarray, h: np.ndarray) -> np.ndarray:
            return self.actions_to_go(p, h, place, pred.speed, pred.turn, obstacles)

        def reached(p: np.ndarray, h: np.ndarray) -> np.ndarray:
            there = np.linalg.norm(p - place.position, axis=1) <= place.tolerance
            if place.heading is None:
                return there
            return there & (line_angle(h, place.heading[None]) <= self.config.heading_tolerance)

        first = search(position, heading, self._body(pred, position, heading), obstacles,
                       to_go, reached, self.config.route_depth, self.config.route_beam,
                       later=self._coarse)
        if first is None:
            return None
        if self._stalled(place, float(to_go(position[None], heading[None])[0])):
            return None
        return pred.commands[first].copy()

    @staticmethod
    def _body(pred: Prediction, position: np.ndarray, heading: np.ndarray) -> BodyMotion:
        """The predicted motion of every command, in the robot's frame."""
        back = -float(np.arctan2(heading[1], heading[0]))
        c, s = np.cos(back), np.sin(back)
        to_body = np.array([[c, -s], [s, c]])
        turned = np.arctan2(cross(heading, pred.heading), pred.heading @ heading)
        return BodyMotion(pred.commands, (pred.end - position) @ to_body.T,
                          (pred.half - position) @ to_body.T, turned)

    def _stalled(self, place: Place, here: float) -> bool:
        """Whether the pursuit of `place` has gone `STALL_ACTIONS` actions without getting
        closer than it ever was (the predictions promise progress that the actions do not
        bring: a turn back and forth, a push against a wall)."""
        key = (tuple(np.round(place.position, 4)),
               None if place.heading is None else tuple(np.round(place.heading, 3)))
        seen = self._pursuits.get(key)
        if seen is None and self.config.drifting_places:
            seen = self._pursuit_near(place, key)
        if seen is None:
            if len(self._pursuits) >= 16:
                self._pursuits.pop(next(iter(self._pursuits)))
            self._pursuits[key] = [here, 0]
            return False
        if here < seen[0] - 0.05:
            seen[0], seen[1] = here, 0
            return False
        seen[1] += 1
        return seen[1] >= STALL_ACTIONS

    def _pursuit_near(self, place: Place, key: tuple) -> list[float] | None:
        """The pursuit remembered of the place nearest `place` within its tolerance, with the
        same heading within `heading_tolerance` (`drifting_places`), moved to `key`: a place
        behind an object is computed afresh every action and drifts by a centimetre or two
        while the robot goes to and fro short of it. Traced in training: a robot 16 cm from
        its place took one action forward and one back for the 26 last actions of a goal,
        each place a new one to the stall count."""
        found, nearest = None, place.tolerance
        for position, heading in self._pursuits:
            apart = float(np.hypot(position[0] - place.position[0],
                                   position[1] - place.position[1]))
            if apart > nearest or (heading is None) != (place.heading is None):
                continue
            if heading is not None and float(line_angle(np.array(heading)[None],
                                                        place.heading[None])[0]) \
                    > self.config.heading_tolerance:
                continue
            found, nearest = (position, heading), apart
        if found is None:
            return None
        seen = self._pursuits.pop(found)
        self._pursuits[key] = seen
        return seen

    def estimate(self, obs: np.ndarray, place: Place, target: int = -1, tool: int = -1
                 ) -> float:
        """Estimated actions from the current pose to `place` (inf when it cannot move)."""
        pred = self.predict(obs, target, tool)
        if pred is None:
            return float("inf")
        return float(self.actions_to_go(self.reader.entity_position(obs, 0),
                                        self.reader.value_now(ROBOT_HEADING, obs), place,
                                        pred.speed, pred.turn)[0])
