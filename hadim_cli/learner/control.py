"""Closed-loop control through the chain of learned affordances: one action per decision.

`Chain.next_action` decides one primitive action from the current observation, from the top
of the chain down (e.g. A2 `tool.position → target.position`, then A1 `robot.position →
target.position` on the tool, then the robot's own motion), and is asked again after every
action. Each level remembers only its *mode*:

- **push**: the level's inverse model, in the current context, gives the change of its input
  that moves its output one step towards its goal; the level below is asked for that change
  (down to the robot's motion, where the navigator picks the wheel command);
- **place**: the current context (e.g. the robot behind the object, the tool behind the
  target) is not one the step is produced from, and a trip to the needed one is worth its
  cost (`Planner._worth_replacing`): the robot drives there by its learned motion, arriving
  facing the way the push goes (`Navigator`), or the tool is brought there by the level below,
  round the objects in the way. Then back to push.

A level leaves push only by that cost rule, so the robot keeps pushing while roughly aligned
and steers the contact every action instead of re-placing for each small correction; a level
that has just been placed pushes at least once before it may re-place again. Nothing is
random; only the learned models and the observation are used.
"""

from __future__ import annotations

import enum
from dataclasses import dataclass, field

import numpy as np

from hadim_cli.learner.affordance import Affordance
from hadim_cli.learner.navigation import Place
from hadim_cli.learner.planner import Pursuit
from hadim_cli.learner.spaces import ACTION, Role, RoleSpace

ROBOT_POSITION_NAME = "robot.position"


class Mode(enum.StrEnum):
    PUSH = "push"
    PLACE = "place"


@dataclass
class _PlacePlan:
    """A trip to the context a level needs: robot places, or waypoints of an object moved by
    `driver` under `binding`."""

    places: list[Place] = field(default_factory=list)
    near: int = -1
    waypoints: list[np.ndarray] = field(default_factory=list)
    driver: Affordance | None = None
    binding: object = None
    index: int = 0


@dataclass
class _State:
    key: tuple
    mode: Mode = Mode.PUSH
    plan: _PlacePlan | None = None
    pushes_since_place: int = 1
    trips: int = 0
    failed: int = 0
    """Trips in a row after which the level still could not push."""


class Chain:
    """Drives `aff`'s output (under binding `b`) to `goal`, one primitive action at a time."""

    def __init__(self, planner, aff: Affordance, b, goal: np.ndarray, start: float):
        self.p = planner
        self.aff, self.b, self.goal = aff, b, goal
        self.start = start
        self.states: dict[int, _State] = {}
        self.trips = 0
        """Trips to a place taken so far (all levels)."""
        self.pursued: list[Pursuit] = []
        """What each level pursued in the last decision, outermost first."""

    def next_action(self, obs: np.ndarray) -> np.ndarray | None:
        self.pursued = []
        return self._level(self.aff, self.b, self.goal, obs, 0, must_act=False)

    # ------------------------------------------------------------------ one level
    def _state(self, depth: int, aff: Affordance, b) -> _State:
        key = (aff.id, b)
        state = self.states.get(depth)
        if state is None or state.key != key:
            state = _State(key)
            self.states[depth] = state
            for deeper in [d for d in self.states if d > depth]:
                del self.states[deeper]
        return state

    def _tolerance(self, aff: Affordance, depth: int) -> float:
        p = self.p
        if depth == 0:
            return max(p.config.reach_tolerance * self.start, p.config.zero_eps)
        return max(p.pc.subgoal_tolerance * p.step_size(aff), p.config.zero_eps)

    def _level(self, aff: Affordance, b, goal: np.ndarray, obs: np.ndarray, depth: int,
               must_act: bool) -> np.ndarray | None:
        """The action that moves `aff`'s output towards `goal`; None when there (and not
        `must_act`: a level asked for one step of change always tries) or when it cannot."""
        p = self.p
        if depth >= p.pc.max_depth or aff.model.n < 2:
            return None
        current = p.value(aff.output, obs, b)
        gap = goal - current
        dist = float(np.linalg.norm(gap))
        if not must_act and dist <= self._tolerance(aff, depth):
            return None
        if dist < 1e-9:
            return None
        step = p.step_size(aff)
        delta = gap if dist <= step else gap * (step / dist)
        mode = "" if aff.input is ACTION else f" [{self._state(depth, aff, b).mode}]"
        self.pursued.append(Pursuit(f"A{aff.id} {aff.input.name} → {aff.output.name}{mode}",
                                    goal, b))
        if aff.input is ACTION:
            return self._primitive(aff, b, goal, delta, obs)
        state = self._state(depth, aff, b)
        if state.mode is Mode.PLACE:
            action = self._place(state, b, obs, depth)
            if action is not None:
                return action
            state.mode, state.plan, state.pushes_since_place = Mode.PUSH, None, 0
        c = p.context(aff, obs, b)
        here = aff.model.infer(delta, c if c.size else None)
        progress = 1.0 - np.linalg.norm(here.y_predicted - delta) / max(float(
            np.linalg.norm(delta)), 1e-9)
        relations = p.reachable_relations(aff)
        # Right after a trip the level pushes from where it arrived, unless it cannot push at
        # all (then one more trip, at most twice in a row).
        may_replace = state.pushes_since_place > 0 or (progress <= 0.0 and state.failed < 2)
        if relations.any() and may_replace:
            spreads = p._spreads(aff)
            supported = (p.support_gap(aff, here.x, c, relations, spreads)
                         <= p.pc.place_support)
            needed = p.needed_context(aff, delta, c, relations)
            off = p._gap(aff, spreads, c, needed, relations)
            if off > p.pc.place_support and p._worth_replacing(
                    aff, b, needed, delta, obs, progress if supported else 0.0, off,
                    dist / max(step, 1e-9)):
                plan = self._plan_place(aff, b, delta, needed, obs)
                if plan is not None:
                    state.mode, state.plan = Mode.PLACE, plan
                    state.trips += 1
                    self.trips += 1
                    action = self._place(state, b, obs, depth)
                    if action is not None:
                        return action
                    state.mode, state.plan = Mode.PUSH, None
        if progress <= 0.0:
            state.failed += 1
            return None
        state.pushes_since_place += 1
        state.failed = 0
        return self._input_change(aff, b, here.x, obs, depth)

    def _primitive(self, aff: Affordance, b, goal: np.ndarray, delta: np.ndarray,
                   obs: np.ndarray) -> np.ndarray | None:
        p = self.p
        if aff.output.name == ROBOT_POSITION_NAME and p._navigating():
            place = Place(goal, None, 0.0)
            return p.navigator.choose(obs, place, p._keepouts(b, obs), b.target, b.tool)
        c = p.context(aff, obs, b)
        here = aff.model.infer(delta, c if c.size else None)
        action = np.clip(here.x, -1.0, 1.0)
        if p.foresees_contact(b, action, obs):
            return None
        return action

    def _input_change(self, aff: Affordance, b, x: np.ndarray, obs: np.ndarray, depth: int
                      ) -> np.ndarray | None:
        """Ask the level below for the change `x` of `aff`'s input space."""
        p = self.p
        space: RoleSpace = aff.input
        controllers = [a for a in p.h.controllers(space) if a.id != aff.id]
        if not controllers:
            return None
        sub = controllers[0]
        sub_b = type(b)(target=b.tool, avoid=b.target) if space.role is Role.TOOL else b
        goal = p.value(space, obs, b) + x
        return self._level(sub, sub_b, goal, obs, depth + 1, must_act=True)

    # ------------------------------------------------------------------ places
    def _plan_place(self, aff: Affordance, b, delta: np.ndarray, needed: np.ndarray,
                    obs: np.ndarray) -> _PlacePlan | None:
        p = self.p
        spreads = p._spreads(aff)
        offset = 0
        for i, space in enumerate(aff.contexts):
            dim = p.value(space, obs, b).shape[0]
            want = needed[offset:offset + dim]
            offset += dim
            target = p._context_goal(space, want, obs, b)
            if target is None:
                continue
            driven, goal, sub_b = target
            drivers = p._drivers(aff, driven, sub_b, b)
            if not drivers:
                continue
            mover = sub_b.target if driven.role is not Role.ROBOT else -1
            waypoints = p._waypoints(driven, goal, obs, b, mover)
            tolerance = max(p.pc.place_support * spreads[i], 0.005)
            if driven.name == ROBOT_POSITION_NAME and p._navigating():
                then = aff.model.infer(delta, needed).x
                heading = p.heading_for(then, obs, b) if aff.input == driven else None
                places = [Place(w, None, 2 * tolerance) for w in waypoints[:-1]]
                places.append(Place(goal, heading, tolerance))
                near = b.tool if space.role is Role.TOOL else b.target
                return _PlacePlan(places=places, near=near)
            return _PlacePlan(waypoints=waypoints, driver=drivers[0], binding=sub_b)
        return None

    def _place(self, state: _State, b, obs: np.ndarray, depth: int) -> np.ndarray | None:
        """The next action of the trip in `state.plan`; None when it is over."""
        p = self.p
        plan = state.plan
        if plan is None:
            return None
        if plan.places:
            while plan.index < len(plan.places):
                place = plan.places[plan.index]
                keep = p._keepouts(b, obs, plan.near, plan.places[-1].position)
                action = p.navigator.choose(obs, place, keep, b.target, b.tool)
                if action is not None:
                    last = plan.index == len(plan.places) - 1
                    self.pursued.append(Pursuit(
                        "navigate to the place" if last else "navigate round an object",
                        place.position, b))
                    return action
                plan.index += 1
            return None
        while plan.index < len(plan.waypoints):
            action = self._level(plan.driver, plan.binding, plan.waypoints[plan.index], obs,
                                 depth + 1, must_act=False)
            if action is not None:
                return action
            plan.index += 1
        return None
