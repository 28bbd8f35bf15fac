"""The neighbour search's fast paths answer bit for bit what the plain scan answers.

An index's buffer (rows added since its KD-tree was built) is searched through a KD-tree of its
own once it is large enough; the plain path scans it (`_brute_knn`). Every answer of a model —
and so every result of a run — must be the same either way.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial import cKDTree

from hadim_cli.learner import models
from hadim_cli.learner.models import LocalLinearModel


@pytest.mark.parametrize("order", ["C", "F"])
@pytest.mark.parametrize("dims", [2, 3, 4, 6])
@pytest.mark.parametrize("size", [49, 130, 700])
def test_tree_search_of_a_buffer_is_the_scan_bit_for_bit(dims: int, size: int, order: str
                                                         ) -> None:
    """Up to the first exact tie it reports: row- or column-major rows (a model's buffer is
    column-major: einsum then sums each distance's squares in another order), with duplicated
    rows (exact ties)."""
    rng = np.random.default_rng(dims * 1000 + size)
    pts = np.asarray(rng.normal(size=(size, dims)), order=order)
    pts[size // 2:size // 2 + 6] = pts[:6]
    queries = np.concatenate([rng.normal(size=(60, dims)), pts[:20]])  # some exact hits
    tree = cKDTree(pts)
    ties = []
    for k in (1, 10, 20, size):
        want_dist, want_idx = models._brute_knn(queries, pts, k)
        dist, idx, tie = models._tree_knn(queries, pts, tree, k)
        assert np.array_equal(dist, want_dist)
        # the rows before the first exact tie are the scan's; after it, they may not be
        before = np.arange(k)[None, :] < tie[:, None]
        assert np.array_equal(idx[before], want_idx[before])
        differs = np.any(idx != want_idx, axis=1)
        assert np.all(tie[differs] < k)
        ties.append(tie < k)
    assert np.any(ties[0]) and not np.all(ties[0])  # k = 1: both kinds of query were asked


def _rows(rng: np.random.Generator, n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    x = rng.uniform(-1, 1, (n, 2))
    c = rng.uniform(-1, 1, (n, 2))
    x[n // 2:n // 2 + 4], c[n // 2:n // 2 + 4] = x[:4], c[:4]  # duplicated rows (ties)
    y = np.c_[np.sin(2 * x[:, 0]) + c[:, 1], x[:, 1] * c[:, 0]]
    return x, c, y


def _answers(model: LocalLinearModel, rng: np.random.Generator) -> list[np.ndarray]:
    x, c, y = _rows(rng, 80)
    x[:10], c[:10] = model.data()[0][-10:], model.data()[1][-10:]  # at stored rows
    inv = model.infer(y[0], c[0])
    out = [model.predict(x, c), *model.forward_neighbours(x, c), *model.inverse_neighbours(y, c),
           *model.inverse_neighbours(y[:5], None), model.predict_loo(np.arange(0, model.n, 7)),
           inv.x, inv.y_predicted, np.array([inv.error, inv.neighbour_index])]
    return out


def _grown_model(rng: np.random.Generator, ask: list[list[np.ndarray]]) -> LocalLinearModel:
    """A model of 800 rows then 5 adds of 40 (buffers of 40-200 rows: under the rebuild
    threshold), asked between adds: every answer appended to `ask`."""
    model = LocalLinearModel(2, 2, [2])
    model.add(*_rows(rng, 800))
    for _ in range(5):
        model.add(*_rows(rng, 40))
        ask.append(_answers(model, rng))
    return model


def test_models_answer_alike_with_and_without_buffer_trees(monkeypatch) -> None:
    fast: list[list[np.ndarray]] = []
    model = _grown_model(np.random.default_rng(5), fast)
    built = [model._indexes[name] for name in ("forward", "inverse", "outcome")]
    assert all(i.n_built == 800 for i in built)       # never rebuilt: the buffers served
    assert all(i.buffer_tree is not None for i in built)  # and were searched by their trees

    monkeypatch.setattr(models, "_BUFFER_TREE", 10**9)  # the plain scan only
    plain: list[list[np.ndarray]] = []
    _grown_model(np.random.default_rng(5), plain)
    for got, want in zip(fast, plain, strict=True):
        for a, b in zip(got, want, strict=True):
            assert np.array_equal(a, b)


def test_an_inverse_answer_asked_again_is_the_same_until_rows_are_added() -> None:
    """`infer` keeps its recent answers: asked again, it answers as a model that never
    answered before — even after the caller changed the arrays it was given — and after an
    `add`, as a model that holds the new rows."""
    rng = np.random.default_rng(11)
    rows = [_rows(rng, 300), _rows(rng, 30)]

    def fresh(batches: int) -> LocalLinearModel:
        m = LocalLinearModel(2, 2, [2])
        for batch in rows[:batches]:
            m.add(*batch)
        return m

    def same(a, b) -> bool:
        return (np.array_equal(a.x, b.x) and np.array_equal(a.y_predicted, b.y_predicted)
                and a.error == b.error and np.array_equal(a.context, b.context)
                and a.neighbour_index == b.neighbour_index)

    model = fresh(1)
    goal, c = np.array([0.3, -0.2]), np.array([0.1, 0.4])
    first = model.infer(goal, c)
    first.x[:] = 9.0                       # a caller's change must not reach the kept answer
    first.context[:] = 9.0
    assert same(model.infer(goal, c), fresh(1).infer(goal, c))
    assert same(model.infer(goal), fresh(1).infer(goal))
    model.add(*rows[1])
    assert same(model.infer(goal, c), fresh(2).infer(goal, c))
    assert not same(fresh(1).infer(goal, c), fresh(2).infer(goal, c))
