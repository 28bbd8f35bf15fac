"""Named variants of a baseline's protocol (issue 46): the paper's, and the one a practitioner
would fix it to. A variant is a set of parameters written into the run's config (so a stored
run says what it is), not a flag threaded through the agents.

`fixed` changes, each for a measured reason (docs/baselines.md, "Why the paper's protocol does
not learn"):
- rewards × 0.001 (+1 / −0.005, guided ≤ +0.02): under +1000 / −5 and γ = 0.99 the values
  span about −500 … +1000, where SB3's Huber loss is linear (every gradient clipped to 1) and
  DQN takes a very long time to fit them (dqn, a2c, curious);
- the goal in the robot's frame as an input (`features.goal_frame`; q-learning: the
  robot-frame discretisation `qlearning.robot_frame_cells`);
- HER (future, k = 4) on DQN, as CURIOUS has;
- ε decaying 1 → 0.05 over 50 000 iterations instead of 5000 (horizon 500 000).
"""

from __future__ import annotations

import dataclasses
import enum

from hadim_cli.baselines.config import HER_PARAMS, Algorithm, BaselineConfig
from hadim_cli.baselines.rewards import Reward

REWARD_SCALE = 0.001
FIXED_HORIZON = 500_000


class Variant(enum.StrEnum):
    PAPER = "paper"
    """The paper's protocol as the 50 000-iteration grids ran it (docs/baselines.md)."""
    FIXED = "fixed"
    """What a practitioner fixes (this module's docstring)."""


def apply_variant(cfg: BaselineConfig, variant: Variant) -> BaselineConfig:
    """`cfg` with the variant's parameters."""
    if variant is Variant.PAPER:
        return cfg
    algo = Algorithm(cfg.algorithm)
    params = dict(cfg.params)
    if algo is Algorithm.Q_LEARNING:
        params["frame"] = "robot"
    else:
        params.update(reward_scale=REWARD_SCALE, goal_frame=True)
    if algo is Algorithm.DQN:
        params["her"] = {**HER_PARAMS, "copy_info_dict": Reward(cfg.reward) is Reward.GUIDED}
    return dataclasses.replace(cfg, params=params, horizon=FIXED_HORIZON, variant=variant.value)
