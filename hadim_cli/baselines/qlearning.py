"""Tabular Q-learning as a UVFA (the goal is part of the state), ours, in numpy.

Ω is discretised uniformly, as the paper does "when required": every position (the robot's,
each object's and the goal) into `cells` × `cells` squares of the room, the robot's heading
into `headings` sectors; a state is the tuple of those indices, packed into one integer. The
table holds only the states visited (a dict), and is checkpointed as two arrays (state keys,
their 4 action values). Exploration is ε-greedy with ε decaying linearly from 1 to `eps_end`
over `eps_fraction` of the run's horizon, as SB3's DQN; all draws come from the agent's own
`numpy.random.Generator`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from hadim_cli.baselines.tasks import HALF_ROOM


@dataclass(frozen=True)
class QLearningParams:
    alpha: float = 0.1
    """Step size of the update."""
    gamma: float = 0.99
    cells: int = 20
    """Squares per side of the room for every position (0.2 m in a 4 m room: the goal
    zone's diameter)."""
    headings: int = 16
    """Sectors of the robot's heading."""
    eps_end: float = 0.05
    eps_fraction: float = 0.1
    frame: str = "room"
    """How Ω is discretised: "room" (the paper's: every position in the room's grid, the
    heading in sectors) or "robot" (each object and the goal seen from the robot: bearing in
    `headings` sectors of the robot's frame, distance in the `DISTANCES` rings)."""


DISTANCES = (0.1, 0.2, 0.3, 0.5, 0.8, 1.2, 2.0)
"""Ring edges (m) of the robot-frame discretisation: finer near, where the goal zone is."""


def robot_frame_cells(obs: dict[str, np.ndarray], headings: int) -> list[int]:
    """(sector, ring) of each object relative to the robot, then of the goal relative to the
    goal entity (the achieved goal), in the robot's frame."""
    o, g = obs["observation"].astype(np.float64), obs["desired_goal"].astype(np.float64)
    heading = math.atan2(o[3], o[2])
    vectors = [o[4 + 2 * k: 6 + 2 * k] - o[:2] for k in range((len(o) - 4) // 2)]
    vectors.append(g - obs["achieved_goal"].astype(np.float64))
    cells = []
    for v in vectors:
        bearing = (math.atan2(v[1], v[0]) - heading + math.pi) % (2 * math.pi)
        cells.append(int(bearing / (2 * math.pi) * headings) % headings)
        cells.append(int(np.searchsorted(DISTANCES, math.hypot(v[0], v[1]))))
    return cells


class TabularQ:
    """Q(s, a) over the discretised observation and goal of a goal environment."""

    def __init__(self, env, params: QLearningParams, horizon: int, rng: np.random.Generator):
        self.env = env
        self.p = params
        self.horizon = horizon
        self.rng = rng
        self.n_actions = int(env.action_space.n)
        self.table: dict[int, np.ndarray] = {}
        self.iterations = 0
        self.episodes = 0
        self._obs: dict[str, np.ndarray] | None = None

    # ------------------------------------------------------------------ discretisation

    def state(self, obs: dict[str, np.ndarray]) -> int:
        if self.p.frame == "robot":
            key = 0
            for c in robot_frame_cells(obs, self.p.headings):
                key = key * max(self.p.headings, len(DISTANCES) + 1) + c
            return key
        o, g = obs["observation"], obs["desired_goal"]
        points = np.concatenate([o[:2], o[4:], g]).astype(np.float64)
        cells = np.clip(((points + HALF_ROOM) / (2 * HALF_ROOM) * self.p.cells).astype(int),
                        0, self.p.cells - 1)
        sector = int((math.atan2(float(o[3]), float(o[2])) + math.pi)
                     / (2 * math.pi) * self.p.headings) % self.p.headings
        key = sector
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
