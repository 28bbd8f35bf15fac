from __future__ import annotations

import numpy as np

from hadim_cli.learner.dataset import Dataset, dataset_digest
from hadim_cli.learner.spaces import (
    ACTION,
    Role,
    RoleSpace,
    Rows,
    SpaceReader,
    actor_contexts,
    context_candidates,
    parse_space,
)
from hadim_cli.world.layout import LayoutBounds, ObservationLayout, Property


def _layout(n=3):
    return ObservationLayout.build(n, 4, LayoutBounds(2, 2, 1.5, 0.25, 0.6))


def test_space_names_round_trip():
    spaces = [ACTION, RoleSpace(Role.ROBOT, Property.POSITION),
              RoleSpace(Role.TARGET, Property.POSITION, Role.ROBOT),
              RoleSpace(Role.TARGET, Property.POSITION, Role.TOOL),
              RoleSpace(Role.TOOL, Property.RADIUS)]
    for s in spaces:
        assert parse_space(s.name) == s
    assert RoleSpace(Role.TARGET, Property.POSITION, Role.ROBOT).name == "target-robot"


def test_reader_reads_bound_entities_and_relative_positions():
    layout = _layout()
    reader = SpaceReader(layout)
    obs = np.arange(layout.size, dtype=float)[None, :]
    rows = Rows(np.array([0, 0]), np.array([1, 3]), np.array([2, 1]))
    target = reader.read(RoleSpace(Role.TARGET, Property.POSITION), obs, rows)
    assert np.array_equal(target[0], obs[0, layout.space("obj1", Property.POSITION).slice])
    assert np.array_equal(target[1], obs[0, layout.space("obj3", Property.POSITION).slice])
    rel = reader.read(RoleSpace(Role.TARGET, Property.POSITION, Role.TOOL), obs, rows)
    tool = reader.read(RoleSpace(Role.TOOL, Property.POSITION), obs, rows)
    assert np.allclose(rel, target - tool)
    robot = reader.read(RoleSpace(Role.ROBOT, Property.LIDAR), obs, rows)
    assert robot.shape == (2, 4)


def test_context_candidates_follow_roles():
    rover = actor_contexts(_layout())
    names = {c.name for c in context_candidates(frozenset({Role.ROBOT}), rover)}
    assert "target-robot" not in names and "robot.heading" in names
    names = {c.name for c in context_candidates(frozenset({Role.TARGET, Role.TOOL}), rover)}
    assert {"target-robot", "target-tool", "tool-robot", "target.radius"} <= names


def test_dataset_records_outcomes_and_episodes():
    d = Dataset(obs_size=3, action_size=2)
    d.start_episode()
    for i in range(300):  # crosses the initial capacity
        d.append(np.array([0.1, -0.1]), np.full(3, float(i)), np.full(3, float(i) + 0.5))
    d.start_episode()
    d.append(np.zeros(2), np.zeros(3), np.ones(3))
    assert len(d) == 301
    assert np.allclose(d.outcomes[:300], 0.5) and np.allclose(d.outcomes[300], 1.0)
    assert [(e.start, e.stop) for e in d.episodes()] == [(0, 300), (300, 301)]
    digest = d.sha256()
    assert digest == dataset_digest(d.actions, d.contexts, d.outcomes)
    d2 = Dataset(obs_size=3, action_size=2)
    d2.extend(d.actions[:300], d.contexts[:300], d.outcomes[:300])
    d2.extend(d.actions[300:], d.contexts[300:], d.outcomes[300:])
    assert d2.sha256() == digest
    # The digest reads the values, whatever type they were read back in.
    whole = (np.arange(6.0).reshape(3, 2), np.ones((3, 3)), np.full((3, 3), 0.5))
    assert dataset_digest(*(a.astype(np.float32) for a in whole)) == dataset_digest(*whole)


def test_p_a_features_of_the_robot_are_its_own():
    """p_A is trained with the robot as a negative target: reading the robot in the target
    role must give the robot's visual properties (they lie elsewhere than an object's), the
    same features p_A is asked about at selection time."""
    from hadim_cli.config import load_config
    from hadim_cli.learner.affordance import Fitter

    layout = _layout(3)
    reader = SpaceReader(layout)
    obs = np.random.default_rng(0).uniform(0.1, 1.0, size=(2, layout.size))
    d = Dataset(layout.size, 2)
    d.append(np.zeros(2), obs[0], obs[1])
    fitter = Fitter(d, reader, load_config().learner)
    entities = np.arange(len(layout.entities))
    rows = Rows(np.zeros(entities.size, dtype=np.int64), entities,
                np.full(entities.size, -1))
    trained = fitter.target_features(rows)
    asked = np.stack([reader.visual_features(obs[0], int(e)) for e in entities])
    np.testing.assert_array_equal(trained, asked)
    radius = RoleSpace(Role.TARGET, Property.RADIUS)
    assert reader.read(radius, d.contexts, rows)[0, 0] == obs[0][layout.space("robot",
                                                                          Property.RADIUS).start]


def test_surface_relations_read_a_contact_alike_whatever_the_sizes():
    """With a relation offset, a relative position is read between surfaces: bodies in
    contact read the offset's length towards each other, small or large, and
    `relation_to_offset` turns a reading back into centres."""
    layout = _layout()
    reader = SpaceReader(layout, relation_offset=0.3)
    rel = RoleSpace(Role.TARGET, Property.POSITION, Role.TOOL)
    obs = np.zeros((2, layout.size))
    direction = np.array([0.6, 0.8])
    for row, (r_target, r_tool) in enumerate(((0.08, 0.1), (0.25, 0.2))):
        for entity, radius, at in (("obj1", r_target, direction * (r_target + r_tool)),
                                   ("obj2", r_tool, np.zeros(2))):
            obs[row, layout.space(entity, Property.POSITION).slice] = at
            obs[row, layout.space(entity, Property.RADIUS).slice] = radius
    rows = Rows(np.array([0, 1]), np.array([1, 1]), np.array([2, 2]))
    read = reader.read(rel, obs, rows)
    assert np.allclose(read, 0.3 * direction)  # both pairs in contact: the same reading
    raw = reader.read(rel, obs, rows, raw=True)
    assert np.allclose(raw[1], 0.45 * direction)  # centre to centre on request
    assert np.allclose(reader.relation_to_offset(read[1], 0.45), raw[1])
    # 0.2 m apart at the surfaces reads 0.5 m; centre to centre without an offset.
    assert np.allclose(reader.relation_to_offset(0.5 * direction, 0.18), 0.38 * direction)
    assert np.allclose(SpaceReader(layout).read(rel, obs, rows), raw)
