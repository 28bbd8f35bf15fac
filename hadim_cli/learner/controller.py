"""The controller: a goal of an affordance turned into primitive actions by one search.

H gives a chain from the goal's affordance down to the primitive action: the affordance whose
output the goal is in (`tool.position → target.position`), the affordance that drives its
input (`robot.position → tool.position`, with the tool as its target), and so on until an
affordance whose input is the primitive action (`action → robot.position`). Every action,
`Controller.act` searches over short sequences of primitive actions (a beam `horizon` deep),
imagining each through the chain's forward models — the action moves the robot, the robot's
move moves the tool, the tool's move moves the target — and takes the first action of the
sequence whose imagined end costs least. It replans after every action (receding horizon).

The cost is the estimated number of actions still to go: the goal entity's way to the goal in
its affordance's steps, plus, level by level, each mover's way to the place its affordance
acts from (`places.needed_context`: the tool at the target's far side, the robot behind the
tool), in steps of the level that moves it, round the bodies in between. A mover that turns
(it has an `action → heading` affordance) pays its turns too. Where a mover is on its way to
its place, the level below it is asked to move it there; where it is in place, to move it as
the inverse model says its affordance needs. Going round the tool, re-placing it and pushing
on along a line all come out of this one search: nothing in it names a robot, a tool or a
trip.

Hard constraints prune imagined actions: bodies may touch, never overlap (by more than
`clearance`, for the models' error); the entity a binding forbids (the target, while a tool
moves it) is kept `clearance` clear of; moving apart is always allowed (how a robot wedged
beside an object gets out); every body stays inside the world's bounds. Where every action
looks no better than standing still, the pursuit learns that its estimate there falls short
and raises it (learning real-time search), so the search walks out of the hollow; a
pursuit ends at its budget, or once it lost ground since it began and cannot finish in the
actions left. The controller draws no random numbers and changes nothing in the learner.
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np

from hadim_cli.config import LearnerConfig, PlannerConfig
from hadim_cli.learner.affordance import Affordance, typical_step
from hadim_cli.learner.competence import split_zero
from hadim_cli.learner.frames import is_vector
from hadim_cli.learner.goals import Actuator, Attempt, Binding
from hadim_cli.learner.hierarchy import Hierarchy
from hadim_cli.learner.places import context_slices, needed_context
from hadim_cli.learner.spaces import ACTION, Property, Role, RoleSpace, SpaceReader


class Level(NamedTuple):
    """One affordance of the chain under its binding: its output belongs to `moved`, its
    input to `mover` (-1: the primitive action); `relation`: the columns of its context
    relating the two (None: none), the place it acts from."""

    affordance: Affordance
    binding: Binding
    moved: int
    mover: int
    relation: slice | None


@dataclass
class Pursuit:
    """What the controller keeps between the actions of one goal."""

    affordance: Affordance
    binding: Binding
    goal: np.ndarray
    start: float
    """The output's distance to the goal when the pursuit began."""
    budget: float = np.inf
    """Actions it may take."""
    used: int = 0
    """Actions taken so far."""
    first: float = np.inf
    """Its estimate of actions to go before its first action."""
    levels: tuple[Level, ...] | None = None
    """Its chain (`Controller.chain`), found at its first action: H does not change during
    a pursuit."""
    places: dict[tuple[int, bytes], tuple[np.ndarray, np.ndarray | None]] = field(
        default_factory=dict)
    """Per affordance and its contexts' values other than the relation it acts from, the
    place and input `places.needed_context` read off its rows (the models do not change
    during a pursuit)."""
    seen: list[np.ndarray] = field(default_factory=list)
    """The states acted from (bodies' positions in steps, heading in turns: `_key`)."""
    raised: list[float] = field(default_factory=list)
    """Per state of `seen`, what the search learned its estimate falls short by: the
    least estimate of its successors plus the action, less its own (learning real-time
    search, Korf 1990)."""
    tried: list[tuple[np.ndarray, int, np.ndarray]] = field(default_factory=list)
    """What its commands did: per action taken, the state it was taken from (`_key`), the
    command (its index in `Controller.commands`) and the change it made to the bottom
    level's output, observed at the next action."""
    last: tuple[np.ndarray, int] | None = None
    """The observation the last action was taken from, and its command's index."""


@dataclass(frozen=True)
class Decision:
    """The trace of one action: what the search saw (for an observer; nothing reads it
    back)."""

    action: np.ndarray
    to_go: float
    """Estimated actions to go before the action."""
    predicted: float
    """The chosen sequence's estimated actions, its own included."""
    label: str
    """What the action serves: the lowest level whose mover is off its place
    ("place tool for A6"), else the goal's own affordance."""
    gaps: tuple[float, ...] = field(default_factory=tuple)
    """Per level with a place, its mover's distance to it (m)."""


@dataclass
class _Plan:
    """One action's view of the chain: each level's step, and the place and input of each
    level for an outcome along (1, 0), turned to each imagined outcome's direction."""

    levels: tuple[Level, ...]
    goal: np.ndarray
    steps: np.ndarray
    turner: Affordance | None
    """The affordance turning the mover at the bottom (None: it does not turn)."""
    turn: float
    """Its typical turn per action (rad; inf: it does not turn)."""
    places: list[np.ndarray | None]
    inputs: list[np.ndarray | None]


class _Found(NamedTuple):
    """What one search found: the command to take (its index in `Controller.commands`, -1:
    none allowed) and its sequence's estimated actions; the estimate from the observation
    (`now`), what the pursuit learned raises it by there, and each level's gap and the label
    for the trace."""

    command: int
    predicted: float
    now: float
    raised: float
    gaps: tuple[float, ...]
    label: str


def _rotate(v: np.ndarray, u: np.ndarray) -> np.ndarray:
    """`v` (2,) turned from (1, 0) to each unit direction of `u` (M, 2)."""
    return np.stack([u[:, 0] * v[0] - u[:, 1] * v[1], u[:, 1] * v[0] + u[:, 0] * v[1]], 1)


def _unit(v: np.ndarray) -> np.ndarray:
    n = np.linalg.norm(v, axis=-1, keepdims=True)
    return np.where(n > 1e-12, v / np.maximum(n, 1e-12), 0.0)


def _line_angle(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Angle (0..π/2) between the lines along unit rows of `a` and `b` (either way counts)."""
    return np.arccos(np.clip(np.abs(np.sum(a * b, axis=-1)), 0.0, 1.0))


def _turned(u: np.ndarray, angle: np.ndarray) -> np.ndarray:
    c, s = np.cos(angle), np.sin(angle)
    return np.stack([c * u[:, 0] - s * u[:, 1], s * u[:, 0] + c * u[:, 1]], 1)


def detour(frm: np.ndarray, to: np.ndarray, centres: np.ndarray, radii: np.ndarray
           ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Length of the shortest way from each `frm` to its `to` (both (M, 2)) that goes round
    the discs (`centres` (M, K, 2), `radii` (M, K)) in between — along the tangents and the
    arc of the disc whose detour is longest — with the directions it starts and arrives in.
    A start within a disc counts as on its rim; a disc holding the end is no obstacle."""
    way = to - frm
    dist = np.linalg.norm(way, axis=1)
    first = _unit(way)
    if centres.shape[1] == 0:
        return dist, first, first.copy()
    rel = frm[:, None] - centres
    end = np.linalg.norm(to[:, None] - centres, axis=2)
    s = np.clip(-np.einsum("mkd,md->mk", rel, way) / np.maximum(dist ** 2, 1e-12)[:, None],
                0.0, 1.0)
    near = rel + s[..., None] * way[:, None]
    d0 = np.maximum(np.linalg.norm(rel, axis=2), radii)
    # Only a way that comes nearer the centre than it starts, into the disc, goes round.
    hit = (np.einsum("mkd,mkd->mk", near, near) < radii ** 2) & (s > 1e-9) & (end > radii)
    if not hit.any():
        return dist, first, first.copy()
    u0 = _unit(rel)
    u1 = _unit(to[:, None] - centres)
    apart = np.arccos(np.clip(np.einsum("mkd,mkd->mk", u0, u1), -1.0, 1.0))
    a0 = np.arccos(np.minimum(radii / np.maximum(d0, 1e-12), 1.0))
    a1 = np.arccos(np.minimum(radii / np.maximum(end, 1e-12), 1.0))
    around = (np.sqrt(np.maximum(d0 ** 2 - radii ** 2, 0.0))
              + np.sqrt(np.maximum(end ** 2 - radii ** 2, 0.0))
              + radii * np.maximum(apart - a0 - a1, 0.0))
    around = np.where(hit, around, -np.inf)
    k = np.argmax(around, axis=1)
    rows = np.arange(frm.shape[0])
    longest = around[rows, k]
    longer = longest > dist
    c, r, u0k, u1k = centres[rows, k], radii[rows, k], u0[rows, k], u1[rows, k]
    a0k, a1k, d0k = a0[rows, k], a1[rows, k], d0[rows, k]
    side = np.where(u0k[:, 0] * u1k[:, 1] - u0k[:, 1] * u1k[:, 0] >= 0, 1.0, -1.0)
    touch = c + r[:, None] * _turned(u0k, side * a0k)
    tangent = np.stack([-side * u0k[:, 1], side * u0k[:, 0]], 1)
    start = np.where((d0k <= r * (1 + 1e-9))[:, None], tangent, _unit(touch - frm))
    leave = c + r[:, None] * _turned(u1k, -side * a1k)
    length = np.where(longer, longest, dist)
    return (length, np.where(longer[:, None], start, first),
            np.where(longer[:, None], _unit(to - leave), first))


class Controller:
    """Turns goals of affordances into primitive actions (paper §4.3, 'TransformToPrimitive';
    see the module doc). `predict`: forward predictions to use instead of a level's learned
    model, by the level's input space name — only for evaluation (`evaluation.exact`)."""

    def __init__(self, hierarchy: Hierarchy, reader: SpaceReader, config: LearnerConfig,
                 planner: PlannerConfig | None = None):
        self.h = hierarchy
        self.reader = reader
        self.config = config
        self.pc = PlannerConfig() if planner is None else planner
        dim = reader.dim(ACTION)
        axis = np.linspace(-1.0, 1.0, self.pc.commands)  # (every world's box is [-1, 1]^dim)
        axis = np.sign(axis) * np.abs(axis) ** 1.5  # finer near standing still
        grid = np.stack(np.meshgrid(*[axis] * dim, indexing="ij"), -1).reshape(-1, dim)
        self.commands = grid[np.linalg.norm(grid, axis=1) > 1e-9]
        """The primitive actions the search tries: `commands` values per component of the
        action, every combination of them but standing still."""
        self._fine = float(np.min(np.abs(axis[np.abs(axis) > 1e-9])))
        """The finest command's share of a full one: states nearer than half of it (in
        actions) are one state to the learned estimates (`_raised`)."""
        self.observer: Callable[[Decision], None] | None = None
        """Handed each action's `Decision` (evaluation records them)."""
        self.stand_ins: dict[str, Callable[[np.ndarray, np.ndarray, np.ndarray], np.ndarray]] = {}
        """Per input space name, predictions (input changes, contexts' observations, binding
        entities) → output changes replacing that level's model (`evaluation.exact`)."""
        layout = reader.layout
        self._positions = np.array([layout.space(e, Property.POSITION).start
                                    for e in layout.entities])
        self._position_columns = self._positions[:, None] + np.arange(2)
        self._relative_columns = layout.object_columns(Property.RELATIVE)
        self._radius_columns = np.array([layout.space(e, Property.RADIUS).start
                                         for e in layout.entities])
        bounds = layout.space(layout.entities[0], Property.POSITION)
        self._low, self._high = np.asarray(bounds.low), np.asarray(bounds.high)

    # ------------------------------------------------------------------ public contract
    def pursue(self, aff: Affordance, binding: Binding, goal: np.ndarray,
               obs: np.ndarray, budget: float = np.inf) -> Pursuit:
        """A new pursuit of `goal` (an absolute value of `aff`'s output) from `obs`, in at
        most `budget` actions."""
        goal = np.asarray(goal, dtype=float)
        if aff.output.prop is Property.HEADING:
            goal = goal / max(float(np.linalg.norm(goal)), 1e-9)
        start = float(np.linalg.norm(goal - self._value(aff.output, obs, binding)))
        return Pursuit(aff, binding, goal, start, budget)

    def act(self, obs: np.ndarray, pursuit: Pursuit) -> np.ndarray | None:
        """The next primitive action towards the pursuit's goal; None when the goal is
        reached, the chain cannot act, or the pursuit has lost ground since it began (its
        estimate of actions to go, raised by what it learned, above the first) and that
        estimate exceeds the actions left: a goal beyond the budget is still pursued as far
        as it goes."""
        aff, b = pursuit.affordance, pursuit.binding
        dist = float(np.linalg.norm(pursuit.goal - self._value(aff.output, obs, b)))
        if dist <= max(self.config.reach_tolerance * pursuit.start, self.config.zero_eps):
            return None
        if pursuit.used >= pursuit.budget:
            return None
        plan = self._plan(obs, pursuit)
        if plan is None:
            return None
        self._learn_what_it_did(obs, plan, pursuit)
        found = self._search(obs, plan, pursuit)
        here = found.now + found.raised
        if pursuit.used == 0:
            pursuit.first = here
        elif here > pursuit.budget - pursuit.used and here > pursuit.first:
            return None  # lost ground since it began, and not expected within the actions left
        if found.command < 0:
            return None
        action = self.commands[found.command].copy()
        # What the estimate here fell short by is learned, so that a state the search keeps
        # coming back to looks as far as it proved to be.
        if found.predicted > here + 1e-9:
            pursuit.seen.append(self._key(obs[None], plan)[0])
            pursuit.raised.append(found.predicted - found.now)
        pursuit.last = (obs.copy(), found.command)
        pursuit.used += 1
        if self.observer is not None:
            self.observer(Decision(action.copy(), found.now, found.predicted, found.label,
                                   found.gaps))
        return action

    def reach(self, aff: Affordance, binding: Binding, goal: np.ndarray, actuator: Actuator,
              budget: int) -> Attempt:
        """Pursue `goal` with `actuator` until reached, given up or `budget` actions."""
        pursuit = self.pursue(aff, binding, goal, actuator.obs, budget)
        while pursuit.used < budget and not actuator.exhausted:
            action = self.act(actuator.obs, pursuit)
            if action is None:
                break
            actuator.act(action)
        final = float(np.linalg.norm(pursuit.goal
                                     - self._value(aff.output, actuator.obs, binding)))
        return Attempt(pursuit.start, final, pursuit.used)

    def chain(self, aff: Affordance, binding: Binding) -> tuple[Level, ...] | None:
        """The levels from `aff` down to an affordance of the primitive action, each
        driving the input of the one above (none twice); None when some input has no driver
        with data. Drivers are tried most competent first, and the first chain that can
        bring about every relation its levels act from (both entities of each moved by the
        chain) is taken, else the first found: an affordance of the action on a body that
        acts only beside the robot leaves no level to bring the robot there."""
        return self._chain((), aff, binding)

    def _chain(self, above: tuple[Level, ...], aff: Affordance, binding: Binding
               ) -> tuple[Level, ...] | None:
        levels = (*above, self._level(aff, binding))
        if aff.input is ACTION:
            return levels
        space = aff.input
        if space.role is Role.TOOL:
            binding = Binding(target=binding.tool, avoid=binding.target)
        used = {lv.affordance.id for lv in levels}
        found = None
        for driver in self.h.controllers(space):
            if (driver.id in used or driver.model.n < 2
                    or (binding.tool < 0 and driver.has_tool)):
                continue
            chain = self._chain(levels, driver, binding)
            if chain is None:
                continue
            if _complete(chain):
                return chain
            found = found or chain
        return found

    # ------------------------------------------------------------------ the chain
    def _level(self, aff: Affordance, b: Binding) -> Level:
        relation = None
        if aff.input is not ACTION and aff.input.prop is Property.POSITION:
            for space, sl in zip(aff.contexts, context_slices(aff), strict=True):
                if space.role is aff.output.role and space.relative_to is aff.input.role:
                    relation = sl
                    break
        mover = -1 if aff.input is ACTION else _entity(aff.input.role, b)
        return Level(aff, b, _entity(aff.output.role, b), mover, relation)

    def _value(self, space: RoleSpace, obs: np.ndarray, b: Binding) -> np.ndarray:
        return self.reader.value_now(space, obs, b.target, b.tool)

    def _contexts(self, aff: Affordance, arr: np.ndarray, b: Binding) -> np.ndarray | None:
        if not aff.contexts:
            return None
        return self.reader.read_each(aff.contexts, arr, b.target, b.tool)

    def _step(self, aff: Affordance) -> float:
        return max(typical_step(aff, self.pc.step_quantile, self.config.zero_eps), 1e-3)

    def _turner(self, entity: int) -> Affordance | None:
        """The most competent affordance of the primitive action on the heading of
        `entity`'s role (None: it does not turn)."""
        if entity != 0:
            return None
        found = [a for a in self.h.with_output(RoleSpace(Role.ROBOT, Property.HEADING))
                 if a.input is ACTION and a.model.n >= 2]
        return max(found, key=lambda a: a.competence, default=None)

    def _plan(self, obs: np.ndarray, pursuit: Pursuit) -> _Plan | None:
        if pursuit.levels is None:
            pursuit.levels = self.chain(pursuit.affordance, pursuit.binding)
        levels = pursuit.levels
        if levels is None:
            return None
        steps = np.array([self._step(lv.affordance) for lv in levels])
        turner = self._turner(levels[-1].moved)
        turn = np.inf if turner is None else 2 * np.arcsin(min(self._step(turner) / 2, 1.0))
        places, inputs = [], []
        for lv, step in zip(levels, steps, strict=True):
            place = x = None
            if lv.relation is not None:
                aff = lv.affordance
                c = self._contexts(aff, obs[None], lv.binding)[0]
                driven = np.array([sl == lv.relation for sl in context_slices(aff)])
                key = (aff.id, np.delete(c, np.r_[lv.relation]).tobytes())
                if key not in pursuit.places:
                    need, x = needed_context(aff, np.array([step, 0.0]), c, driven,
                                             zero_eps=self.config.zero_eps,
                                             k=2 * self.config.k_inverse,
                                             support=self.pc.context_support,
                                             agreement=self.pc.agreement)
                    pursuit.places[key] = (need[lv.relation], x)
                place, x = pursuit.places[key]
                contact = self.reader.relation_offset
                if contact is not None:
                    # Bodies act on each other in contact: the place is the relation's
                    # bearing at contact (the rows' lengths tell where approaches began).
                    place = place * (contact / max(float(np.linalg.norm(place)), 1e-9))
            places.append(place)
            inputs.append(x)
        return _Plan(levels, pursuit.goal, steps, turner, turn, places, inputs)

    # ------------------------------------------------------------------ imagining
    def _imagine(self, arr: np.ndarray, plan: _Plan, pursuit: Pursuit
                 ) -> tuple[np.ndarray, np.ndarray]:
        """Every command from each observation of `arr` (M, D), imagined through the chain:
        the observations after (M·N, D), and the mask of those the hard constraints allow.
        A command the pursuit took from near a state does there what it did (`_did`)."""
        n = self.commands.shape[0]
        before = np.repeat(arr, n, 0)
        after = before.copy()
        x = np.tile(self.commands, (arr.shape[0], 1))
        for lv in reversed(plan.levels):
            aff, b = lv.affordance, lv.binding
            c = self._contexts(aff, before, b)
            stand_in = self.stand_ins.get(aff.input.name)
            if stand_in is not None:
                y = stand_in(x, before, np.array([lv.moved, lv.mover]))
            elif lv.mover >= 0 and aff.input.prop is Property.POSITION:
                # Only a mover that reaches the body moves it: the rest are not asked.
                y = np.zeros((x.shape[0], aff.model.dy))
                hit = np.flatnonzero(self._reaches(before, lv, x))
                if hit.size:
                    y[hit] = aff.model.predict(x[hit], None if c is None else c[hit])
            else:
                y = aff.model.predict(x, c)
            if aff.input is ACTION:
                self._did(arr, plan, pursuit, y)
            self._write(after, lv.moved, aff.output.prop, y)
            x = y
        bottom, turner = plan.levels[-1], plan.turner
        if turner is not None and turner.output != bottom.affordance.output:
            stand_in = self.stand_ins.get("heading")
            acts = np.tile(self.commands, (arr.shape[0], 1))
            y = (stand_in(acts, before, np.array([0, -1])) if stand_in is not None
                 else turner.model.predict(acts, self._contexts(turner, before, Binding())))
            self._write(after, bottom.moved, Property.HEADING, y)
        after[:, self._relative_columns] = (after[:, self._position_columns[1:]]
                                            - after[:, None, self._position_columns[0]])
        return after, self._allowed(before, after, plan.levels)

    def _reaches(self, arr: np.ndarray, lv: Level, x: np.ndarray) -> np.ndarray:
        """Whether the mover of `lv`, moved by `x` from where it is in `arr`, would overlap
        the body it moves on the way (by more than `zero_eps`): only then does it push it (a
        move along its rim slides by; the model's rows from further are pushes through a
        third body)."""
        pos, radii = self._bodies(arr)
        start, centre = pos[:, lv.mover], pos[:, lv.moved]
        length2 = np.maximum(np.sum(x * x, 1), 1e-12)
        s = np.clip(np.sum((centre - start) * x, 1) / length2, 0.0, 1.0)
        nearest = np.linalg.norm(start + s[:, None] * x - centre, axis=1)
        touch = radii[:, lv.mover] + radii[:, lv.moved] - self.config.zero_eps
        return (nearest <= touch) & ~split_zero(x, self.config.zero_eps)

    def _write(self, arr: np.ndarray, entity: int, prop: Property, change: np.ndarray) -> None:
        lay = self.reader.layout
        sl = lay.space(lay.entities[entity], prop).slice
        if prop is Property.HEADING:
            arr[:, sl] = _unit(arr[:, sl] + change)
        else:
            arr[:, sl] += change

    def _bodies(self, arr: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Every entity's position (M, E, 2) and radius (M, E) in `arr`."""
        return arr[:, self._position_columns], arr[:, self._radius_columns]

    def _allowed(self, before: np.ndarray, after: np.ndarray, levels: tuple[Level, ...]
                 ) -> np.ndarray:
        """The hard constraints: see the module doc."""
        p0, radii = self._bodies(before)
        p1, _ = self._bodies(after)
        moved = np.flatnonzero(np.any(np.abs(p1 - p0) > 1e-9, axis=(0, 2)))
        ok = np.ones(before.shape[0], dtype=bool)
        if moved.size == 0:
            return ok
        # Bodies may touch, never overlap; the entity a binding forbids its mover is kept
        # clear of. Moving apart is always allowed.
        forbidden = np.zeros((moved.size, p0.shape[1]), dtype=bool)
        for lv in levels:
            if lv.binding.avoid >= 0:
                pair = (lv.mover if lv.mover >= 0 else lv.moved, lv.binding.avoid)
                for i, j in (pair, pair[::-1]):
                    forbidden[moved == i, j] = True
        least = (radii[:, moved, None] + radii[:, None, :]
                 + np.where(forbidden, self.pc.clearance, -self.pc.clearance))
        d0 = np.linalg.norm(p0[:, moved, None] - p0[:, None], axis=3)
        d1 = np.linalg.norm(p1[:, moved, None] - p1[:, None], axis=3)
        fine = (d1 >= least) | (d1 >= d0 - 1e-6)
        fine[:, np.arange(moved.size), moved] = True  # a body and itself
        ok &= fine.all(axis=(1, 2))
        q0, q1, r = p0[:, moved], p1[:, moved], radii[:, moved, None]
        inside = ((q1 - r >= self._low) & (q1 + r <= self._high)).all(2)
        ok &= (inside | (np.abs(q1).max(2) <= np.abs(q0).max(2))).all(1)
        return ok

    # ------------------------------------------------------------------ the cost
    def _to_go(self, arr: np.ndarray, plan: _Plan, trace: bool = False):
        """Estimated actions to go from each observation of `arr` (M, D) (see the module
        doc); with `trace`, also each level's gap to its place and the label of the first
        observation."""
        levels, steps = plan.levels, plan.steps
        top = levels[0]
        pos, radii = self._bodies(arr)
        out = self.reader.read_each((top.affordance.output,), arr, top.binding.target,
                                    top.binding.tool)
        way = plan.goal - out
        gaps: list[float] = []
        label = f"A{top.affordance.id} {top.affordance.output.name}"
        if top.affordance.output.prop is Property.POSITION and top.moved >= 0:
            length, u, _ = self._way(pos, radii, top.moved, plan.goal[None], levels)
        else:
            length, u = np.linalg.norm(way, axis=1), _unit(way)
        cost = length / steps[0]
        # What the movers below must do weighs as much as the step it serves: to move the
        # goal entity less than a step, a mover need not be exactly in place.
        share = np.clip(length / steps[0], 0.0, 1.0)
        if top.mover < 0 and top.affordance.output.prop is Property.POSITION:
            cost = cost + share * self._turns(arr, plan, top.moved, u)
        for i, lv in enumerate(levels[:-1]):
            if lv.relation is None or plan.places[i] is None or not is_vector(lv.affordance.output):
                continue
            turned = _rotate(plan.places[i], u)
            if self.reader.relation_offset is not None:
                contact = radii[:, lv.moved] + radii[:, lv.mover]
                norm = np.maximum(np.linalg.norm(turned, axis=1), 1e-9)
                centre = np.maximum(norm - self.reader.relation_offset + contact, 1e-3)
                turned = turned * (centre / norm)[:, None]
            place = pos[:, lv.moved] - turned
            gap, toward, arrive = self._way(pos, radii, lv.mover, place, levels)
            low = steps[i + 1]
            cost = cost + share * gap / low
            push = _unit(_rotate(plan.inputs[i], u)) if plan.inputs[i] is not None else u
            w = np.clip(gap / low, 0.0, 1.0)
            u = _unit(w[:, None] * toward + (1.0 - w[:, None]) * push)
            if i + 2 < len(levels):
                # On the way, the mover is moved along the way; in place, along the push:
                # its own mover will have to go round it from one side to the other.
                under = levels[i + 1].mover
                turn = np.arccos(np.clip(np.sum(arrive * push, 1), -1.0, 1.0))
                round_it = (radii[:, lv.mover] + radii[:, under]) * turn
                cost = cost + share * w * round_it / steps[i + 2]
            if levels[i + 1].mover < 0:
                cost = cost + share * self._turns(arr, plan, lv.mover, u)
            if trace:
                gaps.append(float(gap[0]))
                if gap[0] > low:
                    label = f"place {lv.affordance.input.role.value} for A{lv.affordance.id}"
        if trace:
            return cost, tuple(gaps), label
        return cost

    def _way(self, pos: np.ndarray, radii: np.ndarray, entity: int, to: np.ndarray,
             levels: tuple[Level, ...]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """`detour` of `entity` from where it is to `to` round every other body but those
        that move it (they travel with it)."""
        others, acted_on = _obstacles(tuple((lv.moved, lv.mover) for lv in levels), entity,
                                      pos.shape[1])
        frm = pos[:, entity]
        to = np.broadcast_to(to, frm.shape)
        keep = radii[:, entity, None] + radii[:, others] + self.pc.clearance
        # The body it acts on is gone round at contact: its place lies just there.
        keep[:, acted_on] -= self.pc.clearance + 1e-3
        return detour(frm, to, pos[:, others], keep)

    def _turns(self, arr: np.ndarray, plan: _Plan, entity: int, u: np.ndarray) -> np.ndarray:
        """Actions a turning mover needs to face the line of `u` (0 for one that does not
        turn)."""
        if not np.isfinite(plan.turn) or entity != 0:
            return np.zeros(arr.shape[0])
        lay = self.reader.layout
        heading = _unit(arr[:, lay.space(lay.entities[0], Property.HEADING).slice])
        return _line_angle(heading, u) / plan.turn

    # ------------------------------------------------------------------ the search
    def _search(self, obs: np.ndarray, plan: _Plan, pursuit: Pursuit) -> _Found:
        """The estimate from `obs`, and the first command of the sequence (at most `horizon`
        deep, `beam` kept per depth) whose imagined end has the least actions used plus
        estimated to go (the estimate raised where the pursuit learned it falls short), with
        that total; no command when the constraints allow none. The observation is costed
        with its first successors, in one pass."""
        n = self.commands.shape[0]
        after, ok = self._imagine(obs[None], plan, pursuit)
        after, origin = after[ok], np.flatnonzero(ok)
        rows = np.concatenate([obs[None], after])
        estimate, gaps, label = self._to_go(rows, plan, trace=True)
        raised = self._raised(rows, plan, pursuit)
        now, here_raised = float(estimate[0]), float(raised[0])
        to_go = estimate[1:] + raised[1:]
        best: tuple[float, int] | None = None
        states, first = obs[None], np.zeros(1, dtype=np.int64)
        for depth in range(1, self.pc.horizon + 1):
            if depth > 1:
                after, ok = self._imagine(states, plan, pursuit)
                after, origin = after[ok], np.repeat(first, n)[ok]
                to_go = self._to_go(after, plan) + self._raised(after, plan, pursuit)
            if after.shape[0] == 0:
                break
            total = depth + to_go
            i = int(np.argmin(total))
            if best is None or total[i] < best[0] - 1e-9:
                best = (float(total[i]), int(origin[i]))
            keep = np.argsort(total, kind="stable")[:self.pc.beam]
            states, first = after[keep], origin[keep]
        if best is None:
            return _Found(-1, np.inf, now, here_raised, gaps, label)
        return _Found(best[1], best[0], now, here_raised, gaps, label)

    def _key(self, arr: np.ndarray, plan: _Plan) -> np.ndarray:
        """Where the chain's bodies are in each observation of `arr`, in actions: positions
        in the bottom level's steps, a turning mover's heading in its turns."""
        pos, _ = self._bodies(arr)
        entities = sorted({lv.moved for lv in plan.levels})
        key = [pos[:, entities].reshape(arr.shape[0], -1) / plan.steps[-1]]
        if np.isfinite(plan.turn):
            lay = self.reader.layout
            h = arr[:, lay.space(lay.entities[0], Property.HEADING).slice]
            key.append(np.arctan2(h[:, 1:2], h[:, 0:1]) / plan.turn)
        return np.concatenate(key, 1)

    def _apart(self, arr: np.ndarray, plan: _Plan, keys: list[np.ndarray]) -> np.ndarray:
        """How far (M, R) each observation of `arr` is from each state of `keys` (`_key`), in
        actions: the largest of the bodies' moves and the turn between them."""
        key, seen = self._key(arr, plan), np.stack(keys)
        diff = key[:, None, :] - seen[None, :, :]
        if np.isfinite(plan.turn):
            diff[..., -1] = (diff[..., -1] + np.pi / plan.turn) % (2 * np.pi / plan.turn) \
                - np.pi / plan.turn
        return np.max(np.abs(diff), axis=2)

    def _raised(self, arr: np.ndarray, plan: _Plan, pursuit: Pursuit) -> np.ndarray:
        """What the pursuit learned the estimate falls short by at each observation of
        `arr`: the most of the states it acted from within half the finest command of it."""
        if not pursuit.seen:
            return np.zeros(arr.shape[0])
        near = self._apart(arr, plan, pursuit.seen) <= self._fine / 2
        return np.max(np.where(near, np.asarray(pursuit.raised)[None, :], 0.0), axis=1)

    def _learn_what_it_did(self, obs: np.ndarray, plan: _Plan, pursuit: Pursuit) -> None:
        """Keep what the last command did to the bottom level's output (`Pursuit.tried`)."""
        if pursuit.last is None:
            return
        before, command = pursuit.last
        bottom = plan.levels[-1]
        space, b = bottom.affordance.output, bottom.binding
        change = self._value(space, obs, b) - self._value(space, before, b)
        pursuit.tried.append((self._key(before[None], plan)[0], command, change))
        pursuit.last = None

    def _did(self, arr: np.ndarray, plan: _Plan, pursuit: Pursuit, y: np.ndarray) -> None:
        """Replace in `y` (M·N, output) the bottom level's predictions of every command the
        pursuit took from within half a step of an observation of `arr` (M, D) by what it did
        there, the nearest such state's: where the model is wrong (an arm pressing a joint
        against its limit, a robot against a fixed body), the search learns it from the
        actions that proved it, and stops asking for the same move."""
        if not pursuit.tried:
            return
        keys, commands, changes = zip(*pursuit.tried, strict=True)
        apart = self._apart(arr, plan, list(keys))
        n = self.commands.shape[0]
        commands = np.asarray(commands)
        for command in np.unique(commands):
            mine = np.flatnonzero(commands == command)
            nearest = mine[np.argmin(apart[:, mine], axis=1)]
            rows = np.flatnonzero(apart[np.arange(arr.shape[0]), nearest] <= 0.5)
            y[rows * n + command] = np.asarray(changes)[nearest[rows]]

@functools.lru_cache(maxsize=64)
def _obstacles(chain: tuple[tuple[int, int], ...], entity: int, n_entities: int
               ) -> tuple[np.ndarray, np.ndarray]:
    """The bodies `entity` goes round in a chain of (moved, mover) levels (every other but
    those that move it: they travel with it), and which of them it acts on (read-only)."""
    below = [i for i, (moved, _) in enumerate(chain) if moved == entity]
    movers = {mover for _, mover in chain[below[0]:]} if below else set()
    others = np.array([j for j in range(n_entities) if j != entity and j not in movers],
                      dtype=np.int64)
    moves = {moved for moved, mover in chain if mover == entity}
    acted_on = np.array([j in moves for j in others], dtype=bool)
    others.flags.writeable = acted_on.flags.writeable = False
    return others, acted_on


def _complete(levels: tuple[Level, ...]) -> bool:
    """Whether the chain moves both entities of every relation its levels act from."""
    moved = {lv.moved for lv in levels}
    return all(_entity(space.role, lv.binding) in moved
               and _entity(space.relative_to, lv.binding) in moved
               for lv in levels for space in lv.affordance.contexts
               if space.relative_to is not None)


def _entity(role: Role, b: Binding) -> int:
    if role is Role.ROBOT:
        return 0
    return b.target if role is Role.TARGET else b.tool

