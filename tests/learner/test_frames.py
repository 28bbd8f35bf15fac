"""Models in the frame of a relation: a push learned from some bearings holds at any other."""

from __future__ import annotations

import numpy as np
import pytest

from hadim_cli.learner.competence import split_zero
from hadim_cli.learner.frames import Frame, FramedModel, relation_frame, seen, seen_where
from hadim_cli.learner.models import LocalLinearModel
from hadim_cli.learner.spaces import ACTION, Role, RoleSpace
from hadim_cli.world.actions import ROVER_ACTIONS
from hadim_cli.world.layout import Property

REACH = 0.3
"""The toy relation's length at contact (as a surface relation reads it)."""


def pushes(rng: np.random.Generator, n: int, bearings: tuple[float, float]):
    """A toy push: relation r (bearing in `bearings`, length REACH + gap) and a heading; the
    mover travels x; the target moves along r by the travel along r beyond the gap."""
    ang = rng.uniform(*bearings, n)
    u = np.c_[np.cos(ang), np.sin(ang)]
    gap = rng.uniform(0.0, 0.1, n)
    r = u * (REACH + gap)[:, None]
    head = rng.uniform(-np.pi, np.pi, n)
    heading = np.c_[np.cos(head), np.sin(head)]
    x = rng.uniform(-0.15, 0.15, (n, 2))
    along = np.einsum("ij,ij->i", x, u)
    y = u * np.maximum(along - gap, 0.0)[:, None]
    return x, np.c_[r, heading], y


def fitted(cls, x, c, y):
    if cls is FramedModel:
        model = FramedModel(2, 2, [2, 2], Frame(0, True, True, (1,)))
    else:
        model = LocalLinearModel(2, 2, [2, 2])
    model.add(x, c, y)
    return model


def test_a_push_learned_at_some_bearings_holds_at_others() -> None:
    """Rows from bearings in [0, 90°]; queries at bearings in [180°, 270°]: the framed model
    predicts and inverts them, the room-frame model does not."""
    rng = np.random.default_rng(0)
    x, c, y = pushes(rng, 600, (0.0, np.pi / 2))
    xq, cq, yq = pushes(rng, 200, (np.pi, 1.5 * np.pi))
    framed, room = fitted(FramedModel, x, c, y), fitted(LocalLinearModel, x, c, y)
    err_framed = np.linalg.norm(framed.predict(xq, cq) - yq, axis=1).mean()
    err_room = np.linalg.norm(room.predict(xq, cq) - yq, axis=1).mean()
    assert err_framed < 0.01 < err_room
    moved = np.flatnonzero(np.linalg.norm(yq, axis=1) > 0.03)
    assert moved.size >= 20
    misses = {}
    for name, model in (("framed", framed), ("room", room)):
        miss = []
        for i in moved:
            res = model.infer(yq[i], cq[i])
            u = cq[i, :2] / np.linalg.norm(cq[i, :2])
            gap = np.linalg.norm(cq[i, :2]) - REACH
            reached = u * max(float(res.x @ u) - gap, 0.0)
            miss.append(np.linalg.norm(reached - yq[i]) / np.linalg.norm(yq[i]))
            np.testing.assert_allclose(res.y_predicted, model.predict(res.x, cq[i])[0],
                                       atol=1e-9)
        misses[name] = float(np.mean(miss))
    assert misses["framed"] < 0.15 and misses["room"] > 0.5, misses


def test_answers_are_in_room_coordinates() -> None:
    """`data` gives back the rows as added; LOO and neighbours agree with a room-frame model
    where the frame is the room's (every relation along the first axis)."""
    rng = np.random.default_rng(1)
    x, c, y = pushes(rng, 300, (0.0, 0.0))
    framed = fitted(FramedModel, x, c, y)
    for got, want in zip(framed.data(), (x, c, y), strict=True):
        np.testing.assert_array_equal(got, want)
    assert framed.n == 300 and framed.dc == 4 and framed.context_dims == (2, 2)
    assert framed.scales().values.shape == (4,)
    loo = framed.predict_loo(np.arange(20))
    assert loo.shape == (20, 2) and np.linalg.norm(loo - y[:20], axis=1).mean() < 0.01
    dist, nb = framed.inverse_neighbours(y[:3], c[:3], k=4)
    assert nb.shape == (3, 4) and np.all(dist[:, 0] <= dist[:, -1])
    _, nb = framed.inverse_neighbours(y[:3], k=4)  # no context: room outcomes
    assert nb.shape == (3, 4)
    moved = int(np.argmax(np.linalg.norm(y, axis=1)))
    res = framed.infer(y[moved])  # no context: in the frames of the nearest outcomes' rows
    assert res.error < 0.1 and res.context.shape == (4,)
    _, nb = framed.forward_neighbours(x[:2], c[:2], k=5)
    assert nb.shape == (2, 5)


def test_rows_turned_along_an_outcome_or_to_a_relation() -> None:
    """`turned(along=d)`: each moving row's outcome points along d, its relation keeps its
    length and its angle to the outcome; `turned(at=c)`: each relation has c's bearing."""
    rng = np.random.default_rng(3)
    x, c, y = pushes(rng, 200, (-np.pi, np.pi))
    model = fitted(FramedModel, x, c, y)
    d = np.array([0.0, -2.0])
    tx, tc, ty = model.turned(along=d)
    moving = np.linalg.norm(y, axis=1) > 1e-9
    np.testing.assert_allclose(ty[moving, 0], 0.0, atol=1e-12)
    assert np.all(ty[moving, 1] < 0)
    np.testing.assert_array_equal(ty[~moving], y[~moving])
    for a, b in ((tc[:, :2], c[:, :2]), (tc[:, 2:], c[:, 2:]), (tx, x), (ty, y)):
        np.testing.assert_allclose(np.linalg.norm(a, axis=1), np.linalg.norm(b, axis=1))
    cross = lambda p, q: p[:, 0] * q[:, 1] - p[:, 1] * q[:, 0]  # noqa: E731
    np.testing.assert_allclose(cross(tc[moving, :2], ty[moving]),
                               cross(c[moving, :2], y[moving]), atol=1e-12)
    at = np.array([0.0, 0.5, 1.0, 0.0])
    _, tc, _ = model.turned(at=at)
    np.testing.assert_allclose(tc[:, 0], 0.0, atol=1e-12)
    np.testing.assert_allclose(tc[:, 1], np.linalg.norm(c[:, :2], axis=1))
    with pytest.raises(ValueError, match="either"):
        model.turned()


def test_state_round_trip_is_identical() -> None:
    rng = np.random.default_rng(2)
    x, c, y = pushes(rng, 500, (-np.pi, np.pi))
    model = fitted(FramedModel, x[:400], c[:400], y[:400])
    model.add(x[400:], c[400:], y[400:])  # leaves rows in the inner model's buffers
    copy = FramedModel.from_state(model.state(), **model.params())
    xq, cq, yq = pushes(rng, 30, (-np.pi, np.pi))
    np.testing.assert_array_equal(copy.predict(xq, cq), model.predict(xq, cq))
    np.testing.assert_array_equal(copy.predict_loo(), model.predict_loo())
    for i in range(5):
        np.testing.assert_array_equal(copy.infer(yq[i], cq[i]).x, model.infer(yq[i], cq[i]).x)
    for m in (copy, model):
        for j in range(0, 30, 5):
            m.add(xq[j:j + 5], cq[j:j + 5], yq[j:j + 5])
    np.testing.assert_array_equal(copy.predict(x[:20], c[:20]), model.predict(x[:20], c[:20]))
    with pytest.raises(ValueError, match="FramedModel"):
        LocalLinearModel.from_state(model.state())
    with pytest.raises(ValueError, match="no frame"):
        FramedModel.from_state(LocalLinearModel(2, 2, [2, 2]).state())
    with pytest.raises(ValueError, match="differs"):
        FramedModel.from_state(model.state(), frame=Frame(1, True, True, (0,)))


def test_bad_frames_are_refused() -> None:
    with pytest.raises(ValueError, match="2-D context"):
        FramedModel(2, 2, [1, 2], Frame(0, True, True))
    with pytest.raises(ValueError, match="2-D context, got index 1"):
        FramedModel(2, 2, [2], Frame(1, True, True))
    with pytest.raises(ValueError, match="output must be 2-D"):
        FramedModel(2, 1, [2], Frame(0, True, True))
    model = FramedModel(2, 2, [2], Frame(0, True, True))
    with pytest.raises(ValueError, match="as many rows"):
        model.add(np.zeros((1, 2)), np.ones((3, 2)), np.zeros((3, 2)))
    with pytest.raises(ValueError, match="needs a context"):
        model.add(np.zeros((1, 2)), None, np.zeros((1, 2)))
    assert model.n == 0
    model.add(np.zeros((3, 2)), np.ones((3, 2)), np.ones((3, 2)))
    with pytest.raises(ValueError, match=r"^x must have 2 columns"):
        model.predict(np.zeros((1, 3)), np.ones(2))


def test_which_relation_frames_an_affordance() -> None:
    target_tool = RoleSpace(Role.TARGET, Property.POSITION, Role.TOOL)
    target_robot = RoleSpace(Role.TARGET, Property.POSITION, Role.ROBOT)
    heading = RoleSpace(Role.ROBOT, Property.HEADING)
    radius = RoleSpace(Role.TARGET, Property.RADIUS)
    target = RoleSpace(Role.TARGET, Property.POSITION)
    tool = RoleSpace(Role.TOOL, Property.POSITION)
    robot = RoleSpace(Role.ROBOT, Property.POSITION)
    # Through a tool: the target-tool relation, even listed second.
    assert relation_frame(tool, target, (target_robot, target_tool, radius)) == \
        Frame(1, True, True, (0,))
    # Without it, the target's other relation; the heading turns, the radius does not.
    assert relation_frame(tool, target, (heading, radius, target_robot)) == \
        Frame(2, True, True, (0,))
    # A primitive action does not turn.
    assert relation_frame(ACTION, target, (target_robot,)) == Frame(0, False, True, ())
    assert relation_frame(robot, target, (radius,)) is None


def test_both_kinds_of_model_offer_the_model_interface() -> None:
    from hadim_cli.learner.models import Model

    for cls in (FramedModel, LocalLinearModel):
        assert isinstance(fitted(cls, *pushes(np.random.default_rng(0), 20, (0.0, 1.0))), Model)


def _where(turn: str) -> dict[str, np.ndarray]:
    return {"at": np.array([0.3, -0.1, 0.0, 1.0])} if turn == "at" else \
        {"along": np.array([0.4, 0.3])}


def _assert_seen_where_is_seen(model, zero_eps: float, where: dict[str, np.ndarray]) -> None:
    """`seen_where` gives the rows of `seen` whose outcome is not null, bit for bit."""
    whole = seen(model, **where)
    keep = ~split_zero(whole[2], zero_eps)
    assert 0 < keep.sum() < keep.size
    rows, *part = seen_where(model, zero_eps, **where)
    np.testing.assert_array_equal(rows, np.flatnonzero(keep))
    for got, want in zip(part, whole, strict=True):
        assert got.tobytes() == np.ascontiguousarray(want[keep]).tobytes()


@pytest.mark.parametrize("cls", [FramedModel, LocalLinearModel])
@pytest.mark.parametrize("turn", ["along", "at", "no frame.y"])
def test_the_rows_with_an_effect_are_turned_as_all_rows_are(cls, turn) -> None:
    """`seen_where` turns only the rows whose turned outcome it keeps (the planner's passes
    over an affordance's rows, O(n) per call): they are those rows of `seen`, bit for bit; if
    it keeps none, all rows."""
    rng = np.random.default_rng(5)
    x, c, y = pushes(rng, 300, (-np.pi, np.pi))
    if turn == "no frame.y" and cls is FramedModel:
        model = FramedModel(2, 2, [2, 2], Frame(0, True, False, (1,)))
        model.add(x, c, y)
    else:
        model = fitted(cls, x, c, y)
    where = _where(turn)
    _assert_seen_where_is_seen(model, 1e-9, where)
    whole = seen(model, **where)
    rows, *part = seen_where(model, 1e9, **where)
    assert rows is None
    for got, want in zip(part, whole, strict=True):
        assert got.tobytes() == np.ascontiguousarray(want).tobytes()


def test_the_robot_s_own_motion_is_framed_by_its_heading() -> None:
    heading = RoleSpace(Role.ROBOT, Property.HEADING)
    robot = RoleSpace(Role.ROBOT, Property.POSITION)
    target = RoleSpace(Role.TARGET, Property.POSITION)
    lidar = RoleSpace(Role.ROBOT, Property.LIDAR)
    assert relation_frame(ACTION, robot, (heading,)) == Frame(0, False, True, ())
    assert relation_frame(ACTION, heading, (lidar, heading)) == Frame(1, False, True, ())
    # Without the heading as a context there is nothing to frame by; an object's motion keeps
    # the frame of its relation.
    assert relation_frame(ACTION, robot, (lidar,)) is None
    target_robot = RoleSpace(Role.TARGET, Property.POSITION, Role.ROBOT)
    assert relation_frame(ACTION, target, (heading, target_robot)) == \
        Frame(1, False, True, (0,))


def test_a_heading_framed_motion_model_predicts_headings_it_saw_few_moves_from() -> None:
    """A wheel command moves the robot the same way in its own frame: framed by the heading,
    every row of a command teaches it for every heading. Here full-speed commands were only
    ever taken facing east; the room model, asked facing north, mixes in neighbours that
    faced elsewhere, the framed one turns what it knows."""
    rng = np.random.default_rng(3)
    n = 600
    action = rng.uniform(-1, 1, (n, 2))
    fast = np.abs(action).max(axis=1) > 0.8
    angle = np.where(fast, rng.normal(0.0, 0.1, n), rng.uniform(-np.pi, np.pi, n))
    heading = np.stack([np.cos(angle), np.sin(angle)], axis=1)
    forward = 0.06 * (action[:, 0] + action[:, 1])
    turn = 0.4 * (action[:, 1] - action[:, 0])
    body = np.stack([forward * np.cos(turn / 2), forward * np.sin(turn / 2)], axis=1)
    y = np.stack([body[:, 0] * heading[:, 0] - body[:, 1] * heading[:, 1],
                  body[:, 0] * heading[:, 1] + body[:, 1] * heading[:, 0]], axis=1)
    framed = FramedModel(2, 2, (2,), Frame(0, False, True, ()))
    room = LocalLinearModel(2, 2, (2,))
    for model in (framed, room):
        model.add(action, heading, y)
    query = np.array([[0.95, 0.9]])
    north = np.array([[0.0, 1.0]])
    want = np.array([[0.0, 0.06 * 1.85]])  # straight ahead (a slight turn aside)
    framed_error = np.linalg.norm(framed.predict(query, north) - want)
    room_error = np.linalg.norm(room.predict(query, north) - want)
    assert framed_error < 0.01
    assert room_error > 3 * framed_error


def test_the_learner_frames_the_robot_s_motion_models_by_its_heading() -> None:
    """The learner's models of the robot's own motion (and the context trials it fits) are
    framed by the heading when it is their context."""
    from hadim_cli.config import LearnerConfig, WorldConfig
    from hadim_cli.learner.affordance import Fitter
    from hadim_cli.learner.dataset import Dataset
    from hadim_cli.learner.spaces import SpaceReader
    from hadim_cli.world.world import World

    layout = World(WorldConfig()).layout
    heading = RoleSpace(Role.ROBOT, Property.HEADING)
    robot = RoleSpace(Role.ROBOT, Property.POSITION)
    fitter = Fitter(Dataset(layout.size, 2), SpaceReader(layout, actions=ROVER_ACTIONS),
                    LearnerConfig())
    for out in (robot, heading):
        for trial in (False, True):
            model = fitter.new_model(ACTION, out, (heading,), trial=trial)
            assert isinstance(model, FramedModel)
    assert isinstance(fitter.new_model(ACTION, robot, ()), LocalLinearModel)


@pytest.mark.parametrize("turn", ["along", "at"])
def test_the_kept_norms_and_directions_follow_the_rows_added(turn) -> None:
    """A framed model keeps each row's outcome norm and directions (what its turns are made
    of) and extends them as rows come in: asked between adds, it answers as a model built
    with all the rows at once."""
    rng = np.random.default_rng(8)
    batches = [pushes(rng, n, (-np.pi, np.pi)) for n in (200, 7, 1, 40)]
    model = FramedModel(2, 2, [2, 2], Frame(0, True, True, (1,)))
    for batch in batches:
        model.add(*batch)
        _assert_seen_where_is_seen(model, 1e-9, _where(turn))
        _assert_seen_where_is_seen(model, 0.02, _where(turn))


@pytest.mark.parametrize("turn", ["along", "at"])
def test_outcomes_at_the_null_threshold_are_measured_turned(turn) -> None:
    """Outcomes whose norm is the null threshold to the last bits: turned, some fall on the
    other side of it, and `seen_where` keeps the rows that `seen`'s turned outcomes keep."""
    rng = np.random.default_rng(9)
    x, c, y = pushes(rng, 400, (-np.pi, np.pi))
    eps = 0.01
    ang = rng.uniform(-np.pi, np.pi, 300)
    y[:300] = eps * np.c_[np.cos(ang), np.sin(ang)]
    model = fitted(FramedModel, x, c, y)
    stored = ~split_zero(model.data()[2], eps)
    turned = ~split_zero(seen(model, **_where(turn))[2], eps)
    assert np.any(stored != turned)  # the case this test is about
    _assert_seen_where_is_seen(model, eps, _where(turn))


def test_a_framed_outcome_that_does_not_turn_keeps_the_rows_where_it_is_not_null() -> None:
    """An outcome of other than two columns (a LIDAR's, say) does not turn with the frame:
    `seen_where` keeps the rows where its norm is not null, as `seen` reads them."""
    rng = np.random.default_rng(12)
    x, c, y = pushes(rng, 300, (-np.pi, np.pi))
    model = FramedModel(2, 4, [2, 2], Frame(0, True, False, (1,)))
    model.add(x, c, np.c_[y, 0.5 * y])
    _assert_seen_where_is_seen(model, 1e-9, _where("at"))


def test_without_a_context_n_candidates_bounds_the_search_in_the_nearest_rows_context() -> None:
    """Asked without a context, a framed model searches in the context of the stored outcome
    nearest the goal, trying as many candidates as asked there too."""
    rng = np.random.default_rng(13)
    x, c, y = pushes(rng, 400, (-np.pi, np.pi))
    model = fitted(FramedModel, x, c, y)
    differ = 0
    for goal in ([0.05, 0.02], [-0.03, 0.06], [0.0, -0.08]):
        _, nb = model.inverse_neighbours(np.array(goal), k=1)
        near = model.data()[1][nb[0][0]]
        there = model.infer(goal, near, n_candidates=1)
        np.testing.assert_array_equal(model.infer(goal, n_candidates=1).x, there.x)
        differ += not np.array_equal(model.infer(goal, near).x, there.x)
    assert differ  # one candidate is not the default's many


def test_the_arm_s_motion_is_framed_by_its_orientation_and_generalises_round_its_base() -> None:
    """The arm declares its orientation (the first link's direction) apart from its bends:
    the learner's model of the effector's motion with both as contexts is framed by the
    orientation, so moves seen only with the arm pointing east teach it the arm pointing
    north (the table is the same all round the base); in room coordinates it cannot."""
    from hadim_cli.config import Body, LearnerConfig, WorldConfig
    from hadim_cli.learner.affordance import Fitter
    from hadim_cli.learner.dataset import Dataset
    from hadim_cli.learner.spaces import SpaceReader
    from hadim_cli.world.environment import make_world
    from hadim_cli.world.kinematics import effector_position

    world = make_world(WorldConfig(body=Body.ARM))
    layout, arm = world.layout, WorldConfig().arm
    effector = RoleSpace(Role.ROBOT, Property.POSITION)
    contexts = (RoleSpace(Role.ROBOT, Property.JOINTS), RoleSpace(Role.ROBOT, Property.ORIENTATION))
    fitter = Fitter(Dataset(layout.size, 3), SpaceReader(layout, actions=world.action_space),
                    LearnerConfig())
    model = fitter.new_model(ACTION, effector, contexts)
    assert isinstance(model, FramedModel)

    turn = arm.max_joint_speed * WorldConfig().action_duration
    rng = np.random.default_rng(4)

    def rows(n: int, shoulder: tuple[float, float]):
        q = np.column_stack([rng.uniform(*shoulder, n), rng.uniform(-1.5, 1.5, (n, 2))])
        x = rng.uniform(-1, 1, (n, 3))
        y = np.array([effector_position(arm.link_lengths, a + c * turn)
                      - effector_position(arm.link_lengths, a) for a, c in zip(q, x, strict=True)])
        c = np.column_stack([q[:, 1:], np.cos(q[:, 0]), np.sin(q[:, 0])])
        return x, c, y

    x, c, y = rows(600, (-0.2, 0.2))  # pointing east only
    room = LocalLinearModel(3, 2, (2, 2))
    for m in (model, room):
        m.add(x, c, y)
    qx, qc, qy = rows(50, (np.pi / 2 - 0.2, np.pi / 2 + 0.2))  # pointing north
    scale = float(np.median(np.linalg.norm(qy, axis=1)))
    framed_error = float(np.median(np.linalg.norm(model.predict(qx, qc) - qy, axis=1)))
    room_error = float(np.median(np.linalg.norm(room.predict(qx, qc) - qy, axis=1)))
    assert framed_error < 0.2 * scale
    assert room_error > 3 * framed_error
