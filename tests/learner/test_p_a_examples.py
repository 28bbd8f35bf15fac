"""Which objects teach p_A what: positives respond, negatives were pushed in vain."""

from __future__ import annotations

import numpy as np

from hadim_cli.config import load_config
from hadim_cli.learner.adaptation import Adaptation
from hadim_cli.learner.affordance import Fitter
from hadim_cli.learner.dataset import Dataset
from hadim_cli.learner.hierarchy import Hierarchy
from hadim_cli.learner.spaces import Property, Role, RoleSpace, Rows, SpaceReader
from hadim_cli.world.layout import LayoutBounds, ObservationLayout

ROBOT_POSITION = RoleSpace(Role.ROBOT, Property.POSITION)
TARGET_POSITION = RoleSpace(Role.TARGET, Property.POSITION)
TARGET_ROBOT = RoleSpace(Role.TARGET, Property.POSITION, Role.ROBOT)
GREEN, RED = (0.2, 0.8, 0.2), (0.8, 0.2, 0.2)


class Scene:
    """Flat observations of a robot and three objects, written through the layout."""

    def __init__(self):
        self.layout = ObservationLayout.build(3, 4, LayoutBounds(2, 2, 1.5, 0.25, 0.6))
        self.obs = np.zeros(self.layout.size)
        self.set("robot", Property.RADIUS, [0.15])
        self.set("robot", Property.COLOR, [0.2, 0.2, 0.8])
        for name, colour in (("obj1", GREEN), ("obj2", RED), ("obj3", GREEN)):
            self.set(name, Property.RADIUS, [0.12])
            self.set(name, Property.HEIGHT, [0.2])
            self.set(name, Property.COLOR, colour)
        for i, name in enumerate(("obj1", "obj2", "obj3")):
            self.place(name, [-1.5 + i, 1.5])  # parked far away

    def set(self, entity: str, prop: Property, value) -> None:
        self.obs[self.layout.space(entity, prop).slice] = value

    def place(self, entity: str, xy) -> None:
        self.set(entity, Property.POSITION, xy)
        if entity != "robot":
            robot = self.obs[self.layout.space("robot", Property.POSITION).slice]
            self.set(entity, Property.RELATIVE, np.asarray(xy) - robot)

    def push(self, d: Dataset, obj: str, direction, moves: bool) -> None:
        """The robot, in contact behind `obj`, drives 0.1 m along `direction`."""
        u = np.asarray(direction, dtype=float)
        self.place("robot", [0.0, 0.0])
        self.place(obj, 0.27 * u)
        before = self.obs.copy()
        self.place("robot", 0.1 * u)
        self.place(obj, 0.27 * u + (0.09 * u if moves else 0.0))
        d.append(np.zeros(2), before, self.obs.copy())
        self.place(obj, [0.0, -1.5])  # out of the way again
        self.obs[self.layout.space(obj, Property.RELATIVE).slice] = [0.0, -1.5]


def test_p_a_learns_from_objects_pushed_in_vain_not_from_the_model_s_errors():
    rng = np.random.default_rng(0)
    config = load_config().learner
    scene = Scene()
    reader = SpaceReader(scene.layout)
    d = Dataset(scene.layout.size, 2)
    d.start_episode()
    angles = np.linspace(0, 2 * np.pi, 40, endpoint=False)
    for a in angles:  # many pushes of the green obj1 in every direction
        scene.push(d, "obj1", [np.cos(a), np.sin(a)], moves=True)
    fitter = Fitter(d, reader, config)
    hierarchy = Hierarchy()
    rows = Rows(np.arange(len(d)), np.full(len(d), 1), np.full(len(d), -1))
    aff = fitter.new_affordance(hierarchy.allocate_id(), ROBOT_POSITION, TARGET_POSITION,
                                (TARGET_ROBOT,), rows, len(d), rng)
    hierarchy.add(aff, len(d))
    adaptation = Adaptation(hierarchy, fitter, config)

    d.start_episode()  # a new environment episode
    start = len(d)
    scene.push(d, "obj2", [1.0, 0.0], moves=False)  # red: pushed head-on, does not move
    scene.push(d, "obj3", [1.0, 0.0], moves=False)  # green: stuck this once (a graze) …
    scene.push(d, "obj3", [0.0, 1.0], moves=True)   # … but it does move in this episode
    sample = fitter.candidate_rows(aff.input, aff.output, np.arange(start, len(d)))
    moved = fitter.nonzero(sample.y)
    negative = adaptation._applied_in_vain(aff, sample, moved)
    assert set(sample.rows.target[negative]) == {2}  # the red object only
    assert set(sample.rows.target[moved]) == {3}

    # A far object the model wrongly expects to move (no contact) is no negative either.
    far = fitter.candidate_rows(aff.input, aff.output, np.arange(0, 1))
    assert not adaptation._applied_in_vain(aff, far, fitter.nonzero(far.y)).any()
