"""One learning session: the world, the learner and their generators, episode by episode.

One seeded `numpy.random.Generator` is the root of all randomness: it spawns the world's
generator (scenes) and the learner's (exploration, subsampling, p_A). Evaluation draws from
neither. `Session.state()` / `Session.restore()` capture everything a bit-identical
continuation needs, as JSON and arrays (no pickle); the store persists them.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from hadim_cli.config import Config
from hadim_cli.learner.dataset import Dataset
from hadim_cli.learner.explorer import Learner, LearningEpisode
from hadim_cli.world.environment import Environment, make_world


class TrainingActuator:
    """Executes primitive actions in the training world and records each one in D."""

    def __init__(self, world: Environment[Any, Any], dataset: Dataset, obs: np.ndarray):
        self.world = world
        self.dataset = dataset
        self._obs = obs

    @property
    def obs(self) -> np.ndarray:
        return self._obs

    @property
    def exhausted(self) -> bool:
        return self.world.episode_over

    def act(self, action: np.ndarray) -> np.ndarray:
        before = self._obs
        self._obs = self.world.step(action)
        self.dataset.append(np.asarray(action, dtype=float), before, self._obs)
        return self._obs


@dataclass(frozen=True)
class EpisodeLog:
    """One environment episode: its index, iterations [start, stop) and learning episodes."""

    index: int
    start: int
    stop: int
    learning: tuple[LearningEpisode, ...]


class Session:
    """World + learner + generators; runs environment episodes."""

    def __init__(self, config: Config, seed: int):
        import torch

        # p_A is a 32-wide MLP trained on batches of a few dozen rows: intra-op threads only
        # add synchronisation, and with sessions running side by side (`hadim sweep`)
        # they fought over the cores — 8 ms per backward pass instead of 0.1 ms.
        torch.set_num_threads(1)
        self.config = config
        self.seed = seed
        root = np.random.default_rng(seed)
        self.world_rng, self.learner_rng = root.spawn(2)
        self.world = make_world(config.world)
        self.learner = Learner(config.learner, self.world.layout, self.world.action_space,
                               config.planner)
        self.episodes_done = 0

    @property
    def iteration(self) -> int:
        return self.learner.iteration

    def run_episode(self) -> EpisodeLog:
        """One environment episode: a fresh scene, learning episodes until its actions run out."""
        obs = self.world.reset(self.world_rng)
        start = self.iteration
        self.learner.dataset.start_episode()
        actuator = TrainingActuator(self.world, self.learner.dataset, obs)
        learning = []
        while not actuator.exhausted:
            learning.append(self.learner.learning_episode(actuator, self.learner_rng))
        log = EpisodeLog(self.episodes_done, start, self.iteration, tuple(learning))
        self.episodes_done += 1
        return log

    def run(self, iterations: int,
            on_episode: Callable[[EpisodeLog], bool | None] | None = None) -> None:
        """Run episodes until `iterations` in total; `on_episode` returning True stops early."""
        while self.iteration < iterations:
            log = self.run_episode()
            if on_episode is not None and on_episode(log):
                return
