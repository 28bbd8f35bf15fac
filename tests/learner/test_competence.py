"""Competence of models and learning progress."""

from __future__ import annotations

import numpy as np
import pytest

from hadim_cli.learner.competence import (
    competence_of_error,
    evaluation_rows,
    held_out_errors,
    model_competence,
    normalised_errors,
    range_scale,
    split_zero,
)
from hadim_cli.learner.interest import learning_progress
from hadim_cli.learner.models import LocalLinearModel

EPS = 1e-3


def push_data(rng: np.random.Generator, n: int, zero_by_context: bool = True):
    """Actions x, a context angle θ; the object moves by x rotated by θ, except when |θ| > 2
    (or, with `zero_by_context` False, when x₀ < 0: then zeros are predictable from x alone)."""
    x = rng.uniform(-1, 1, (n, 2))
    theta = rng.uniform(-np.pi, np.pi, (n, 1))
    co, si = np.cos(theta[:, 0]), np.sin(theta[:, 0])
    y = 0.1 * np.c_[co * x[:, 0] - si * x[:, 1], si * x[:, 0] + co * x[:, 1]]
    y[np.abs(theta[:, 0]) > 2.0 if zero_by_context else x[:, 0] < 0] = 0.0
    return x, theta, y


def fitted(x: np.ndarray, c: np.ndarray | None, y: np.ndarray) -> LocalLinearModel:
    model = LocalLinearModel(2, 2, [] if c is None else [c.shape[1]])
    model.add(x, c, y)
    return model


def test_competence_of_error_shape() -> None:
    assert competence_of_error(0.0) == 1.0
    e = np.linspace(0, 2, 201)
    c = competence_of_error(e)
    assert np.all(np.diff(c) <= 0)
    assert np.all((c >= 0) & (c <= 1))
    assert np.all(c[e >= 1] == 0)
    np.testing.assert_allclose(competence_of_error(0.1, sharpness=20.0), 0.99 * np.exp(-2))
    assert competence_of_error(0.1, sharpness=5.0) > competence_of_error(0.1, sharpness=20.0)


def test_errors_and_zero_split() -> None:
    y = np.array([[3.0, 4.0], [0.0, 0.0], [1e-4, 0.0]])
    np.testing.assert_allclose(normalised_errors(np.zeros_like(y), y, 5.0), [1.0, 0.0, 2e-5])
    np.testing.assert_array_equal(split_zero(y, EPS), [False, True, True])


def test_true_model_beats_wrong_ones() -> None:
    rng = np.random.default_rng(0)
    x, theta, y = push_data(rng, 2000)
    good = model_competence(fitted(x, theta, y), zero_eps=EPS)
    assert good.n_zero > 0 and good.n_nonzero > 0
    assert good.competence > 0.5
    missing_context = fitted(x, None, y)
    shuffled = fitted(x, theta, y[rng.permutation(len(y))])
    for wrong in (missing_context, shuffled):
        report = model_competence(wrong, zero_eps=EPS)
        assert report.competence < 0.1 * good.competence
        assert report.nonzero_competence < 0.1


def test_zeros_predictable_without_context() -> None:
    """When nothing-moved is predictable from x alone, the non-zero score still tells."""
    rng = np.random.default_rng(3)
    x, theta, y = push_data(rng, 2000, zero_by_context=False)
    good = model_competence(fitted(x, theta, y), zero_eps=EPS)
    wrong = model_competence(fitted(x, None, y), zero_eps=EPS)
    assert wrong.nonzero_competence < 0.05 < 0.4 < good.nonzero_competence
    assert wrong.competence < good.competence
    strict = model_competence(fitted(x, None, y), zero_eps=EPS, zero_weight=0.0)
    assert strict.competence == wrong.nonzero_competence


def test_nothing_moved_is_not_competence() -> None:
    rng = np.random.default_rng(1)
    x = rng.uniform(-1, 1, (300, 2))
    zeros = LocalLinearModel(2, 2, [])
    zeros.add(x, None, np.zeros((300, 2)))
    report = model_competence(zeros, zero_eps=EPS)
    assert report.competence == 0.0 and report.n_nonzero == 0 and report.n_zero == 300
    # Mostly zeros, and the rare moves unpredictable: the perfect zero score does not carry it.
    y = np.zeros((300, 2))
    y[::10] = rng.normal(0, 0.1, (30, 2))
    mostly = LocalLinearModel(2, 2, [])
    mostly.add(x, None, y)
    report = model_competence(mostly, zero_eps=EPS)
    assert report.zero_competence > 0.5
    assert report.competence <= 0.5 * (report.zero_competence + 0.1)


def test_subset_evaluation_is_deterministic_and_balanced() -> None:
    rng = np.random.default_rng(2)
    x, theta, y = push_data(rng, 3000)
    model = LocalLinearModel(2, 2, [1])
    model.add(x, theta, y)
    a = model_competence(model, zero_eps=EPS, max_rows=400, rng=np.random.default_rng(7))
    b = model_competence(model, zero_eps=EPS, max_rows=400, rng=np.random.default_rng(7))
    full = model_competence(model, zero_eps=EPS)
    assert a == b
    assert a.n_zero == a.n_nonzero == 200
    assert abs(a.competence - full.competence) < 0.1
    zero = np.zeros(10, dtype=bool)
    zero[:2] = True
    rows = evaluation_rows(zero, 6, None)
    assert rows.size == 6 and zero[rows].sum() == 2  # the small group gives its share away
    np.testing.assert_array_equal(evaluation_rows(zero, None, None), np.arange(10))
    # As many rows as allowed: all of them, and nothing drawn from the learner's generator.
    gen = np.random.default_rng(5)
    before = gen.bit_generator.state
    np.testing.assert_array_equal(evaluation_rows(zero, 10, gen), np.arange(10))
    assert gen.bit_generator.state == before


def test_learning_progress() -> None:
    rising = np.linspace(0, 1, 20)
    flat = np.full(20, 0.6)
    assert learning_progress(rising, 20) > learning_progress(flat, 20)
    assert learning_progress(flat, 20) == 0.0
    np.testing.assert_allclose(learning_progress(rising, 20), 10 / 19)
    assert learning_progress([0.3], 10) == 0.0
    assert learning_progress([], 10) == 0.0
    np.testing.assert_allclose(learning_progress([0.0, 0.0, 1.0, 1.0, 1.0], 4), 0.5)
    assert learning_progress(rising[::-1], 20) == learning_progress(rising, 20)


def test_held_out_errors_leave_each_row_out_of_its_own_fit() -> None:
    """`hadim affordances --errors`: a row unlike its neighbours is predicted from them
    alone. Rows on y = 2x and one 1 too high: its held-out error is the whole 1 (in-sample,
    its own weight would pull the fit towards it), every other row's is small."""
    model = LocalLinearModel(1, 1, k_forward=6)
    x = np.linspace(0.0, 1.0, 41)
    y = 2 * x
    y[20] += 1.0
    model.add(x[:, None], None, y[:, None])
    e = held_out_errors(model)
    assert e is not None and set(e) == {"p50", "p90", "p99", "max"}
    assert e["max"] == pytest.approx(1.0, abs=0.05)
    assert e["p50"] < 0.05
    assert held_out_errors(LocalLinearModel(1, 1)) is None
    one = LocalLinearModel(1, 1)
    one.add(np.array([[0.0]]), None, np.array([[1.0]]))
    assert held_out_errors(one) is None
    two = LocalLinearModel(1, 1)  # from two rows on: each predicted from the other
    two.add(np.array([[0.0], [1.0]]), None, np.array([[1.0], [3.0]]))
    assert held_out_errors(two) == pytest.approx({"p50": 2.0, "p90": 2.0, "p99": 2.0,
                                                  "max": 2.0})


def test_the_range_of_a_space_is_twice_a_high_quantile_of_its_moves():
    """`range_scale`, the length competence divides errors by: the width of the space's
    range, i.e. twice the 95th percentile of the norms of the outcomes that moved (a move in
    any direction spans the diameter); the rows where nothing moved do not count."""
    norms = np.arange(1, 101, dtype=np.float64) / 100   # 0.01 … 1.00
    angles = np.linspace(0, 2 * np.pi, norms.size, endpoint=False)
    y = np.c_[norms * np.cos(angles), norms * np.sin(angles)]
    y = np.concatenate([y, np.zeros((300, 2))])          # many rows where nothing moved
    assert range_scale(y, EPS) == pytest.approx(2 * np.quantile(norms, 0.95))
    assert range_scale(y, EPS, quantile=0.5) == pytest.approx(2 * np.median(norms))
    assert range_scale(y, 0.5) == pytest.approx(2 * np.quantile(norms[norms > 0.5], 0.95))
    assert range_scale(np.zeros((5, 2)), EPS) == 1.0    # nothing moved: unit scale
