"""CURIOUS (Colas et al., ICML 2019), "DQN variant": modular goals and a learning-progress
curriculum over modules, around the same goal environment. DQN and hindsight relabelling
(`HerReplayBuffer`, future strategy, k = 4) come from stable-baselines3; this module holds what
SB3 lacks: the modular goal encoding and the module choice.

- Modules are the task's goal spaces: the position of each entity of the room (the robot; the
  target; the tool). The goal vector holds one (x, y) slot per module, only the active one
  non-zero, then a one-hot module descriptor; the achieved goal is encoded the same way with
  the episode's module, so HER's relabelled goals keep the module and the reward is the sparse
  one on the active slot.
- Module choice at each reset: p(m) = 0.4 / N + 0.6 · LP(m) / Σ LP (uniform while Σ LP = 0),
  LP(m) = |mean of the newer half − mean of the older half| of the last 300 outcomes
  (success 1 / failure 0) of episodes on module m.
- All draws come from the base environment's `np_random` (seeded by `reset(seed=…)`).
- Goals: the task's own goal for the task's module; for another module a point drawn the same
  way around that entity's start (the robot: anywhere in the goal box).

- Modular HER (`modular_her_buffer`, runs whose config has `her.modular`): a relabelled
  transition gets a module drawn with the same LP probabilities and, as its goal, that
  module's outcome (its entity's position) at a future step of the episode (k = 4 relabelled
  per real transition); achieved goals are re-encoded in that module and the reward
  recomputed — so an episode spent on the robot's module also teaches the target's.

Deviations from the paper's CURIOUS (documented in docs/baselines.md): DQN for DDPG (4
discrete actions); one process for 19 workers; outcomes of every episode feed LP (the paper
uses 10 % greedy self-evaluation episodes: at 1000 actions per episode, 50 000 iterations
hold too few of them); one HER buffer, not per-module buffers weighted by LP (the module of
a relabelled transition is drawn by LP instead). Runs stored before modular HER relabel the
goal within the episode's module only.
"""

from __future__ import annotations

import math
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from hadim_cli.baselines.env import GoalWorldEnv
from hadim_cli.baselines.rewards import GOAL_REWARD, STEP_PENALTY
from hadim_cli.baselines.tasks import GOAL_BOX, GOAL_RADIUS, GOAL_RING, HALF_ROOM

WINDOW = 300
UNIFORM_SHARE = 0.4


def learning_progress(outcomes: list[int]) -> float:
    """|mean(newer half) − mean(older half)| of the last `WINDOW` outcomes (0 if < 2)."""
    recent = outcomes[-WINDOW:]
    if len(recent) < 2:
        return 0.0
    half = len(recent) // 2
    return abs(float(np.mean(recent[-half:])) - float(np.mean(recent[:-half])))


def module_probabilities(lps: list[float]) -> np.ndarray:
    """0.4 / N + 0.6 · LP / ΣLP; uniform when no module progresses."""
    n = len(lps)
    total = float(sum(lps))
    if total <= 0:
        return np.full(n, 1.0 / n)
    return UNIFORM_SHARE / n + (1 - UNIFORM_SHARE) * np.asarray(lps) / total


def entity_positions(observations: np.ndarray, modules: np.ndarray,
                     objects_at: int) -> np.ndarray:
    """Each row's position of module `modules[i]`'s entity: the actor (0) at columns 0-1 of
    the observation, object k (k ≥ 1) at columns `objects_at` + 2(k − 1) onwards, after the
    actor's pose (`GoalWorldEnv.position_columns`: 4 on the rover, after its heading's cos,
    sin; 5 on the three-link arm, after its joints)."""
    obs = np.asarray(observations)
    modules = np.asarray(modules, dtype=np.intp)
    start = np.where(modules == 0, 0, objects_at + 2 * (modules - 1))
    rows = np.arange(len(obs))
    return np.stack([obs[rows, start], obs[rows, start + 1]], axis=1)


def encode_goals(positions: np.ndarray, modules: np.ndarray, n_modules: int) -> np.ndarray:
    """`ModularGoalEnv.encode` of many (position, module) pairs: one (x, y) slot per module,
    only the module's filled, then a one-hot module descriptor."""
    modules = np.asarray(modules, dtype=np.intp)
    out = np.zeros((len(modules), 3 * n_modules), dtype=np.float32)
    rows = np.arange(len(modules))
    out[rows, 2 * modules] = positions[:, 0]
    out[rows, 2 * modules + 1] = positions[:, 1]
    out[rows, 2 * n_modules + modules] = 1.0
    return out


def modular_her_buffer(buffer_class: type) -> type:
    """`buffer_class` (SB3's `HerReplayBuffer`, future strategy) relabelling module and goal:
    each relabelled transition gets a module drawn from `module_probabilities` (set by the
    agent: the LP probabilities of the environment's modules) and that module's outcome at a
    future step of its episode as goal. Draws from numpy's global generator, as SB3's HER
    sampling does (seeded and checkpointed with it)."""

    class ModularHer(buffer_class):  # type: ignore[misc, valid-type]
        module_probabilities = None
        """() → probabilities of the modules (set after construction)."""
        objects_at: int | None = None
        """The first object's column in an observation (set after construction:
        `GoalWorldEnv.position_columns`)."""

        def _future_indices(self, batch_indices, env_indices) -> np.ndarray:
            start = self.ep_start[batch_indices, env_indices]
            length = self.ep_length[batch_indices, env_indices]
            current = (batch_indices - start) % self.buffer_size
            return (np.random.randint(current, length) + start) % self.buffer_size

        def _get_virtual_samples(self, batch_indices, env_indices, env=None):
            obs = {k: v[batch_indices, env_indices, :] for k, v in self.observations.items()}
            nxt = {k: v[batch_indices, env_indices, :]
                   for k, v in self.next_observations.items()}
            n = obs["desired_goal"].shape[-1] // 3
            probs = (np.full(n, 1.0 / n) if self.module_probabilities is None
                     else self.module_probabilities())
            modules = np.random.choice(n, size=len(batch_indices), p=probs)
            future = self._future_indices(batch_indices, env_indices)
            later = self.next_observations["observation"][future, env_indices]
            at = self.objects_at
            assert at is not None, "objects_at is set by the agent that builds the buffer"
            goals = encode_goals(entity_positions(later, modules, at), modules, n)
            obs["achieved_goal"] = encode_goals(
                entity_positions(obs["observation"], modules, at), modules, n)
            nxt["achieved_goal"] = encode_goals(
                entity_positions(nxt["observation"], modules, at), modules, n)
            obs["desired_goal"] = goals
            nxt["desired_goal"] = goals
            rewards = self.env.env_method("compute_reward", nxt["achieved_goal"], goals,
                                          [{}] * len(goals), indices=[0])[0].astype(np.float32)
            return self._samples(obs, nxt, batch_indices, env_indices, rewards, env)

        def _samples(self, obs, nxt, batch_indices, env_indices, rewards, env):
            from stable_baselines3.common.type_aliases import DictReplayBufferSamples

            obs, nxt = self._normalize_obs(obs, env), self._normalize_obs(nxt, env)
            dones = (self.dones[batch_indices, env_indices]
                     * (1 - self.timeouts[batch_indices, env_indices]))
            return DictReplayBufferSamples(
                observations={k: self.to_torch(v) for k, v in obs.items()},
                actions=self.to_torch(self.actions[batch_indices, env_indices]),
                next_observations={k: self.to_torch(v) for k, v in nxt.items()},
                dones=self.to_torch(dones).reshape(-1, 1),
                rewards=self.to_torch(self._normalize_reward(rewards.reshape(-1, 1), env)))

    ModularHer.__name__ = f"Modular{buffer_class.__name__}"
    return ModularHer


class ModularGoalEnv(gym.Wrapper):
    """A goal environment whose goals are (module, position) pairs chosen by learning progress."""

    def __init__(self, env: GoalWorldEnv):
        super().__init__(env)
        self.base = env
        self.n_modules = 1 + len(env.task.objects)
        self.task_module = env.task.goal_entity
        self.outcomes: list[list[int]] = [[] for _ in range(self.n_modules)]
        self.module = self.task_module
        size = 3 * self.n_modules
        high = np.concatenate([np.full(2 * self.n_modules, HALF_ROOM),
                               np.ones(self.n_modules)]).astype(np.float32)
        low = np.concatenate([-high[:2 * self.n_modules],
                              np.zeros(self.n_modules)]).astype(np.float32)
        self.observation_space = spaces.Dict({
            "observation": env.observation_space["observation"],
            "achieved_goal": spaces.Box(low, high, shape=(size,), dtype=np.float32),
            "desired_goal": spaces.Box(low, high, shape=(size,), dtype=np.float32),
        })
        self._goal = np.zeros(size, dtype=np.float32)

    # ------------------------------------------------------------------ encoding

    def encode(self, position: np.ndarray, module: int) -> np.ndarray:
        out = np.zeros(3 * self.n_modules, dtype=np.float32)
        out[2 * module: 2 * module + 2] = position
        out[2 * self.n_modules + module] = 1.0
        return out

    def _entity(self, obs: np.ndarray, module: int) -> np.ndarray:
        return obs[self.base.position_columns(module)]

    def _wrap(self, obs: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
        o = obs["observation"]
        return {"observation": o, "achieved_goal": self.encode(self._entity(o, self.module),
                                                               self.module),
                "desired_goal": self._goal.copy()}

    # ------------------------------------------------------------------ gymnasium

    def reset(self, *, seed: int | None = None, options: dict | None = None):
        obs, info = self.env.reset(seed=seed, options=options)
        self.module = int(self.base.np_random.choice(self.n_modules, p=self.probabilities()))
        if self.module == self.task_module:
            goal = obs["desired_goal"]
        else:
            goal = self._draw_goal(self._entity(obs["observation"], self.module))
        self._goal = self.encode(goal, self.module)
        return self._wrap(obs), info

    def _draw_goal(self, start: np.ndarray) -> np.ndarray:
        rng = self.base.np_random
        for _ in range(1000):
            if self.module == 0:
                goal = rng.uniform(-GOAL_BOX, GOAL_BOX, size=2)
            else:
                d, a = rng.uniform(*GOAL_RING), rng.uniform(-math.pi, math.pi)
                goal = start + d * np.array([math.cos(a), math.sin(a)])
            if np.all(np.abs(goal) <= GOAL_BOX) and np.linalg.norm(goal - start) > 2 * GOAL_RADIUS:
                return goal.astype(np.float32)
        return np.clip(start, -GOAL_BOX, GOAL_BOX).astype(np.float32)

    def step(self, action):
        obs, _, terminated, truncated, info = self.env.step(action)
        out = self._wrap(obs)
        reward = float(self.compute_reward(out["achieved_goal"], out["desired_goal"], info))
        success = reward == GOAL_REWARD * self.base.reward_scale
        # The base env ends the episode at the task's goal; here the module's goal does.
        terminated = success or bool(info.get("contact"))
        truncated = not terminated and self.base.steps >= self.base.max_steps
        info["is_success"] = success
        if terminated or truncated:
            kept = self.outcomes[self.module][-(WINDOW - 1):]
            self.outcomes[self.module] = [*kept, int(success)]
        return out, reward, terminated, truncated, info

    def compute_reward(self, achieved_goal, desired_goal, info) -> np.ndarray:
        """Sparse, on the active module's slot (both goals carry the same module), times the
        base environment's reward scale."""
        d = np.asarray(achieved_goal, np.float64) - np.asarray(desired_goal, np.float64)
        dist = np.sqrt(np.sum(d * d, axis=-1))
        return np.where(dist <= GOAL_RADIUS, GOAL_REWARD, STEP_PENALTY) * self.base.reward_scale

    def probabilities(self) -> np.ndarray:
        """The module probabilities of the next reset (LP of each module's outcomes)."""
        return module_probabilities([learning_progress(o) for o in self.outcomes])

    # ------------------------------------------------------------------ evaluation, state

    def start_from(self, scene, point) -> dict[str, np.ndarray]:
        """An evaluation episode on the task's module."""
        obs = self.base.start_from(scene, point)
        self.module = self.task_module
        self._goal = self.encode(np.asarray(point, dtype=np.float32), self.module)
        return self._wrap(obs)

    def snapshot(self) -> dict[str, Any]:
        return {"base": self.base.snapshot(), "outcomes": self.outcomes, "module": self.module,
                "goal": self._goal.tolist()}

    def restore(self, snap: dict[str, Any]) -> dict[str, np.ndarray] | None:
        obs = self.base.restore(snap["base"])
        self.outcomes = [list(o) for o in snap["outcomes"]]
        self.module = int(snap["module"])
        self._goal = np.asarray(snap["goal"], dtype=np.float32)
        return None if obs is None else self._wrap(obs)
