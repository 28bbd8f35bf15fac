"""The goal in the robot's frame, as inputs a practitioner adds to a goal-conditioned policy.

The paper's encoding gives the network absolute positions, the robot's heading as (cos, sin)
and the goal: to act it must learn "where is the goal, seen from the robot" — a rotation by
the heading, a product of inputs a [64, 64] MLP approximates slowly. `goal_frame` computes it:
each object's position relative to the robot, and each goal slot's desired − achieved, rotated
into the robot's frame. Computed from the observation's keys inside the network, so HER's
relabelled goals get their own relative inputs.
"""

from __future__ import annotations

from typing import Any


def goal_frame(observation, achieved, desired, slots: int):
    """(batch, 2 · (objects + slots)) relative inputs, in the robot's frame (torch tensors)."""
    import torch

    robot = observation[:, :2]
    cos, sin = observation[:, 2:3], observation[:, 3:4]

    def rotate(v):
        return torch.cat([cos * v[:, :1] + sin * v[:, 1:2], -sin * v[:, :1] + cos * v[:, 1:2]],
                         dim=1)

    parts = [rotate(observation[:, 4 + 2 * k: 6 + 2 * k] - robot)
             for k in range((observation.shape[1] - 4) // 2)]
    parts += [rotate(desired[:, 2 * i: 2 * i + 2] - achieved[:, 2 * i: 2 * i + 2])
              for i in range(slots)]
    return torch.cat(parts, dim=1)


def goal_frame_extractor() -> type:
    """An SB3 features extractor class: the flattened keys (as `MultiInputPolicy`'s) and
    `goal_frame` (its `slots`: goal slots, 1, or CURIOUS's modules)."""
    import torch
    from stable_baselines3.common.torch_layers import BaseFeaturesExtractor

    class GoalFrame(BaseFeaturesExtractor):
        def __init__(self, space: Any, slots: int):
            size = sum(int(space[k].shape[0]) for k in ("observation", "achieved_goal",
                                                         "desired_goal"))
            objects = (int(space["observation"].shape[0]) - 4) // 2
            super().__init__(space, size + 2 * (objects + slots))
            self.slots = slots

        def forward(self, obs):
            o, a, d = obs["observation"], obs["achieved_goal"], obs["desired_goal"]
            return torch.cat([o, a, d, goal_frame(o, a, d, self.slots)], dim=1)

    return GoalFrame
