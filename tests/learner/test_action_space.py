"""The learner and the controller take the primitive action from the world: its size and its
box. A hand-built body of three action components — a disc on a table whose effector each
component pushes one way — with no heading and no LIDAR, among three parked objects."""

from __future__ import annotations

import numpy as np

from hadim_cli.config import LearnerConfig
from hadim_cli.learner.dataset import Dataset
from hadim_cli.learner.explorer import Learner
from hadim_cli.learner.goals import Binding
from hadim_cli.learner.spaces import ACTION, Property, Role, RoleSpace, Rows
from hadim_cli.world.actions import ROVER_ACTIONS, joint_actions
from hadim_cli.world.layout import EFFECTOR, LayoutBounds, ObservationLayout, arm_spaces

EFFECTOR_POSITION = RoleSpace(Role.ROBOT, Property.POSITION)
PUSH = np.array([[0.05, 0.0, 0.03], [0.0, 0.05, -0.03]])
"""How far each action component moves the effector (m): column j for component j at 1."""
BOUNDS = LayoutBounds(2, 2, 1.5, 0.25, 0.6, joint_limits=(np.pi, 2.0, 2.0))


class Slider:
    """An actuator of the hand-built body: the effector moves by PUSH @ action; every action
    it is handed is recorded, and in `dataset` if given (as training's actuator does)."""

    def __init__(self, layout: ObservationLayout, dataset: Dataset | None = None,
                 budget: int = 10_000):
        self.layout = layout
        self.dataset = dataset
        self.budget = budget
        self.sent: list[np.ndarray] = []
        self.obs = np.zeros(layout.size)
        self._set(EFFECTOR, Property.RADIUS, [0.05])
        for i, name in enumerate(layout.objects):
            self._set(name, Property.RADIUS, [0.1])
            self._set(name, Property.COLOR, [0.2, 0.8, 0.2])
            self._set(name, Property.POSITION, [-1.5 + 1.5 * i, 1.8])
        self._place(np.zeros(2))

    def _set(self, entity: str, prop: Property, value) -> None:
        self.obs[self.layout.space(entity, prop).slice] = value

    def _place(self, xy: np.ndarray) -> None:
        self._set(EFFECTOR, Property.POSITION, xy)
        for name in self.layout.objects:
            pos = self.obs[self.layout.space(name, Property.POSITION).slice]
            self._set(name, Property.RELATIVE, pos - xy)

    @property
    def exhausted(self) -> bool:
        return len(self.sent) >= self.budget

    def act(self, action: np.ndarray) -> np.ndarray:
        action = np.asarray(action, dtype=float)
        self.sent.append(action.copy())
        before = self.obs.copy()
        here = self.obs[self.layout.space(EFFECTOR, Property.POSITION).slice]
        self._place(np.clip(here + PUSH @ action, -1.2, 1.2))
        if self.dataset is not None:
            self.dataset.append(action, before, self.obs.copy())
        return self.obs.copy()


def _body() -> tuple[Learner, Slider]:
    layout = ObservationLayout.for_actor(EFFECTOR, arm_spaces(3), 3, BOUNDS)
    learner = Learner(LearnerConfig(), layout, joint_actions(3))
    return learner, Slider(layout, learner.dataset)


def test_the_learner_babbles_and_stores_actions_of_the_worlds_size():
    learner, body = _body()
    rng = np.random.default_rng(0)
    learner.dataset.start_episode()
    while learner.iteration < 150:
        before = len(body.sent)
        learner.learning_episode(body, rng)
        assert len(body.sent) > before
    stored = learner.dataset.actions
    assert stored.shape == (learner.iteration, 3) and learner.iteration >= 150
    assert np.array_equal(stored, np.stack(body.sent))  # D holds what was executed
    assert (np.abs(stored) <= 1.0).all()
    assert (stored.min(axis=0) < -0.8).all() and (stored.max(axis=0) > 0.8).all()
    # It learns the effector's motion from its three components, with none of the rover's
    # spaces: the body has no heading and no LIDAR.
    movers = [a for a in learner.hierarchy.with_output(EFFECTOR_POSITION) if a.input is ACTION]
    assert movers and movers[0].model.dx == 3
    for aff in learner.hierarchy:
        assert all(s.prop not in (Property.HEADING, Property.LIDAR)
                   for s in (aff.input, aff.output, *aff.contexts))


def test_the_command_grid_spans_every_component_of_the_action():
    learner, _ = _body()
    commands = learner.controller.commands
    per_axis = ROVER_ACTIONS.dim  # the rover's grid: the same values on each component
    rover = Learner(LearnerConfig(), learner.layout, ROVER_ACTIONS).controller.commands
    assert rover.shape == (80, per_axis)
    values = np.unique(rover[:, 0])
    assert values.size == 9 and np.array_equal(np.unique(rover[:, 1]), values)
    assert commands.shape == (9 ** 3 - 1, 3)
    for j in range(3):
        assert np.array_equal(np.unique(commands[:, j]), values)
    assert np.unique(commands, axis=0).shape[0] == commands.shape[0]
    assert not (np.linalg.norm(commands, axis=1) < 1e-9).any()  # standing still is no command
    # Both in the same order: the first component slowest.
    for grid in (rover, commands):
        assert [tuple(c) for c in grid] == sorted(tuple(c) for c in grid)


def test_the_controller_drives_the_effector_with_all_three_components():
    learner, body = _body()
    rng = np.random.default_rng(1)
    learner.dataset.start_episode()
    for action in rng.uniform(-1.0, 1.0, (200, 3)):
        body.act(action)
    t = np.arange(200, dtype=np.int64)
    unbound = np.full(200, -1, dtype=np.int64)
    aff = learner.fitter.new_affordance(0, ACTION, EFFECTOR_POSITION, (),
                                        Rows(t, unbound, unbound), 200, rng)
    learner.hierarchy.add(aff, 200)
    body = Slider(learner.layout)  # from the table's centre, a fresh record
    goal = np.array([0.3, -0.2])
    attempt = learner.controller.reach(aff, Binding(), goal, body, budget=40)
    assert 0 < attempt.actions == len(body.sent)
    assert attempt.final_distance < 0.03
    used = np.stack(body.sent)
    assert used.shape[1] == 3 and (np.abs(used) <= 1.0).all()
    # The third component moves the effector along both axes: the search uses it.
    assert np.abs(used[:, 2]).max() > 0.5
