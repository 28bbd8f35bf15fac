"""What a baseline run is, and every check its config allows before an agent is built.

A baseline run stores a `BaselineConfig` as its config (`kind = "baseline"`). Its checks (an
algorithm's combinations, totals and periods the agent's steps divide, a task of the run's
kind) need neither the agents' libraries (stable-baselines3, torch) nor the world's physics
(pymunk, gymnasium): `hadim baseline train` and the refusals of `resume` and `eval` on a
baseline run answer before any of them is imported (`agents` builds the agents).
"""

from __future__ import annotations

import enum
import math
from dataclasses import asdict, dataclass, field, replace
from typing import Any, TypeVar

from hadim_cli.baselines.qlearning import QLearningParams
from hadim_cli.baselines.rewards import Reward
from hadim_cli.baselines.tasks import body_tasks, rl_task
from hadim_cli.config import Body, WorldConfig, stored_config
from hadim_cli.errors import HadimError
from hadim_cli.evaluation.tasks import Task, check_body, check_inside

E = TypeVar("E", bound=enum.StrEnum)


class Actions(enum.StrEnum):
    DISCRETE = "discrete"
    """The paper's 4 actions: forward, backward, turn left, turn right."""
    CONTINUOUS = "continuous"
    """The wheel command (left, right) ∈ [-1, 1]², as the learner's primitive action."""


def choice(kind: type[E], value: str, what: str) -> E:
    """`value` as a member of `kind`, or a `HadimError` listing the allowed values."""
    try:
        return kind(value)
    except ValueError:
        allowed = ", ".join(m.value for m in kind)
        raise HadimError(f"unknown {what} '{value}' (known: {allowed})") from None


CHUNK_MULTIPLE = 20
"""Chunks (iterations between checkpoints) are multiples of DQN's train_freq (4) and A2C's
n_steps (5), so SB3 never runs past a chunk's end."""


class Algorithm(enum.StrEnum):
    Q_LEARNING = "q-learning"
    DQN = "dqn"
    A2C = "a2c"
    CURIOUS = "curious"


DQN_PARAMS: dict[str, Any] = {
    "learning_rate": 1e-4, "buffer_size": 100_000, "learning_starts": 1000, "batch_size": 32,
    "gamma": 0.99, "train_freq": 4, "gradient_steps": 1, "target_update_interval": 1000,
    "exploration_fraction": 0.1, "exploration_initial_eps": 1.0, "exploration_final_eps": 0.05,
}
"""SB3's DQN defaults but target_update_interval 10 000 → 1 000 (a 50 000-iteration run would
update its target 5 times) and learning_starts 100 → 1 000; net [64, 64] (SB3's default)."""
A2C_PARAMS: dict[str, Any] = {"learning_rate": 7e-4, "n_steps": 5, "gamma": 0.99,
                              "ent_coef": 0.0}
"""SB3's A2C defaults (RMSprop, n_steps 5), one environment."""
HER_PARAMS: dict[str, Any] = {"n_sampled_goal": 4, "goal_selection_strategy": "future"}
CURIOUS_HER: dict[str, Any] = {**HER_PARAMS, "modular": True}
"""CURIOUS's modular HER: module and goal relabelled (`curious.modular_her_buffer`)."""


@dataclass(frozen=True)
class BaselineConfig:
    """What a baseline run is: stored as the run's config (`kind = "baseline"`)."""

    algorithm: str
    task: str
    reward: str
    actions: str = "discrete"
    horizon: int = 50_000
    """Iterations the exploration schedule spans (the first `train`'s --iterations)."""
    chunk: int = 1000
    """Iterations between checkpoints (--checkpoint-every; default --eval-every, else 1000);
    evaluations also end a chunk."""
    eval_every: int = 1000
    eval_at: tuple[int, ...] = ()
    """Iterations evaluated at besides the multiples of `eval_every` (a log-spaced schedule,
    `schedule.log_schedule`); each a multiple of `multiple`."""
    episode_length: int = 1000
    """Actions before an episode is truncated (the paper's 1000)."""
    n_envs: int = 1
    """Environments stepped together (SB3's vectorised environment); iterations count the
    steps of every environment."""
    params: dict[str, Any] = field(default_factory=dict)
    world: dict[str, Any] = field(default_factory=dict)
    variant: str = "paper"
    """The protocol's variant (`variants.Variant`): the paper's, or the practitioner's fix."""

    def to_dict(self) -> dict[str, Any]:
        return {"kind": "baseline", "baseline": asdict(self)}

    @property
    def multiple(self) -> int:
        return chunk_multiple(self.params, self.n_envs)

    @property
    def world_config(self) -> WorldConfig:
        if not self.world:
            return WorldConfig()
        # A run stored before a world key existed keeps the world it trained in.
        return stored_config({"world": self.world}).world


def refusal(algo: Algorithm, reward: Reward, actions: Actions) -> str | None:
    """Why this combination is not one of the comparison's (None when it is)."""
    if algo is not Algorithm.A2C and actions is not Actions.DISCRETE:
        return f"{algo.value} needs --actions discrete (only a2c takes continuous)"
    if algo is Algorithm.CURIOUS and reward is not Reward.SPARSE:
        return "curious learns on the sparse reward, as in the paper: --reward sparse"
    return None


def chunk_multiple(params: dict[str, Any], n_envs: int) -> int:
    """What chunks, totals and evaluation periods are multiples of, so that SB3 never runs
    past a chunk's end: a DQN training step (train_freq steps of every environment) and an
    A2C rollout (n_steps of every environment) end on it."""
    step = int(params.get("train_freq", params.get("n_steps", 1)))
    return math.lcm(CHUNK_MULTIPLE, step * n_envs)


def _check_envs(algo: Algorithm, n_envs: int) -> None:
    if n_envs < 1:
        raise HadimError(f"--n-envs must be at least 1, got {n_envs}")
    if n_envs > 1 and algo not in (Algorithm.DQN, Algorithm.A2C):
        raise HadimError(f"{algo.value} runs one environment (--n-envs 1): only dqn and a2c "
                         "step several")


def task_world(task: str) -> WorldConfig:
    """The default world of the body a built-in task belongs to (the rover's for a name no
    task file holds: `make_config` then names the known tasks)."""
    from hadim_cli.evaluation.tasks import load_task, task_names

    if task not in task_names():
        return WorldConfig()
    return replace(WorldConfig(), body=load_task(task).body)


def make_config(algorithm: str, task: str, reward: str, actions: str, horizon: int,
                eval_every: int, world: WorldConfig, episode_length: int = 1000,
                checkpoint_every: int | None = None, n_envs: int = 1) -> BaselineConfig:
    """A checked config with the algorithm's parameters resolved; `HadimError` if impossible."""
    algo = choice(Algorithm, algorithm, "algorithm")
    acts = choice(Actions, actions, "actions")
    if task not in body_tasks(world):
        known = "; ".join(f"the {body.value}'s: {', '.join(body_tasks(replace(world, body=body)))}"
                          for body in Body)
        raise HadimError(f"unknown task '{task}' for the {world.body.value} (known: {known})")
    why = refusal(algo, choice(Reward, reward, "reward"), acts)
    if why is not None:
        raise HadimError(why)
    _check_envs(algo, n_envs)
    params = {Algorithm.Q_LEARNING: asdict(QLearningParams()), Algorithm.DQN: DQN_PARAMS,
              Algorithm.A2C: A2C_PARAMS, Algorithm.CURIOUS: {**DQN_PARAMS, "her": CURIOUS_HER}}
    chosen = dict(params[algo])
    multiple = chunk_multiple(chosen, n_envs)
    for option, value in (("--eval-every", eval_every), ("--checkpoint-every", checkpoint_every)):
        if value is not None and value % multiple:
            raise HadimError(f"{option} must be a multiple of {multiple}, got {value}")
    if "gradient_steps" in chosen:  # one gradient step per train_freq steps of each env
        chosen["gradient_steps"] *= n_envs
    if "learning_starts" in chosen:  # HER samples only from finished episodes
        chosen["learning_starts"] = min(chosen["learning_starts"], episode_length)
    return BaselineConfig(algo.value, task, reward, acts.value, horizon=horizon,
                          chunk=checkpoint_every or eval_every or -(-1000 // multiple) * multiple,
                          eval_every=eval_every,
                          episode_length=episode_length, n_envs=n_envs, params=chosen,
                          world=asdict(world))


def read_config(stored: dict[str, Any]) -> BaselineConfig:
    values = dict(stored["baseline"])
    values["eval_at"] = tuple(values.get("eval_at", ()))
    return BaselineConfig(**values)


def check_total(total: int, multiple: int = CHUNK_MULTIPLE) -> None:
    if total % multiple:
        raise HadimError(f"--iterations must be a multiple of {multiple} for this baseline "
                         f"run, got {total}")


def check_fits(cfg: BaselineConfig, task: Task) -> None:
    """A baseline drives the entity it trained for, inside the room's walls: refuse a task of
    another body or another kind, or a target point outside the walls."""
    world = cfg.world_config
    check_body(task, world)
    trained = rl_task(cfg.task, world)
    if task.headings is not None:
        raise HadimError(f"task {task.name} asks for headings: the baselines learn positions "
                         "only")
    wants_objects = 0 if task.drives_actor else (2 if task.tool else 1)
    if wants_objects != len(trained.objects):
        raise HadimError(f"this run learned {cfg.task}; task {task.name} drives "
                         f"{'the robot' if task.drives_actor else 'an object'}"
                         f"{' through a tool' if task.tool else ''}: evaluate it on "
                         f"--task {cfg.task} (or a points file of that kind)")
    check_inside(task, world)
