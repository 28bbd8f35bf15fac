"""The primitive action space a world declares, and sequences of actions: read from a file, or
drawn at random."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from hadim_cli.errors import ActionError, HadimError

_NUMERIC_KINDS = frozenset("fiu")
_POWERS = {2: "²", 3: "³"}


@dataclass(frozen=True)
class ActionSpace:
    """A primitive action: one command in [-1, 1] per component, held for one action.

    The world declares it (`world.action_space`), so that whoever drives the world needs to
    know nothing of the body: the rover's is (left, right) wheel intensities, the arm's one
    joint speed per joint.
    """

    names: tuple[str, ...]
    """One name per component, in order."""
    what: str
    """What a component is, in words ("intensities", "joint speeds")."""
    moves: tuple[tuple[float, ...], ...] = ()
    """A few whole commands that stand for the body's elementary moves, for a learner that
    picks among a handful of discrete actions (the RL baselines' `Discrete` action): the
    rover's forward, backward, turn left, turn right. Empty: each component at +1, then at
    −1, the others at 0 (the arm: each joint turned one way, then the other)."""

    low = -1.0
    high = 1.0

    @property
    def dim(self) -> int:
        return len(self.names)

    @property
    def box(self) -> str:
        """The action box in words: [-1, 1]²."""
        return f"[-1, 1]{_POWERS.get(self.dim, f'^{self.dim}')}"

    def check(self, action: object) -> tuple[float, ...]:
        """The components of `action` as floats, or `ActionError` (never a silent clip)."""
        arr = action if isinstance(action, np.ndarray) else None
        if arr is None:
            try:
                arr = np.asarray(action)
            except (TypeError, ValueError):
                raise ActionError(f"action must be {self.dim} numbers in [-1, 1], "
                                  f"got {action!r}") from None
        if arr.dtype.kind not in _NUMERIC_KINDS:
            raise ActionError(f"action must be {self.dim} numbers in [-1, 1], got {action!r}")
        if arr.shape != (self.dim,):
            raise ActionError(f"action must have shape ({self.dim},) ({', '.join(self.names)}), "
                              f"got shape {arr.shape}")
        values = tuple(float(v) for v in arr.tolist())
        # NaN fails every comparison, so this also refuses non-finite values.
        if not all(-1.0 <= v <= 1.0 for v in values):
            raise ActionError(f"action {self.what} must be finite and in [-1, 1], got "
                              f"({', '.join(repr(v) for v in values)})")
        return values

    @property
    def discrete(self) -> np.ndarray:
        """(k, dim): the commands of the discrete actions 0 … k − 1 (`moves`)."""
        if self.moves:
            return np.array(self.moves, dtype=np.float64)
        eye = np.eye(self.dim)
        return np.stack([eye, 0.0 - eye], axis=1).reshape(-1, self.dim)  # no -0.0

    def sample(self, rng: np.random.Generator, n: int) -> np.ndarray:
        """`n` actions uniform in the action box, shape (n, dim)."""
        return rng.uniform(self.low, self.high, size=(n, self.dim))


ROVER_ACTIONS = ActionSpace(("left", "right"), "intensities",
                            ((1.0, 1.0), (-1.0, -1.0), (-1.0, 1.0), (1.0, -1.0)))
"""The rover's: the intensity of the current to each wheel; its moves forward, backward, turn
left, turn right (the paper's four discrete actions, §5.3)."""


def joint_actions(n_joints: int) -> ActionSpace:
    """The arm's: the speed of each joint, base outwards (joint1 the shoulder)."""
    return ActionSpace(tuple(f"joint{i + 1}" for i in range(n_joints)), "joint speeds")


def random_actions(rng: np.random.Generator, n: int,
                   space: ActionSpace = ROVER_ACTIONS) -> np.ndarray:
    """`n` primitive actions uniform in the action box, shape (n, dim)."""
    return space.sample(rng, n)


def load_actions(path: Path, space: ActionSpace = ROVER_ACTIONS) -> np.ndarray:
    """An (N, dim) array of actions from a `.npy` file or a text/CSV file of dim columns."""
    path = Path(path)
    if not path.is_file():
        raise HadimError(f"actions file not found: {path}")
    try:
        if path.suffix == ".npy":
            actions = np.load(path, allow_pickle=False)
        else:
            text = path.read_text().replace(",", " ")
            actions = np.loadtxt(text.splitlines(), dtype=np.float64, ndmin=2)
    except (ValueError, OSError) as exc:
        raise HadimError(f"cannot read actions from {path}: {exc}") from None
    actions = np.asarray(actions, dtype=np.float64)
    if actions.ndim != 2 or actions.shape[1] != space.dim:
        raise HadimError(f"actions file {path} must hold N rows of {space.dim} {space.what} "
                         f"({', '.join(space.names)}), got shape {actions.shape}")
    bad = ~(np.isfinite(actions).all(axis=1) & (np.abs(actions) <= 1.0).all(axis=1))
    if bad.any():
        row = int(np.flatnonzero(bad)[0])
        raise ActionError(f"actions file {path}, row {row + 1}: {actions[row].tolist()} is not "
                          f"in {space.box}")
    return actions
