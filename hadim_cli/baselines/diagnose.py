"""Why a baseline does (not) learn: the measurements a practitioner makes, from a stored run.

- training episodes per block of iterations: how many ended, how many in the goal zone, their
  mean return and length (the rewards the agent saw, unscaled: the paper's +1000 / −5 scale);
- exploration coverage: the share of the room's 0.2 m cells the robot (and the goal entity)
  visited;
- the value scale: the greedy values Q(s, ·) of the run's agent on its stored states (DQN,
  CURIOUS: the network; Q-learning: the table), against what +1000 / −5 and γ make possible
  (about −500 … +1000), and how far apart the four actions' values are.

Pure functions over stored episodes, but `value_scale` (restores the agent).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import asdict, dataclass
from typing import Any

import numpy as np

from hadim_cli.baselines.rewards import GOAL_REWARD

CELL = 0.2
HALF_ROOM = 2.0


@dataclass(frozen=True)
class Block:
    """Training episodes ending within iterations [start, end)."""

    start: int
    end: int
    episodes: int
    reached: int
    """Episodes that ended with the goal entity in the goal zone."""
    mean_return: float
    mean_length: float
    robot_coverage: float
    """Share of the room's CELL-sized cells the robot visited in the block."""
    goal_entity_coverage: float


def _cells(xy: np.ndarray) -> set[tuple[int, int]]:
    idx = np.clip(((xy + HALF_ROOM) / CELL).astype(int), 0, int(2 * HALF_ROOM / CELL) - 1)
    return set(map(tuple, idx.tolist()))


def training_blocks(episodes: Sequence, block: int, goal_columns: tuple[int, int]
                    ) -> list[Block]:
    """`Block`s of `block` iterations from a run's stored chunks (`extra` holds each chunk's
    rewards and episode ends; contexts the observation before each action)."""
    rewards = np.concatenate([np.asarray(e.extra["rewards"], float) for e in episodes])
    contexts = np.concatenate([e.contexts for e in episodes])
    ends = [(e.first_iteration + i, bool(term))
            for e in episodes for i, term, _trunc in e.extra["ends"]]
    total = len(rewards)
    n_cells = int(2 * HALF_ROOM / CELL) ** 2
    out, start_ep = [], 0
    for start in range(0, total, block):
        end = min(total, start + block)
        mine = [(it, term) for it, term in ends if start <= it < end]
        returns, lengths, reached = [], [], 0
        for it, _term in mine:
            returns.append(float(rewards[start_ep: it + 1].sum()))
            lengths.append(it + 1 - start_ep)
            reached += rewards[it] == GOAL_REWARD
            start_ep = it + 1
        out.append(Block(start, end, len(mine), int(reached),
                         float(np.mean(returns)) if returns else float("nan"),
                         float(np.mean(lengths)) if lengths else float("nan"),
                         len(_cells(contexts[start:end, :2])) / n_cells,
                         len(_cells(contexts[start:end, list(goal_columns)])) / n_cells))
    return out


@dataclass(frozen=True)
class ValueScale:
    states: int
    greedy_mean: float
    greedy_min: float
    greedy_max: float
    action_gap: float
    """Mean over states of max − min of the four actions' values."""
    possible: tuple[float, float]
    """The values +1000 / −5 (times the run's reward scale) and γ allow."""
    return_mean: float
    """Mean discounted return-to-go the agent actually got from those states (times the
    reward scale): what its values should approach."""


def returns_to_go(rewards: np.ndarray, ends: Sequence[int], gamma: float) -> np.ndarray:
    """Discounted return from each iteration to its episode's end (`ends`: the iterations
    that ended an episode; the last, unfinished episode is cut where the data ends)."""
    out = np.zeros(len(rewards))
    stops = set(ends)
    acc = 0.0
    for i in range(len(rewards) - 1, -1, -1):
        acc = rewards[i] + (0.0 if i in stops else gamma * acc)
        out[i] = acc
    return out


def value_scale(session, contexts: np.ndarray, returns: np.ndarray, rng: np.random.Generator,
                n: int = 2000) -> ValueScale | None:
    """Q(s, ·) of the run's agent on up to `n` stored states (None for A2C), beside the
    returns `returns` (per stored state) the agent got from them."""
    from hadim_cli.baselines.config import Algorithm

    algo = Algorithm(session.cfg.algorithm)
    if algo is Algorithm.A2C:
        return None
    chosen = rng.choice(len(contexts), size=min(n, len(contexts)), replace=False)
    pick = contexts[chosen]
    env = session.agent.env
    values = []
    for row in pick:
        obs = _obs(env, row)
        if algo is Algorithm.Q_LEARNING:
            q = session.agent.q.table.get(session.agent.q.state(obs))
            values.append(np.zeros(session.agent.q.n_actions) if q is None else q)
        else:
            import torch

            policy = session.agent.model.policy
            tensor, _ = policy.obs_to_tensor(obs)
            with torch.no_grad():
                values.append(policy.q_net(tensor).numpy()[0])
    v = np.array(values)
    gamma = float(session.cfg.params.get("gamma", 0.99))
    scale = float(session.cfg.params.get("reward_scale", 1.0))
    greedy = v.max(axis=1)
    return ValueScale(len(v), float(greedy.mean()), float(greedy.min()), float(greedy.max()),
                      float((v.max(axis=1) - v.min(axis=1)).mean()),
                      (-5 * scale / (1 - gamma), GOAL_REWARD * scale),
                      float(returns[chosen].mean() * scale))


def _obs(env, row: np.ndarray) -> dict[str, np.ndarray]:
    """A stored context (observation, then goal) as the agent's observation. CURIOUS: on the
    task's module."""
    base = getattr(env, "base", env)
    o = row[:-2].astype(np.float32)
    goal = row[-2:].astype(np.float32)
    achieved = o[base.position_columns(base.task.goal_entity)]
    if hasattr(env, "encode"):
        m = env.task_module
        return {"observation": o, "achieved_goal": env.encode(achieved, m),
                "desired_goal": env.encode(goal, m)}
    return {"observation": o, "achieved_goal": achieved, "desired_goal": goal}


def diagnose(store, run: str, block: int = 10_000, seed: int = 0) -> dict[str, Any]:
    """Every measurement of this module on a stored baseline run, as JSON-able numbers."""
    from hadim_cli.baselines import runs as baseline_runs

    record = store.get_run(run)
    session = baseline_runs.restore(store, record)
    episodes = store.episodes(run)
    base = session.agent.base
    where = base.position_columns(base.task.goal_entity)
    goal = (where.start, where.start + 1)
    blocks = training_blocks(episodes, block, goal)
    contexts = np.concatenate([e.contexts for e in episodes])
    rewards = np.concatenate([np.asarray(e.extra["rewards"], float) for e in episodes])
    ends = [e.first_iteration + i for e in episodes for i, _t, _u in e.extra["ends"]]
    returns = returns_to_go(rewards, ends, float(session.cfg.params.get("gamma", 0.99)))
    scale = value_scale(session, contexts, returns, np.random.default_rng(seed))
    out: dict[str, Any] = {"run": run, "iterations": record.iterations,
                           "blocks": [asdict(b) for b in blocks],
                           "value_scale": None if scale is None else asdict(scale)}
    if session.cfg.algorithm == "q-learning":
        out["table_states"] = len(session.agent.q.table)
    return out
