"""Local linear forward/inverse models: accuracy, exact incremental kNN, LOO, state."""

from __future__ import annotations

import numpy as np
import pytest

from hadim_cli.learner.models import LocalLinearModel, SpaceScale, spread_scale

A = np.array([[1.0, 0.5], [-0.3, 0.8]])
B = np.array([[0.4, 0.0], [0.1, -0.6]])


def linear_data(rng: np.random.Generator, n: int, noise: float = 0.0, context: bool = True):
    x = rng.uniform(-1, 1, (n, 2))
    c = rng.uniform(0, 5, (n, 2)) if context else np.empty((n, 0))
    y = x @ A.T + (c @ B.T if context else 0.0) + rng.normal(0, noise, (n, 2))
    return x, c, y


def rotate(x: np.ndarray, theta: np.ndarray) -> np.ndarray:
    co, si = np.cos(theta[:, 0]), np.sin(theta[:, 0])
    return np.c_[co * x[:, 0] - si * x[:, 1], si * x[:, 0] + co * x[:, 1]]


def brute_knn(model: LocalLinearModel, which: str, q: np.ndarray, k: int) -> np.ndarray:
    """Neighbour indices by brute force, with the index's own normalisation."""
    x, c, y = model.data()
    pts = {"forward": np.c_[x, c], "inverse": np.c_[y, c], "outcome": y}[which]
    scale = model.index_scale(which)
    per_col = scale.per_column()
    cols = {"forward": np.r_[0:2, 2:2 + c.shape[1]],
            "inverse": np.r_[per_col.size - 2:per_col.size, 2:2 + c.shape[1]],
            "outcome": np.r_[per_col.size - 2:per_col.size]}[which]
    d = np.linalg.norm((q[:, None, :] - pts[None]) / per_col[cols], axis=2)
    return np.argsort(d, axis=1)[:, :k]


@pytest.mark.parametrize("context", [True, False])
def test_recovers_linear_map(context: bool) -> None:
    rng = np.random.default_rng(0)
    x, c, y = linear_data(rng, 1500, noise=0.002, context=context)
    model = LocalLinearModel(2, 2, [2] if context else [], x_low=[-1, -1], x_high=[1, 1])
    model.add(x, c if context else None, y)
    xq, cq, yq = linear_data(rng, 200, context=context)
    cq_arg = cq if context else None
    assert np.abs(model.predict(xq, cq_arg) - yq).max() < 0.02
    jac = model.jacobian(xq, cq_arg)
    assert jac.shape == (200, 2, 2)
    assert np.abs(jac - A).mean() < 0.03
    for i in range(20):
        x_true = rng.uniform(-0.8, 0.8, 2)
        goal = A @ x_true + (B @ cq[i] if context else 0.0)
        res = model.infer(goal, cq[i] if context else None)
        reached = A @ res.x + (B @ cq[i] if context else 0.0)
        assert np.linalg.norm(reached - goal) < 0.03
        assert res.error < 0.05
        assert np.all(np.abs(res.x) <= 1.0)
        assert res.context.shape == ((2,) if context else (0,))
        assert 0 <= res.neighbour_index < model.n


def test_infer_without_context_returns_a_neighbours_context() -> None:
    rng = np.random.default_rng(1)
    x, c, y = linear_data(rng, 1000)
    model = LocalLinearModel(2, 2, [2])
    model.add(x, c, y)
    goal = y[17] + 0.01
    res = model.infer(goal)
    _, cs, _ = model.data()
    np.testing.assert_array_equal(res.context, cs[res.neighbour_index])
    np.testing.assert_allclose(res.y_predicted, A @ res.x + B @ res.context, atol=0.02)


def test_infer_clips_to_input_bounds() -> None:
    rng = np.random.default_rng(2)
    x, c, y = linear_data(rng, 500, context=False)
    model = LocalLinearModel(2, 2, [], x_low=[-1, -1], x_high=[1, 1])
    model.add(x, None, y)
    res = model.infer(A @ np.array([3.0, 3.0]))  # out of reach
    assert np.all(res.x <= 1.0) and np.all(res.x >= -1.0)


def test_rotation_by_context_angle() -> None:
    rng = np.random.default_rng(3)
    n = 3000
    x, th = rng.uniform(-1, 1, (n, 2)), rng.uniform(-np.pi, np.pi, (n, 1))
    model = LocalLinearModel(2, 2, [1])
    model.add(x, th, 0.1 * rotate(x, th))
    xq, tq = rng.uniform(-1, 1, (500, 2)), rng.uniform(-np.pi, np.pi, (500, 1))
    err = np.linalg.norm(model.predict(xq, tq) - 0.1 * rotate(xq, tq), axis=1) / 0.1
    assert np.median(err) < 0.03
    assert np.quantile(err, 0.9) < 0.08
    x_true = np.array([0.5, -0.2])
    goal = 0.1 * rotate(x_true[None], tq[:1])[0]
    res = model.infer(goal, tq[0])
    assert np.linalg.norm(0.1 * rotate(res.x[None], tq[:1])[0] - goal) < 0.005


def test_incremental_knn_is_exact() -> None:
    rng = np.random.default_rng(4)
    x, c, y = linear_data(rng, 900, noise=0.05)
    model = LocalLinearModel(2, 2, [2])
    start = 0
    for size in [5, 1, 30, 3, 100, 1, 1, 200, 7, 250, 300, 2]:
        model.add(x[start:start + size], c[start:start + size], y[start:start + size])
        start += size
        xq, cq, yq = linear_data(rng, 25, noise=0.05)
        k = min(10, model.n)
        _, nb = model.forward_neighbours(xq, cq, k)
        np.testing.assert_array_equal(nb, brute_knn(model, "forward", np.c_[xq, cq], k))
        _, nb = model.inverse_neighbours(yq, cq, k)
        np.testing.assert_array_equal(nb, brute_knn(model, "inverse", np.c_[yq, cq], k))
        _, nb = model.inverse_neighbours(yq, None, k)
        np.testing.assert_array_equal(nb, brute_knn(model, "outcome", yq, k))
    assert start == x.shape[0]
    # Some rows are still in the brute-force buffer: the test exercised the merge.
    assert model.state()["built"][0, 0] < model.n
    # Once rebuilt over all rows it answers like a model built in one go.
    model.rebuild()
    whole = LocalLinearModel(2, 2, [2])
    whole.add(x, c, y)
    xq, cq, _ = linear_data(rng, 100)
    np.testing.assert_array_equal(model.forward_neighbours(xq, cq)[1],
                                  whole.forward_neighbours(xq, cq)[1])
    np.testing.assert_array_equal(model.predict(xq, cq), whole.predict(xq, cq))


def test_loo_excludes_self() -> None:
    rng = np.random.default_rng(5)
    x, c, y = linear_data(rng, 400, noise=0.05)
    model = LocalLinearModel(2, 2, [2])
    model.add(x, c, y)
    idx = np.arange(0, 400, 7)
    loo = model.predict_loo(idx)
    inside = model.predict(x[idx], c[idx])
    assert np.all(np.linalg.norm(loo - inside, axis=1) > 1e-9)
    assert model.predict_loo().shape == (400, 2)
    np.testing.assert_array_equal(model.predict_loo()[idx], loo)
    # Noiseless linear map: LOO is exact up to the ridge's bias.
    x, c, y = linear_data(rng, 400)
    exact = LocalLinearModel(2, 2, [2], ridge=1e-9)
    exact.add(x, c, y)
    assert np.abs(exact.predict_loo() - y).max() < 1e-5
    default = LocalLinearModel(2, 2, [2])
    default.add(x, c, y)
    err = np.linalg.norm(default.predict_loo() - y, axis=1)
    assert np.quantile(err, 0.95) < 1e-2  # the outputs' scale is ≈ 2


def test_state_round_trip_is_identical() -> None:
    rng = np.random.default_rng(6)
    x, c, y = linear_data(rng, 700, noise=0.01)
    model = LocalLinearModel(2, 2, [2], x_low=[-1, -1], x_high=[1, 1])
    model.add(x[:500], c[:500], y[:500])
    model.infer(y[0])
    model.add(x[500:], c[500:], y[500:])  # leaves rows in the buffers
    model.predict(x[:3], c[:3])
    state = model.state()
    assert all(isinstance(v, np.ndarray) for v in state.values())
    copy = LocalLinearModel.from_state(state)
    assert copy.params().keys() == model.params().keys()
    xq, cq, yq = linear_data(rng, 50)
    np.testing.assert_array_equal(copy.predict(xq, cq), model.predict(xq, cq))
    np.testing.assert_array_equal(copy.predict_loo(), model.predict_loo())
    for i in range(5):
        a, b = copy.infer(yq[i], cq[i]), model.infer(yq[i], cq[i])
        np.testing.assert_array_equal(a.x, b.x)
        assert a.neighbour_index == b.neighbour_index
        a, b = copy.infer(yq[i]), model.infer(yq[i])
        np.testing.assert_array_equal(a.x, b.x)
    # Both keep evolving identically.
    x2, c2, y2 = linear_data(rng, 300)
    for m in (copy, model):
        for j in range(0, 300, 10):
            m.add(x2[j:j + 10], c2[j:j + 10], y2[j:j + 10])
            m.predict(xq, cq)
    np.testing.assert_array_equal(copy.predict(xq, cq), model.predict(xq, cq))
    again = LocalLinearModel.from_state(model.state(), **model.params())
    np.testing.assert_array_equal(again.predict(xq, cq), model.predict(xq, cq))


def test_small_models_fall_back_gracefully() -> None:
    model = LocalLinearModel(2, 2, [2])
    with pytest.raises(ValueError):
        model.predict(np.zeros((1, 2)), np.zeros((1, 2)))
    model.add(np.array([[0.1, 0.2], [0.3, -0.1]]), np.array([[1.0, 2.0], [1.5, 2.5]]),
              np.array([[1.0, 0.0], [3.0, 0.0]]))
    # Two rows: under-determined, the weighted mean of the neighbours.
    pred = model.predict(np.array([[0.2, 0.0]]), np.array([[1.2, 2.2]]))
    assert 1.0 <= pred[0, 0] <= 3.0
    np.testing.assert_allclose(model.predict_loo(), [[3.0, 0.0], [1.0, 0.0]])
    assert model.infer(np.array([2.0, 0.0])).x.shape == (2,)


def test_space_scale_keeps_geometry_within_a_space() -> None:
    data = np.array([[3.0, 4.0, 10.0], [0.0, 0.0, 12.0], [-3.0, -4.0, 14.0]])
    scale = SpaceScale.fit(data, [2, 1], [False, True])
    # change space: RMS norm of the non-zero rows; state space: RMS distance to its mean
    np.testing.assert_allclose(scale.values, [5.0, np.sqrt(8.0 / 3.0)])
    np.testing.assert_allclose(scale.per_column(), [5.0, 5.0, np.sqrt(8.0 / 3.0)])
    assert scale.drift(scale) == 0.0
    const = SpaceScale.fit(np.ones((4, 1)), [1], [True])
    assert const.values[0] > 0


def test_bad_shapes_are_rejected() -> None:
    model = LocalLinearModel(2, 2, [2])
    with pytest.raises(ValueError):
        model.add(np.zeros((3, 2)), None, np.zeros((3, 2)))
    with pytest.raises(ValueError):
        model.add(np.zeros((3, 2)), np.zeros((3, 2)), np.zeros((2, 2)))
    with pytest.raises(ValueError):
        model.add(np.zeros((3, 3)), np.zeros((3, 2)), np.zeros((3, 2)))
    with pytest.raises(ValueError):
        model.add(np.full((1, 2), np.nan), np.zeros((1, 2)), np.zeros((1, 2)))


def blocked_data(rng: np.random.Generator, n: int, share: float, noise: float = 0.002):
    """A linear map of a 2-D input with a `share` of rows whose outcome is null (a robot
    blocked by a wall among free moves)."""
    x = rng.uniform(-1, 1, (n, 2))
    y = x @ A.T + rng.normal(0, noise, (n, 2))
    blocked = rng.random(n) < share
    y[blocked] = 0.0
    return x, y, blocked


def test_robust_fits_ignore_a_few_blocked_rows() -> None:
    rng = np.random.default_rng(11)
    x, y, _ = blocked_data(rng, 2000, 0.05)
    xq, yq, _ = blocked_data(rng, 300, 0.0)
    errors = {}
    for robust in (0, 1):
        model = LocalLinearModel(2, 2, robust_iterations=robust)
        model.add(x, None, y)
        errors[robust] = np.linalg.norm(model.predict(xq) - yq, axis=1)
    # Plain fits are pulled toward the null outcomes of their blocked neighbours.
    assert np.percentile(errors[0], 90) > 0.08
    assert np.percentile(errors[1], 90) < 0.04
    assert np.percentile(errors[1], 75) < 0.3 * np.percentile(errors[0], 75)


def test_robust_fits_leave_clean_data_alone() -> None:
    rng = np.random.default_rng(12)
    x, c, y = linear_data(rng, 1500, noise=0.002)
    xq, cq, _ = linear_data(rng, 100)
    plain = LocalLinearModel(2, 2, [2])
    robust = LocalLinearModel(2, 2, [2], robust_iterations=2)
    for m in (plain, robust):
        m.add(x, c, y)
    np.testing.assert_allclose(robust.predict(xq, cq), plain.predict(xq, cq), atol=0.01)


def test_a_robust_fit_does_not_depend_on_the_other_queries_of_its_batch() -> None:
    rng = np.random.default_rng(13)
    # Noise-free: the clean neighbours fit exactly, and the residual scale is its floor.
    x, y, _ = blocked_data(rng, 800, 0.1, noise=0.0)
    model = LocalLinearModel(2, 2, robust_iterations=1)
    model.add(x, None, y)
    xq = rng.uniform(-1, 1, (40, 2)) * np.linspace(0.05, 1.0, 40)[:, None]
    together = model.predict(xq)
    alone = np.concatenate([model.predict(xq[i:i + 1]) for i in range(40)])
    np.testing.assert_array_equal(together, alone)


def test_robust_iterations_survive_a_state_round_trip_and_old_states_are_plain() -> None:
    rng = np.random.default_rng(14)
    x, y, _ = blocked_data(rng, 400, 0.1)
    model = LocalLinearModel(2, 2, robust_iterations=1)
    model.add(x, None, y)
    copy = LocalLinearModel.from_state(model.state())
    assert copy.robust_iterations == 1
    np.testing.assert_array_equal(copy.predict(x[:20]), model.predict(x[:20]))
    old = model.state()
    old["k"] = old["k"][:3]  # a state saved before robust fits existed
    assert LocalLinearModel.from_state(old).robust_iterations == 0


@pytest.mark.parametrize("context", [True, False])
def test_one_inverse_step_from_the_stored_rows_lands_on_a_linear_maps_goal(context: bool) -> None:
    """Without refinement (`refine_steps=0`) the inverse model's answer is the best of its
    candidates: the stored inputs and one damped Newton step from each towards the goal. On a
    linear map that step lands on the goal, far closer than any stored row's outcome; a step
    in the wrong direction (or none) leaves only the stored inputs, a grid's spacing away."""
    grid = np.linspace(-1, 1, 6)   # stored inputs 0.4 apart
    x = np.array([(a, b) for a in grid for b in grid])
    c = np.tile([[2.0, 1.0]], (x.shape[0], 1)) if context else None
    y = x @ A.T + (c @ B.T if context else 0.0)
    model = LocalLinearModel(2, 2, [2] if context else [], refine_steps=0, damping=1e-6)
    model.add(x, c, y)
    for x_true in ([0.2, -0.4], [-0.6, 0.6], [0.0, 0.0]):
        goal = A @ np.array(x_true) + (B @ [2.0, 1.0] if context else 0.0)
        res = model.infer(goal, c[0] if context else None)
        np.testing.assert_allclose(res.x, x_true, atol=1e-3)
        assert res.error < 1e-3
        np.testing.assert_allclose(res.y_predicted, goal, atol=1e-3)


def test_refinement_steps_bring_a_curved_maps_answer_closer_to_the_goal() -> None:
    """On a curved map one Newton step from a stored row falls short; each refinement step
    (`refine_steps`) goes on from the best candidate towards the goal and is kept only when
    the forward model predicts it closer: more steps never answer worse, here better."""
    rng = np.random.default_rng(4)
    x = rng.uniform(-1, 1, (400, 2))

    def curve(v: np.ndarray) -> np.ndarray:
        return np.c_[np.sin(2 * v[:, 0]) + v[:, 1] ** 3, v[:, 0] * v[:, 1] + v[:, 1]]

    goals = curve(rng.uniform(-0.7, 0.7, (15, 2)))
    predicted = []
    for steps in (0, 1, 3):
        model = LocalLinearModel(2, 2, [], refine_steps=steps, k_inverse=5,
                                 x_low=[-1, -1], x_high=[1, 1])
        model.add(x, None, curve(x))
        answers = [model.infer(g) for g in goals]
        predicted.append(np.array([a.error for a in answers]))
    assert np.all(predicted[1] <= predicted[0]) and np.all(predicted[2] <= predicted[1])
    assert predicted[1].mean() < 0.5 * predicted[0].mean()
    assert predicted[2].mean() < predicted[1].mean()


def test_a_state_spaces_scale_is_the_rows_spread_about_their_mean_wherever_they_lie() -> None:
    """A state space (a position) is scaled by the RMS distance of its rows to their mean
    point: moving the rows, each column by its own amount, changes nothing."""
    rows = np.array([[0.0, 10.0], [2.0, 10.0], [1.0, 11.0], [1.0, 9.0]])
    assert spread_scale(rows) == pytest.approx(1.0)
    assert spread_scale(rows + [5.0, -30.0]) == pytest.approx(1.0)


def test_bad_dimensions_and_rows_are_refused_with_a_message_saying_what() -> None:
    with pytest.raises(ValueError, match=r"dimensions must be ≥ 1, got dx=0, dy=2"):
        LocalLinearModel(0, 2, [])
    model = LocalLinearModel(2, 2, [])
    with pytest.raises(ValueError, match="rows must be finite"):
        model.add(np.full((1, 2), np.inf), None, np.zeros((1, 2)))


def test_the_inverse_error_is_the_miss_in_units_of_the_outputs_scale() -> None:
    """`InverseResult.error` is ‖y_predicted − y_goal‖ over the output space's scale: the same
    data in millimetres instead of metres miss an out-of-reach goal by the same error."""
    rng = np.random.default_rng(6)
    x, _, y = linear_data(rng, 400, context=False)
    goal = A @ np.array([3.0, 3.0])  # out of reach of the input box
    errors = []
    for unit in (1.0, 1000.0):
        model = LocalLinearModel(2, 2, [], x_low=[-1, -1], x_high=[1, 1])
        model.add(x, None, unit * y)
        res = model.infer(unit * goal)
        miss = np.linalg.norm(res.y_predicted - unit * goal)
        assert res.error == pytest.approx(miss / model.index_scale("inverse").values[-1])
        errors.append(res.error)
    assert errors[0] > 0.5
    assert errors[1] == pytest.approx(errors[0], rel=1e-6)


def test_an_inverse_answer_is_remembered_for_its_goal_and_its_context() -> None:
    """The same goal asked in two contexts gets each context's answer, as a model asked only
    that question gives it."""
    rng = np.random.default_rng(7)
    x, c, y = linear_data(rng, 600, context=True)
    goal = np.array([1.0, 0.5])
    contexts = (np.array([1.0, 1.0]), np.array([4.0, 3.0]))
    model = LocalLinearModel(2, 2, [2], x_low=[-1, -1], x_high=[1, 1])
    model.add(x, c, y)
    asked = [model.infer(goal, ctx).x for ctx in contexts]
    for ctx, answer in zip(contexts, asked, strict=True):
        fresh = LocalLinearModel(2, 2, [2], x_low=[-1, -1], x_high=[1, 1])
        fresh.add(x, c, y)
        np.testing.assert_array_equal(answer, fresh.infer(goal, ctx).x)
    assert np.linalg.norm(asked[0] - asked[1]) > 0.1
