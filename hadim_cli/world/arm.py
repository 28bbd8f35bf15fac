"""The planar arm on its table (the paper's future work, issue #48): `reset`, `step`, observe.

The same contract as the room (`environment.Environment`): the world declares its body
(`Body.ARM`), its primitive action (one speed command in [-1, 1] per joint, held for
`action_duration`, then `settle_time` with the joints held still) and its observation layout:
entity 0 is the `effector` (its position, every joint's angle, and its looks), entities 1..n
the objects, read as in the room (position, position relative to the effector, radius,
height, colour, shape). A fresh pymunk space at every reset (`arm_physics.py`).
"""

from __future__ import annotations

import math

import numpy as np

from hadim_cli.config import Body, WorldConfig
from hadim_cli.errors import HadimError
from hadim_cli.world.actions import joint_actions
from hadim_cli.world.arm_physics import ArmPhysics, build_arm_physics
from hadim_cli.world.environment import (
    Environment,
    check_objects,
    fill_looks,
    fill_object_looks,
)
from hadim_cli.world.kinematics import joint_ranges
from hadim_cli.world.layout import (
    EFFECTOR,
    LayoutBounds,
    ObservationLayout,
    Property,
    Shape,
    arm_spaces,
)
from hadim_cli.world.placement import ROBOT_COLOR, draw_arm_scene
from hadim_cli.world.scene import ArmScene


def _angles(links: list[list[float]]) -> list[float]:
    """Every joint's angle, base outwards, from the links' (x, y, angle) poses: the first
    link's angle, then each link's from the one before it (plain floats: cheaper than numpy at
    this size)."""
    joints, inner = [], 0.0
    for _, _, angle in links:
        joints.append(angle - inner)
        inner = angle
    return joints


def arm_layout(config: WorldConfig) -> ObservationLayout:
    """The observation layout of arm worlds built from `config`."""
    arm = config.arm
    bounds = LayoutBounds(
        half_width=arm.table_width / 2,
        half_height=arm.table_height / 2,
        lidar_range=0.0,
        radius_max=max(config.object_radius_max, arm.effector_radius),
        height_max=max(config.object_height_max, arm.effector_height),
        joint_limits=tuple(arm.joint_limits),
    )
    return ObservationLayout.for_actor(EFFECTOR, arm_spaces(len(arm.link_lengths)),
                                       config.n_green + config.n_red, bounds)


class ArmWorld(Environment[ArmScene, ArmPhysics]):
    """The arm, its table and the objects of one episode at a time."""

    body = Body.ARM

    def __init__(self, config: WorldConfig):
        super().__init__(config, arm_layout(config))
        arm = config.arm
        self.action_space = joint_actions(len(arm.link_lengths))
        """One speed command per joint, base outwards, each in [-1, 1]."""
        self._n = len(arm.link_lengths)
        self._last_length = arm.link_lengths[-1]
        self._ranges = joint_ranges(arm.joint_limits)
        self._speed = arm.max_joint_speed
        self._effector_pos = self.layout.space(EFFECTOR, Property.POSITION).slice
        self._orientation = self.layout.space(EFFECTOR, Property.ORIENTATION).slice
        self._joints = self.layout.space(EFFECTOR, Property.JOINTS).slice

    # ------------------------------------------------------------------ episode

    def draw_scene(self, rng: np.random.Generator) -> ArmScene:
        return draw_arm_scene(self.config, rng)

    def _check_scene(self, scene: ArmScene) -> None:
        arm = self.config.arm
        check_objects(self.layout, scene.objects, arm.table_width / 2, arm.table_height / 2,
                      "table")
        if len(scene.joints) != self._n:
            raise HadimError(f"the scene gives {len(scene.joints)} joint angles, the arm has "
                             f"{self._n} joints (world.arm.link_lengths)")
        for i, (q, limit) in enumerate(zip(scene.joints, self._ranges, strict=True)):
            if not abs(q) <= limit:
                raise HadimError(f"the scene turns joint {i + 1} to {q} rad, beyond its "
                                 f"limit ±{limit:g}")

    def _build(self, scene: ArmScene) -> ArmPhysics:
        return build_arm_physics(self.config, scene)

    def _fill_static(self, scene: ArmScene) -> None:
        arm = self.config.arm
        fill_looks(self._obs, self.layout, EFFECTOR, arm.effector_radius, arm.effector_height,
                   ROBOT_COLOR, Shape.CYLINDER)
        fill_object_looks(self._obs, self.layout, scene.objects)

    # ------------------------------------------------------------------ acting

    def step(self, action: object) -> np.ndarray:
        """Drive each joint at its command × `max_joint_speed` for one action (each motor's
        torque bounded), then hold the joints still for `settle_time`; observe."""
        physics = self._require_physics()
        command = self.action_space.check(action)
        speed = self._speed
        for motor, c in zip(physics.motors, command, strict=True):
            motor.rate = -c * speed
        physics.contacts.start()
        space, dt = physics.space, self._dt
        for _ in range(self._substeps):
            space.step(dt)
        if self._settle:
            for motor in physics.motors:
                motor.rate = 0.0
            for _ in range(self._settle):
                space.step(dt)
        self._steps += 1
        self.last_contacts = frozenset(physics.contacts.touched)
        return self.observe()

    # ------------------------------------------------------------------ observing

    def joint_angles(self) -> np.ndarray:
        """Every joint's angle (rad), base outwards: the first link's from the table's +x
        axis (the observation's `Property.ORIENTATION`), each other's from the link before it
        (`Property.JOINTS`)."""
        return np.array(_angles(self._require_physics().poses.poses()[:self._n].tolist()))

    def effector_position(self) -> tuple[float, float]:
        """(x, y) of the effector's centre (m), read from the last link's body."""
        x, y = self.observe()[self._effector_pos].tolist()
        return x, y

    def observe(self) -> np.ndarray:
        obs, n = self._obs, self._n
        poses = self._require_physics().poses.poses()
        links = poses[:n].tolist()
        joints = _angles(links)
        x, y, angle = links[-1]
        tip = (x + self._last_length * math.cos(angle), y + self._last_length * math.sin(angle))
        centers = poses[n:, :2]
        obs[self._effector_pos] = tip
        obs[self._orientation] = (math.cos(joints[0]), math.sin(joints[0]))
        obs[self._joints] = joints[1:]
        obs[self._obj_pos] = centers
        obs[self._obj_rel] = centers - tip
        return obs.copy()
