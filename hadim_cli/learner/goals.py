"""What a controller is asked and answers: a goal's binding, the actuator it acts through,
and the result of an attempt. Shared by the controllers (`planner.Planner`,
`controller.Controller`) and their callers (exploration, evaluation)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol

import numpy as np


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
    avoid: int = -1
    """An entity the robot must not touch: the target while a tool moves it (a tool
    affordance's data are the target's moves *without* the robot touching it)."""


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
