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

from dataclasses import dataclass
from typing import Protocol

import numpy as np

from hadim_cli.config import LearnerConfig
from hadim_cli.learner.affordance import Affordance, typical_step
from hadim_cli.learner.hierarchy import Hierarchy
from hadim_cli.learner.spaces import ACTION, Property, Role, RoleSpace, SpaceReader

MAX_DEPTH = 4
STEP_QUANTILE = 0.9
"""Sub-goals are cut to this quantile of an affordance's non-null outcome norms."""
CONTEXT_SUPPORT = 0.1
"""Contexts further apart than this (in spreads of the context space) are not the same."""
APPROACH_MARGIN = 0.06


class Actuator(Protocol):
    """Executes primitive actions: the world during training (recording D) or evaluation."""

    @property
    def obs(self) -> np.ndarray: ...

    @property
    def exhausted(self) -> bool: ...

    def act(self, action: np.ndarray) -> np.ndarray: ...


@dataclass(frozen=True)
class Binding:
    """Entity indices filling an affordance's roles (-1: unbound)."""

    target: int = -1
    tool: int = -1


@dataclass(frozen=True)
class Attempt:
    """The result of trying to reach one goal."""

    start_distance: float
    final_distance: float
    actions: int

    @property
    def competence(self) -> float:
        if self.start_distance <= 1e-9:
            return 1.0
        return 1.0 - min(1.0, self.final_distance / self.start_distance)


def _normalise_heading(space: RoleSpace, value: np.ndarray) -> np.ndarray:
    if space.prop is Property.HEADING:
        n = np.linalg.norm(value)
        return value / n if n > 1e-9 else np.array([1.0, 0.0])
    return value


class Planner:
    """Turns goals of affordances into primitive actions (paper §4.3, 'TransformToPrimitive')."""

    def __init__(self, hierarchy: Hierarchy, reader: SpaceReader, config: LearnerConfig):
        self.h = hierarchy
        self.reader = reader
        self.config = config

    # ------------------------------------------------------------------ reading the state
    def value(self, space: RoleSpace, obs: np.ndarray, b: Binding) -> np.ndarray:
        return self.reader.value_now(space, obs, b.target, b.tool)

    def context(self, aff: Affordance, obs: np.ndarray, b: Binding) -> np.ndarray:
        if not aff.contexts:
            return np.zeros(0)
        return np.concatenate([self.value(c, obs, b) for c in aff.contexts])

    def step_size(self, aff: Affordance) -> float:
        """The typical size of one step of `aff`: a high quantile of its non-null outcomes."""
        return typical_step(aff, STEP_QUANTILE, self.config.zero_eps)

    # ------------------------------------------------------------------ reaching goals
    def reach(self, aff: Affordance, b: Binding, goal: np.ndarray, actuator: Actuator,
              budget: int, depth: int = 0) -> Attempt:
        """Drive `aff`'s output (under binding `b`) towards the absolute value `goal`."""
        goal = _normalise_heading(aff.output, np.asarray(goal, dtype=float))
        start = float(np.linalg.norm(goal - self.value(aff.output, actuator.obs, b)))
        used = 0
        stalls = 0
        while used < budget and not actuator.exhausted:
            current = self.value(aff.output, actuator.obs, b)
            gap = goal - current
            dist = float(np.linalg.norm(gap))
            if dist <= max(self.config.reach_tolerance * start, self.config.zero_eps):
                break
            step = self.step_size(aff)
            delta = gap if dist <= step else gap * (step / dist)
            done = self._one_step(aff, b, delta, actuator, budget - used, depth)
            used += max(done, 0)
            if done <= 0:
                stalls += 1
                if stalls >= 2 or done < 0:
                    break
            else:
                stalls = 0
        final = float(np.linalg.norm(goal - self.value(aff.output, actuator.obs, b)))
        return Attempt(start, final, used)

    def _one_step(self, aff: Affordance, b: Binding, delta: np.ndarray, actuator: Actuator,
                  budget: int, depth: int) -> int:
        """Execute one planned step; returns actions used (-1: nothing can be done)."""
        if aff.model.n < 2:
            return -1
        obs = actuator.obs
        c = self.context(aff, obs, b)
        here = aff.model.infer(delta, c if c.size else None)
        progress = 1.0 - np.linalg.norm(here.y_predicted - delta) / max(np.linalg.norm(delta),
                                                                         1e-9)
        # The inverse answer is only trusted where such outcomes were seen: if the current
        # context is far from the context of the data it comes from, reach that context first.
        unsupported = (self._has_reachable_relation(aff)
                       and self.context_gap(aff, c, here.context) > CONTEXT_SUPPORT)
        if (progress < 0.3 or unsupported) and aff.contexts and depth < MAX_DEPTH:
            anywhere = aff.model.infer(delta)
            used = self._reach_context(aff, b, anywhere.context, actuator, budget, depth)
            if used > 0:
                return used
        if progress <= 0.0:
            return -1
        return self.execute(aff.input, here.x, b, actuator, budget, depth, exclude=aff.id)

    def _has_reachable_relation(self, aff: Affordance) -> bool:
        """Whether `aff` has a relative-position context (e.g. target-robot) another affordance
        can drive. Only such spatial relations are checked for support: for the robot's own
        pose (heading) the progress test suffices, and turning first at every step costs more
        than it gives."""
        for space in aff.contexts:
            if space.relative_to is None:
                continue
            probe = Binding(0 if aff.has_target else -1, 0 if aff.has_tool else -1)
            plan = self._context_goal(space, np.zeros(2), np.zeros(self.reader.layout.size),
                                      probe)
            if plan is not None and plan[0] != aff.output and [
                    a for a in self.h.controllers(plan[0]) if a.id != aff.id]:
                return True
        return False

    def context_gap(self, aff: Affordance, c: np.ndarray, other: np.ndarray) -> float:
        """Largest distance between two contexts, per context space, in units of its spread."""
        if not aff.contexts or c.size == 0:
            return 0.0
        _, data, _ = aff.model.data()
        spread = data.std(axis=0)
        gap, offset = 0.0, 0
        for dim in aff.model.context_dims:
            sl = slice(offset, offset + dim)
            scale = max(float(np.linalg.norm(spread[sl])), 1e-6)
            gap = max(gap, float(np.linalg.norm(c[sl] - other[sl])) / scale)
            offset += dim
        return gap

    def execute(self, space: RoleSpace, x: np.ndarray, b: Binding, actuator: Actuator,
                budget: int, depth: int, exclude: int = -1) -> int:
        """Produce the change `x` of the controllable `space`; returns actions used."""
        if space is ACTION:
            actuator.act(np.clip(x, -1.0, 1.0))
            return 1
        if depth >= MAX_DEPTH or budget <= 0:
            return -1
        controllers = [a for a in self.h.controllers(space) if a.id != exclude]
        if not controllers:
            return -1
        sub = controllers[0]
        sub_b = Binding(target=b.tool) if space.role is Role.TOOL else b
        goal = self.value(space, actuator.obs, b) + x
        sub_budget = min(budget, self.config.subgoal_budget)
        return self.reach(sub, sub_b, goal, actuator, sub_budget, depth + 1).actions

    # ------------------------------------------------------------------ reaching contexts
    def _reach_context(self, aff: Affordance, b: Binding, needed: np.ndarray,
                       actuator: Actuator, budget: int, depth: int) -> int:
        """Move controllable context spaces of `aff` to the values `needed`."""
        used = 0
        offset = 0
        for space in aff.contexts:
            dim = self.value(space, actuator.obs, b).shape[0]
            want = needed[offset:offset + dim]
            offset += dim
            plan = self._context_goal(space, want, actuator.obs, b)
            if plan is None:
                continue
            driven, goal, sub_b = plan
            if driven == aff.output:
                continue  # moving its own output is what `aff` is for, not a precondition
            current = self.value(driven, actuator.obs, sub_b)
            if np.linalg.norm(goal - current) < 0.25 * self.step_size(aff) + 0.02:
                continue
            controllers = [a for a in self.h.controllers(driven) if a.id != aff.id]
            if not controllers:
                continue
            sub = controllers[0]
            target_entity = sub_b.target if driven.role is not Role.ROBOT else -1
            for waypoint in self._waypoints(driven, goal, actuator.obs, b, target_entity):
                attempt = self.reach(sub, sub_b, waypoint, actuator,
                                     min(budget - used, self.config.goal_budget), depth + 1)
                used += attempt.actions
                if used >= budget or actuator.exhausted:
                    return used
        return used

    def _context_goal(self, space: RoleSpace, want: np.ndarray, obs: np.ndarray,
                      b: Binding) -> tuple[RoleSpace, np.ndarray, Binding] | None:
        """Which controllable space to drive, to what value, so that `space` reads `want`."""
        robot_pos = RoleSpace(Role.ROBOT, Property.POSITION)
        if space.role is Role.ROBOT and space.prop in (Property.POSITION, Property.HEADING):
            return space, _normalise_heading(space, want), b
        if space.relative_to is Role.ROBOT:
            anchor = self.value(RoleSpace(space.role, Property.POSITION), obs, b)
            return robot_pos, anchor - want, b
        if space.role is Role.TARGET and space.relative_to is Role.TOOL:
            anchor = self.value(RoleSpace(Role.TARGET, Property.POSITION), obs, b)
            tool_as_target = Binding(target=b.tool)
            return RoleSpace(Role.TARGET, Property.POSITION), anchor - want, tool_as_target
        return None

    def _waypoints(self, driven: RoleSpace, goal: np.ndarray, obs: np.ndarray, b: Binding,
                   mover: int) -> list[np.ndarray]:
        """Go round the object we are about to push instead of through it."""
        if driven.prop is not Property.POSITION or b.target < 0:
            return [goal]
        mover_entity = 0 if driven.role is Role.ROBOT else mover
        if mover_entity < 0:
            return [goal]
        start = self.reader.entity_position(obs, mover_entity)
        obstacle = b.target if mover_entity != b.target else b.tool
        if obstacle < 0:
            return [goal]
        centre = self.reader.entity_position(obs, obstacle)
        clearance = (self.reader.entity_radius(obs, obstacle)
                     + self.reader.entity_radius(obs, mover_entity) + APPROACH_MARGIN)
        seg = goal - start
        length2 = float(seg @ seg)
        if length2 < 1e-12:
            return [goal]
        s = float(np.clip((centre - start) @ seg / length2, 0.0, 1.0))
        if s >= 0.95 or np.linalg.norm(start + s * seg - centre) >= clearance:
            return [goal]
        a0 = np.arctan2(*(start - centre)[::-1])
        a1 = np.arctan2(*(goal - centre)[::-1])
        turn = (a1 - a0 + np.pi) % (2 * np.pi) - np.pi
        radius = clearance + 0.05
        points = []
        for frac in (1 / 3, 2 / 3):
            ang = a0 + frac * turn
            points.append(centre + radius * np.array([np.cos(ang), np.sin(ang)]))
        return [*points, goal]
