"""SAGG-RIAC interest maps: a region tree over one affordance's goal (output) space.

Each leaf of the tree keeps the goals attempted in it, in time order, with the competence
reached. Its *interest* is its learning progress, by one of two measures (`Progress`): the
absolute difference between the mean competence of the newer and of the older half of its last
`window` attempts (explauto's, the default), or the paper's (§4.4): the competence near a goal
is the mean over the k last outcomes of the region, the learning progress its derivative, and
the interest the mean of the n last learning progresses. A leaf holding more than
`max_goals_per_region` goals splits at the cut that best separates learning progress. Goals
are drawn by choosing a leaf in proportion to its interest, then uniformly inside it, with
some uniform exploration of the whole box.

The maths (learning progress, split quality, best cut, proportional choice) are pure
functions; `InterestMap` only holds state.
"""

from __future__ import annotations

import enum
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any, NamedTuple

import numpy as np

FORMAT = 1
"""Version of the `InterestMap.state()` layout."""

_NO_NODE = -1


class Progress(enum.StrEnum):
    """How a region's learning progress (its interest) is measured."""

    HALF_WINDOW = "half-window"
    """|mean(newer half) − mean(older half)| of the last `window` competences."""
    PAPER = "paper"
    """The paper's (§4.4): |mean of the last `window` derivatives of the competence|, the
    competence being the mean of the last `window` values (`paper_progress`)."""


# ---------------------------------------------------------------------------- pure maths
def learning_progress(competences: Sequence[float] | np.ndarray, window: int) -> float:
    """|mean(newer half) − mean(older half)| of the last `window` competences (0 if < 2).

    With an odd count the newer half holds the extra value.
    """
    if window < 1:
        return 0.0
    c = np.asarray(competences, dtype=np.float64)[-window:]
    if c.size < 2:
        return 0.0
    half = c.size // 2
    return float(abs(c[half:].mean() - c[:half].mean()))


def paper_progress(competences: Sequence[float] | np.ndarray, k: int, n: int) -> float:
    """The paper's interest of a region (§4.4): |mean of the last `n` learning progresses|.

    The competence after each outcome is the mean of the region's last `k` values (all of them
    while fewer); a learning progress is its change from one outcome to the next (the
    derivative); the interest is the mean of the last `n` of them. The mean is signed before
    its absolute value is taken (SAGG-RIAC counts a loss of competence as a progress): the
    changes of a competence that only jitters cancel out. 0 with fewer than 2 values.
    """
    if k < 1 or n < 1:
        return 0.0
    v = np.asarray(competences, dtype=np.float64)[-(n + k):]  # the last n + 1 means need these
    if v.size < 2:
        return 0.0
    sums = np.concatenate([[0.0], np.cumsum(v)])
    end = np.arange(1, v.size + 1)
    begin = np.maximum(0, end - k)
    competence = (sums[end] - sums[begin]) / (end - begin)
    return float(abs(np.diff(competence)[-n:].mean()))


def progress(competences: Sequence[float] | np.ndarray, window: int,
             measure: Progress = Progress.HALF_WINDOW) -> float:
    """The learning progress of a region's competences (in time order) by `measure`."""
    if measure is Progress.PAPER:
        return paper_progress(competences, window, window)
    return learning_progress(competences, window)


def balance(n_left: int, n_right: int) -> float:
    """4·n_l·n_r / n²: 1 for an even split, towards 0 as one side gets tiny."""
    n = n_left + n_right
    return 0.0 if n == 0 else 4.0 * n_left * n_right / (n * n)


def split_quality(left: Sequence[float] | np.ndarray, right: Sequence[float] | np.ndarray,
                  window: int, measure: Progress = Progress.HALF_WINDOW) -> float:
    """|LP_left − LP_right| × balance: how well a cut separates learning progress.

    `left` and `right` are the competences of the two children, each in time order.
    """
    if len(left) == 0 or len(right) == 0:
        return 0.0
    gap = abs(progress(left, window, measure) - progress(right, window, measure))
    return gap * balance(len(left), len(right))


def candidate_cuts(values: np.ndarray, low: float, high: float, n_candidates: int,
                   min_width: float) -> np.ndarray:
    """Cut positions along one dimension: the interior quantiles of `values`.

    A cut is kept if it leaves each child at least `min_width` wide and puts goals on both
    sides (a goal equal to the cut goes to the right child).
    """
    q = np.arange(1, n_candidates + 1, dtype=np.float64) / (n_candidates + 1)
    cuts = np.unique(np.quantile(values, q))
    ok = (cuts - low >= min_width) & (high - cuts >= min_width)
    ok &= (cuts > values.min()) & (cuts <= values.max())
    return cuts[ok]


class Cut(NamedTuple):
    """Where a region splits: goals with `goal[dim] < value` go to the left child."""

    dim: int
    value: float
    quality: float


def best_cut(goals: np.ndarray, competences: np.ndarray, low: np.ndarray, high: np.ndarray,
             *, window: int, n_candidates: int, min_width: np.ndarray,
             measure: Progress = Progress.HALF_WINDOW) -> Cut | None:
    """The cut maximising `split_quality`, or None if no admissible cut exists.

    Ties (e.g. no learning progress anywhere) go to the more balanced cut, then to the
    dimension where the region is widest relative to `min_width`, then to the first found.
    """
    best: Cut | None = None
    best_key: tuple[float, float, float] | None = None
    for dim in range(goals.shape[1]):
        values = goals[:, dim]
        for value in candidate_cuts(values, float(low[dim]), float(high[dim]), n_candidates,
                                    float(min_width[dim])):
            left = values < value
            n_left = int(left.sum())
            quality = split_quality(competences[left], competences[~left], window, measure)
            key = (quality, balance(n_left, len(values) - n_left),
                   float((high[dim] - low[dim]) / min_width[dim]))
            if best_key is None or key > best_key:
                best, best_key = Cut(dim, float(value), quality), key
    return best


def proportional_index(weights: np.ndarray, u: float) -> int:
    """Index i drawn with probability weights[i] / sum(weights), given u ~ U[0, 1)."""
    cum = np.cumsum(weights)
    i = int(np.searchsorted(cum, u * cum[-1], side="right"))
    return min(i, len(weights) - 1)


def select_index(interests: Sequence[float] | np.ndarray, rng: np.random.Generator,
                 epsilon: float) -> int:
    """Choose among items in proportion to interest; uniformly with probability `epsilon`
    or when every interest is 0. Always draws exactly one U[0, 1) then one more value."""
    w = np.asarray(interests, dtype=np.float64)
    if w.ndim != 1 or w.size == 0:
        raise ValueError("select_index needs a non-empty 1-D list of interests")
    if not np.all(np.isfinite(w)) or np.any(w < 0):
        raise ValueError(f"interests must be finite and >= 0, got {w.tolist()}")
    uniform = rng.random() < epsilon or not w.any()
    u = rng.random()
    if uniform:
        return min(int(u * w.size), w.size - 1)
    return proportional_index(w, u)


# ---------------------------------------------------------------------------- records
@dataclass(frozen=True)
class RegionView:
    """One leaf of an interest map, for storage and visualisation."""

    region_id: int
    """Id of the region; the root is 0, children get the next free ids."""
    parent_id: int | None
    """Id of the region it was split from (None for the root)."""
    low: tuple[float, ...]
    """Lower corner of the region's box."""
    high: tuple[float, ...]
    """Upper corner of the region's box."""
    n_goals: int
    """Goals attempted in the region (inherited from its ancestors included)."""
    interest: float
    """Current interest (learning progress) of the region."""


@dataclass
class _Leaf:
    goals: list[np.ndarray] = field(default_factory=list)
    competences: list[float] = field(default_factory=list)
    iterations: list[int] = field(default_factory=list)
    sequence: list[int] = field(default_factory=list)
    """Each goal's place in the order the map recorded them (saved states list goals in
    that order, so a checkpoint of the map only grows at its end)."""
    interest: float = 0.0
    next_split_at: int = 0
    """Do not try to split before holding more goals than this (raised after a failed try)."""


# ---------------------------------------------------------------------------- the map
class InterestMap:
    """A SAGG-RIAC region tree over the box [low, high] of one goal space.

    The map's overall `interest` (used to choose which affordance to explore) is the
    unweighted mean of its leaves' interests: the expected interest of a region picked at
    random. A sum would grow with the number of splits (every leaf carries a noise floor of
    learning progress), and a max is the extreme of many noisy estimates; the mean is
    comparable across maps of different ages.
    """

    def __init__(self, low: Sequence[float], high: Sequence[float], *,
                 max_goals_per_region: int = 50, window: int = 20, n_cut_candidates: int = 8,
                 min_region_fraction: float = 1 / 32, unexplored_interest: float = 0.02,
                 measure: Progress | str = Progress.HALF_WINDOW):
        lo = np.array(low, dtype=np.float64).reshape(-1)
        hi = np.array(high, dtype=np.float64).reshape(-1)
        if lo.size == 0 or lo.shape != hi.shape:
            raise ValueError(f"low and high must be non-empty and of the same length, "
                             f"got {lo.size} and {hi.size}")
        if not (np.all(np.isfinite(lo)) and np.all(np.isfinite(hi)) and np.all(lo < hi)):
            raise ValueError(f"need finite bounds with low < high, got {lo} and {hi}")
        if max_goals_per_region < 2 or window < 1 or n_cut_candidates < 1:
            raise ValueError("need max_goals_per_region >= 2, window >= 1, "
                             "n_cut_candidates >= 1")
        if not 0.0 < min_region_fraction < 0.5:
            raise ValueError(f"min_region_fraction must be in (0, 0.5), "
                             f"got {min_region_fraction}")
        if not 0.0 <= unexplored_interest <= 1.0:
            raise ValueError(f"unexplored_interest must be in [0, 1], got {unexplored_interest}")
        self.low, self.high = lo, hi
        self.max_goals_per_region = int(max_goals_per_region)
        self.window = int(window)
        self.n_cut_candidates = int(n_cut_candidates)
        self.min_region_fraction = float(min_region_fraction)
        self.unexplored_interest = float(unexplored_interest)
        self.measure = Progress(measure)
        self._min_width = (hi - lo) * self.min_region_fraction
        # Region tree, indexed by region id.
        self._low: list[np.ndarray] = [lo.copy()]
        self._high: list[np.ndarray] = [hi.copy()]
        self._parent: list[int] = [_NO_NODE]
        self._split_dim: list[int] = [_NO_NODE]
        self._split_value: list[float] = [0.0]
        self._left: list[int] = [_NO_NODE]
        self._right: list[int] = [_NO_NODE]
        self._leaves: dict[int, _Leaf] = {0: self._new_leaf()}
        self._leaf_ids: list[int] = [0]  # ascending; fixes the order leaves are sampled in
        self._n_goals = 0

    # ------------------------------------------------------------------ properties
    @property
    def dim(self) -> int:
        return int(self.low.size)

    @property
    def n_goals(self) -> int:
        """Goals recorded so far."""
        return self._n_goals

    @property
    def n_regions(self) -> int:
        """Leaves of the tree."""
        return len(self._leaf_ids)

    @property
    def interest(self) -> float:
        """Overall interest of the map: the mean of its leaves' interests (see class doc)."""
        return float(np.mean(self._interests()))

    # ------------------------------------------------------------------ updates
    def add(self, goal: Sequence[float] | np.ndarray, competence: float, iteration: int) -> None:
        """Record an attempted goal (clipped into the box) and the competence reached.

        Competence is clipped into [0, 1]; a non-finite goal or competence is an error.
        """
        g = np.asarray(goal, dtype=np.float64).reshape(-1)
        if g.size != self.dim or not np.all(np.isfinite(g)):
            raise ValueError(f"goal must be {self.dim} finite values, got {goal!r}")
        c = float(competence)
        if not np.isfinite(c):
            raise ValueError(f"competence must be finite, got {competence!r}")
        g = np.clip(g, self.low, self.high)
        node = self._leaf_of(g)
        leaf = self._leaves[node]
        leaf.goals.append(g)
        leaf.competences.append(min(max(c, 0.0), 1.0))
        leaf.iterations.append(int(iteration))
        leaf.sequence.append(self._n_goals)
        self._n_goals += 1
        self._refresh(leaf)
        if len(leaf.goals) > max(self.max_goals_per_region, leaf.next_split_at):
            self._try_split(node)

    def _leaf_of(self, goal: np.ndarray) -> int:
        node = 0
        while self._split_dim[node] != _NO_NODE:
            go_left = goal[self._split_dim[node]] < self._split_value[node]
            node = self._left[node] if go_left else self._right[node]
        return node

    def _new_leaf(self) -> _Leaf:
        leaf = _Leaf()
        self._refresh(leaf)
        return leaf

    def _refresh(self, leaf: _Leaf) -> None:
        if len(leaf.competences) < 2:
            leaf.interest = self.unexplored_interest
        else:
            leaf.interest = progress(leaf.competences, self.window, self.measure)

    def _try_split(self, node: int) -> None:
        leaf = self._leaves[node]
        goals = np.stack(leaf.goals)
        comps = np.asarray(leaf.competences, dtype=np.float64)
        cut = best_cut(goals, comps, self._low[node], self._high[node], window=self.window,
                       n_candidates=self.n_cut_candidates, min_width=self._min_width,
                       measure=self.measure)
        if cut is None:
            # Nothing admissible (goals piled up, region at minimum size): retry much later.
            leaf.next_split_at = len(leaf.goals) + self.max_goals_per_region
            return
        left_mask = goals[:, cut.dim] < cut.value
        ids = []
        for mask in (left_mask, ~left_mask):
            rid = len(self._low)
            low, high = self._low[node].copy(), self._high[node].copy()
            if mask is left_mask:
                high[cut.dim] = cut.value
            else:
                low[cut.dim] = cut.value
            self._append_node(node, low, high)
            idx = np.flatnonzero(mask)
            child = _Leaf([leaf.goals[i] for i in idx], [leaf.competences[i] for i in idx],
                          [leaf.iterations[i] for i in idx], [leaf.sequence[i] for i in idx])
            self._refresh(child)
            self._leaves[rid] = child
            ids.append(rid)
        self._split_dim[node], self._split_value[node] = cut.dim, cut.value
        self._left[node], self._right[node] = ids
        del self._leaves[node]
        self._leaf_ids.remove(node)
        self._leaf_ids.extend(ids)

    def _append_node(self, parent: int, low: np.ndarray, high: np.ndarray) -> None:
        self._low.append(low)
        self._high.append(high)
        self._parent.append(parent)
        self._split_dim.append(_NO_NODE)
        self._split_value.append(0.0)
        self._left.append(_NO_NODE)
        self._right.append(_NO_NODE)

    # ------------------------------------------------------------------ sampling
    def _interests(self) -> np.ndarray:
        return np.array([self._leaves[i].interest for i in self._leaf_ids], dtype=np.float64)

    def sample_goal(self, rng: np.random.Generator, *, epsilon: float = 0.2) -> np.ndarray:
        """A goal: uniform in the whole box with probability `epsilon`, else uniform in a leaf
        chosen in proportion to interest (uniformly if every interest is 0)."""
        if rng.random() < epsilon:
            return rng.uniform(self.low, self.high)
        k = select_index(self._interests(), rng, 0.0)
        rid = self._leaf_ids[k]
        return rng.uniform(self._low[rid], self._high[rid])

    # ------------------------------------------------------------------ views
    def leaves(self) -> list[RegionView]:
        """The current leaves, in ascending region id."""
        views = []
        for rid in self._leaf_ids:
            leaf = self._leaves[rid]
            parent = self._parent[rid]
            views.append(RegionView(rid, None if parent == _NO_NODE else parent,
                                    tuple(float(v) for v in self._low[rid]),
                                    tuple(float(v) for v in self._high[rid]),
                                    len(leaf.goals), float(leaf.interest)))
        return views

    # ------------------------------------------------------------------ persistence
    def params(self) -> dict[str, Any]:
        """Constructor arguments (JSON-serialisable)."""
        return {"low": self.low.tolist(), "high": self.high.tolist(),
                "max_goals_per_region": self.max_goals_per_region, "window": self.window,
                "n_cut_candidates": self.n_cut_candidates,
                "min_region_fraction": self.min_region_fraction,
                "unexplored_interest": self.unexplored_interest,
                "measure": self.measure.value}

    def state(self) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
        """(JSON-serialisable parameters, arrays) from which `from_state` rebuilds the map.
        Goals are listed in the order they were recorded, whatever leaf holds them now: a
        new goal lands at the end of the arrays and a split moves none, so a store that
        keeps only what a checkpoint adds writes only the new goals (one learning episode
        of the paper's maps records several goals of one iteration, and an order by leaf or
        by iteration alone changed at every split)."""
        meta = {"format": FORMAT, **self.params()}
        goals, comps, iters, region, seq = [], [], [], [], []
        split_at = np.zeros(len(self._low), dtype=np.int64)
        for rid in self._leaf_ids:
            leaf = self._leaves[rid]
            goals.extend(leaf.goals)
            comps.extend(leaf.competences)
            iters.extend(leaf.iterations)
            seq.extend(leaf.sequence)
            region.extend([rid] * len(leaf.goals))
            split_at[rid] = leaf.next_split_at
        order = np.argsort(np.array(seq, dtype=np.int64), kind="stable")
        goals = [goals[i] for i in order]
        comps = [comps[i] for i in order]
        iters = [iters[i] for i in order]
        region = [region[i] for i in order]
        arrays = {
            "node_low": np.array(self._low, dtype=np.float64),
            "node_high": np.array(self._high, dtype=np.float64),
            "node_parent": np.array(self._parent, dtype=np.int64),
            "node_split_dim": np.array(self._split_dim, dtype=np.int64),
            "node_split_value": np.array(self._split_value, dtype=np.float64),
            "node_left": np.array(self._left, dtype=np.int64),
            "node_right": np.array(self._right, dtype=np.int64),
            "node_next_split_at": split_at,
            "goals": (np.array(goals, dtype=np.float64) if goals
                      else np.zeros((0, self.dim), dtype=np.float64)),
            "competences": np.array(comps, dtype=np.float64),
            "iterations": np.array(iters, dtype=np.int64),
            "goal_region": np.array(region, dtype=np.int64),
        }
        return meta, arrays

    @classmethod
    def from_state(cls, meta: dict[str, Any], arrays: dict[str, np.ndarray]) -> InterestMap:
        """Rebuild a map saved by `state()`; it then behaves exactly like the saved one."""
        if meta.get("format") != FORMAT:
            raise ValueError(f"interest map state has format {meta.get('format')!r}, "
                             f"this version reads format {FORMAT}")
        params = {k: v for k, v in meta.items() if k != "format"}
        m = cls(params.pop("low"), params.pop("high"), **params)
        try:
            m._load_arrays(arrays)
        except (KeyError, IndexError, ValueError) as exc:
            raise ValueError(f"interest map state is inconsistent: {exc}") from exc
        return m

    def _load_arrays(self, a: dict[str, np.ndarray]) -> None:
        n_nodes = int(a["node_low"].shape[0])
        self._low = [np.array(r, dtype=np.float64) for r in a["node_low"]]
        self._high = [np.array(r, dtype=np.float64) for r in a["node_high"]]
        if n_nodes == 0 or any(r.shape != (self.dim,) for r in self._low + self._high):
            raise ValueError("node bounds do not match the map's dimension")
        self._parent = [int(v) for v in a["node_parent"]]
        self._split_dim = [int(v) for v in a["node_split_dim"]]
        self._split_value = [float(v) for v in a["node_split_value"]]
        self._left = [int(v) for v in a["node_left"]]
        self._right = [int(v) for v in a["node_right"]]
        if not all(len(x) == n_nodes for x in (self._parent, self._split_dim,
                                                 self._split_value, self._left, self._right)):
            raise ValueError("node arrays differ in length")
        self._leaf_ids = [i for i in range(n_nodes) if self._split_dim[i] == _NO_NODE]
        self._leaves = {i: _Leaf(next_split_at=int(a["node_next_split_at"][i]))
                        for i in self._leaf_ids}
        goals, comps = a["goals"], a["competences"]
        iters, region = a["iterations"], a["goal_region"]
        if not (len(goals) == len(comps) == len(iters) == len(region)):
            raise ValueError("goal arrays differ in length")
        for i, (g, c, it, rid) in enumerate(zip(goals, comps, iters, region, strict=True)):
            leaf = self._leaves[int(rid)]
            leaf.goals.append(np.array(g, dtype=np.float64))
            leaf.competences.append(float(c))
            leaf.iterations.append(int(it))
            leaf.sequence.append(i)
        for leaf in self._leaves.values():
            self._refresh(leaf)
        self._n_goals = int(len(goals))
