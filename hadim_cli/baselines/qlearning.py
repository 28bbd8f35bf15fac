"""Tabular Q-learning as a UVFA (the goal is part of the state), ours, in numpy.

Ω is discretised uniformly, as the paper does "when required", from what the environment's
world declares for the observation the task reads (`Grid`): every position (the actor's, each
object's and the goal) into `cells` × `cells` squares of its bounds, every direction of the
body (the rover's heading, the arm's orientation) into `headings` sectors of the turn, and
every joint angle (the arm's bends) into `headings` bins of its range; a state is the tuple of
those indices, packed into one integer. The table holds only the states visited (a dict), and
is checkpointed as two arrays (state keys, their action values, one per discrete move the
world declares). Exploration is ε-greedy with ε decaying linearly from 1 to `eps_end` over
`eps_fraction` of the run's horizon, as SB3's DQN; all draws come from the agent's own
`numpy.random.Generator`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from hadim_cli.errors import HadimError
from hadim_cli.world.layout import Property

DIRECTIONS = (Property.HEADING, Property.ORIENTATION)
"""Directions of the body, as (cos, sin): cut into sectors of the whole turn."""


@dataclass(frozen=True)
class QLearningParams:
    alpha: float = 0.1
    """Step size of the update."""
    gamma: float = 0.99
    cells: int = 20
    """Squares per side of the room for every position (0.2 m in a 4 m room: the goal
    zone's diameter)."""
    headings: int = 16
    """Sectors of every angle the body declares: of the whole turn for a direction (the
    rover's heading, the arm's orientation), of its range for a joint's bend."""
    eps_end: float = 0.05
    eps_fraction: float = 0.1
    frame: str = "room"
    """How Ω is discretised: "room" (the paper's: every position in the room's grid, the
    body's angles in sectors) or "robot" (each object and the goal seen from the actor:
    bearing in `headings` sectors of the frame of the body's direction, distance in the
    `DISTANCES` rings; a joint's bend as in "room")."""


DISTANCES = (0.1, 0.2, 0.3, 0.5, 0.8, 1.2, 2.0)
"""Ring edges (m) of the robot-frame discretisation: finer near, where the goal zone is."""


@dataclass(frozen=True)
class Grid:
    """Where a goal environment's observation holds what Ω is cut by, with the bounds its
    world declares: no body named, so any world's environment is discretised alike."""

    positions: np.ndarray
    """Columns of every position coordinate: the actor's (x, y), then each object's."""
    low: np.ndarray
    """Lower bound of each of those coordinates, then of the goal's (x, y)."""
    span: np.ndarray
    """Width of each one's bounds."""
    directions: tuple[tuple[int, int], ...]
    """(cos, sin) columns of each direction of the body."""
    angles: tuple[tuple[int, float, float], ...]
    """(column, low, high) of each joint angle."""

    @classmethod
    def of(cls, env) -> Grid:
        """The grid of a `GoalWorldEnv` (`env.observed`: its spaces and their columns)."""
        positions, bounds, directions, angles = [], [], [], []
        for spec, cols in env.observed:
            index = list(range(cols.start, cols.stop))
            if spec.prop is Property.POSITION:
                positions += index
                bounds += list(zip(spec.low, spec.high, strict=True))
            elif spec.prop in DIRECTIONS:
                directions.append((index[0], index[1]))
            else:  # a joint's bend in its range (`Property.JOINTS`)
                angles += [(i, float(lo), float(hi))
                           for i, lo, hi in zip(index, spec.low, spec.high, strict=True)]
        goal = env.observation_space["desired_goal"]
        bounds += list(zip(goal.low.tolist(), goal.high.tolist(), strict=True))
        low, high = (np.array(b, dtype=np.float64) for b in zip(*bounds, strict=True))
        return cls(np.array(positions, dtype=np.intp), low, high - low, tuple(directions),
                   tuple(angles))

    def angle_bins(self, o: np.ndarray, n: int) -> list[int]:
        """Each direction's sector of the whole turn, then each joint's bin of its range."""
        bins = [int((math.atan2(float(o[s]), float(o[c])) + math.pi) / (2 * math.pi) * n) % n
                for c, s in self.directions]
        bins += [min(n - 1, max(0, int((float(o[i]) - lo) / (hi - lo) * n)))
                 for i, lo, hi in self.angles]
        return bins


def robot_frame_cells(obs: dict[str, np.ndarray], headings: int, grid: Grid) -> list[int]:
    """(sector, ring) of each object relative to the actor, then of the goal relative to the
    goal entity (the achieved goal), in the frame of the body's first direction; then each
    joint's bin."""
    if not grid.directions:
        raise HadimError("q-learning's robot frame turns with a direction of the body (a "
                         "heading or an orientation); this world declares none")
    o, g = obs["observation"].astype(np.float64), obs["desired_goal"].astype(np.float64)
    c, s = grid.directions[0]
    heading = math.atan2(o[s], o[c])
    points = o[grid.positions]
    vectors = [points[2 * k: 2 * k + 2] - points[:2] for k in range(1, len(points) // 2)]
    vectors.append(g - obs["achieved_goal"].astype(np.float64))
    cells = []
    for v in vectors:
        bearing = (math.atan2(v[1], v[0]) - heading + math.pi) % (2 * math.pi)
        cells.append(int(bearing / (2 * math.pi) * headings) % headings)
        cells.append(int(np.searchsorted(DISTANCES, math.hypot(v[0], v[1]))))
    return cells + grid.angle_bins(o, headings)[len(grid.directions):]


class TabularQ:
    """Q(s, a) over the discretised observation and goal of a goal environment."""

    def __init__(self, env, params: QLearningParams, horizon: int, rng: np.random.Generator):
        self.env = env
        self.p = params
        self.horizon = horizon
        self.rng = rng
        self.n_actions = int(env.action_space.n)
        self.grid = Grid.of(env)
        self.table: dict[int, np.ndarray] = {}
        self.iterations = 0
        self.episodes = 0
        self._obs: dict[str, np.ndarray] | None = None

    # ------------------------------------------------------------------ discretisation

    def state(self, obs: dict[str, np.ndarray]) -> int:
        if self.p.frame == "robot":
            key = 0
            for c in robot_frame_cells(obs, self.p.headings, self.grid):
                key = key * max(self.p.headings, len(DISTANCES) + 1) + c
            return key
        o, g = obs["observation"], obs["desired_goal"]
        points = np.concatenate([o[self.grid.positions], g]).astype(np.float64)
        cells = np.clip(((points - self.grid.low) / self.grid.span * self.p.cells).astype(int),
                        0, self.p.cells - 1)
        key = 0
        for b in self.grid.angle_bins(o, self.p.headings):
            key = key * self.p.headings + b
        for c in cells.tolist():
            key = key * self.p.cells + c
        return key

    def values(self, key: int) -> np.ndarray:
        row = self.table.get(key)
        if row is None:
            row = self.table[key] = np.zeros(self.n_actions)
        return row

    @property
    def epsilon(self) -> float:
        frac = min(1.0, self.iterations / max(1.0, self.p.eps_fraction * self.horizon))
        return 1.0 + frac * (self.p.eps_end - 1.0)

    # ------------------------------------------------------------------ acting, learning

    def greedy(self, obs: dict[str, np.ndarray]) -> int:
        row = self.table.get(self.state(obs))
        return 0 if row is None else int(np.argmax(row))

    def learn(self, steps: int) -> None:
        """`steps` environment steps of ε-greedy Q-learning, continuing the episode."""
        for _ in range(steps):
            if self._obs is None:
                self._obs, _ = self.env.reset(seed=int(self.rng.integers(2**31)))
            key = self.state(self._obs)
            row = self.values(key)
            if self.rng.random() < self.epsilon:
                action = int(self.rng.integers(self.n_actions))
            else:
                action = int(np.argmax(row))
            obs, reward, terminated, truncated, _ = self.env.step(action)
            target = reward if terminated else reward + self.p.gamma * float(
                np.max(self.values(self.state(obs))))
            row[action] += self.p.alpha * (target - row[action])
            self.iterations += 1
            if terminated or truncated:
                self._obs = None
                self.episodes += 1
            else:
                self._obs = obs

    # ------------------------------------------------------------------ checkpoints

    def state_dict(self) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
        keys = np.fromiter(self.table.keys(), dtype=np.int64, count=len(self.table))
        values = (np.stack(list(self.table.values())) if self.table
                  else np.zeros((0, self.n_actions)))
        return ({"iterations": self.iterations, "episodes": self.episodes,
                 "rng": self.rng.bit_generator.state, "in_episode": self._obs is not None},
                {"q.keys": keys, "q.values": values})

    def load_state_dict(self, meta: dict[str, Any], arrays: dict[str, np.ndarray],
                        obs: dict[str, np.ndarray] | None) -> None:
        keys, values = arrays["q.keys"], arrays["q.values"]
        self.table = {int(k): np.array(v) for k, v in zip(keys.tolist(), values, strict=True)}
        self.iterations = int(meta["iterations"])
        self.episodes = int(meta["episodes"])
        self.rng.bit_generator.state = meta["rng"]
        self._obs = obs if meta["in_episode"] else None
