"""H, the hierarchy of affordances, and the timeline of its changes."""

from __future__ import annotations

import enum
from dataclasses import dataclass, field
from typing import Any

from hadim_cli.learner.affordance import Affordance
from hadim_cli.learner.spaces import ACTION, Property, Role, RoleSpace

TOOL_POSITION = RoleSpace(Role.TOOL, Property.POSITION)


class EventKind(enum.StrEnum):
    """Kinds of change of H (the affordance timeline, paper Fig. 4)."""

    CREATED = "created"
    CONTEXT_ADDED = "context_added"
    CONTEXT_REPLACED = "context_replaced"
    CONTEXT_REMOVED = "context_removed"
    DELETED = "deleted"


@dataclass(frozen=True)
class Event:
    """One change of H at one iteration."""

    iteration: int
    affordance_id: int
    kind: EventKind
    input: str
    output: str
    contexts: tuple[str, ...]
    competence: float
    detail: dict[str, Any] = field(default_factory=dict)


def _node(space: RoleSpace) -> str:
    """Graph node of a space: tool and target positions are the same kind of thing."""
    if space.role is Role.TOOL:
        return f"target.{space.prop}"
    return space.name


@dataclass
class Hierarchy:
    """The set H of affordances, with id allocation and the event timeline."""

    affordances: dict[int, Affordance] = field(default_factory=dict)
    next_id: int = 0
    events: list[Event] = field(default_factory=list)

    def __len__(self) -> int:
        return len(self.affordances)

    def __iter__(self):
        return iter(sorted(self.affordances.values(), key=lambda a: a.id))

    def allocate_id(self) -> int:
        self.next_id += 1
        return self.next_id - 1

    def record(self, aff: Affordance, kind: EventKind, iteration: int, **detail: Any) -> Event:
        event = Event(iteration, aff.id, kind, aff.input.name, aff.output.name,
                      tuple(c.name for c in aff.contexts), float(aff.competence), detail)
        self.events.append(event)
        return event

    def add(self, aff: Affordance, iteration: int) -> Event:
        self.affordances[aff.id] = aff
        return self.record(aff, EventKind.CREATED, iteration)

    def delete(self, aff: Affordance, iteration: int) -> Event:
        del self.affordances[aff.id]
        return self.record(aff, EventKind.DELETED, iteration)

    def with_output(self, space: RoleSpace) -> list[Affordance]:
        return [a for a in self if a.output == space]

    def controllers(self, space: RoleSpace) -> list[Affordance]:
        """Affordances able to drive `space` (tool positions are object positions)."""
        wanted = RoleSpace(Role.TARGET, space.prop) if space.role is Role.TOOL else space
        found = [a for a in self if a.output == wanted]
        if space.role is Role.TOOL:
            found = [a for a in found if not a.has_tool]
        return sorted(found, key=lambda a: -a.competence)

    def controllable(self) -> set[RoleSpace]:
        return {a.output for a in self}

    def _reaches(self, start: str, goal: str) -> bool:
        edges: dict[str, set[str]] = {}
        for a in self:
            if a.input is ACTION or a.input.role is Role.TOOL:
                continue
            edges.setdefault(_node(a.input), set()).add(_node(a.output))
        stack, seen = [start], set()
        while stack:
            node = stack.pop()
            if node == goal:
                return True
            if node not in seen:
                seen.add(node)
                stack.extend(edges.get(node, ()))
        return False

    def candidate_inputs(self, output: RoleSpace) -> list[RoleSpace]:
        """A ∪ Ω_controllable, minus inputs that would close a cycle or repeat an affordance."""
        existing = {a.input for a in self.with_output(output)}
        out: list[RoleSpace] = [ACTION]
        for space in sorted(self.controllable()):
            if space.role is Role.TARGET:
                continue
            if space != output and not self._reaches(_node(output), _node(space)):
                out.append(space)
        if output.role is Role.TARGET and self.controllers(TOOL_POSITION):
            out.append(TOOL_POSITION)
        return [s for s in out if s not in existing]

    def deletable(self, aff: Affordance) -> bool:
        """No other affordance needs `aff` as the only controller of its input."""
        others = [a for a in self if a.id != aff.id and a.output == aff.output]
        if others:
            return True
        for a in self:
            if a.id == aff.id:
                continue
            node = _node(a.input)
            if node == _node(aff.output):
                return False
        return True
