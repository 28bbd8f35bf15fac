"""Spaces written by role, so an affordance generalises across objects.

A concrete observation space is (entity, property) — `obj3.position`. An affordance is written
with *roles* instead of entities: `robot.position`, `target.position`, `target-robot` (the
position of the affected object relative to the robot), `tool.position`, `target-tool`, … A
`Binding` fills the roles (which object is the target, which the tool) and turns a role space
into columns of the flat observation vectors of D.
"""

from __future__ import annotations

import enum
import re
from dataclasses import dataclass
from functools import cached_property

import numpy as np

from hadim_cli.world.actions import ActionSpace
from hadim_cli.world.layout import VISUAL_PROPERTIES, ObservationLayout, Property


class Role(enum.StrEnum):
    """Who a space belongs to in an affordance."""

    ACTION = "action"
    ROBOT = "robot"
    """The actor (entity 0): the body's own part that acts on the objects, whatever the world
    calls it (the rover's `robot`, the arm's `effector`)."""
    TARGET = "target"
    """The object whose property the affordance changes."""
    TOOL = "tool"
    """An object through which the affordance acts on the target."""


@dataclass(frozen=True, order=True)
class RoleSpace:
    """A space of an affordance: `role.prop`, or `role - relative_to` for relative positions."""

    role: Role
    prop: Property | None = None
    relative_to: Role | None = None

    @property
    def name(self) -> str:
        if self.role is Role.ACTION:
            return "action"
        if self.relative_to is not None:
            return f"{self.role.value}-{self.relative_to.value}"
        assert self.prop is not None
        return f"{self.role.value}.{self.prop.value}"

    @property
    def roles(self) -> frozenset[Role]:
        out = {self.role}
        if self.relative_to is not None:
            out.add(self.relative_to)
        return frozenset(out - {Role.ACTION})

    def __str__(self) -> str:
        return self.name


ACTION = RoleSpace(Role.ACTION)
ROBOT_POSITION = RoleSpace(Role.ROBOT, Property.POSITION)
ROBOT_HEADING = RoleSpace(Role.ROBOT, Property.HEADING)


def parse_space(name: str) -> RoleSpace:
    """Inverse of `RoleSpace.name`."""
    if name == "action":
        return ACTION
    if "-" in name:
        role, other = name.split("-", 1)
        return RoleSpace(Role(role), Property.POSITION, Role(other))
    role, prop = name.split(".", 1)
    return RoleSpace(Role(role), Property(prop))


def shown_as(text: str, actor: str) -> str:
    """`text` — a space's stored name, or words holding such names and roles (a controller's
    label, `place robot for A2`, an affordance's `describe()`, `A1(robot.position → …)`) — as
    a reader of a run of this world wants it: the actor's
    role called what the world calls its actor (`robot.joints` → `effector.joints`,
    `target-robot` → `target-effector`); the rover's text unchanged. For display only: runs
    store, and `parse_space` reads, the role's own name."""
    if actor == Role.ROBOT.value:
        return text
    return " ".join(_shown_word(word, actor) for word in text.split(" "))


def _shown_word(word: str, actor: str) -> str:
    head, core, tail = _WORD.fullmatch(word).groups("")  # type: ignore[union-attr]
    return head + _shown_name(core, actor) + tail


_WORD = re.compile(r"(A\d+\(|\()?(.*?)([),]*)", re.DOTALL)
"""A word of a description: an affordance's `A1(` or a bracket before, brackets and commas
after, the name between."""


def _shown_name(word: str, actor: str) -> str:
    if word == Role.ROBOT.value:
        return actor
    try:
        space = parse_space(word)
    except ValueError:
        return word
    if space.role is Role.ACTION:
        return word

    def role(r: Role) -> str:
        return actor if r is Role.ROBOT else r.value

    if space.relative_to is not None:
        return f"{role(space.role)}-{role(space.relative_to)}"
    assert space.prop is not None
    return f"{role(space.role)}.{space.prop.value}"


def actor_contexts(layout: ObservationLayout) -> tuple[Property, ...]:
    """The actor's properties that can tell two situations apart: every one the world declares
    for it but its looks (which never change), in name order — the rover's heading, LIDAR and
    position, the arm's joints, orientation and position."""
    return tuple(sorted((s.prop for s in layout.spaces
                         if s.entity == layout.actor and s.prop not in VISUAL_PROPERTIES),
                        key=lambda p: p.value))


# Spaces whose change an affordance may predict (its output), those the world declares
# (`SpaceReader.declares`: the heading where the actor has one). Relative positions are fixed
# functions of two absolute positions and LIDAR a function of the room: they serve as contexts
# only, which keeps H from filling with trivial correlations (see docs/algorithm.md).
OUTPUT_SPACES: tuple[RoleSpace, ...] = (
    RoleSpace(Role.ROBOT, Property.POSITION),
    RoleSpace(Role.ROBOT, Property.HEADING),
    RoleSpace(Role.TARGET, Property.POSITION),
)
OPEN_OUTPUT_SPACES: tuple[RoleSpace, ...] = (*OUTPUT_SPACES, RoleSpace(Role.ROBOT, Property.LIDAR))
"""With `learner.open_outputs`: the LIDAR as well. (Objects have no heading; the tool's
position is `target.position` under another binding; a relative position's change would be
read raw, which `Fitter.values` does not do for outputs.)"""


OBJECT_PROPERTIES: tuple[Property, ...] = (
    Property.POSITION, Property.RADIUS, Property.HEIGHT, Property.COLOR, Property.SHAPE)
"""An object's observed spaces (its position relative to the robot comes as `role-robot`)."""


def context_candidates(roles: frozenset[Role],
                       actor: tuple[Property, ...]) -> tuple[RoleSpace, ...]:
    """Every context space that can be read for an affordance involving `roles`, as the
    paper's Algorithm 2 has them: the actor's properties `actor` (`actor_contexts`: the
    rover's heading, LIDAR and position); every observed space of each bound object (absolute
    position, radius, height, colour, shape) and its position relative to the actor; the
    target's position relative to the tool."""
    out: list[RoleSpace] = [RoleSpace(Role.ROBOT, prop) for prop in actor]
    props = OBJECT_PROPERTIES
    for role in (Role.TARGET, Role.TOOL):
        if role not in roles:
            continue
        out.append(RoleSpace(role, Property.POSITION, Role.ROBOT))
        out.extend(RoleSpace(role, p) for p in props)
    if {Role.TARGET, Role.TOOL} <= roles:
        out.append(RoleSpace(Role.TARGET, Property.POSITION, Role.TOOL))
    return tuple(out)


@dataclass(frozen=True)
class Rows:
    """Rows of an affordance's data: iteration indices into D and the binding of each row.

    `target` and `tool` hold entity indices of the layout (0 is the robot, -1 unbound).
    `borrowed` marks rows whose outcome is read in `borrowed_space` of the affordance's output
    instead of the output itself: data of another output that matched the affordance and were
    added to it (`learner.paper_match_adds`, the paper's Algorithm 2); None: no row is.
    """

    t: np.ndarray
    target: np.ndarray
    tool: np.ndarray
    borrowed: np.ndarray | None = None

    @classmethod
    def empty(cls) -> Rows:
        z = np.zeros(0, dtype=np.int64)
        return cls(z, z.copy(), z.copy())

    def __len__(self) -> int:
        return int(self.t.shape[0])

    def lent(self) -> np.ndarray:
        """Mask of the borrowed rows."""
        if self.borrowed is None:
            return np.zeros(len(self), dtype=bool)
        return self.borrowed

    def concat(self, other: Rows) -> Rows:
        borrowed = None
        if self.borrowed is not None or other.borrowed is not None:
            borrowed = np.concatenate([self.lent(), other.lent()])
        return Rows(np.concatenate([self.t, other.t]), np.concatenate([self.target, other.target]),
                    np.concatenate([self.tool, other.tool]), borrowed)

    def take(self, idx: np.ndarray) -> Rows:
        borrowed = None if self.borrowed is None else self.borrowed[idx]
        return Rows(self.t[idx], self.target[idx], self.tool[idx], borrowed)

    def lending(self) -> Rows:
        """These rows, every one marked borrowed."""
        return Rows(self.t, self.target, self.tool, np.ones(len(self), dtype=bool))


def borrowed_space(output: RoleSpace) -> RoleSpace | None:
    """The space whose data an affordance of `output` can take in (`Rows.borrowed`): the
    same property of the other entity — the robot's position for an object's, an object's
    for the robot's. None for any other output: a heading or the LIDAR is no other
    output's quantity (`Adaptation.matches_other_output` matches only the same property)."""
    if output.prop is not Property.POSITION or output.relative_to is not None:
        return None
    if output.role is Role.ROBOT:
        return RoleSpace(Role.TARGET, Property.POSITION)
    if output.role is Role.TARGET:
        return RoleSpace(Role.ROBOT, Property.POSITION)
    return None


class SpaceReader:
    """Reads role spaces out of D's flat arrays for many rows at once (vectorised).

    A relative position (`target-robot`, `target-tool`, …) is read centre to centre, or, with
    a `relation_offset` r, between the two bodies' surfaces: the centre-to-centre vector with
    its length cut by the sum of the radii and lengthened by r. Two bodies in contact then
    read a relation of length r towards each other whatever their sizes (as a LIDAR sees the
    surface of an object, not its centre), and a push learned on one object carries over to a
    larger one; r > 0 keeps the direction of a contact.
    """

    def __init__(self, layout: ObservationLayout, relation_offset: float | None = None,
                 actions: ActionSpace | None = None):
        if relation_offset is not None and relation_offset <= 0:
            raise ValueError(f"relation_offset must be > 0, got {relation_offset}")
        self.layout = layout
        self.relation_offset = relation_offset
        self.actions = actions
        """The world's primitive action space (None: a reader of observations only)."""
        self.actor_contexts = actor_contexts(layout)
        self._entity_start = np.array(
            [layout.space(e, Property.POSITION).start for e in layout.entities], dtype=np.int64)

    def entity_name(self, role: Role) -> str:
        """The entity whose spaces stand for `role`'s: the actor, or (every object's being
        alike) the first object."""
        return self.layout.actor if role is Role.ROBOT else self.layout.objects[0]

    def dim(self, space: RoleSpace) -> int:
        """Values of `space`: the action's components, or its entity's property's."""
        if space.role is Role.ACTION:
            return self._action_space().dim
        return self.layout.space(self.entity_name(space.role),
                                 space.prop or Property.POSITION).dim

    def _action_space(self) -> ActionSpace:
        if self.actions is None:
            raise ValueError("this reader was given no action space")
        return self.actions

    def action_box(self) -> tuple[np.ndarray, np.ndarray]:
        """The primitive action's lower and upper bounds, one per component."""
        actions = self._action_space()
        return np.full(actions.dim, actions.low), np.full(actions.dim, actions.high)

    def declares(self, space: RoleSpace) -> bool:
        """Whether the world observes `space` (the rover's robot has a heading, the arm's
        effector none)."""
        if space.role is Role.ACTION:
            return self.actions is not None
        prop = space.prop or Property.POSITION
        return all(self.layout.has(self.entity_name(role), prop)
                   for role in (space.role, space.relative_to) if role is not None)

    @cached_property
    def _offsets(self) -> dict[tuple[bool, Property], tuple[int, int]]:
        """(is_robot, property) → (offset from the entity's position column, dim)."""
        out: dict[tuple[bool, Property], tuple[int, int]] = {}
        for is_robot, entity in ((True, self.layout.actor), (False, self.layout.objects[0])):
            base = self.layout.space(entity, Property.POSITION).start
            for spec in self.layout.spaces:
                if spec.entity == entity:
                    out[(is_robot, spec.prop)] = (spec.start - base, spec.dim)
        return out

    def _entity_of(self, role: Role, rows: Rows) -> np.ndarray:
        if role is Role.ROBOT:
            return np.zeros(len(rows), dtype=np.int64)
        return rows.target if role is Role.TARGET else rows.tool

    def _gather(self, arr: np.ndarray, role: Role, prop: Property, rows: Rows) -> np.ndarray:
        entity = self._entity_of(role, rows)
        # Offsets follow the entity actually bound, not the role: the robot laid in the target
        # role (a negative example of p_A) has its properties elsewhere than an object.
        offset, dim = self._offsets[(role is Role.ROBOT, prop)]
        if role is not Role.ROBOT and (entity == 0).any():
            robot_offset, robot_dim = self._offsets[(True, prop)]
            if robot_dim != dim:
                raise ValueError(f"the robot's {prop.value} has {robot_dim} values, "
                                 f"an object's {dim}")
            offset = np.where(entity == 0, robot_offset, offset)
        cols = self._entity_start[entity] + offset
        return arr[rows.t[:, None], cols[:, None] + np.arange(dim)]

    def read(self, space: RoleSpace, arr: np.ndarray, rows: Rows,
             actions: np.ndarray | None = None, *, raw: bool = False) -> np.ndarray:
        """Values of `space` in `arr` (contexts, or outcomes for deltas) at `rows`.

        `raw` reads a relative position centre to centre whatever the reader's offset: a
        distance to compare with radii, or its change between two observations (from the
        outcomes, a relative position must be read raw: a change has no radii)."""
        if space.role is Role.ACTION:
            assert actions is not None
            return actions[rows.t]
        assert space.prop is not None
        values = self._gather(arr, space.role, space.prop, rows)
        if space.relative_to is not None:
            values = values - self._gather(arr, space.relative_to, space.prop, rows)
            if not raw and self.relation_offset is not None:
                contact = self.contact(space, arr, rows)
                norm = np.maximum(np.linalg.norm(values, axis=1), 1e-9)
                values = values * ((norm - contact + self.relation_offset) / norm)[:, None]
        return values

    def contact(self, space: RoleSpace, arr: np.ndarray, rows: Rows) -> np.ndarray:
        """Centre distance at which the two bodies of the relative position `space` touch (the
        sum of their radii) in the observations `arr` at `rows`."""
        assert space.relative_to is not None
        return (self._gather(arr, space.role, Property.RADIUS, rows)[:, 0]
                + self._gather(arr, space.relative_to, Property.RADIUS, rows)[:, 0])

    def relation_to_offset(self, want: np.ndarray, contact: float) -> np.ndarray:
        """The centre-to-centre offset of two bodies whose radii sum to `contact` that reads
        as the relation `want` (the inverse of `read` for a relative position). A relation
        shorter than the offset asks for the bodies pressed together (a push from behind
        presses on); at least 1 mm apart, centre to centre, in its direction."""
        if self.relation_offset is None:
            return np.asarray(want, dtype=float)
        norm = max(float(np.linalg.norm(want)), 1e-9)
        length = max(norm - self.relation_offset + contact, 1e-3)
        return np.asarray(want, dtype=float) * (length / norm)

    def offset_now(self, space: RoleSpace, want: np.ndarray, obs: np.ndarray, target: int = -1,
                   tool: int = -1) -> np.ndarray:
        """`relation_to_offset` for the bodies `space` binds in one observation: where the
        second body must stand, from the first, for `space` to read `want`."""
        rows = Rows(np.zeros(1, dtype=np.int64), np.array([target]), np.array([tool]))
        return self.relation_to_offset(want, float(self.contact(space, obs[None, :], rows)[0]))

    def read_many(self, spaces: tuple[RoleSpace, ...], arr: np.ndarray, rows: Rows) -> np.ndarray:
        if not spaces:
            return np.zeros((len(rows), 0))
        return np.concatenate([self.read(s, arr, rows) for s in spaces], axis=1)

    def read_each(self, spaces: tuple[RoleSpace, ...], obs: np.ndarray, target: int = -1,
                  tool: int = -1) -> np.ndarray:
        """`spaces` (concatenated) in each observation of `obs` (B, D) under one binding: a
        (B, dims) array, row i read from `obs[i]` as `value_now` reads one."""
        m = obs.shape[0]
        return self.read_many(spaces, obs, Rows(np.arange(m), np.full(m, target),
                                                np.full(m, tool)))

    def value_now(self, space: RoleSpace, obs: np.ndarray, target: int = -1,
                  tool: int = -1) -> np.ndarray:
        """The value of `space` in one observation under one binding."""
        rows = Rows(np.zeros(1, dtype=np.int64), np.array([target]), np.array([tool]))
        return self.read(space, obs[None, :], rows)[0]

    def features(self, arr: np.ndarray, rows: Rows) -> np.ndarray:
        """p_A's input, the one definition: the visual properties (radius, height, colour,
        shape) of each row's target in the observations `arr`, each divided by its space's
        upper bound (about [0, 1])."""
        parts = []
        for prop in VISUAL_PROPERTIES:
            high = self.layout.space(self.layout.actor, prop).high
            high = np.maximum(np.asarray(high, dtype=float), 1e-9)
            parts.append(self.read(RoleSpace(Role.TARGET, prop), arr, rows) / high)
        return np.concatenate(parts, axis=1)

    def visual_features(self, obs: np.ndarray, entity: int) -> np.ndarray:
        """`features` of one entity (the robot or an object) in one observation."""
        one = np.zeros(1, dtype=np.int64)
        return self.features(obs[None, :], Rows(one, np.array([entity]), one - 1))[0]

    def entity_position(self, obs: np.ndarray, entity: int) -> np.ndarray:
        """The entity's position in one observation (2,), or in each of a batch (B, 2)."""
        start = self._entity_start[entity]
        return obs[..., start:start + 2]

    def entity_radius(self, obs: np.ndarray, entity: int) -> float:
        name = self.layout.entities[entity]
        return float(obs[self.layout.space(name, Property.RADIUS).start])
