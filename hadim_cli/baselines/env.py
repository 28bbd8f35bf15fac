"""Goal-conditioned Gymnasium environments over the same `World` (paper §5.3).

`GoalWorldEnv(task, actions, reward)` is one task of the comparison: the robot starts anywhere
with any heading, the objects of the task are drawn around it, a goal is drawn for the task's
goal entity; an episode ends when the goal entity enters the goal zone (`terminated`), on
push-with-tool when the robot touches the target (`terminated`, failed), or after 1000
actions (`truncated`). Observations are a Dict (`observation`, `achieved_goal`,
`desired_goal`), so SB3's `MultiInputPolicy` is a UVFA and HER can relabel goals;
`compute_reward` is vectorised.

Randomness comes only from `self.np_random` (seeded by `reset(seed=…)`). `snapshot()` and
`restore()` capture an episode in progress as JSON (its scene, goal and actions) and rebuild it
bit-identically by replaying the actions in a fresh world.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Mapping, Sequence
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from hadim_cli.baselines.config import Actions, choice
from hadim_cli.baselines.rewards import (
    GOAL_REWARD,
    Reward,
    guided_reward,
    reward_1,
    sparse_reward,
)
from hadim_cli.baselines.tasks import (
    GOAL_RADIUS,
    HALF_ROOM,
    RLTask,
    draw_goal,
    draw_start,
    rl_task,
)
from hadim_cli.config import WorldConfig
from hadim_cli.errors import HadimError
from hadim_cli.world.layout import ROBOT, Property
from hadim_cli.world.scene import ObjectSpec, Scene
from hadim_cli.world.world import World

MAX_STEPS = 1000


DISCRETE_WHEELS = np.array([[1.0, 1.0], [-1.0, -1.0], [-1.0, 1.0], [1.0, -1.0]])
"""Wheel intensities of the discrete actions 0 forward, 1 backward, 2 turn left, 3 right."""

Recorder = Callable[[np.ndarray, np.ndarray, np.ndarray, float, bool, bool], None]


def world_config(base: WorldConfig, task: RLTask) -> WorldConfig:
    """The room of `base` holding only the task's objects."""
    return dataclasses.replace(base, n_green=len(task.objects), n_red=0,
                               episode_length=MAX_STEPS)


def _info_chains(info: Any, key: str) -> np.ndarray:
    if isinstance(info, Mapping):
        return np.asarray(info[key])
    return np.stack([np.asarray(i[key]) for i in np.asarray(info).ravel()])


class GoalWorldEnv(gym.Env):
    """One task of the comparison as a goal-conditioned Gymnasium environment."""

    metadata = {"render_modes": []}

    def __init__(self, task: str = "move-robot", actions: str = "discrete",
                 reward: str = "sparse", world: WorldConfig | None = None,
                 max_steps: int = MAX_STEPS, reward_scale: float = 1.0):
        self.actions = choice(Actions, actions, "actions")
        self.reward_kind = choice(Reward, reward, "reward")
        base = world or WorldConfig()
        self.task = rl_task(task, base.robot_radius)
        self.world = World(world_config(base, self.task))
        self.radius = GOAL_RADIUS
        self.max_steps = max_steps
        """Actions before an episode is truncated (the paper's 1000; smaller in tests)."""
        self.reward_scale = reward_scale
        """Factor of every reward the learner sees (1: the paper's +1000 / −5; 0.001 brings
        values near ±1, `variants.Variant.FIXED`); runs record the unscaled reward."""
        n = len(self.task.objects)
        self._dims = 4 + 2 * n
        box = np.full(self._dims, HALF_ROOM, dtype=np.float32)
        box[2:4] = 1.0
        goal = np.full(2, HALF_ROOM, dtype=np.float32)
        self.observation_space = spaces.Dict({
            "observation": spaces.Box(-box, box, dtype=np.float32),
            "achieved_goal": spaces.Box(-goal, goal, dtype=np.float32),
            "desired_goal": spaces.Box(-goal, goal, dtype=np.float32),
        })
        self.action_space = (spaces.Discrete(4) if self.actions is Actions.DISCRETE
                             else spaces.Box(-1.0, 1.0, shape=(2,), dtype=np.float32))
        lay = self.world.layout
        pos = [lay.space(e, Property.POSITION).start for e in lay.entities]
        head = lay.space(ROBOT, Property.HEADING).start
        # Where observation, the chain and the goal entity sit in the world's flat vector.
        self._obs_index = np.array([pos[0], pos[0] + 1, head, head + 1]
                                   + [p + k for p in pos[1:] for k in (0, 1)], dtype=np.intp)
        self._chain_index = np.array([[pos[e], pos[e] + 1] for e in self.task.chain],
                                     dtype=np.intp)
        self._scene: Scene | None = None
        self._goal = np.zeros(2, dtype=np.float32)
        self._flat = np.zeros(lay.size)
        self._taken: list[list[float]] = []
        self.recorder: Recorder | None = None
        """Called after every step with (wheels, observation and goal before, after, reward,
        terminated, truncated): how a run records its transitions."""

    # ------------------------------------------------------------------ gymnasium

    def reset(self, *, seed: int | None = None, options: dict | None = None):
        super().reset(seed=seed)
        scene = draw_start(self.task, self.np_random)
        goal = draw_goal(self.task, scene, self.np_random)
        return self._start(scene, goal), {}

    def step(self, action):
        if self._scene is None:
            raise HadimError("the environment has no episode yet: call reset() first")
        wheels = self.wheels(action)
        before = self._flat
        self._flat = self.world.step(wheels)
        self._taken.append(wheels.tolist())
        obs = self._observation()
        info = self._info(before)
        achieved, desired = obs["achieved_goal"].tolist(), self._goal.tolist()
        chain_after = info["chain_after"].tolist()
        chain_after[-1] = achieved  # the reward reads the float32 goal it returns
        reward = reward_1(self.reward_kind, info["chain_before"].tolist(), chain_after,
                          desired, self.radius)
        terminated = reward == GOAL_REWARD
        info["is_success"] = terminated
        raw, reward = reward, reward * self.reward_scale
        contact = self.task.forbidden_contact
        if contact is not None and contact in self.world.last_contacts:
            terminated = True
            info["contact"] = True
        truncated = not terminated and len(self._taken) >= self.max_steps
        if self.recorder is not None:
            self.recorder(wheels, np.concatenate([before[self._obs_index], self._goal]),
                          np.concatenate([self._flat[self._obs_index], self._goal]), raw,
                          terminated, truncated)
        return obs, reward, terminated, truncated, info

    def compute_reward(self, achieved_goal, desired_goal, info) -> np.ndarray:
        """The task's reward, vectorised over any leading batch shape. The guided reward
        reads the chain's positions before and after the action from `info`."""
        if self.reward_kind is Reward.SPARSE:
            return sparse_reward(achieved_goal, desired_goal, self.radius) * self.reward_scale
        before = _info_chains(info, "chain_before")
        after = _info_chains(info, "chain_after").copy()
        after[..., -1, :] = np.asarray(achieved_goal).reshape(after[..., -1, :].shape)
        return guided_reward(before, after, desired_goal, self.radius).reshape(
            np.shape(achieved_goal)[:-1]) * self.reward_scale

    # ------------------------------------------------------------------ helpers

    def wheels(self, action) -> np.ndarray:
        """The wheel command (left, right) of an action of this environment's action space."""
        if self.actions is Actions.DISCRETE:
            return DISCRETE_WHEELS[int(action)]
        return np.clip(np.asarray(action, dtype=np.float64).reshape(2), -1.0, 1.0)

    def _start(self, scene: Scene, goal: np.ndarray) -> dict[str, np.ndarray]:
        self._scene = scene
        self._goal = np.asarray(goal, dtype=np.float32)
        self._flat = self.world.reset(scene=scene)
        self._taken = []
        return self._observation()

    def _observation(self) -> dict[str, np.ndarray]:
        flat = self._flat
        return {"observation": flat[self._obs_index].astype(np.float32),
                "achieved_goal": flat[self._chain_index[-1]].astype(np.float32),
                "desired_goal": self._goal.copy()}

    def _info(self, before: np.ndarray) -> dict[str, Any]:
        return {"chain_before": before[self._chain_index], "chain_after":
                self._flat[self._chain_index]}

    @property
    def columns(self) -> list[str]:
        """Names of the values of a recorded observation and goal."""
        names = ["robot.x", "robot.y", "robot.cos", "robot.sin"]
        for i in range(len(self.task.objects)):
            names += [f"obj{i + 1}.x", f"obj{i + 1}.y"]
        return names + ["goal.x", "goal.y"]

    @property
    def goal(self) -> np.ndarray:
        return self._goal.copy()

    @property
    def steps(self) -> int:
        return len(self._taken)

    def start_from(self, scene: Scene, goal: Sequence[float]) -> dict[str, np.ndarray]:
        """Start an episode from a given scene and goal (evaluation)."""
        return self._start(scene, np.asarray(goal))

    # ------------------------------------------------------------------ checkpoints

    def snapshot(self) -> dict[str, Any]:
        """The episode in progress and the generator, as JSON."""
        scene = self._scene
        return {
            "rng": self.np_random.bit_generator.state,
            "scene": None if scene is None else {
                "robot": [scene.robot_x, scene.robot_y, scene.robot_heading],
                "objects": [[o.x, o.y] for o in scene.objects]},
            "goal": self._goal.tolist(), "actions": self._taken,
        }

    def restore(self, snap: Mapping[str, Any]) -> dict[str, np.ndarray] | None:
        """Rebuild the episode of `snapshot()`; its observation, or None if none had begun."""
        self.np_random.bit_generator.state = snap["rng"]
        if snap["scene"] is None:
            return None
        objects = tuple(ObjectSpec(x, y, s.radius, s.height, s.color, s.pushable, s.shape)
                        for (x, y), s in zip(snap["scene"]["objects"], self.task.objects,
                                             strict=True))
        self._start(Scene(objects, *snap["scene"]["robot"]), np.asarray(snap["goal"]))
        for wheels in snap["actions"]:
            self._flat = self.world.step(np.asarray(wheels))
            self._taken.append(list(wheels))
        return self._observation()


def register() -> None:
    """`hadim/move-robot-v0`, `hadim/push-object-v0`, `hadim/push-with-tool-v0`; pass
    `actions="continuous"` and `reward="guided"` to `gymnasium.make` for the variants."""
    for task in ("move-robot", "push-object", "push-with-tool"):
        env_id = f"hadim/{task}-v0"
        if env_id not in gym.registry:
            gym.register(id=env_id, entry_point="hadim_cli.baselines.env:GoalWorldEnv",
                         kwargs={"task": task}, disable_env_checker=True)
