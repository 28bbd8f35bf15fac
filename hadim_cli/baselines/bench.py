"""`hadim bench env`: steps per second of a goal environment against `World.step` alone.

Both loops run the same wheel commands from the same start scenes, interleaved block by block
so machine load hits both alike; the world loop only steps the world of the same task (no
observation dict, reward, termination or recording). Resets are not timed.
"""

from __future__ import annotations

import time
from dataclasses import asdict, dataclass

import numpy as np

from hadim_cli.baselines.env import GoalWorldEnv
from hadim_cli.world.world import World

BLOCK = 200


@dataclass(frozen=True)
class EnvBench:
    task: str
    reward: str
    actions: str
    steps: int
    env_steps_per_s: float
    world_steps_per_s: float

    @property
    def overhead(self) -> float:
        """Extra time per step of the environment over `World.step` (0.1 = 10 %)."""
        return self.world_steps_per_s / self.env_steps_per_s - 1.0

    def to_dict(self) -> dict:
        return {**asdict(self), "overhead": self.overhead}


def bench_env(task: str, reward: str, actions: str, steps: int, seed: int) -> EnvBench:
    env = GoalWorldEnv(task, actions, reward)
    world = World(env.world.config)
    rng = np.random.default_rng(seed)
    env_s = world_s = 0.0
    env.reset(seed=seed)
    done = 0
    while done < steps:
        n = min(BLOCK, steps - done)
        picks = [env.action_space.sample() for _ in range(n)]
        wheels = [env.wheels(a) for a in picks]
        obs, _ = env.reset(seed=int(rng.integers(2**31)))
        world.reset(scene=env._scene)
        t = time.perf_counter()
        for a in picks:
            env.step(a)  # an episode that ends keeps stepping: the world allows it
        env_s += time.perf_counter() - t
        t = time.perf_counter()
        for w in wheels:
            world.step(w)
        world_s += time.perf_counter() - t
        done += n
    return EnvBench(task, reward, actions, steps, steps / env_s, steps / world_s)
