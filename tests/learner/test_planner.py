"""Planner pieces at small sizes: the context to reach first, and the rules around it."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np

from hadim_cli.config import load_config
from hadim_cli.learner.adaptation import required_gain
from hadim_cli.learner.hierarchy import Hierarchy
from hadim_cli.learner.models import LocalLinearModel
from hadim_cli.learner.planner import Planner


def _push_like_model(rng: np.random.Generator, outliers: int) -> LocalLinearModel:
    """Rows of a push: the object moves along the contact direction (robot behind it), plus
    `outliers` rows with the same outcome from a far, odd place (a bounce)."""
    model = LocalLinearModel(2, 2, [1, 2])  # input; contexts: radius, relation
    angles = rng.uniform(-np.pi, np.pi, 300)
    radius = rng.uniform(0.08, 0.25, 300)
    direction = np.stack([np.cos(angles), np.sin(angles)], axis=1)
    relation = direction * (radius + 0.15)[:, None]
    step = rng.uniform(0.02, 0.12, 300)[:, None]
    model.add(direction * step, np.concatenate([radius[:, None], relation], axis=1),
              direction * step * 0.9)
    odd = np.tile([[0.6, -0.6]], (outliers, 1))
    model.add(np.tile([[0.1, 0.0]], (outliers, 1)),
              np.concatenate([np.full((outliers, 1), 0.12), odd], axis=1),
              np.tile([[0.1, 0.0]], (outliers, 1)))
    return model


def test_the_context_to_reach_is_where_such_outcomes_usually_come_from():
    rng = np.random.default_rng(0)
    config = load_config().learner
    planner = Planner(Hierarchy(), reader=None, config=config)  # reader unused here
    aff = SimpleNamespace(model=_push_like_model(rng, outliers=3))
    relations = np.array([False, True])  # the radius is fixed, the relation reachable
    current = np.array([0.12, -0.5, 0.4])  # an object of radius 0.12, robot far away
    needed = planner.needed_context(aff, np.array([0.1, 0.0]), current, relations)
    assert needed[0] == 0.12  # what cannot be changed stays as it is
    # Behind the object along the push (+x), at contact distance 0.27 — not the odd rows.
    assert abs(needed[1] - 0.27) < 0.05 and abs(needed[2]) < 0.05
    # Pushing along +y needs the robot below the object.
    needed = planner.needed_context(aff, np.array([0.0, 0.1]), current, relations)
    assert abs(needed[1]) < 0.05 and abs(needed[2] - 0.27) < 0.05


def test_a_context_change_must_earn_its_complexity():
    assert required_gain(1, 2, 0.1) == 0.1  # adding
    assert required_gain(1, 1, 0.1) == 0.05  # replacing
    assert required_gain(2, 1, 0.1) == 0.0  # removing: as good and simpler is enough


def test_the_planner_refuses_an_action_that_would_touch_what_it_must_avoid():
    """While a tool moves the target, the robot's own motion model screens each action: one
    predicted to bring the robot into contact with the target is not executed."""
    from hadim_cli.learner.planner import ROBOT_POSITION, Binding
    from hadim_cli.learner.spaces import ACTION, SpaceReader
    from hadim_cli.world.layout import LayoutBounds, ObservationLayout, Property

    layout = ObservationLayout.build(2, 4, LayoutBounds(2, 2, 1.5, 0.25, 0.6))
    obs = np.zeros(layout.size)
    obs[layout.space("robot", Property.RADIUS).slice] = 0.15
    obs[layout.space("obj1", Property.RADIUS).slice] = 0.12
    obs[layout.space("obj1", Property.POSITION).slice] = [0.4, 0.0]
    obs[layout.space("obj2", Property.POSITION).slice] = [-1.0, 1.0]
    actions = np.random.default_rng(1).uniform(-1, 1, (200, 2))
    model = LocalLinearModel(2, 2)
    model.add(actions, None, 0.15 * actions)  # a robot that moves 0.15 m per unit of action
    mover = SimpleNamespace(id=0, input=ACTION, output=ROBOT_POSITION, contexts=(),
                            model=model, has_tool=False, competence=1.0)
    hierarchy = SimpleNamespace(controllers=lambda space: [mover] if space == ROBOT_POSITION
                                else [])
    planner = Planner(hierarchy, SpaceReader(layout), load_config().learner)
    towards, away = np.array([1.0, 0.0]), np.array([-1.0, 0.0])
    assert planner.foresees_contact(Binding(target=2, avoid=1), towards, obs)
    assert not planner.foresees_contact(Binding(target=2, avoid=1), away, obs)
    assert not planner.foresees_contact(Binding(target=1), towards, obs)  # nothing to avoid
