"""Goal-conditioned Gymnasium environments over the same `World` (paper §5.3).

`GoalWorldEnv(task, actions, reward)` is one task of the comparison: the robot starts anywhere
with any heading, the objects of the task are drawn around it, a goal is drawn for the task's
goal entity; an episode ends when the goal entity enters the goal zone (`terminated`), on
push-with-tool when the robot touches the target (`terminated`, failed), or after 1000
actions (`truncated`). Observations are a Dict (`observation`, `achieved_goal`,
`desired_goal`), so SB3's `MultiInputPolicy` is a UVFA and HER can relabel goals;
`compute_reward` is vectorised.

The environment follows what its world declares (`make_world`): on the arm (`world.body =
"arm"`, tasks `reach`, `arm-push`, `arm-push-with-tool`) the observation holds the effector's
position, orientation and bends instead of the robot's position and heading, the discrete actions
are the arm's moves (each joint one way or the other: `ActionSpace.discrete`), the continuous
ones one speed per joint, and the forbidden contact is the effector's.

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
    ARM_TASKS,
    GOAL_RADIUS,
    TASKS,
    RLTask,
    draw_goal,
    draw_start,
    rl_task,
)
from hadim_cli.config import Body, WorldConfig
from hadim_cli.errors import HadimError
from hadim_cli.world.actions import ROVER_ACTIONS
from hadim_cli.world.environment import make_world
from hadim_cli.world.layout import ObservationLayout, Property, SpaceSpec
from hadim_cli.world.scene import ArmScene, ObjectSpec, Scene

MAX_STEPS = 1000


DISCRETE_WHEELS = ROVER_ACTIONS.discrete
"""Wheel intensities of the rover's discrete actions 0 forward, 1 backward, 2 turn left,
3 right."""
POSE: tuple[tuple[Property, tuple[str, ...] | None], ...] = (
    (Property.HEADING, ("cos", "sin")), (Property.ORIENTATION, ("cos", "sin")),
    (Property.JOINTS, None))
"""The actor's pose beyond its position, whichever of these the world declares, and the names
of its values (None: the names of the last action components, one joint each: the joints
after the first, whose direction is the orientation)."""

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
        self.task = rl_task(task, base)
        self.world = make_world(world_config(base, self.task))
        self.radius = GOAL_RADIUS
        self.max_steps = max_steps
        """Actions before an episode is truncated (the paper's 1000; smaller in tests)."""
        self.reward_scale = reward_scale
        """Factor of every reward the learner sees (1: the paper's +1000 / −5; 0.001 brings
        values near ±1, `variants.Variant.FIXED`); runs record the unscaled reward."""
        lay = self.world.layout
        moves = self.world.action_space
        self._moves = moves.discrete
        self._observed = _observed(lay)
        # Where observation, the chain and the goal entity sit in the world's flat vector.
        self._obs_index = np.concatenate([np.arange(s.start, s.start + s.dim)
                                          for s in self._observed]).astype(np.intp)
        self._dims = len(self._obs_index)
        low = np.concatenate([s.low for s in self._observed]).astype(np.float32)
        high = np.concatenate([s.high for s in self._observed]).astype(np.float32)
        # A joint pressed to its stop reads up to ~0.4 mrad past it (docs/world.md): held in.
        self._low, self._high = low, high
        goal = lay.space(lay.actor, Property.POSITION)
        goal_low, goal_high = (np.asarray(b, dtype=np.float32) for b in (goal.low, goal.high))
        self.observation_space = spaces.Dict({
            "observation": spaces.Box(low, high, dtype=np.float32),
            "achieved_goal": spaces.Box(goal_low, goal_high, dtype=np.float32),
            "desired_goal": spaces.Box(goal_low, goal_high, dtype=np.float32),
        })
        self.action_space = (spaces.Discrete(len(self._moves))
                             if self.actions is Actions.DISCRETE
                             else spaces.Box(-1.0, 1.0, shape=(moves.dim,), dtype=np.float32))
        pos = [lay.space(e, Property.POSITION).start for e in lay.entities]
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
        contact = self.task.forbidden_contact(self.world.layout.actor)
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
        """The world's command (the rover's wheels (left, right), the arm's joint speeds) of
        an action of this environment's action space."""
        if self.actions is Actions.DISCRETE:
            return self._moves[int(action)]
        dim = self._moves.shape[1]
        return np.clip(np.asarray(action, dtype=np.float64).reshape(dim), -1.0, 1.0)

    def _start(self, scene: Scene | ArmScene, goal: np.ndarray) -> dict[str, np.ndarray]:
        self._scene = scene
        self._goal = np.asarray(goal, dtype=np.float32)
        self._flat = self.world.reset(scene=scene)
        self._taken = []
        return self._observation()

    def _observation(self) -> dict[str, np.ndarray]:
        flat = self._flat
        return {"observation": np.clip(flat[self._obs_index].astype(np.float32), self._low,
                                       self._high),
                "achieved_goal": flat[self._chain_index[-1]].astype(np.float32),
                "desired_goal": self._goal.copy()}

    def _info(self, before: np.ndarray) -> dict[str, Any]:
        return {"chain_before": before[self._chain_index], "chain_after":
                self._flat[self._chain_index]}

    @property
    def columns(self) -> list[str]:
        """Names of the values of a recorded observation and goal."""
        suffixes = dict(POSE)
        names = []
        for s in self._observed:
            values = (("x", "y") if s.prop is Property.POSITION
                      else suffixes[s.prop] or self.world.action_space.names[-s.dim:])
            names += [f"{s.entity}.{v}" for v in values]
        return names + ["goal.x", "goal.y"]

    @property
    def observed(self) -> tuple[tuple[SpaceSpec, slice], ...]:
        """Each space an observation holds, as its world declares it (entity, property,
        bounds), with its columns in `observation_space["observation"]`."""
        out, start = [], 0
        for s in self._observed:
            out.append((s, slice(start, start + s.dim)))
            start += s.dim
        return tuple(out)

    def position_columns(self, entity: int) -> slice:
        """Where entity `entity` (0: the actor) of the layout has its position in an
        observation (`observation_space["observation"]`)."""
        name = self.world.layout.entities[entity]
        for s, cols in self.observed:
            if s.entity == name and s.prop is Property.POSITION:
                return cols
        raise ValueError(f"entity {name} has no position in this observation")

    @property
    def goal(self) -> np.ndarray:
        return self._goal.copy()

    @property
    def steps(self) -> int:
        return len(self._taken)

    def start_from(self, scene: Scene | ArmScene, goal: Sequence[float]
                   ) -> dict[str, np.ndarray]:
        """Start an episode from a given scene and goal (evaluation)."""
        return self._start(scene, np.asarray(goal))

    # ------------------------------------------------------------------ checkpoints

    def snapshot(self) -> dict[str, Any]:
        """The episode in progress and the generator, as JSON."""
        scene = self._scene
        return {
            "rng": self.np_random.bit_generator.state,
            "scene": None if scene is None else {
                **({"joints": list(scene.joints)} if isinstance(scene, ArmScene) else
                   {"robot": [scene.robot_x, scene.robot_y, scene.robot_heading]}),
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
        saved = snap["scene"]
        scene = (ArmScene(objects, tuple(saved["joints"])) if "joints" in saved
                 else Scene(objects, *saved["robot"]))
        self._start(scene, np.asarray(snap["goal"]))
        for wheels in snap["actions"]:
            self._flat = self.world.step(np.asarray(wheels))
            self._taken.append(list(wheels))
        return self._observation()


def _observed(lay: ObservationLayout) -> list[SpaceSpec]:
    """The spaces an observation holds: the actor's position and pose (`POSE`), then each
    object's position."""
    actor = [lay.space(lay.actor, Property.POSITION)]
    actor += [lay.space(lay.actor, p) for p, _ in POSE if lay.has(lay.actor, p)]
    return actor + [lay.space(o, Property.POSITION) for o in lay.objects]


def register() -> None:
    """`hadim/move-robot-v0`, `hadim/push-object-v0`, `hadim/push-with-tool-v0`, and the
    arm's `hadim/reach-v0`, `hadim/arm-push-v0`, `hadim/arm-push-with-tool-v0`; pass
    `actions="continuous"` and `reward="guided"` to `gymnasium.make` for the variants."""
    arm = WorldConfig(body=Body.ARM)
    for task in (*TASKS, *ARM_TASKS):
        env_id = f"hadim/{task}-v0"
        kwargs: dict[str, Any] = {"task": task}
        if task in ARM_TASKS:
            kwargs["world"] = arm
        if env_id not in gym.registry:
            gym.register(id=env_id, entry_point="hadim_cli.baselines.env:GoalWorldEnv",
                         kwargs=kwargs, disable_env_checker=True)
