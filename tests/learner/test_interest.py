"""SAGG-RIAC interest maps: learning progress, splits, sampling, persistence."""

from __future__ import annotations

import json

import numpy as np
import pytest

from hadim_cli.learner.interest import (
    InterestMap,
    Progress,
    RegionView,
    balance,
    best_cut,
    learning_progress,
    paper_progress,
    proportional_index,
    select_index,
    split_quality,
)


# ---------------------------------------------------------------------------- pure maths
@pytest.mark.parametrize(
    ("values", "window", "expected"),
    [
        ([], 20, 0.0),
        ([0.7], 20, 0.0),
        ([0.2, 0.6], 20, 0.4),
        ([0.6, 0.2], 20, 0.4),  # regress as well as progress: absolute value
        ([0.5] * 10, 20, 0.0),
        ([0.0, 0.0, 1.0, 1.0], 20, 1.0),
        ([0.0, 0.0, 0.0, 1.0], 20, 0.5),
        ([0.0, 0.3, 0.6], 20, 0.45),  # odd count: newer half holds the extra value
        ([1.0, 1.0, 0.0, 0.0, 0.5, 0.5], 4, 0.5),  # only the last 4 count
        ([0.1, 0.9], 0, 0.0),
    ],
)
def test_learning_progress(values: list[float], window: int, expected: float) -> None:
    assert learning_progress(values, window) == pytest.approx(expected)


@pytest.mark.parametrize(
    ("values", "k", "n", "expected"),
    [
        ([], 2, 2, 0.0),
        ([0.7], 2, 2, 0.0),
        ([0.2, 0.6], 20, 20, 0.2),  # competences 0.2, then 0.4: one progress of 0.2
        ([0.0, 0.0, 1.0, 1.0], 2, 2, 0.5),  # competences 0, 0, .5, 1: progresses .5, .5
        ([0.0, 0.0, 0.0, 1.0, 1.0, 1.0], 2, 3, 1 / 3),  # progresses 0, .5, .5, 0 → last 3
        ([1.0, 1.0, 1.0, 0.0, 0.0, 0.0], 2, 3, 1 / 3),  # a loss counts as a progress
        ([1.0, 0.0, 1.0, 0.0, 1.0, 0.0], 3, 2, 0.0),  # a jitter: progresses cancel out
        ([0.5] * 30, 5, 5, 0.0),
        ([0.0] * 20 + [1.0] * 4, 4, 2, 0.25),  # only the last n progresses, k deep
    ],
)
def test_paper_progress(values: list[float], k: int, n: int, expected: float) -> None:
    """The paper's interest (§4.4): the mean of the last n derivatives of the competence, the
    competence being the mean of the last k values."""
    assert paper_progress(values, k, n) == pytest.approx(expected)


def test_paper_progress_is_a_scaled_half_window_difference_when_full() -> None:
    """With k = n and 2n values, the mean of the n last progresses telescopes: it is the
    difference between the means of the newer and the older n values, over n — a measure
    unlike the half-window difference (`learning_progress`) of the same values."""
    values = np.random.default_rng(3).random(40)
    expected = abs(values[20:].mean() - values[:20].mean()) / 20
    assert paper_progress(values, 20, 20) == pytest.approx(expected)
    assert paper_progress(np.concatenate([[9.0] * 5, values]), 20, 20) == \
        pytest.approx(expected)  # older values do not count
    assert learning_progress(values, 20) != pytest.approx(expected)


def test_a_paper_map_measures_interest_and_splits_by_the_papers_progress() -> None:
    """A map built with `Progress.PAPER` uses `paper_progress` for its leaves' interest and
    for the quality of its cuts, and keeps the measure through its state."""
    m = InterestMap([0.0], [1.0], max_goals_per_region=40, window=4,
                    measure=Progress.PAPER)
    comps = [0.0] * 6 + [1.0] * 3
    for i, c in enumerate(comps):
        m.add([0.5], c, i)
    assert m.interest == pytest.approx(paper_progress(comps, 4, 4))
    assert m.interest != pytest.approx(learning_progress(comps, 4))
    left, right = [0.0] * 4 + [1.0] * 4, [0.5] * 8  # progresses .25 and 0 (half-window: 0, 0)
    assert split_quality(left, right, 4, Progress.PAPER) == pytest.approx(0.25)
    assert split_quality(left, right, 4) == 0.0
    meta, arrays = m.state()
    copy = InterestMap.from_state(json.loads(json.dumps(meta)), arrays)
    assert copy.measure is Progress.PAPER and copy.interest == m.interest
    old = {k: v for k, v in meta.items() if k != "measure"}  # a map stored before the option
    assert InterestMap.from_state(old, arrays).measure is Progress.HALF_WINDOW


def test_balance_and_split_quality() -> None:
    assert balance(5, 5) == 1.0
    assert balance(1, 9) == pytest.approx(0.36)
    assert balance(0, 9) == 0.0
    rising, flat = [0.0, 0.0, 1.0, 1.0], [0.5, 0.5, 0.5, 0.5]
    assert split_quality(rising, flat, 20) == pytest.approx(1.0)
    assert split_quality(rising, [], 20) == 0.0
    assert split_quality(flat, flat, 20) == 0.0
    # A lopsided cut with the same progress gap scores lower.
    assert split_quality(rising, flat * 4, 20) < split_quality(rising, flat, 20)


def test_best_cut_separates_progress() -> None:
    rng = np.random.default_rng(0)
    goals = rng.uniform(0.0, 1.0, size=(60, 2))
    t = np.arange(60) / 59
    comps = np.where(goals[:, 1] < 0.4, t, 0.5)  # learning only where y < 0.4
    cut = best_cut(goals, comps, np.zeros(2), np.ones(2), window=20, n_candidates=8,
                   min_width=np.full(2, 0.05))
    assert cut is not None
    assert cut.dim == 1
    assert 0.3 < cut.value < 0.5


def test_best_cut_none_when_goals_pile_up() -> None:
    goals = np.full((60, 1), 0.5)
    cut = best_cut(goals, np.linspace(0, 1, 60), np.zeros(1), np.ones(1), window=20,
                   n_candidates=8, min_width=np.full(1, 0.01))
    assert cut is None


# ---------------------------------------------------------------------------- splitting
def _fill(m: InterestMap, rng: np.random.Generator, n: int, start: int = 0) -> None:
    """Uniform goals; competence rises over time for x < 0, flat elsewhere."""
    for i in range(start, start + n):
        g = rng.uniform(m.low, m.high)
        comp = min(1.0, i / n) if g[0] < 0 else 0.4
        m.add(g, comp, i)


def test_leaf_splits_after_max_goals_and_children_hold_goals() -> None:
    m = InterestMap([-0.3, -0.3], [0.3, 0.3], max_goals_per_region=50)
    rng = np.random.default_rng(1)
    _fill(m, rng, 50)
    assert m.n_regions == 1
    assert m.leaves()[0].n_goals == 50
    _fill(m, rng, 1, start=50)
    views = m.leaves()
    assert len(views) == 2
    assert all(v.n_goals > 0 for v in views)
    assert sum(v.n_goals for v in views) == 51
    assert all(v.parent_id == 0 for v in views)
    assert [v.region_id for v in views] == [1, 2]


def test_cut_separates_learning_from_flat_region() -> None:
    m = InterestMap([-0.3, -0.3], [0.3, 0.3], max_goals_per_region=50)
    _fill(m, np.random.default_rng(2), 51)
    left, right = m.leaves()
    # The cut is along x, near 0, and the learning (x < 0) side is the more interesting.
    assert left.high[0] == right.low[0]
    assert -0.1 < left.high[0] < 0.1
    assert left.high[1] == 0.3 and left.low[1] == -0.3
    assert left.interest > right.interest + 0.2


def test_sampling_prefers_high_interest_region() -> None:
    m = InterestMap([-0.3, -0.3], [0.3, 0.3], max_goals_per_region=50)
    _fill(m, np.random.default_rng(2), 51)
    left, right = m.leaves()
    rng = np.random.default_rng(3)
    goals = np.array([m.sample_goal(rng, epsilon=0.0) for _ in range(2000)])
    in_left = goals[:, 0] < left.high[0]
    expected = left.interest / (left.interest + right.interest)
    assert in_left.mean() == pytest.approx(expected, abs=0.04)
    assert in_left.mean() > 0.8


def test_epsilon_one_is_uniform_in_the_box() -> None:
    m = InterestMap([-0.3, -0.3], [0.3, 0.3], max_goals_per_region=50)
    _fill(m, np.random.default_rng(2), 51)
    rng = np.random.default_rng(4)
    goals = np.array([m.sample_goal(rng, epsilon=1.0) for _ in range(4000)])
    assert np.all(goals >= -0.3) and np.all(goals <= 0.3)
    assert (goals[:, 0] < 0).mean() == pytest.approx(0.5, abs=0.03)
    assert goals.mean(axis=0) == pytest.approx([0.0, 0.0], abs=0.01)


def test_goals_stay_in_bounds_and_outside_goals_are_clipped() -> None:
    m = InterestMap([0.0], [1.0], max_goals_per_region=10, window=6)
    rng = np.random.default_rng(5)
    for i in range(300):
        m.add([rng.uniform(-1.0, 2.0)], rng.random(), i)
    for v in m.leaves():
        assert 0.0 <= v.low[0] < v.high[0] <= 1.0
    assert sum(v.n_goals for v in m.leaves()) == 300
    samples = np.array([m.sample_goal(rng) for _ in range(500)])
    assert np.all((samples >= 0.0) & (samples <= 1.0))
    # The leaves tile the box.
    edges = sorted((v.low[0], v.high[0]) for v in m.leaves())
    assert edges[0][0] == 0.0 and edges[-1][1] == 1.0
    assert all(a[1] == b[0] for a, b in zip(edges, edges[1:], strict=False))


def test_unexplored_map_has_default_interest_and_bad_input_is_refused() -> None:
    m = InterestMap([0.0, 0.0], [1.0, 1.0], unexplored_interest=0.02)
    assert m.interest == 0.02
    assert m.leaves() == [RegionView(0, None, (0.0, 0.0), (1.0, 1.0), 0, 0.02)]
    with pytest.raises(ValueError):
        m.add([0.5], 0.5, 0)
    with pytest.raises(ValueError):
        m.add([0.5, np.nan], 0.5, 0)
    with pytest.raises(ValueError):
        m.add([0.5, 0.5], np.inf, 0)
    with pytest.raises(ValueError):
        InterestMap([0.0], [0.0])
    with pytest.raises(ValueError, match="same length, got 2 and 1"):
        InterestMap([0.0, 0.0], [1.0])


def test_map_interest_is_mean_of_leaf_interests() -> None:
    m = InterestMap([-0.3, -0.3], [0.3, 0.3])
    _fill(m, np.random.default_rng(6), 400)
    assert m.interest == pytest.approx(np.mean([v.interest for v in m.leaves()]))


# ---------------------------------------------------------------------------- selection
def test_select_index_proportional_and_deterministic() -> None:
    interests = [0.1, 0.0, 0.3]
    rng = np.random.default_rng(7)
    picks = np.array([select_index(interests, rng, 0.0) for _ in range(4000)])
    assert not np.any(picks == 1)
    assert (picks == 2).mean() == pytest.approx(0.75, abs=0.03)
    a = [select_index(interests, np.random.default_rng(8), 0.2) for _ in range(5)]
    b = [select_index(interests, np.random.default_rng(8), 0.2) for _ in range(5)]
    assert a == b


def test_select_index_uniform_when_epsilon_one_or_all_zero() -> None:
    rng = np.random.default_rng(9)
    for interests, eps in (([0.0, 0.0, 0.0, 0.0], 0.0), ([1.0, 0.0, 0.0, 0.0], 1.0)):
        picks = np.array([select_index(interests, rng, eps) for _ in range(4000)])
        assert np.bincount(picks, minlength=4) / 4000 == pytest.approx([0.25] * 4, abs=0.03)
    with pytest.raises(ValueError):
        select_index([], rng, 0.1)
    with pytest.raises(ValueError, match=r"finite and >= 0, got \[0.1, -0.2\]"):
        select_index([0.1, -0.2], rng, 0.1)


def test_a_draw_never_lands_on_a_zero_weight_even_at_the_ends_of_u() -> None:
    """u ~ U[0, 1) is mapped onto the cumulative weights so that an entry of weight 0 (a
    region or affordance of no interest) is never drawn, u = 0 included."""
    assert proportional_index(np.array([0.0, 1.0, 0.0]), 0.0) == 1
    assert proportional_index(np.array([1.0, 0.0, 1.0]), 0.5) == 2
    assert proportional_index(np.array([1.0, 0.0, 1.0]), np.nextafter(0.5, 0.0)) == 0


# ---------------------------------------------------------------------------- persistence
def test_state_round_trip_gives_identical_future() -> None:
    m = InterestMap([-0.3, -0.3, 0.0], [0.3, 0.3, 1.0], max_goals_per_region=20, window=10)
    rng = np.random.default_rng(10)
    for i in range(500):
        m.add(m.sample_goal(rng), rng.random(), i)
    meta, arrays = m.state()
    meta = json.loads(json.dumps(meta))  # must survive JSON
    assert all(isinstance(a, np.ndarray) and a.dtype != object for a in arrays.values())
    copy = InterestMap.from_state(meta, {k: a.copy() for k, a in arrays.items()})
    assert copy.leaves() == m.leaves()
    assert copy.interest == m.interest
    r1, r2 = np.random.default_rng(11), np.random.default_rng(11)
    for i in range(500, 800):
        g1, g2 = m.sample_goal(r1), copy.sample_goal(r2)
        assert np.array_equal(g1, g2)
        c = float(r1.random())
        assert c == float(r2.random())
        m.add(g1, c, i)
        copy.add(g2, c, i)
    assert copy.leaves() == m.leaves()
    a1, a2 = m.state()[1], copy.state()[1]
    assert all(np.array_equal(a1[k], a2[k]) for k in a1)


def test_a_maps_state_lists_its_goals_in_the_order_they_were_recorded_across_splits() -> None:
    """A store keeps only what a checkpoint adds: the goals of the state are in the order they
    were added, whichever leaf holds them, so a later state's goals begin with an earlier
    state's — a split moves none of them."""
    m = InterestMap([-1.0, -1.0], [1.0, 1.0], max_goals_per_region=10, window=4)
    rng = np.random.default_rng(5)
    added = []
    for i in range(60):
        g = rng.uniform(-1.0, 1.0, 2)
        added.append(g)
        m.add(g, float(rng.random()), 3 * i)
    assert m.n_regions > 2  # goals spread over several leaves
    before = m.state()[1]
    assert np.array_equal(before["goals"], np.array(added))
    assert np.array_equal(before["iterations"], 3 * np.arange(60))
    for i in range(60, 90):
        m.add(rng.uniform(-1.0, 1.0, 2), float(rng.random()), 3 * i)
    after = m.state()[1]
    for key in ("goals", "competences", "iterations"):
        assert np.array_equal(after[key][:60], before[key]), key


def test_a_maps_state_keeps_its_indices_and_counts_as_integers() -> None:
    """The tree's links, split counts, iterations and regions are stored as integers (a
    checkpoint's arrays keep their kinds), whatever the map has been through."""
    m = InterestMap([-1.0, -1.0], [1.0, 1.0], max_goals_per_region=10, window=4)
    _fill(m, np.random.default_rng(3), 40)
    assert m.n_regions > 1
    arrays = m.state()[1]
    for key in ("node_parent", "node_split_dim", "node_left", "node_right",
                "node_next_split_at", "iterations", "goal_region"):
        assert arrays[key].dtype == np.int64, key
    for key in ("node_low", "node_high", "node_split_value", "goals", "competences"):
        assert arrays[key].dtype == np.float64, key


def test_from_state_refuses_unknown_format() -> None:
    meta, arrays = InterestMap([0.0], [1.0]).state()
    with pytest.raises(ValueError, match="format"):
        InterestMap.from_state({**meta, "format": 99}, arrays)
    with pytest.raises(ValueError, match="inconsistent"):
        InterestMap.from_state(meta, {k: v for k, v in arrays.items() if k != "goals"})


def test_same_generator_same_map() -> None:
    def run() -> list[RegionView]:
        m = InterestMap([-1.0, -1.0], [1.0, 1.0])
        rng = np.random.default_rng(12)
        for i in range(600):
            g = m.sample_goal(rng)
            m.add(g, float(np.exp(-np.linalg.norm(g)) * min(1.0, i / 300)), i)
        return m.leaves()

    assert run() == run()
