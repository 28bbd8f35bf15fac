"""Planning: reach a goal in an affordance's output space by chaining learned affordances.

`Planner.reach` replans after every executed step: it cuts the remaining distance into a
sub-goal no larger than the affordance's typical step, asks the inverse model for the input
that produces it in the current context and executes that input — directly when it is a
primitive action, else recursively through the affordance that controls the input's space
(paper §4.3). When the inverse model cannot produce the sub-goal from the current context but
could from another one, and that context is controllable (e.g. the robot's position relative to
the object), the planner first reaches that context (moving behind an object before pushing
it), going round the object when the straight path would hit it. The planner draws no random
numbers: evaluation can use it without touching the learner's generators.
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass
from typing import Protocol

import numpy as np

from hadim_cli.config import LearnerConfig, PlannerConfig
from hadim_cli.learner.affordance import (
    CONTACT_MARGIN,
    Affordance,
    per_model_rows,
    typical_step,
)
from hadim_cli.learner.competence import split_zero
from hadim_cli.learner.frames import is_vector, seen_where, turns_with_scene
from hadim_cli.learner.goals import Actuator, Attempt, Binding
from hadim_cli.learner.hierarchy import Hierarchy
from hadim_cli.learner.navigation import (
    ROBOT_HEADING,
    ROBOT_POSITION,
    Keepout,
    Navigator,
    Place,
    line_angle,
)
from hadim_cli.learner.routes import Obstacles
from hadim_cli.learner.spaces import ACTION, Property, Role, RoleSpace, SpaceReader
from hadim_cli.world.layout import ROBOT

LINE_STEP = 0.025
"""Resolution (m) of `line_stagings`' search along the push's line."""
LINE_REACH = 0.8
"""How far back (m) on the push's line `line_stagings` looks for a point to stage from."""
WALL_GAP = 0.02
"""Room (m) `line_stagings` leaves between a wall and the object or its pusher."""
IDLE_CHANGE = 1e-4
"""An action moved nothing when no value of the observation changed by more than this."""
STRAIGHT_LENGTHS = np.array([0.25, 0.375, 0.5, 0.625, 0.75, 0.875, 1.0, 1.25, 1.5, 2.0])
"""`convoy`'s lengths of a straight move, in units of the larger of the inverse model's
answer and the outcome wanted (`Planner.straight_move`)."""
DRIFT_POWER = 4
"""`convoy_plan`'s cost of a relation's predicted drift, `convoy_drift_cost` × (gap /
`realign`)^4: next to nothing while the relation is well within `realign`, the full cost as
it reaches it."""
CONVOY_PURSUIT = "convoy through the chain"
"""The pursuit of a convoy's action chosen through the chain (`Planner._convoy_plan`)."""
MIN_PROGRESS = 0.2
"""`convoy_plan` takes only commands predicted to bring the target this share of a step
nearer its goal."""


@dataclass(frozen=True)
class Pursuit:
    """One level of what the planner pursues: an affordance (or the navigator) and its goal."""

    label: str
    goal: np.ndarray
    binding: Binding
    places: int = -1
    """The affordance whose context this pursuit places (a trip; -1: not a placement)."""


def _normalise_heading(space: RoleSpace, value: np.ndarray) -> np.ndarray:
    if space.prop is Property.HEADING:
        n = np.linalg.norm(value)
        return value / n if n > 1e-9 else np.array([1.0, 0.0])
    return value


def _slices(aff: Affordance) -> Iterator[tuple[int, slice]]:
    """(index, columns) of each context space of `aff` in its context vectors."""
    offset = 0
    for i, dim in enumerate(aff.model.context_dims):
        yield i, slice(offset, offset + dim)
        offset += dim


def _relation_slice(aff: Affordance) -> tuple[int, slice] | None:
    """(index, columns) of `aff`'s context relating its output to its input (the target's
    relation to the tool for the tool affordance, the pushed object's to the robot for a push),
    None if it has none."""
    return next(((i, sl) for i, sl in _slices(aff)
                 if aff.contexts[i].role is aff.output.role
                 and aff.contexts[i].relative_to is aff.input.role), None)


def _context_part(aff: Affordance, c: np.ndarray, space: RoleSpace) -> np.ndarray | None:
    """The columns of the context vector `c` of `aff` that hold `space` (None: not a context
    of `aff`)."""
    for i, sl in _slices(aff):
        if aff.contexts[i] == space:
            return c[sl]
    return None


def _at_length(v: np.ndarray, length: float) -> np.ndarray:
    """The vector `v` (not null) scaled to `length`, on its own bearing."""
    return v * (length / float(np.linalg.norm(v)))


def _at_own_lengths(aff: Affordance, c: np.ndarray, v: np.ndarray, relations: np.ndarray,
                    further: bool) -> np.ndarray:
    """`v` with each relation of `relations` that the context `c` holds nearer than `v` does
    (or, `further`, further) brought to `c`'s length on `v`'s own bearing."""
    out = v.copy()
    for i, sl in _slices(aff):
        now, want = float(np.linalg.norm(c[sl])), float(np.linalg.norm(v[sl]))
        if relations[i] and (now > want if further else now < want):
            out[sl] = _at_length(v[sl], now)
    return out


def _unit_heading(h: np.ndarray | None) -> np.ndarray | None:
    """`h` scaled to unit length (None when absent or null)."""
    if h is None:
        return None
    n = float(np.linalg.norm(h))
    return h / n if n > 1e-9 else None


class Pusher(Protocol):
    """Pushes `entity` to `goal` with the robot, never touching `avoid` (-1: none), within
    `budget` actions; returns the actions used (-1: none)."""

    def __call__(self, entity: int, goal: np.ndarray, avoid: int, actuator: Actuator,
                 budget: int) -> int: ...


class ToolGuide(Protocol):
    """The move of the tool (bound by `b`) that brings the target toward `goal`."""

    def __call__(self, obs: np.ndarray, goal: np.ndarray, b: Binding) -> np.ndarray: ...


class Planner:
    """Turns goals of affordances into primitive actions (paper §4.3, 'TransformToPrimitive')."""

    def __init__(self, hierarchy: Hierarchy, reader: SpaceReader, config: LearnerConfig,
                 planner: PlannerConfig | None = None):
        self.h = hierarchy
        self.reader = reader
        self.config = config
        self.pc = PlannerConfig() if planner is None else planner
        self.navigator = Navigator(hierarchy, reader, self.pc)
        self.stack: list[Pursuit] = []
        """What the planner is pursuing now, outermost first (read by episode recordings)."""
        self.trip_starts: list[np.ndarray] = []
        """The observation each trip to a place (a re-placement of the robot or of a tool) of
        the last goal started from: each counted once, when it starts after an action that
        was not a placement (read by evaluation: how far the goal still was)."""
        self._placed_for: frozenset[int] = frozenset()
        """Affordances whose placement the last primitive action served (a trip under way)."""
        self._convoy_output = -1
        """While a `convoy` move of an object is executed: the entity that object pushes (the
        target, for the tool); -1 otherwise."""
        self._spare_small = True
        """Whether a sub-goal's small correction is spared a trip (`stall_trips`): not once
        the outermost goal stalled while still far."""
        self._idle: tuple[np.ndarray, np.ndarray] | None = None
        """(the action, the observation after it) when the last primitive action moved
        nothing (`skip_idle_repeats`)."""
        self._convoy_acted = False
        """Whether the last primitive action was a convoy's, chosen through the chain
        (`convoy_goes_on`)."""
        self.pusher: Pusher | None = None
        """An exact stand-in for the robot pushing an object where a level above asks
        (`evaluation.exact`, evaluation only); None: the learned affordances push."""
        self.tool_guide: ToolGuide | None = None
        """An exact stand-in for the tool level's decisions: the tool's next move for the
        target to reach a goal (`evaluation.exact`, evaluation only); None: learned."""

    @property
    def trips(self) -> int:
        """Trips to a place of the last goal (`trip_starts`)."""
        return len(self.trip_starts)

    # ------------------------------------------------------------------ reading the state
    def value(self, space: RoleSpace, obs: np.ndarray, b: Binding) -> np.ndarray:
        return self.reader.value_now(space, obs, b.target, b.tool)

    def context(self, aff: Affordance, obs: np.ndarray, b: Binding) -> np.ndarray:
        if not aff.contexts:
            return np.zeros(0)
        return np.concatenate([self.value(c, obs, b) for c in aff.contexts])

    def effect(self, y: np.ndarray) -> np.ndarray:
        """Mask of the outcomes `y` where something moved (the shared `split_zero` rule): the
        rows that show where an affordance acts from."""
        return ~split_zero(y, self.config.zero_eps)

    def step_size(self, aff: Affordance) -> float:
        """The typical size of one step of `aff`: a high quantile of its non-null outcomes."""
        return typical_step(aff, self.pc.step_quantile, self.config.zero_eps)

    # ------------------------------------------------------------------ reaching goals
    def reach(self, aff: Affordance, b: Binding, goal: np.ndarray, actuator: Actuator,
              budget: int, depth: int = 0) -> Attempt:
        """Drive `aff`'s output (under binding `b`) towards the absolute value `goal`."""
        goal = _normalise_heading(aff.output, np.asarray(goal, dtype=float))
        start = float(np.linalg.norm(goal - self.value(aff.output, actuator.obs, b)))
        if depth == 0:
            self.navigator.forget()
            self.trip_starts = []
            self._placed_for = frozenset()
        self.stack.append(Pursuit(f"A{aff.id} {aff.output.name}", goal, b))
        try:
            used = self._reach_loop(aff, b, goal, start, actuator, budget, depth)
        finally:
            self.stack.pop()
        final = float(np.linalg.norm(goal - self.value(aff.output, actuator.obs, b)))
        return Attempt(start, final, used)

    def _reach_loop(self, aff: Affordance, b: Binding, goal: np.ndarray, start: float,
                    actuator: Actuator, budget: int, depth: int) -> int:
        used = 0
        stalls = 0
        while used < budget and not actuator.exhausted:
            current = self.value(aff.output, actuator.obs, b)
            gap = goal - current
            dist = float(np.linalg.norm(gap))
            step = self.step_size(aff)
            # A sub-goal (depth > 0) serves a parent that replans after it: chasing its last
            # few millimetres would cost whole actions (a turn, a nudge) for nothing. With
            # `short_subgoals` the slack is a share of the sub-goal's own length when that is
            # shorter than a step: else a short one reads as reached before its first action.
            scale = min(step, start) if self.pc.short_subgoals else step
            slack = self.pc.subgoal_tolerance * scale if depth > 0 else 0.0
            if dist <= max(self.config.reach_tolerance * start, self.config.zero_eps, slack):
                break
            delta = gap if dist <= step else gap * (step / dist)
            if depth == 0:
                self._spare_small = (not self.pc.stall_trips or stalls == 0
                                     or dist < self.pc.small_correction * step)
            if self.tool_guide is not None and aff.input.role is Role.TOOL:
                done = self.execute(aff.input, self.tool_guide(actuator.obs, goal, b), b,
                                    actuator, budget - used, depth, exclude=aff.id)
            else:
                done = self._one_step(aff, b, delta, actuator, budget - used, depth,
                                      remaining=dist / max(step, 1e-9),
                                      spare_trips=(self._spare_small if depth > 0
                                                   else dist < start
                                                   and self._risky_trip(aff, b)),
                                      goal=goal)
            used += max(done, 0)
            if done <= 0:
                stalls += 1
                if stalls >= 2 or done < 0:
                    break
            else:
                stalls = 0
        return used

    def _risky_trip(self, aff: Affordance, b: Binding) -> bool:
        """Whether a trip for `aff`'s next step risks an output already moved towards its
        goal: the binding has an entity the robot must not touch, or (`spare_stagings`) the
        trip moves another object round the output — the tool staged round the target, whose
        pushes can shove it. Traced: a target 2.4 cm from its goal, the tool staged round it
        for the last correction, the target shoved 20 cm off."""
        return b.avoid >= 0 or (self.pc.spare_stagings and self._entity(aff.input, b) > 0)

    def _one_step(self, aff: Affordance, b: Binding, delta: np.ndarray, actuator: Actuator,
                  budget: int, depth: int, remaining: float = 1.0,
                  spare_trips: bool = True, goal: np.ndarray | None = None) -> int:
        """Execute one planned step; returns actions used (-1: nothing can be done).
        `remaining`: steps of `aff` still to go to its goal (weighs a trip to a better place
        against pushing on from here). `spare_trips`: a small remainder is not worth a trip round
        the object — a sub-goal's (its parent replans), or that of a goal already approached
        while an entity must not be touched (the trip risks the whole goal for a few per cent
        of it). `goal`: the output's goal (`hold_relation`)."""
        if aff.model.n < 2:
            return -1
        obs = actuator.obs
        c = self.context(aff, obs, b)
        here = aff.model.infer(delta, c if c.size else None)
        progress = 1.0 - np.linalg.norm(here.y_predicted - delta) / max(np.linalg.norm(delta),
                                                                         1e-9)
        relations = self.reachable_relations(aff)
        if relations.any() and depth < self.pc.max_depth:
            used = self._from_needed(aff, b, delta, c, here.x, progress, relations, actuator,
                                     budget, depth, remaining, spare_trips, goal)
            if used is not None:
                return used
        elif progress < 0.3 and aff.contexts and depth < self.pc.max_depth:
            # A pose context (e.g. the heading for a move): reach that of the best answer.
            used = self._reach_context(aff, b, self.nearest_pose(aff, delta, c), actuator,
                                       budget, depth)
            if used > 0:
                return used
        if progress <= 0.0:
            return -1
        x = here.x
        convoy = self._in_convoy(aff, b)
        if convoy:
            x = self.straight_move(aff, delta, c, x)
        return self.execute(aff.input, x, b, actuator, budget, depth, exclude=aff.id,
                            facing=convoy and self.pc.convoy_facing)

    def _from_needed(self, aff: Affordance, b: Binding, delta: np.ndarray, c: np.ndarray,
                     x: np.ndarray, progress: float, relations: np.ndarray,
                     actuator: Actuator, budget: int, depth: int, remaining: float,
                     spare_trips: bool, goal: np.ndarray | None) -> int | None:
        """`_one_step` for an affordance with a relation the planner can drive: the move
        toward the final place (`hold_relation`; where it applies, with `convoy`, the
        straight move along `delta` instead), a trip to the needed relation, a steered
        push, or the end of a trip's turn to its heading (`face_places`). Returns actions
        used, -1 when nothing can be done, None to push from here with the inverse answer
        `x` (`progress`: its predicted share of `delta`)."""
        obs = actuator.obs
        # The inverse answer is only trusted where such outcomes were seen: if the current
        # relation (e.g. target-robot) is far from that of the data it comes from, first
        # reach the relation from which outcomes like `delta` are usually obtained.
        spreads = self._spreads(aff)
        supported = (self.support_gap(aff, x, c, relations, spreads)
                     <= self.pc.place_support)
        needed = self.needed_context(aff, delta, c, relations | self._poses(aff))
        near = self._as_near(aff, c, needed, relations)
        off = self._gap(aff, spreads, c, near, relations)
        used = self._convoy(aff, b, delta, c, x, near, relations, spreads, actuator, budget,
                            depth, goal)
        if used is not None:
            return used
        way = self._way_to_final_place(aff, b, delta, near if self.pc.near_pursuit
                                       else needed, off, goal, obs)
        if way is not None:
            return self.execute(aff.input, way, b, actuator, budget, depth, exclude=aff.id)
        # A trip under way goes on until it arrives: replanning every action, a trip
        # given up as soon as the relation was back within `realign` left the robot
        # going to and fro across that threshold (a trip, a push, a trip again).
        going_on = self.pc.finish_trips and aff.id in self._placed_for
        if off > self.pc.place_support and (going_on or self._worth_replacing(
                aff, b, needed, delta, obs, progress if supported else 0.0, off, remaining)):
            if spare_trips and (np.linalg.norm(delta)
                                < self.pc.small_correction * self.step_size(aff)):
                # The robot circled a tool for 3 cm; a target pushed 3 cm past its goal
                # was chased round the tool for 50 actions, and touched.
                return -1
            then = aff.model.infer(delta, needed).x
            if self.pc.steer and off <= self.pc.realign and not going_on:
                done = self._steer(aff, b, delta, c, needed, then, relations, spreads,
                                   actuator, budget, depth)
                if done > 0:
                    return done
            used = self._reach_context(aff, b, self._at_contact(aff, needed, relations),
                                       actuator, budget, depth, then=then)
            if used != 0:
                return used
        elif (heading := self._unfaced(aff, b, delta, needed, obs)) is not None:
            used = self._reach_context(aff, b, self._at_contact(aff, needed, relations),
                                       actuator, budget, depth, facing=heading)
            if used > 0:
                return used
        return None

    def _convoy(self, aff: Affordance, b: Binding, delta: np.ndarray, c: np.ndarray,
                x: np.ndarray, near: np.ndarray, relations: np.ndarray, spreads: list[float],
                actuator: Actuator, budget: int, depth: int, goal: np.ndarray | None
                ) -> int | None:
        """`_from_needed`'s convoy, when one applies: where the relation holds
        (`_convoy_hold`), the chain's command (`convoy_plan`) or else the straight step; past
        `realign`, right after a convoy action, the chain's command while pushing on along
        the line is predicted to leave the output within a small correction of its goal
        (`convoy_goes_on`). Returns actions used, None when no convoy applies."""
        held = self._convoy_hold(aff, b, delta, c, near, relations, spreads, goal)
        if held is None:
            going = self._goes_on(aff, b, goal, actuator.obs)
            if going is None or goal is None:
                return None
            return self._convoy_plan(aff, b, delta, c, near, going, actuator, goal)
        if self.pc.convoy_plan and goal is not None:
            done = self._convoy_plan(aff, b, delta, c, near, held, actuator, goal)
            if done is not None:
                return done
        return self._convoy_step(aff, b, self.straight_move(aff, delta, c, x), actuator,
                                 budget, depth)

    def _goes_on(self, aff: Affordance, b: Binding, goal: np.ndarray | None,
                 obs: np.ndarray) -> tuple[int, slice] | None:
        """`convoy_goes_on`: the relation (as `_held_relation` gives it) by which a convoy
        whose relation drifted past `realign` pushes on through the chain — its last action
        was the convoy's, and the output pushed on along the line from its input (the target
        along the tool–target line) would pass within `small_correction` of a step of
        `goal`: a correction is no trip worth taking for what it could still gain (traced
        near goals: three corrections of 13–24 actions for 8 cm, each leaving the line
        15–25° off again). None: it does not go on."""
        relation = _relation_slice(aff)
        if not (self.pc.convoy_goes_on and self.pc.convoy_plan and self._convoy_acted
                and goal is not None and self._entity(aff.input, b) > 0
                and relation is not None):
            return None
        output = self.reader.entity_position(obs, self._entity(aff.output, b))
        line = output - self.reader.entity_position(obs, self._entity(aff.input, b))
        way = goal - output
        rem = float(np.linalg.norm(way))
        cos = float(line @ way) / max(rem * float(np.linalg.norm(line)), 1e-12)
        miss = rem * float(np.sqrt(max(1.0 - cos * cos, 0.0))) if cos > 0.0 else rem
        return relation if miss <= self.pc.small_correction * self.step_size(aff) else None

    def straight_move(self, aff: Affordance, delta: np.ndarray, c: np.ndarray,
                      x: np.ndarray) -> np.ndarray:
        """`convoy`'s move of `aff`'s input: along `delta`, the outcome wanted, at the length
        (`STRAIGHT_LENGTHS` of the larger of |x|, the inverse model's answer, and |delta|)
        whose outcome `aff`'s forward model predicts nearest `delta` in the context `c`. Many
        inputs give one outcome — a robot driving 0.14 m diagonally past an object's back
        nudges it 3 cm along the line of centres, as a straight 3 cm push does — and the
        inverse answer is whichever the model rates best by a millimetre; the straight one
        keeps a chain of pushes lined up."""
        length = max(float(np.linalg.norm(x)), float(np.linalg.norm(delta)))
        way = delta / max(float(np.linalg.norm(delta)), 1e-12)
        moves = (length * STRAIGHT_LENGTHS)[:, None] * way[None]
        y = aff.model.predict(moves, np.repeat(c[None], moves.shape[0], 0) if c.size else None)
        return moves[int(np.argmin(np.linalg.norm(y - delta, axis=1)))].copy()

    def _convoy_step(self, aff: Affordance, b: Binding, move: np.ndarray, actuator: Actuator,
                     budget: int, depth: int) -> int:
        """Execute `convoy`'s `move` of `aff`'s input object, its pusher knowing the entity
        it pushes through that object (`_in_convoy`)."""
        outer, self._convoy_output = self._convoy_output, self._entity(aff.output, b)
        try:
            return self.execute(aff.input, move, b, actuator, budget, depth, exclude=aff.id)
        finally:
            self._convoy_output = outer

    def _convoy_plan(self, aff: Affordance, b: Binding, delta: np.ndarray, c: np.ndarray,
                     near: np.ndarray, held: tuple[int, slice], actuator: Actuator,
                     goal: np.ndarray) -> int | None:
        """`convoy_plan`: the convoy's next primitive action, chosen through the chain's
        forward models — for each of the navigator's wheel commands, the robot's move (its
        motion model), the object's (`aff`'s input, the tool: the robot's push of it, from
        their relation) and the output's (`aff`, from the object's relation to it) — by the
        output's predicted distance to `goal` in steps plus, for each of the two relations,
        `convoy_drift_cost` × (its predicted gap to the one needed along the output's new
        way / `realign`)^`DRIFT_POWER`. Only commands whose predicted turn is at most
        `convoy_turn` (the push's model, from the robot's net move, cannot tell an arc from
        a straight push: 0.6 cm off at the median under 5°, 1.6-1.9 cm at 5-30°), that the
        robot's keep-outs allow, that drive the robot into the object and bring the output
        `MIN_PROGRESS` of a step nearer (a turn on the spot pushes nothing, though the
        push's model, asked about a null move against the object, can predict a push:
        traced, one taken 58 times), never the last command again from the observation it
        left unchanged (`_idle_repeat`). With the robot out of contact behind the object,
        the command that drives it there facing the way. Returns 1 (an action taken), None
        when it does not apply: no pusher acting from the robot's position, the robot not
        behind the object or its relation past `realign`, no command (the convoy step then)."""
        obs = actuator.obs
        sub_b = Binding(target=b.tool, avoid=b.target)
        pushers = [a for a in self.h.controllers(aff.input)
                   if a.id != aff.id and a.input == ROBOT_POSITION and a.model.n >= 2]
        if not pushers or not self._navigating():
            return None
        push = pushers[0]
        relation = _relation_slice(push)
        if relation is None:
            return None
        robot = self.reader.entity_position(obs, 0)
        mover = self._entity(aff.input, b)
        pushed = self.reader.entity_position(obs, mover)
        u = delta / max(float(np.linalg.norm(delta)), 1e-12)
        if float((pushed - robot) @ u) <= 0.0:
            return None
        i3, sl3 = relation
        c3 = self.context(push, obs, sub_b)
        n3 = self.needed_context(push, self.step_size(push) * u, c3,
                                 self.reachable_relations(push) | self._poses(push))
        spreads3 = self._spreads(push)
        if (np.linalg.norm(c3[sl3] - np.linalg.norm(n3[sl3]) * u) / spreads3[i3]
                > self.pc.realign):
            return None
        keep = self._keepouts(sub_b, obs)
        contact = self.reader.entity_radius(obs, 0) + self.reader.entity_radius(obs, mover)
        if np.linalg.norm(pushed - robot) > contact + CONTACT_MARGIN:
            command = self.navigator.choose(obs, Place(pushed - contact * u, u, CONTACT_MARGIN),
                                            keep, sub_b.target, sub_b.tool)
        else:
            command = self._chain_command(aff, push, b, sub_b, near, n3, held, (i3, sl3),
                                          goal, keep, obs)
        if command is None or self._idle_repeat(command, obs):
            return None
        self.stack.append(Pursuit(CONVOY_PURSUIT, goal, b))
        try:
            self._act(actuator, command)
        finally:
            self.stack.pop()
        return 1

    def _chain_command(self, aff: Affordance, push: Affordance, b: Binding, sub_b: Binding,
                       near: np.ndarray, n3: np.ndarray, held: tuple[int, slice],
                       relation: tuple[int, slice], goal: np.ndarray, keep: list[Keepout],
                       obs: np.ndarray) -> np.ndarray | None:
        """`_convoy_plan`'s command with the robot against the object (None: none fits): the
        first of the `convoy_depth` commands in a row whose imagined end costs least (`_chain`),
        each command taken from where the one before is predicted to leave the robot, the
        object and the output. A first command after which no command fits is valued at its
        own end."""
        lengths = (float(np.linalg.norm(near[held[1]])), float(np.linalg.norm(n3[relation[1]])))
        first = self._chain(aff, push, b, sub_b, obs[None], lengths, held, relation, goal)
        if first is None:
            return None
        after, cost, ok = first
        commands = self.navigator.commands
        robot = self.reader.entity_position(obs, 0)
        end = self.reader.entity_position(after[0], 0)
        ok = (ok[0] & self.navigator.allowed_many(obs[None], (0.5 * (robot + end))[None],
                                                  end[None], keep)[0]
              & ~self._idle_repeats(commands, obs))
        if not ok.any():
            return None
        value, after = cost[0], after[0]
        for _ in range(1, self.pc.convoy_depth):
            live = np.flatnonzero(ok)
            then = self._chain(aff, push, b, sub_b, after[live], lengths, held, relation, goal)
            if then is None:
                break
            after_then, cost_then, ok_then = then
            best = np.where(ok_then, cost_then, np.inf).min(axis=1)
            value = value.copy()
            value[live] = np.minimum(value[live], best)
            # Deeper, each first command is followed by its best next command's imagined end.
            pick = np.argmin(np.where(ok_then, cost_then, np.inf), axis=1)
            after = after.copy()
            after[live] = after_then[np.arange(live.size), pick]
        return commands[int(np.argmin(np.where(ok, value, np.inf)))].copy()

    def _chain(self, aff: Affordance, push: Affordance, b: Binding, sub_b: Binding,
               arr: np.ndarray, lengths: tuple[float, float], held: tuple[int, slice],
               relation: tuple[int, slice], goal: np.ndarray
               ) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
        """One convoy action imagined from each observation of `arr` (B, D), for each of the
        navigator's commands, through the chain's forward models: the robot's move, the
        object's (its push, from their relation) and the output's (`aff`, from the object's
        relation to it). Returns the imagined observations (B, N, D); each one's cost, the
        output's distance to `goal` in steps plus, for each relation, `convoy_drift_cost` ×
        (its gap to the relation of `lengths` along the output's new way / `realign`)^
        `DRIFT_POWER`; and the mask of commands that fit: a turn of at most `convoy_turn`,
        a drive into the object and the output brought `MIN_PROGRESS` of a step nearer.
        None: no motion model."""
        motions = self.navigator.motions(arr, sub_b.target, sub_b.tool)
        if motions is None:
            return None
        shift, heading = motions
        m, n = shift.shape[:2]
        flat = shift.reshape(-1, 2)
        moved = push.model.predict(flat, self._contexts(push, arr, sub_b, n))
        out = aff.model.predict(moved, self._contexts(aff, arr, b, n))
        tool, target = self._entity(aff.input, b), self._entity(aff.output, b)
        lay = self.reader.layout
        robot = np.repeat(self.reader.entity_position(arr, 0), n, 0)
        nxt = np.repeat(arr, n, 0)
        for entity, move in ((0, flat), (tool, moved), (target, out)):
            nxt[:, lay.space(lay.entities[entity], Property.POSITION).slice] += move
        nxt[:, lay.space(ROBOT, Property.HEADING).slice] = heading.reshape(-1, 2)
        positions = nxt[:, lay.object_columns(Property.POSITION)]
        nxt[:, lay.object_columns(Property.RELATIVE)] = (
            positions - nxt[:, None, lay.space(ROBOT, Property.POSITION).slice])
        ends = self.reader.entity_position(nxt, target)
        rem = np.linalg.norm(goal - ends, axis=1)
        way = (goal - ends) / np.maximum(rem, 1e-12)[:, None]
        step = self.step_size(aff)
        cost = rem / step
        terms = ((held, aff, b, lengths[0]), (relation, push, sub_b, lengths[1]))
        for (i, sl), who, bind, length in terms:
            rel = self._contexts(who, nxt, bind, 1)[:, sl]
            gap = np.linalg.norm(rel - length * way, axis=1) / self._spreads(who)[i]
            cost = cost + self.pc.convoy_drift_cost * (gap / self.pc.realign) ** DRIFT_POWER
        before = np.repeat(self.reader.entity_position(arr, target), n, 0)
        toward = np.repeat(self.reader.entity_position(arr, tool), n, 0) - robot
        toward /= np.maximum(np.linalg.norm(toward, axis=1), 1e-12)[:, None]
        was = np.repeat(self.reader.read_each((ROBOT_HEADING,), arr), n, 0)
        turn = np.arccos(np.clip(np.sum(heading.reshape(-1, 2) * was, axis=1), -1.0, 1.0))
        ok = ((rem < np.linalg.norm(goal - before, axis=1) - MIN_PROGRESS * step)
              & (np.sum(flat * toward, axis=1) >= MIN_PROGRESS * step)
              & (turn <= np.deg2rad(self.pc.convoy_turn)))
        return nxt.reshape(m, n, -1), cost.reshape(m, n), ok.reshape(m, n)

    def _contexts(self, aff: Affordance, arr: np.ndarray, b: Binding, n: int
                  ) -> np.ndarray | None:
        """`aff`'s context in each observation of `arr` (B, D), each repeated `n` times."""
        if not aff.contexts:
            return None
        return np.repeat(self.reader.read_each(aff.contexts, arr, b.target, b.tool), n, 0)

    def _in_convoy(self, aff: Affordance, b: Binding) -> bool:
        """Whether `aff` is the robot pushing an object for a `convoy` move of it: the entity
        that object pushes is the one `b` says to avoid. Staging the same object round that
        entity is no convoy (its pushes keep the inverse answers: pushed straight too, the
        tool task's robot-only share rose from 62 to 65 %)."""
        return (self._convoy_output >= 0 and b.avoid == self._convoy_output
                and aff.input == ROBOT_POSITION and aff.output.role is not Role.ROBOT)

    def _unfaced(self, aff: Affordance, b: Binding, delta: np.ndarray, needed: np.ndarray,
                 obs: np.ndarray) -> np.ndarray | None:
        """With `face_places`, when the robot's last action served `aff`'s own trip and the
        relation no longer asks for one, but the robot does not face the heading the trip's
        place was taken with (beyond `heading_tolerance`, either way along it): that
        heading. Else None."""
        if not (self.pc.face_places and aff.input == ROBOT_POSITION and self._navigating()
                and aff.id in self._placed_for):
            return None
        heading = self._trip_heading(aff, b, self._needed_heading(aff, needed),
                                     aff.model.infer(delta, needed).x, obs)
        if heading is None:
            return None
        now = self.value(ROBOT_HEADING, obs, b)
        if float(line_angle(now[None], heading[None])[0]) <= self.pc.heading_tolerance:
            return None
        return heading

    def _trip_heading(self, aff: Affordance, b: Binding, heading: np.ndarray | None,
                      then: np.ndarray | None, obs: np.ndarray) -> np.ndarray | None:
        """The heading a trip for `aff`'s needed context arrives with: `heading`, the one
        that context holds (`pose_places`), else, for an affordance acting from the robot's
        position, the heading from which its motion makes the move `then`."""
        if heading is None and then is not None and aff.input == ROBOT_POSITION:
            heading = self.heading_for(then, obs, b)
        return heading

    def _steer(self, aff: Affordance, b: Binding, delta: np.ndarray, c: np.ndarray,
               needed: np.ndarray, then: np.ndarray, relations: np.ndarray,
               spreads: list[float], actuator: Actuator, budget: int, depth: int) -> int:
        """Push on and steer back toward the `needed` relation (`steer`): the move the
        forward model picks (`_steer_by_model`), else the inverse answer `then` plus the way
        back to the needed place (`_steering`). Returns actions used (≤ 0: none could be
        made, and the caller takes the trip instead)."""
        move = self._steer_by_model(aff, delta, c, needed, then, relations, spreads)
        if move is None:
            steer = self._steering(aff, b, needed, actuator.obs)
            move = None if steer is None else then + steer
        if move is None:
            return -1
        return self.execute(aff.input, move, b, actuator, budget, depth, exclude=aff.id)

    def _way_to_final_place(self, aff: Affordance, b: Binding, delta: np.ndarray,
                            needed: np.ndarray, off: float, goal: np.ndarray | None,
                            obs: np.ndarray) -> np.ndarray | None:
        """`hold_relation`'s move of `aff`'s input: toward where it stands, in the `needed`
        relation, from the output at `goal` — at most the length of the inverse model's
        answer for `delta` there. None when `hold_relation` is off, the relation is `off` by
        more than `realign`, there is no goal, the input is not an object pushed by another
        affordance, or no context of `aff` relates the output to it. The robot itself keeps
        the per-step inverse answer: heading it for its final place too lowered pushing an
        object from 0.966 to 0.938 and the tool task from 0.78 to 0.57 (ten learners,
        evaluation only); it turns and drives at will, while an object changes its
        direction only through a trip of its pusher round it."""
        held = self._held_relation(aff, b, delta, off, goal)
        if held is None:
            return None
        space, sl = aff.contexts[held[0]], held[1]
        offset_now = self.reader.offset_now(space, needed[sl], obs, b.target, b.tool)
        position = self.reader.entity_position(obs, self._entity(aff.input, b))
        step = float(np.linalg.norm(aff.model.infer(delta, needed).x))
        if self.pc.pursue_line:
            # Pure pursuit of the line the input must push along: from where it stands in the
            # needed relation to the output now, toward the goal.
            behind = self.value(aff.output, obs, b) - offset_now
            u = delta / max(float(np.linalg.norm(delta)), 1e-12)
            along = float((position - behind) @ u)
            way = behind + u * (min(along, 0.0) + step) - position
        else:
            way = goal - offset_now - position
        length = float(np.linalg.norm(way))
        return way if length <= step else way * (step / max(length, 1e-12))

    def _convoy_hold(self, aff: Affordance, b: Binding, delta: np.ndarray, c: np.ndarray,
                     near: np.ndarray, relations: np.ndarray, spreads: list[float],
                     goal: np.ndarray | None) -> tuple[int, slice] | None:
        """With `convoy`, `_held_relation` with the relation's gap from `c` to `near`, at its
        own length where it trails (`convoy_trailing`); None without `convoy`."""
        if not self.pc.convoy:
            return None
        if self.pc.convoy_trailing:
            # A relation further than its place on the place's bearing (a tool trailing
            # behind the target) holds: what is left of its gap is the bearing's.
            near = _at_own_lengths(aff, c, near, relations, further=True)
        return self._held_relation(aff, b, delta, self._gap(aff, spreads, c, near, relations),
                                   goal)

    def _held_relation(self, aff: Affordance, b: Binding, delta: np.ndarray, off: float,
                       goal: np.ndarray | None) -> tuple[int, slice] | None:
        """Whether `hold_relation` decides `aff`'s next move (`_way_to_final_place`, or with
        `convoy` the straight move): (the index, the columns) of the context of `aff` that
        relates its output to its input, an object pushed by another affordance, with the
        relation within `realign` and a goal; None otherwise (and with `direct_remainders`,
        for a remainder shorter than `small_correction` steps)."""
        if not self.pc.hold_relation or goal is None or off > self.pc.realign:
            return None
        if self._entity(aff.input, b) <= 0:
            return None
        if self.pc.direct_remainders and (float(np.linalg.norm(delta))
                                          < self.pc.small_correction * self.step_size(aff)):
            return None
        return _relation_slice(aff)

    def _steer_by_model(self, aff: Affordance, delta: np.ndarray, c: np.ndarray,
                        needed: np.ndarray, then: np.ndarray, relations: np.ndarray,
                        spreads: list[float]) -> np.ndarray | None:
        """The input move, among `then` turned by up to ±60° and at full or half length, whose
        outcome `aff`'s forward model predicts nearest `delta` and after which the relation
        between `aff`'s output and input entities — moved by the outcome less the move —
        is nearest `needed` (both in units of their scale). None when no context of `aff` is
        that relation. Pushing from a contact off the line, a move along the wanted push
        turned the contact further off (the relation's gap to the needed one grew after 4
        steering steps in 5), as a disc pushes along the line of centres."""
        if aff.input.prop is not Property.POSITION or aff.input.relative_to is not None:
            return None
        cols = [np.arange(sl.start, sl.stop) for i, sl in _slices(aff)
                if aff.contexts[i].prop is Property.POSITION
                and aff.contexts[i].role is aff.output.role
                and aff.contexts[i].relative_to is aff.input.role]
        length = float(np.linalg.norm(then))
        if not cols or length < 1e-9:
            return None
        turns = np.deg2rad(np.arange(-60, 61, 10))
        bearing = float(np.arctan2(then[1], then[0])) + turns
        unit = np.stack([np.cos(bearing), np.sin(bearing)], axis=1)
        moves = np.concatenate([length * unit, 0.5 * length * unit])
        y = aff.model.predict(moves, np.repeat(c[None], moves.shape[0], 0))
        after = np.repeat(c[None], moves.shape[0], 0)
        for col in cols:
            after[:, col] += y - moves
        miss = np.linalg.norm(y - delta, axis=1) / max(float(np.linalg.norm(delta)), 1e-9)
        gaps = self._gaps(aff, spreads, needed, after, relations)
        return moves[int(np.argmin(miss + gaps))].copy()

    def _steering(self, aff: Affordance, b: Binding, needed: np.ndarray, obs: np.ndarray
                  ) -> np.ndarray | None:
        """The move of `aff`'s input entity that would bring its context relation back to
        `needed` (None when the relation is not held by that entity)."""
        mover = self._entity(aff.input, b)
        if mover < 0:
            return None
        for _, _, driven, goal, sub_b, _ in self._context_plans(aff, b, needed, obs):
            if driven.prop is Property.POSITION and self._entity(driven, sub_b) == mover:
                return goal - self.reader.entity_position(obs, mover)
        return None

    @staticmethod
    def _entity(space: RoleSpace, b: Binding) -> int:
        if space.prop is not Property.POSITION or space.relative_to is not None:
            return -1
        return {Role.ROBOT: 0, Role.TARGET: b.target, Role.TOOL: b.tool}[space.role]

    def _worth_replacing(self, aff: Affordance, b: Binding, needed: np.ndarray,
                         delta: np.ndarray, obs: np.ndarray, rate: float, off: float,
                         remaining: float) -> bool:
        """Whether to reach the `needed` context before the next step of `aff`.

        With `replace_by_cost`: pushing on from here moves the output at `rate` (the forward
        model's predicted share of a step, 0 where the data do not support it), so the rest
        costs about `remaining / rate` steps; a trip costs its estimated actions and then
        `remaining` full steps. The trip is taken only when it is cheaper (the authors'
        later planner tries the current place first and moves only when that gains more).
        Without: the fixed tolerances (progress < 0.3, drift > `realign`)."""
        if not self.pc.replace_by_cost:
            return rate <= 0.0 or rate < 0.3 or off > self.pc.realign
        if rate <= 0.05:
            return True
        return self._trip_cost(aff, b, needed, delta, obs) + remaining < remaining / rate

    def _trip_cost(self, aff: Affordance, b: Binding, needed: np.ndarray, delta: np.ndarray,
                   obs: np.ndarray) -> float:
        """Estimated primitive actions to reach the `needed` context of `aff`: the robot's
        drive there (its learned motion, `Navigator.estimate`), and for a relation held by
        another object (the tool), that object's move at its driver's step plus the robot's
        drive to behind it."""
        total = 0.0
        for _, _, driven, goal, sub_b, drivers in self._context_plans(aff, b, needed, obs):
            if driven == ROBOT_POSITION:
                total += self.navigator.estimate(obs, Place(goal), b.target, b.tool)
                continue
            entity = sub_b.target
            position = self.reader.entity_position(obs, entity)
            way = goal - position
            length = float(np.linalg.norm(way))
            if length < 1e-9:
                continue
            behind = position - way / length * (self.reader.entity_radius(obs, entity)
                                                + self.reader.entity_radius(obs, 0))
            total += (length / max(self.step_size(drivers[0]), 1e-3)
                      + self.navigator.estimate(obs, Place(behind), b.target, b.tool))
        return total

    def nearest_pose(self, aff: Affordance, delta: np.ndarray, c: np.ndarray) -> np.ndarray:
        """The context nearest `c` among those of the stored rows whose outcome was like
        `delta` (within `pose_match` of its length): a robot can often drive backwards as well
        as forwards, and the smaller turn is the cheaper one. Falls back to the context of the
        inverse model's best answer anywhere."""
        _, nb = aff.model.inverse_neighbours(delta[None], k=self.config.k_inverse)
        _, ctx, y = aff.model.data()
        rows = nb[0]
        err = np.linalg.norm(y[rows] - delta, axis=1) / max(float(np.linalg.norm(delta)), 1e-9)
        good = rows[err <= self.pc.pose_match]
        if good.size == 0:
            return aff.model.infer(delta).context
        scale = aff.model.scales().per_column()[aff.model.dx:aff.model.dx + ctx.shape[1]]
        travel = np.linalg.norm((ctx[good] - c) / scale, axis=1)
        return ctx[good[int(np.argmin(travel))]].copy()

    def _poses(self, aff: Affordance) -> np.ndarray:
        """Per context space of `aff`: whether it is the robot's heading and `pose_places` asks
        for it to be chosen with the relation (`needed_context`) and taken with the place."""
        return np.array([self.pc.pose_places and space == ROBOT_HEADING
                         for space in aff.contexts], dtype=bool)

    def _needed_heading(self, aff: Affordance, needed: np.ndarray) -> np.ndarray | None:
        """The robot's heading in `needed` when `_poses` chose it (None otherwise)."""
        if not self.pc.pose_places:
            return None
        return _unit_heading(_context_part(aff, needed, ROBOT_HEADING))

    def reachable_relations(self, aff: Affordance) -> np.ndarray:
        """Per context space of `aff`: whether it is a relative position (e.g. target-robot)
        that another affordance can drive. Only such spatial relations are checked for
        support: for the robot's own pose (heading) the progress test suffices, and turning
        first at every step costs more than it gives."""
        out = np.zeros(len(aff.contexts), dtype=bool)
        probe = Binding(0 if aff.has_target else -1, 0 if aff.has_tool else -1)
        for i, space in enumerate(aff.contexts):
            if space.relative_to is None:
                continue
            plan = self._context_goal(space, np.zeros(2), np.zeros(self.reader.layout.size),
                                      probe)
            out[i] = plan is not None and bool(self._drivers(aff, plan[0], plan[2], probe))
        return out

    def _drivers(self, aff: Affordance, driven: RoleSpace, sub_b: Binding,
                 b: Binding) -> list[Affordance]:
        """Affordances other than `aff` that can drive `driven` under binding `sub_b` (most
        competent first), to set up a context of `aff` bound by `b`. None when that is `aff`'s
        own output under its own binding: moving it is what `aff` is for, not a precondition
        (the tool's position is a target position too, but under another binding)."""
        if driven == aff.output and sub_b == b:
            return []
        return [a for a in self.h.controllers(driven)
                if a.id != aff.id and (sub_b.tool >= 0 or not a.has_tool)]

    def needed_context(self, aff: Affordance, delta: np.ndarray, c: np.ndarray,
                       relations: np.ndarray) -> np.ndarray:
        """The context from which `aff` usually produces outcomes like `delta`.

        Among the non-null rows whose outcome is nearest `delta` and whose fixed contexts (not in
        `relations`, the mask of spaces the planner can drive: a relation such as target-robot,
        and with `pose_places` the robot's heading; not e.g. the object's radius) are nearest
        the current ones, the values of the driven spaces where most of them agree (a kernel
        density mode): one push seen from an odd place (a bounce, a chain of contacts) must not
        send the robot there. The result is `c` with those columns replaced. Rows of a model
        in a relation's frame are first turned so that each outcome points along `delta`
        (`frames.seen`): every push, from whatever bearing, then shows where a push along
        `delta` is made from.
        """
        x_cols = aff.model.dx
        # A row where nothing moved shows no place an effect comes from (all rows if none moved).
        _, _, ctx, y = seen_where(aff.model, self.config.zero_eps, along=delta)
        copies = 1
        if self.pc.mirrored_relations and (mirrored := self._mirrored(aff, ctx, y, delta)):
            ctx, y = mirrored
            copies = 2
        scale = aff.model.scales().per_column()
        ctx_scale, y_scale = scale[x_cols:x_cols + ctx.shape[1]], scale[x_cols + ctx.shape[1]:]
        free = np.repeat(relations, aff.model.context_dims)
        query = np.concatenate([(y - delta) / y_scale, ((ctx - c) / ctx_scale)[:, ~free]], 1)
        # Few rows (a new affordance): a neighbourhood of all of them would vote for the
        # largest cluster whatever its outcome. With mirror images, as many stored rows as
        # without: each comes with its image.
        k = min(2 * self.config.k_inverse * copies, max(3, y.shape[0] // 4), y.shape[0])
        dist2 = np.einsum("ij,ij->i", query, query)
        near = np.sort(np.argpartition(dist2, k - 1)[:k])  # sorted: a deterministic order
        # Each row counts by how close its outcome is to `delta` (a Gaussian whose width is the
        # median distance of the neighbours), and is scored by that weight times the weighted
        # number of rows agreeing with its relation.
        closeness = np.exp(-dist2[near] / max(float(np.median(dist2[near])), 1e-12))
        rel = ctx[near][:, free] / ctx_scale[free]
        d2 = np.sum((rel[:, None, :] - rel[None, :, :]) ** 2, axis=2)
        agreement = np.exp(-d2 / (2 * self.pc.context_support) ** 2) @ closeness
        travel = np.linalg.norm(rel - c[free] / ctx_scale[free], axis=1)
        best = int(np.argmax(closeness * agreement - 1e-3 * travel))
        needed = c.copy()
        weights = closeness * (d2[best] <= self.pc.agreement ** 2)
        needed[free] = self._relation_at((y[near] - delta) / y_scale, ctx[near][:, free],
                                         weights)
        if self.pc.relations_seen:
            needed = self._seen_relation(aff, needed, ctx[near][weights > 1e-6],
                                         ctx[near][best])
        if self.pc.solid_bodies:
            needed = self._out_of_bodies(aff, needed, relations)
        return needed

    def _out_of_bodies(self, aff: Affordance, needed: np.ndarray,
                       relations: np.ndarray) -> np.ndarray:
        """`needed` with each relative position of `relations` that places an object (not
        the robot) overlapping another — shorter than `relation_offset`, the reading at
        contact — brought to contact on its own bearing (`solid_bodies`). A young tool
        affordance asked for a tool 7.6 cm from its target's centre, 14 cm inside it: staged
        there, the tool shoved the target, the place behind it moved with every push, and the
        point's budget went to the chase. The robot's own place pressed into the object it
        pushes stands: its trip ends pushing, as the push's rows were made (brought out too,
        the tool task's robot-only share rose from 57.6 to 61.7 %, seven learners)."""
        staged = [sl for i, sl in _slices(aff) if relations[i]
                  and aff.contexts[i].relative_to not in (None, Role.ROBOT)
                  and aff.contexts[i].prop is Property.POSITION]
        if not staged or self.reader.relation_offset is None:
            return needed
        contact = self.reader.relation_offset
        out = needed.copy()
        for sl in staged:
            if 1e-9 < float(np.linalg.norm(needed[sl])) < contact:
                out[sl] = _at_length(needed[sl], contact)
        return out

    @staticmethod
    def _mirrored(aff: Affordance, ctx: np.ndarray, y: np.ndarray, delta: np.ndarray
                  ) -> tuple[np.ndarray, np.ndarray] | None:
        """`mirrored_relations`: the rows (contexts `ctx`, outcomes `y`) followed by their
        mirror images across the line of `delta` — every outcome, relative position and
        heading reflected, sizes and colours kept. The room's physics is the same in a mirror
        (round bodies, a robot whose wheels are alike), so a push seen from one side of its
        line shows the push from the other side too, and the relation fitted over both sides
        lies on the line. Fitted over the rows alone it lay a few degrees to the side the
        learner happened to push from, and a push from there left the narrow cone within
        which a pushed object moves with its pusher (docs/algorithm.md). None when `aff` has
        a context with no mirror image (an absolute position, the LIDAR) or an outcome that
        is not a 2-D vector."""
        length = float(np.linalg.norm(delta))
        if delta.shape[0] != 2 or length < 1e-12 or not is_vector(aff.output):
            return None
        if any(space.prop is Property.LIDAR or (space.prop is Property.POSITION
                                                and space.relative_to is None)
               for space in aff.contexts):
            return None
        vectors = [sl for i, sl in _slices(aff) if turns_with_scene(aff.contexts[i])]
        u = delta / length
        flip = 2.0 * np.outer(u, u) - np.eye(2)
        image = ctx.copy()
        for sl in vectors:
            image[:, sl] = ctx[:, sl] @ flip
        return np.concatenate([ctx, image]), np.concatenate([y, y @ flip])

    def _seen_relation(self, aff: Affordance, needed: np.ndarray, rows: np.ndarray,
                       best: np.ndarray) -> np.ndarray:
        """`needed` with each relative position shorter than every one of the `rows` it was
        fitted on (by more than their lengths' spread) replaced by that of the `best` row
        (`relations_seen`): rows from both sides of an object average to a relation inside
        it. Traced on a learner whose tool
        affordance's rows agreeing on a push held relations of 0.30-0.63 (0.30: in contact)
        from bearings that cancelled: their fit asked for 0.087, a tool 21 cm inside the
        target, and each tool placement shoved the target instead (0.93 at 2000, 0.16 at
        4000)."""
        if not rows.size:
            return needed
        out = needed.copy()
        for i, sl in _slices(aff):
            space = aff.contexts[i]
            if space.relative_to is None or space.prop is not Property.POSITION:
                continue
            lengths = np.linalg.norm(rows[:, sl], axis=1)
            if np.linalg.norm(needed[sl]) < lengths.min() - lengths.std():
                out[sl] = best[sl]
        return out

    @staticmethod
    def _relation_at(dy: np.ndarray, rel: np.ndarray, w: np.ndarray) -> np.ndarray:
        """The relation at the wanted outcome, from rows with normalised outcome offsets `dy`
        from it, relations `rel` and weights `w`: the intercept of a weighted linear
        fit rel ≈ a + B·dy (the neighbours' outcomes are never exactly the wanted one, and their
        relations differ with them: one row's relation was 10° off the push on average, the
        fit's 6°), or their weighted mean when too few rows weigh."""
        if int((w > 1e-6).sum()) < dy.shape[1] + 3:
            return (w @ rel) / max(float(w.sum()), 1e-12)
        sw = np.sqrt(w)[:, None]
        design = np.concatenate([np.ones((dy.shape[0], 1)), dy], axis=1)
        coef, *_ = np.linalg.lstsq(design * sw, rel * sw, rcond=None)
        return coef[0]

    def support_gap(self, aff: Affordance, x: np.ndarray, c: np.ndarray,
                    relations: np.ndarray, spreads: list[float] | None = None) -> float:
        """How far the data behind the forward prediction of `x` in context `c` are from `c`:
        the smallest relation gap (`_gap`) of the nearest stored rows *with an effect* in
        normalised (input, context). Rows where nothing moved support no effect: with them,
        a robot 0.45 m from an object looked supported for a push, and its inverse answer (an
        extrapolation) drove it past the object's side. The inverse model's own row is no
        test: its (outcome, context) search is led by the outcome. Rows of a model in a
        relation's frame are turned to the bearing of `c`'s relation first (`frames.seen`), as
        the model reads them. `spreads`: `_spreads(aff)`, when the caller has them already."""
        effect, xs, ctx, _ = seen_where(aff.model, self.config.zero_eps, at=c)
        if effect is None or effect.size < self.pc.support_neighbours:
            return np.inf
        scale = aff.model.scales().per_column()[:xs.shape[1] + ctx.shape[1]]
        z = np.concatenate([xs, ctx], axis=1) / scale
        q = np.concatenate([x, c]) / scale
        d2 = np.einsum("ij,ij->i", z - q, z - q)
        k = self.pc.support_neighbours
        nb = np.argpartition(d2, k - 1)[:k]
        spreads = self._spreads(aff) if spreads is None else spreads
        return float(self._gaps(aff, spreads, c, ctx[nb], relations).min())

    def _spreads(self, aff: Affordance) -> list[float]:
        """Per context space of `aff`: the norm of its per-column standard deviations over the
        rows with an effect (the places it acts from: near contact for a push), or all rows
        when fewer than two have one. Over all rows, a push's relation spreads over the whole
        room, and a robot 0.14 m off the side of an object counted as behind it. Rows are read
        as stored, not turned along one outcome: turned, a push's relation spreads 0.14 m
        instead of 0.34 m, and the planner re-placed the robot so often that pushing an
        object scored 0.85 instead of 0.91 (5 seeds). Kept per model until it has new rows."""
        return list(per_model_rows(aff.model, ("spreads", self.config.zero_eps),
                                   self._model_spreads))

    def _model_spreads(self, model) -> tuple[float, ...]:
        _, data, y = model.data()
        effect = self.effect(y)
        if effect.sum() >= 2:
            data = data[effect]
        spread = data.std(axis=0)
        out, offset = [], 0
        for dim in model.context_dims:
            out.append(max(float(np.linalg.norm(spread[offset:offset + dim])), 1e-6))
            offset += dim
        return tuple(out)

    def _as_near(self, aff: Affordance, c: np.ndarray, needed: np.ndarray,
                 relations: np.ndarray) -> np.ndarray:
        """`needed` with each relation of `relations` that `c` holds nearer (a shorter
        relation: the bodies closer, down to contact) brought to `c`'s length on its own
        bearing (`closer_places`): a pusher that closed in along the bearing it must push
        from stands where it must. Else `needed` unchanged. The rows a small push is chosen
        from began up to 9 cm short of contact; the push that closed that gap read as a
        pusher 9 cm off its place, and the next step sent it back there (a trip per push)."""
        if not self.pc.closer_places:
            return needed
        return _at_own_lengths(aff, c, needed, relations, further=False)

    def _at_contact(self, aff: Affordance, needed: np.ndarray,
                    relations: np.ndarray) -> np.ndarray:
        """`needed` with each relation of `relations` (those the planner drives) that reads a
        gap between the bodies brought to contact (plus `CONTACT_MARGIN`) on its own bearing
        (`contact_places`): the place a trip drives to. From a gap, the push's first action
        only closed it. With `pusher_contacts`, only a relation to the entity that pushes
        (the tool for a tool affordance, else the robot) is: a tool affordance that took the
        robot's relation to the target as its context (one learner did, until 2280) drove the
        robot against the target, which the tool task fails on contact."""
        if not (self.pc.contact_places and self.pc.closer_places):
            return needed
        offset = self.reader.relation_offset
        if offset is None:
            return needed
        pusher = Role.TOOL if aff.input.role is Role.TOOL else Role.ROBOT
        out = needed.copy()
        for i, sl in _slices(aff):
            if self.pc.pusher_contacts and aff.contexts[i].relative_to is not pusher:
                continue
            if relations[i] and float(np.linalg.norm(needed[sl])) > offset + CONTACT_MARGIN:
                out[sl] = _at_length(needed[sl], offset + CONTACT_MARGIN)
        return out

    @staticmethod
    def _gap(aff: Affordance, spreads: list[float], c: np.ndarray, other: np.ndarray,
             spaces: np.ndarray | None = None) -> float:
        """Largest distance between two contexts, per context space (of those in the mask
        `spaces`, all by default), in units of its spread (`_spreads`)."""
        return float(Planner._gaps(aff, spreads, c, other[None], spaces)[0])

    @staticmethod
    def _gaps(aff: Affordance, spreads: list[float], c: np.ndarray, others: np.ndarray,
              spaces: np.ndarray | None = None) -> np.ndarray:
        """`_gap` of `c` to each row of `others`."""
        gap = np.zeros(others.shape[0])
        for i, sl in _slices(aff):
            if spaces is not None and not spaces[i]:
                continue
            gap = np.maximum(gap, np.linalg.norm(others[:, sl] - c[sl], axis=1) / spreads[i])
        return gap

    def execute(self, space: RoleSpace, x: np.ndarray, b: Binding, actuator: Actuator,
                budget: int, depth: int, exclude: int = -1, facing: bool = False) -> int:
        """Produce the change `x` of the controllable `space`; returns actions used.
        `facing`: the robot's position is changed facing along `x` (either way along it), a
        pose the navigator reaches (`convoy_facing`)."""
        if space is ACTION:
            action = np.clip(x, -1.0, 1.0)
            if self.foresees_contact(b, action, actuator.obs) or self._idle_repeat(
                    action, actuator.obs):
                return -1
            self._act(actuator, action)
            return 1
        if depth >= self.pc.max_depth or budget <= 0:
            return -1
        if space == ROBOT_POSITION and self._navigating():
            mover = self.navigator.movers()[0]
            step = self.step_size(mover) if mover is not None else float(np.linalg.norm(x))
            goal = self.value(space, actuator.obs, b) + x
            place = Place(goal, _unit_heading(x) if facing else None,
                          max(self.pc.subgoal_tolerance * step, 0.005))
            done = self.navigate([place], b, actuator, min(budget, self.config.subgoal_budget))
            if done > 0:
                return done
            # The learned motion sees no way from here: the inverse model's way below.
        sub_b = Binding(target=b.tool, avoid=b.target) if space.role is Role.TOOL else b
        goal = self.value(space, actuator.obs, b) + x
        if self.pusher is not None and space.prop is Property.POSITION and space.role in (
                Role.TARGET, Role.TOOL):
            return self.pusher(sub_b.target, goal, sub_b.avoid, actuator,
                               min(budget, self.config.subgoal_budget))
        controllers = [a for a in self.h.controllers(space) if a.id != exclude]
        if not controllers:
            return -1
        sub = controllers[0]
        sub_budget = min(budget, self.config.subgoal_budget)
        return self.reach(sub, sub_b, goal, actuator, sub_budget, depth + 1).actions

    def _navigating(self) -> bool:
        return self.pc.navigation and self.navigator.available()

    def _keepouts(self, b: Binding, obs: np.ndarray, near: int = -1,
                  route: list[Place] | None = None) -> list[Keepout]:
        """The entity `b` says to avoid, with `avoid_margin`; and `near`, the object a place is
        taken next to, kept at contact distance but never further than any place of the
        `route` (a detour round the entity to avoid may pass closer to `near` than the last
        place: a keep-out beyond that waypoint left the robot turning back and forth, every
        way to it refused)."""
        robot_r = self.reader.entity_radius(obs, 0)
        out = []
        if b.avoid >= 0:
            # Never closer than the margin (not even going round it): the motion model's
            # errors near contact are those that touch the target.
            margin = self._avoid_distance(obs, b)
            out.append(Keepout(b.avoid, margin, margin))
        if near >= 0 and near != b.avoid and route:
            centre = self.reader.entity_position(obs, near)
            contact = robot_r + self.reader.entity_radius(obs, near) + CONTACT_MARGIN
            closest = min(float(np.linalg.norm(p.position - centre)) for p in route)
            out.append(Keepout(near, min(contact, closest - 0.005)))
        return out

    def navigate(self, places: list[Place], b: Binding, actuator: Actuator, budget: int,
                 near: int = -1, search: bool = False) -> int:
        """Drive the robot through `places` by the navigator; returns actions used (-1: it
        could not move at all). `search`: each place is reached by the trip search
        (`Navigator.route`) round every object, `near` the one it is taken next to."""
        used = 0
        for place in places:
            self.stack.append(Pursuit("navigate robot.position", place.position, b))
            try:
                used = self._drive(place, places, b, actuator, budget, near, used, search)
            finally:
                self.stack.pop()
        return used if used > 0 else -1

    def _drive(self, place: Place, route: list[Place], b: Binding, actuator: Actuator,
               budget: int, near: int, used: int, search: bool) -> int:
        while used < budget and not actuator.exhausted:
            if search:
                action = self.navigator.route(actuator.obs, place,
                                              self._obstacles(b, actuator.obs, near, place),
                                              b.target, b.tool)
            else:
                keep = self._keepouts(b, actuator.obs, near, route)
                action = self.navigator.choose(actuator.obs, place, keep, b.target, b.tool)
            if action is None:
                break
            self._act(actuator, action)
            used += 1
        return used

    def _obstacles(self, b: Binding, obs: np.ndarray, near: int, place: Place) -> Obstacles:
        """Every object as a disc the robot's centre keeps out of on a trip to `place`: at
        contact plus `CONTACT_MARGIN`; the entity `b` says to avoid at `_avoid_distance`; and
        `near`, the object the place is next to, no further than just short of the place."""
        robot_r = self.reader.entity_radius(obs, 0)
        n = len(self.reader.layout.entities)
        centres = np.array([self.reader.entity_position(obs, e) for e in range(1, n)])
        radii = np.array([robot_r + self.reader.entity_radius(obs, e) + CONTACT_MARGIN
                          for e in range(1, n)])
        if b.avoid >= 1:
            radii[b.avoid - 1] = self._avoid_distance(obs, b)
        if near >= 1 and near != b.avoid:
            radii[near - 1] = min(radii[near - 1],
                                  float(np.linalg.norm(place.position - centres[near - 1]))
                                  - 0.005)
        return Obstacles(centres.reshape(-1, 2), radii)

    def _act(self, actuator: Actuator, action: np.ndarray) -> None:
        """One primitive action, remembering whether it served a placement (`trips`) and
        whether it moved nothing (`_idle_repeat`)."""
        before = np.array(actuator.obs, dtype=float) if self.pc.skip_idle_repeats else None
        actuator.act(action)
        self._placed_for = frozenset(p.places for p in self.stack if p.places >= 0)
        self._convoy_acted = any(p.label == CONVOY_PURSUIT for p in self.stack)
        if before is None:
            return  # nothing is refused: no observation to keep
        after = np.array(actuator.obs, dtype=float)
        still = np.allclose(after, before, rtol=0.0, atol=IDLE_CHANGE)
        self._idle = (np.array(action, dtype=float), after) if still else None

    def _idle_repeat(self, action: np.ndarray, obs: np.ndarray) -> bool:
        """Whether `action` is the last primitive action again, from the observation it left
        unchanged (`skip_idle_repeats`): the planner decides from the observation alone, so
        it would repeat that action until the budget ran out. Traced in training: a robot
        backing into a fixed object 28 times, the last 28 actions of a tool goal's 40; in
        3.6-9.8 % of a run's actions the robot pushed on something that did not move."""
        return bool(self._idle_repeats(np.atleast_2d(action), obs)[0])

    def _idle_repeats(self, actions: np.ndarray, obs: np.ndarray) -> np.ndarray:
        """`_idle_repeat` of each row of `actions`, the observation compared once."""
        if not self.pc.skip_idle_repeats or self._idle is None:
            return np.zeros(actions.shape[0], dtype=bool)
        last, left = self._idle
        if not np.allclose(obs, left, rtol=0.0, atol=IDLE_CHANGE):
            return np.zeros(actions.shape[0], dtype=bool)
        return np.all(np.abs(actions - last) <= 1e-9, axis=1)

    def heading_for(self, move: np.ndarray, obs: np.ndarray, b: Binding) -> np.ndarray | None:
        """The heading from which the robot's learned motion produces the displacement `move`
        in one action (`nearest_pose` of the motion affordance), None if that affordance has
        no heading context."""
        mover = self.navigator.movers()[0]
        heading = ROBOT_HEADING
        if mover is None or heading not in mover.contexts or np.linalg.norm(move) < 1e-9:
            return None
        c = self.context(mover, obs, b)
        scale = self.step_size(mover) / max(float(np.linalg.norm(move)), 1e-9)
        pose = self.nearest_pose(mover, move * scale, c)
        return _unit_heading(_context_part(mover, pose, heading))

    def foresees_contact(self, b: Binding, action: np.ndarray, obs: np.ndarray) -> bool:
        """Whether the robot's own motion model predicts that `action` brings the robot within
        `avoid_margin` of the entity `b` says to avoid (half-way or at the end of the
        action)."""
        if b.avoid < 0:
            return False
        movers = [a for a in self.h.controllers(ROBOT_POSITION) if a.input is ACTION]
        if not movers:
            return False
        mover = movers[0]
        c = self.context(mover, obs, b)
        shift = mover.model.predict(action[None], c[None] if c.size else None)[0]
        robot = self.reader.entity_position(obs, 0)
        other = self.reader.entity_position(obs, b.avoid)
        reach = self._avoid_distance(obs, b)
        return any(np.linalg.norm(robot + f * shift - other) <= reach for f in (0.5, 1.0))

    def _avoid_distance(self, obs: np.ndarray, b: Binding) -> float:
        """The distance between centres the robot keeps from the entity `b` says to avoid:
        touching, plus `avoid_margin`."""
        return (self.reader.entity_radius(obs, 0) + self.reader.entity_radius(obs, b.avoid)
                + self.pc.avoid_margin)

    # ------------------------------------------------------------------ reaching contexts
    def _reach_context(self, aff: Affordance, b: Binding, needed: np.ndarray,
                       actuator: Actuator, budget: int, depth: int,
                       then: np.ndarray | None = None, facing: np.ndarray | None = None
                       ) -> int:
        """Move controllable context spaces of `aff` to the values `needed`. `then`: the input
        change `aff` will ask for from there (with navigation, the robot arrives facing the
        way that change moves it). `facing`: the heading a trip at its place goes on for
        (`face_places`): the robot's place is driven to even when it stands there."""
        used = 0
        spreads = self._spreads(aff)
        heading = self._needed_heading(aff, needed)
        for i, space, driven, goal, sub_b, controllers in self._context_plans(
                aff, b, needed, actuator.obs):
            current = self.value(driven, actuator.obs, sub_b)
            if np.linalg.norm(goal - current) < 0.25 * self.step_size(aff) + 0.02 and not (
                    facing is not None and driven == ROBOT_POSITION):
                continue
            if (driven == ROBOT_HEADING and heading is not None and self._navigating()
                    and line_angle(current, goal) <= self.pc.heading_tolerance):
                continue  # the robot arrived at its place facing the heading needed
            self.stack.append(Pursuit(f"place {space.name} for A{aff.id}", goal, b, aff.id))
            try:
                done = self._place(aff, b, i, driven, goal, sub_b, controllers[0], spreads,
                                   actuator, budget - used, depth, then,
                                   heading if facing is None else facing)
            finally:
                self.stack.pop()
            if done < 0:
                return used if used > 0 else -1
            used += done
            if used >= budget or actuator.exhausted:
                return used
        return used

    def _place(self, aff: Affordance, b: Binding, i: int, driven: RoleSpace, goal: np.ndarray,
               sub_b: Binding, sub: Affordance, spreads: list[float],
               actuator: Actuator, budget: int, depth: int, then: np.ndarray | None,
               heading: np.ndarray | None = None) -> int:
        """Drive `driven` (under `sub_b`) to `goal` so that `aff`'s context space `i` reads
        what it needs; returns actions used, -1 when the place is one the robot cannot take:
        where it would touch the entity it must avoid (a place behind a tool that lies in
        the target: going for it touched the target). `heading`: the robot's heading `aff`
        needs there (`pose_places`); else, for an affordance acting from the robot's position,
        the heading from which its motion makes the move `then`."""
        used = 0
        if driven == ROBOT_POSITION and b.avoid >= 0 and (
                np.linalg.norm(goal - self.reader.entity_position(actuator.obs, b.avoid))
                < self._avoid_distance(actuator.obs, b)):
            return -1
        if self.pc.room_places and not self._inside_room(goal, driven, sub_b, actuator.obs):
            return -1
        starting = not self._placed_for  # the planner replans every action: a trip goes on
        before = actuator.obs
        target_entity = sub_b.target if driven.role is not Role.ROBOT else -1
        waypoints = self._waypoints(driven, goal, actuator.obs, b, target_entity)
        space = aff.contexts[i]
        if driven == ROBOT_POSITION and self._navigating() and space.relative_to is not None:
            heading = self._trip_heading(aff, b, heading, then, actuator.obs)
            near = b.tool if space.role is Role.TOOL else b.target
            tolerance = max(self.pc.place_support * spreads[i], 0.005)
            places = [] if self.pc.route_search else [Place(w, None, 2 * tolerance)
                                                      for w in waypoints[:-1]]
            places.append(Place(goal, heading, tolerance))
            done = self.navigate(places, b, actuator, min(budget, self.config.goal_budget),
                                 near, search=self.pc.route_search)
            if done > 0:
                self._count_trip(starting, before)
                return done
            # The learned motion sees no way from here: the inverse model's way below.
        self._count_trip(starting, before)
        for waypoint in waypoints:
            attempt = self.reach(sub, sub_b, waypoint, actuator,
                                 min(budget - used, self.config.goal_budget), depth + 1)
            used += attempt.actions
            if used >= budget or actuator.exhausted:
                break
        return used

    def _inside_room(self, place: np.ndarray, driven: RoleSpace, b: Binding,
                     obs: np.ndarray) -> bool:
        """Whether the body `driven` moves (the robot, or `b`'s target) can stand at the
        position `place` (`room_places`): no nearer a wall than its radius. The room is the
        robot's position space, which the layout gives the learner."""
        if driven.prop is not Property.POSITION:
            return True
        body = 0 if driven.role is Role.ROBOT else b.target
        return self._fits_room(place, self.reader.entity_radius(obs, body))

    def _fits_room(self, centre: np.ndarray, radius: float, gap: float = 0.0) -> bool:
        """Whether a disc of `radius` centred at `centre` lies in the room with `gap` to
        spare from every wall: the room is the robot's position space (centred on 0)."""
        half = np.asarray(self.reader.layout.space(ROBOT, Property.POSITION).high)
        return bool(np.all(np.abs(centre) <= half - radius - gap))

    def _count_trip(self, starting: bool, obs: np.ndarray) -> None:
        """Count a trip that began from the observation `obs`, when it is a new one."""
        if starting:
            self.trip_starts.append(obs)

    def _context_plans(self, aff: Affordance, b: Binding, needed: np.ndarray, obs: np.ndarray
                       ) -> Iterator[tuple[int, RoleSpace, RoleSpace, np.ndarray, Binding,
                                           list[Affordance]]]:
        """For each context space of `aff` that can be driven to its part of `needed`: (its
        index, the space, the space to drive, the value to drive it to, under which binding,
        the affordances that can)."""
        offset = 0
        for i, space in enumerate(aff.contexts):
            dim = self.value(space, obs, b).shape[0]
            want = needed[offset:offset + dim]
            offset += dim
            plan = self._context_goal(space, want, obs, b)
            if plan is None:
                continue
            driven, goal, sub_b = plan
            drivers = self._drivers(aff, driven, sub_b, b)
            if drivers:
                yield i, space, driven, goal, sub_b, drivers

    def _context_goal(self, space: RoleSpace, want: np.ndarray, obs: np.ndarray,
                      b: Binding) -> tuple[RoleSpace, np.ndarray, Binding] | None:
        """Which controllable space to drive, to what value, so that `space` reads `want`."""
        if space.role is Role.ROBOT and space.prop in (Property.POSITION, Property.HEADING):
            return space, _normalise_heading(space, want), b
        if space.relative_to is None:
            return None
        anchor = self.value(RoleSpace(space.role, Property.POSITION), obs, b)
        offset = self.reader.offset_now(space, want, obs, b.target, b.tool)
        if space.relative_to is Role.ROBOT:
            return ROBOT_POSITION, anchor - offset, b
        if space.role is Role.TARGET and space.relative_to is Role.TOOL:
            tool_as_target = Binding(target=b.tool, avoid=b.target)
            return RoleSpace(Role.TARGET, Property.POSITION), anchor - offset, tool_as_target
        return None

    def _waypoints(self, driven: RoleSpace, goal: np.ndarray, obs: np.ndarray, b: Binding,
                   mover: int) -> list[np.ndarray]:
        """Go round the objects in the way (the object about to be pushed first of all, and
        any other: in `push-with-tool` touching the target directly fails) instead of
        through them; at most `max_detours` detours. An object (not the robot) with
        `line_stagings`: through a point on the push's line instead (`_back_on_line`)."""
        if driven.prop is not Property.POSITION or b.target < 0:
            return [goal]
        mover_entity = 0 if driven.role is Role.ROBOT else mover
        if mover_entity < 0:
            return [goal]
        obstacles = [e for e in range(1, len(self.reader.layout.entities)) if e != mover_entity]
        mover_radius = self.reader.entity_radius(obs, mover_entity)
        points: list[np.ndarray] = []
        start = self.reader.entity_position(obs, mover_entity)
        for _ in range(self.pc.max_detours):
            hit = self._first_obstacle(start, goal, obs, obstacles, mover_radius)
            if hit is None:
                break
            if self.pc.line_stagings and mover_entity > 0 and not points:
                back = self._back_on_line(start, goal, obs, obstacles, mover_radius, b.target)
                if back is not None:
                    return back
            centre, clearance = hit
            a0 = np.arctan2(*(start - centre)[::-1])
            a1 = np.arctan2(*(goal - centre)[::-1])
            turn = (a1 - a0 + np.pi) % (2 * np.pi) - np.pi
            radius = clearance + 0.05
            for frac in (1 / 3, 2 / 3):
                ang = a0 + frac * turn
                points.append(centre + radius * np.array([np.cos(ang), np.sin(ang)]))
            start = points[-1]
        return [*points, goal]

    def _back_on_line(self, start: np.ndarray, goal: np.ndarray, obs: np.ndarray,
                      obstacles: list[int], mover_radius: float, target: int
                      ) -> list[np.ndarray] | None:
        """`line_stagings`' way for an object from `start` to the place `goal` it pushes
        `target` from, when something is in the straight way: through the nearest point
        further back on the push's line (from `target`'s centre through `goal`), in steps of
        `LINE_STEP` up to `LINE_REACH`, that lies clear of every object and whose straight
        way from `start` clears them too, and from there along the line. None when no such
        point leaves the object and its pusher behind it inside the room."""
        away = goal - self.reader.entity_position(obs, target)
        length = float(np.linalg.norm(away))
        if length < 1e-9:
            return None
        u = away / length
        robot_r = self.reader.entity_radius(obs, 0)
        discs = Obstacles(np.array([self.reader.entity_position(obs, e) for e in obstacles]),
                          np.array([self._clearance(obs, e, mover_radius) for e in obstacles]))
        for back in np.arange(1, round(LINE_REACH / LINE_STEP) + 1) * LINE_STEP:
            point = goal + back * u
            pusher = point + (mover_radius + robot_r) * u
            if not (self._fits_room(point, mover_radius, WALL_GAP)
                    and self._fits_room(pusher, robot_r, WALL_GAP)):
                return None  # further back is further out of the room
            if discs.holds(point):
                continue
            if self._first_obstacle(start, point, obs, obstacles, mover_radius) is None:
                return [point, goal]
        return None

    def _first_obstacle(self, start: np.ndarray, goal: np.ndarray, obs: np.ndarray,
                        obstacles: list[int], mover_radius: float
                        ) -> tuple[np.ndarray, float] | None:
        """(centre, clearance) of the first obstacle the segment start → goal passes too close
        to, if any. An obstacle met only at the very end (the goal is next to the object to
        push) is not in the way."""
        seg = goal - start
        length2 = float(seg @ seg)
        if length2 < 1e-12:
            return None
        first: tuple[float, int] | None = None
        for e in obstacles:
            centre = self.reader.entity_position(obs, e)
            clearance = self._clearance(obs, e, mover_radius)
            s = float(np.clip((centre - start) @ seg / length2, 0.0, 1.0))
            if s >= 0.95 or np.linalg.norm(start + s * seg - centre) >= clearance:
                continue
            if first is None or s < first[0]:
                first = (s, e)
        if first is None:
            return None
        return self._cluster(first[1], obs, obstacles, mover_radius)

    def _clearance(self, obs: np.ndarray, entity: int, mover_radius: float) -> float:
        """How far (between centres) a mover of `mover_radius` keeps from `entity` going
        round it: touching, plus `approach_margin`."""
        return self.reader.entity_radius(obs, entity) + mover_radius + self.pc.approach_margin

    def _cluster(self, first: int, obs: np.ndarray, obstacles: list[int],
                 mover_radius: float) -> tuple[np.ndarray, float]:
        """The disc (centre, clearance) round the obstacle `first` and every other whose
        clearance overlaps it, one after another: no way passes between them, so a detour
        goes round them all. Round the target alone, a detour led between the target and a
        tool against it, to a waypoint inside the tool."""
        centre = self.reader.entity_position(obs, first)
        clearance = self._clearance(obs, first, mover_radius)
        members = {first}
        grown = True
        while grown:
            grown = False
            for e in obstacles:
                if e in members:
                    continue
                c = self.reader.entity_position(obs, e)
                r = self._clearance(obs, e, mover_radius)
                d = float(np.linalg.norm(c - centre))
                if d >= clearance + r:
                    continue
                members.add(e)
                grown = True
                if d + r > clearance:  # the smallest disc holding both
                    new = 0.5 * (d + r + clearance)
                    centre = centre + (c - centre) / max(d, 1e-12) * (new - clearance)
                    clearance = new
        return centre, clearance
