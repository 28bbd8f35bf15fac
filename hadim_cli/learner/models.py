"""Sensorimotor models of an affordance: forward M_A and inverse L_A over one set of rows.

An affordance maps an input x (a primitive action, or a change of a controllable space) in
context c (the values of its context spaces before acting, concatenated) to an outcome y (the
change of its output space). `LocalLinearModel` holds those rows and answers both directions:

- forward, M_A(x, c) → y: the k nearest rows in normalised (x, c), then a ridge-regularised,
  distance-weighted local linear fit y ≈ W·[x, c, 1] (the authors' code and explauto's
  "nearest neighbours + local least squares");
- inverse, L_A(y_goal[, c]) → x: the nearest recorded outcomes of the goal, one Newton step
  x_i + J_i⁺(y_goal − y_i) through the local Jacobian around each, every candidate checked with
  the forward model, the best kept.

Each space is normalised by one scalar (`SpaceScale`), so that distances weigh spaces equally
while the geometry inside a space is kept. Neighbour searches use a KD-tree (scipy's cKDTree:
exact like scikit-learn's, with ~5× less overhead per call) built over the rows known at the
last rebuild, plus the rows added since (the *buffer*); an index is rebuilt by `add` (never by
a query) when that buffer grows past max(64, 25 % of n) or when the scales have drifted. A
buffer of more than `_BUFFER_TREE` rows is searched through a KD-tree of its own, built when a
query finds it has grown (rows come in once per learning episode, and an evaluation adds none:
one build serves every query until the next add); that tree only proposes candidates, whose
distances are computed as a scan of the buffer computes them, so the answers are bit-identical
to the scan (`_brute_knn`, kept as the reference and used for small buffers; a query whose
answer takes buffer rows at or after an exact tie is answered by the scan).
Every local fit is vectorised over queries: one stacked `np.linalg.solve`. With fewer
neighbours than unknowns the fit drops the context slopes, then all slopes (the mean).

How many neighbours a forward fit takes can be chosen by the model's own rows (`k_choices`):
each time its rows have doubled (from `_CHOOSE_FROM`), the candidate that predicts its rows
best from other moments becomes its neighbourhood. Ten noisy pushes in contact fitted a slope
that sent a push 5° off the line 40° off in prediction, and a planner steering on that model
could not. Other moments: rows come in the order they were recorded, and the `MOMENT_ROWS`
stored just before and after a row — the actions around it, of the same pursuit — are left
out of its prediction (h-block cross-validation, Burman, Chow & Nolan 1994). Plain
leave-one-out predicts a row from those near-copies of itself, and so always chose the
smallest neighbourhood: the arm's effector model, 0.5 cm off its rows left out one by one,
is 2.0 cm off rows of other moments with 10 neighbours and 1.5 with 60.

Everything is deterministic; `state()` / `from_state()` rebuild a model answering bit-identically.

Micro-benchmark: ``python -m hadim_cli.learner.models``.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any, Protocol, runtime_checkable

import numpy as np
from scipy.spatial import cKDTree

SCALE_FLOOR = 1e-6
"""Smallest scale of a space: a constant space must not blow its rounding noise up."""
ROBUST_CUTOFF = 6.0
"""A neighbour whose residual is this many times the median residual of its local fit has no
weight in a robust refit (Cleveland's bisquare, 1979)."""
_ROBUST_FLOOR = 1e-3
"""Least residual scale of a robust refit, relative to the RMS of its neighbours' outcomes."""

_ZERO_REL = 1e-6
"""Rows of a change space whose norm is below this fraction of the largest are "zero"."""

_REBUILD_MIN = 64
_REBUILD_FRACTION = 0.25
"""An index is rebuilt when more than max(_REBUILD_MIN, _REBUILD_FRACTION·n) rows are unindexed."""
_DRIFT = 0.1
"""… or when any scale of its spaces has changed by more than this fraction since its build."""
_CHUNK = 1 << 21
"""Elements per chunk of the brute-force distance pass (bounds its memory)."""
_KEPT_ANSWERS = 16
"""Answers of `infer` a model keeps for questions asked again (until its next `add`)."""
_BUFFER_TREE = 48
"""Buffers of more rows than this are searched through a KD-tree of their own."""
_SLACK = 2
"""Extra candidates asked of a buffer's KD-tree: its distances may differ from the recomputed
ones in the last bit, so that near-ties at the k-th place still resolve as the scan's."""

_CHOOSE_FROM = 32
"""Rows from which a model with `k_choices` first chooses its forward neighbourhood; it
chooses again each time its rows have doubled since."""
MOMENT_ROWS = 8
"""Rows stored within this many of a row are of its moment (the actions just before and after
it), left out of its prediction when the neighbourhood is chosen (`LocalLinearModel._choose_k`):
one random-action sequence's length (`learner.random_sequence_length`'s default), a few
actions of a pursuit."""

_FORWARD, _INVERSE, _OUTCOME = "forward", "inverse", "outcome"
_INDEXES = (_FORWARD, _INVERSE, _OUTCOME)


# ---------------------------------------------------------------------------- scales
def rms_scale(values: np.ndarray, zero_eps: float = 0.0, floor: float = SCALE_FLOOR) -> float:
    """RMS norm of the rows of `values` whose norm exceeds `zero_eps` (at least `floor`)."""
    if values.size == 0:
        return floor
    sq = np.einsum("ij,ij->i", values, values)
    sq = sq[sq > zero_eps * zero_eps]
    if sq.size == 0:
        return floor
    return max(float(np.sqrt(sq.mean())), floor)


def spread_scale(values: np.ndarray, floor: float = SCALE_FLOOR) -> float:
    """RMS distance of the rows of `values` to their mean (at least `floor`)."""
    if values.shape[0] == 0 or values.shape[1] == 0:
        return floor
    dev = values - values.mean(axis=0)
    return max(float(np.sqrt(np.mean(np.einsum("ij,ij->i", dev, dev)))), floor)


@dataclass(frozen=True, eq=False)
class SpaceScale:
    """One scalar scale per space (group of consecutive columns).

    A *change* space (an input or an outcome: its origin means "nothing happened") is scaled by
    the RMS norm of its non-zero rows; a *state* space (a context: its origin is arbitrary) by
    the RMS distance of its rows to their mean. Either is at least `SCALE_FLOOR`.
    """

    dims: tuple[int, ...]
    """Number of columns of each space, in column order."""
    centred: tuple[bool, ...]
    """Per space: True for a state space (scaled by its spread), False for a change space."""
    values: np.ndarray
    """Per space: its scale, > 0."""

    @classmethod
    def fit(cls, data: np.ndarray, dims: Sequence[int], centred: Sequence[bool]) -> SpaceScale:
        """Scales of the column groups `dims` of `data` (rows × sum(dims))."""
        values = np.empty(len(dims))
        start = 0
        for g, (d, cen) in enumerate(zip(dims, centred, strict=True)):
            block = data[:, start:start + d]
            start += d
            if cen:
                values[g] = spread_scale(block)
            else:
                top = float(np.sqrt(np.einsum("ij,ij->i", block, block).max(initial=0.0)))
                values[g] = rms_scale(block, _ZERO_REL * top)
        return cls(tuple(int(d) for d in dims), tuple(bool(c) for c in centred), values)

    def per_column(self) -> np.ndarray:
        """The scale of each column (its space's scale repeated)."""
        return np.repeat(self.values, self.dims)

    def normalise(self, data: np.ndarray) -> np.ndarray:
        """`data` divided column-wise by its space's scale."""
        return data / self.per_column()

    def drift(self, other: SpaceScale) -> float:
        """Largest |log ratio| between the scales of the same spaces in `self` and `other`."""
        return float(np.max(np.abs(np.log(self.values / other.values)), initial=0.0))


# ---------------------------------------------------------------------------- results
@dataclass(frozen=True, eq=False)
class InverseResult:
    """The answer of the inverse model L_A to one goal."""

    x: np.ndarray
    """The input to apply (dx,), clipped to the input bounds if any."""
    y_predicted: np.ndarray
    """The forward model's prediction of the outcome of `x` (dy,)."""
    error: float
    """‖y_predicted − y_goal‖ divided by the output space's scale."""
    context: np.ndarray
    """The context (dc,) of the stored row the answer was built from: where `x` is known to
    work. The planner reaches it first when the current context differs."""
    neighbour_index: int
    """Index of that stored row in `data()`."""


@dataclass
class _Index:
    """A KD-tree over rows [0, n_built) of some normalised columns + brute force over the rest."""

    columns: np.ndarray
    """Columns of the model's data matrix it searches."""
    groups: np.ndarray
    """Indices (into the model's spaces) of the spaces of those columns."""
    scale: SpaceScale | None = None
    """Scales of the data at the last rebuild; queries and stored rows are divided by them."""
    tree: cKDTree | None = None
    n_built: int = -1
    """Rows in the tree (the rest are the brute-force buffer); -1 before the first build."""
    checked: int = 0
    """Buffer size at the last check for drifting scales."""
    buffer: np.ndarray = field(default_factory=lambda: np.empty((0, 0)))
    """Normalised rows [n_built, n_built + len) (a cache for the buffer's search)."""
    buffer_tree: cKDTree | None = None
    """A KD-tree over all of `buffer` (None: not built since the buffer last grew)."""


@dataclass(frozen=True)
class _LocalFit:
    """Local linear fits around Q queries: value (Q, dy) and dy/d(normalised inputs)."""

    value: np.ndarray
    slopes: np.ndarray
    """(Q, m, dy): slopes per normalised input column; zero for columns left out of the fit."""


# ---------------------------------------------------------------------------- the interface
@runtime_checkable
class Model(Protocol):
    """What the learner and the planner ask of an affordance's models: its rows, M_A, L_A and
    neighbour searches, all in room coordinates. `LocalLinearModel` is one;
    `frames.FramedModel` (fitted in the frame of a relation) another. Code outside the models
    uses these and nothing else (`frames.seen` reads a framed model's rows turned)."""

    dx: int
    dy: int
    context_dims: tuple[int, ...]
    dc: int

    @property
    def n(self) -> int: ...

    def params(self) -> dict[str, Any]: ...

    def add(self, x: np.ndarray, c: np.ndarray | None, y: np.ndarray) -> None: ...

    def data(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]: ...

    def scales(self) -> SpaceScale: ...

    def predict(self, x: np.ndarray, c: np.ndarray | None = None) -> np.ndarray: ...

    def predict_loo(self, indices: np.ndarray | Sequence[int] | None = None,
                    neighbours: int | None = None) -> np.ndarray: ...

    def infer(self, y_goal: np.ndarray, c: np.ndarray | None = None, *,
              n_candidates: int | None = None) -> InverseResult: ...

    def forward_neighbours(self, x: np.ndarray, c: np.ndarray | None = None,
                           k: int | None = None) -> tuple[np.ndarray, np.ndarray]: ...

    def inverse_neighbours(self, y: np.ndarray, c: np.ndarray | None = None,
                           k: int | None = None) -> tuple[np.ndarray, np.ndarray]: ...

    def state(self) -> dict[str, np.ndarray]: ...


# ---------------------------------------------------------------------------- the model
class LocalLinearModel:
    """Rows (x, c, y) of one affordance with its forward and inverse models.

    - `dx`, `dy`: dimensions of the input and output spaces;
    - `context_dims`: dimension of each context space, concatenated in that order in c
      (empty: no context);
    - `k_forward`: neighbours of a forward fit; `k_inverse`: stored outcomes tried by `infer`;
    - `k_choices`: neighbourhoods a forward fit may take instead of `k_forward`, the one of
      least leave-one-out error over the rows chosen whenever they have doubled (empty: always
      `k_forward`);
    - `ridge`: penalty on each local slope, relative to the neighbours' spread along it;
    - `x_low`, `x_high`: bounds of the input (e.g. the primitive action box), applied to the
      answers of `infer`;
    - `trust_radius`: longest inverse step, in units of the input space's scale;
    - `damping`: of the Jacobian pseudo-inverse, in normalised units;
    - `refine_steps`: extra Newton steps from the best inverse candidate;
    - `robust_iterations`: refits of each local fit with the neighbours' bisquare robustness
      weights (Cleveland's LOWESS): a neighbour whose residual exceeds `ROBUST_CUTOFF`
      times the median residual of its fit gets no weight, so a few rows unlike the rest
      (the robot blocked by a wall among free moves) no longer bend the fit; 0: plain fits.
    """

    def __init__(self, dx: int, dy: int, context_dims: Sequence[int] = (), *,
                 k_forward: int = 10, k_inverse: int = 20, ridge: float = 1e-3,
                 x_low: Sequence[float] | np.ndarray | None = None,
                 x_high: Sequence[float] | np.ndarray | None = None,
                 trust_radius: float = 0.5, damping: float = 1e-2, refine_steps: int = 1,
                 robust_iterations: int = 0, k_choices: Sequence[int] = ()):
        self.dx, self.dy = int(dx), int(dy)
        self.context_dims = tuple(int(d) for d in context_dims)
        if self.dx < 1 or self.dy < 1 or any(d < 1 for d in self.context_dims):
            raise ValueError(f"space dimensions must be ≥ 1, got dx={dx}, dy={dy}, "
                             f"context_dims={tuple(context_dims)}")
        if k_forward < 1 or k_inverse < 1:
            raise ValueError(f"k_forward and k_inverse must be ≥ 1, got {k_forward}, {k_inverse}")
        self.dc = sum(self.context_dims)
        self.k_forward, self.k_inverse = int(k_forward), int(k_inverse)
        self.k_choices = tuple(int(k) for k in k_choices)
        if any(k < 1 for k in self.k_choices):
            raise ValueError(f"k_choices must all be ≥ 1, got {self.k_choices}")
        self.k_fit = self.k_forward
        """Neighbours of a forward fit now (`k_forward` until `k_choices` chose one)."""
        self._chosen_at = _CHOOSE_FROM // 2
        """Rows at the last choice of `k_fit` (the next is made at twice as many)."""
        self.ridge, self.damping = float(ridge), float(damping)
        self.trust_radius, self.refine_steps = float(trust_radius), int(refine_steps)
        if robust_iterations < 0:
            raise ValueError(f"robust_iterations must be ≥ 0, got {robust_iterations}")
        self.robust_iterations = int(robust_iterations)
        self.x_low = None if x_low is None else np.asarray(x_low, dtype=np.float64).reshape(-1)
        self.x_high = None if x_high is None else np.asarray(x_high, dtype=np.float64).reshape(-1)
        for bound in (self.x_low, self.x_high):
            if bound is not None and bound.shape != (self.dx,):
                raise ValueError(f"input bounds must have {self.dx} values, got {bound.shape}")
        # Data matrix columns: [x | c | y]; spaces: x, each context, y.
        self._width = self.dx + self.dc + self.dy
        self._dims = (self.dx, *self.context_dims, self.dy)
        self._centred = (False, *([True] * len(self.context_dims)), False)
        self._data = np.empty((0, self._width))
        self._n = 0
        self._scale_cache: tuple[int, SpaceScale] | None = None
        self._answers: dict[tuple, Any] = {}
        """Recent answers of `predict` and `infer` by their arguments' bytes, least recently
        asked first, for the rows [0, `_answered_at`): the controller asks the same question
        again (every command from the same context, the inverse answer from the same
        observation), and the model only changes by `add` or an index rebuilt (which forget
        them)."""
        self._answered_at = 0
        n_spaces = len(self._dims)
        xc = np.arange(self.dx + self.dc)
        yc = np.concatenate([np.arange(self.dx + self.dc, self._width),
                             np.arange(self.dx, self.dx + self.dc)])
        self._indexes = {
            _FORWARD: _Index(xc, np.arange(n_spaces - 1)),
            _INVERSE: _Index(yc, np.r_[n_spaces - 1, np.arange(1, n_spaces - 1)]),
            _OUTCOME: _Index(np.arange(self.dx + self.dc, self._width), np.array([n_spaces - 1])),
        }

    # ------------------------------------------------------------------ data
    @property
    def n(self) -> int:
        """Number of stored rows."""
        return self._n

    def params(self) -> dict[str, Any]:
        """Constructor keyword arguments (besides the dimensions) of this model."""
        return {"k_forward": self.k_forward, "k_inverse": self.k_inverse, "ridge": self.ridge,
                "x_low": self.x_low, "x_high": self.x_high, "trust_radius": self.trust_radius,
                "damping": self.damping, "refine_steps": self.refine_steps,
                "robust_iterations": self.robust_iterations, "k_choices": self.k_choices}

    def add(self, x: np.ndarray, c: np.ndarray | None, y: np.ndarray) -> None:
        """Append a batch of rows: x (B, dx), c (B, dc) or None when dc = 0, y (B, dy)."""
        x = self._rows(x, self.dx, "x")
        b = x.shape[0]
        c = self._contexts(c, b)
        y = self._rows(y, self.dy, "y")
        if y.shape[0] != b:
            raise ValueError(f"x has {b} rows but y has {y.shape[0]}")
        rows = np.concatenate([x, c, y], axis=1)
        if not np.all(np.isfinite(rows)):
            raise ValueError("rows must be finite")
        if self._n + b > self._data.shape[0]:
            grown = np.empty((max(2 * self._data.shape[0], self._n + b, 64), self._width))
            grown[:self._n] = self._data[:self._n]
            self._data = grown
        self._data[self._n:self._n + b] = rows
        self._n += b
        # Index upkeep happens here, never at query time: the scales an index normalises with
        # then depend only on the sequence of adds, so asking the model (e.g. in an evaluation)
        # can never change what it answers later.
        for name in self._indexes:
            self._ensure(name)
        if self.k_choices and self._n >= 2 * self._chosen_at:
            self._choose_k()

    def _choose_k(self) -> None:
        """Take as `k_fit` the neighbourhood of `k_choices` whose forward fits predict the rows
        best from other moments (mean error; the first of equals): each row without the
        `MOMENT_ROWS` stored before and after it (see the module doc)."""
        y = self._data[:self._n, self.dx + self.dc:]
        errors = [float(np.mean(np.linalg.norm(self._loo(None, k, MOMENT_ROWS) - y, axis=1)))
                  for k in self.k_choices]
        self.k_fit = self.k_choices[int(np.argmin(errors))]
        self._chosen_at = self._n

    def data(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Views (X, C, Y) of the stored rows (read-only by convention)."""
        d = self._data[:self._n]
        return d[:, :self.dx], d[:, self.dx:self.dx + self.dc], d[:, self.dx + self.dc:]

    def scales(self) -> SpaceScale:
        """Scales of the spaces (x, each context, y) over the current data."""
        if self._scale_cache is None or self._scale_cache[0] != self._n:
            fitted = SpaceScale.fit(self._data[:self._n], self._dims, self._centred)
            self._scale_cache = (self._n, fitted)
        return self._scale_cache[1]

    # ------------------------------------------------------------------ forward model
    def predict(self, x: np.ndarray, c: np.ndarray | None = None) -> np.ndarray:
        """Forward model M_A: predicted outcomes (Q, dy) of inputs x (Q, dx) in contexts c."""
        x = self._rows(x, self.dx, "x")
        c = self._contexts(c, x.shape[0])
        key = ("predict", x.shape, x.tobytes(), c.tobytes())
        return self._remembered(key, lambda: self._fit_at(x, c).value).copy()

    def jacobian(self, x: np.ndarray, c: np.ndarray | None = None) -> np.ndarray:
        """Local dy/dx (Q, dy, dx) of the forward model at (x, c), from the same local fits."""
        return self._jacobian_of(self._fit_at(x, c))

    def predict_loo(self, indices: np.ndarray | Sequence[int] | None = None,
                    neighbours: int | None = None) -> np.ndarray:
        """Leave-one-out predictions (len(indices), dy) of stored rows (all rows by default),
        by forward fits of the model's own neighbourhood or of `neighbours`.

        Each row is left out of its own neighbourhood (if it has duplicates, they stay).
        """
        if self._n < 2:
            raise ValueError(f"leave-one-out needs at least 2 rows, the model has {self._n}")
        return self._loo(indices, self.k_fit if neighbours is None else neighbours)

    def _loo(self, indices: np.ndarray | Sequence[int] | None, k_fit: int,
             window: int = 0) -> np.ndarray:
        """`predict_loo` with forward fits of `k_fit` neighbours; with a `window`, the rows
        stored within it of a row are left out of its neighbourhood too, as long as enough
        others remain (they fill in, nearest first; the row itself never)."""
        idx = np.arange(self._n) if indices is None else np.asarray(indices, dtype=np.int64)
        if idx.size == 0:
            return np.empty((0, self.dy))
        z = self._data[idx][:, :self.dx + self.dc]
        k = min(k_fit, self._n - 1)
        if window <= 0:
            dist, nb = self._query(_FORWARD, z, k + 1)
            drop = nb == idx[:, None]
            drop[~drop.any(axis=1), -1] = True  # self not among the k+1 (duplicates): the last
            keep = ~drop
            dist, nb = dist[keep].reshape(idx.size, k), nb[keep].reshape(idx.size, k)
            return self._local_fit(z, dist, nb).value
        dist, nb = self._query(_FORWARD, z, min(k + 2 * window + 1, self._n))
        own = nb == idx[:, None]
        near = np.abs(nb - idx[:, None]) <= window
        # Others first (nearest first), then rows of the same moment, the row itself last.
        order = np.argsort(near.astype(np.int8) + 2 * own, axis=1, kind="stable")[:, :k]
        dist, nb = np.take_along_axis(dist, order, 1), np.take_along_axis(nb, order, 1)
        return self._local_fit(z, dist, nb).value

    def _fit_at(self, x: np.ndarray, c: np.ndarray | None) -> _LocalFit:
        self._require_data()
        x = self._rows(x, self.dx, "x")
        z = np.concatenate([x, self._contexts(c, x.shape[0])], axis=1)
        dist, nb = self._query(_FORWARD, z, min(self.k_fit, self._n))
        return self._local_fit(z, dist, nb)

    def _local_fit(self, z: np.ndarray, dist: np.ndarray, nb: np.ndarray) -> _LocalFit:
        """Weighted ridge fits of y ≈ b + W·(z_i − z) over neighbours `nb` of each query z."""
        q, k = nb.shape
        m = self.dx + self.dc
        inv = 1.0 / self._indexes[_FORWARD].scale.per_column()
        y_nb = self._data[nb, m:]
        if k >= m + 1:
            used = m            # a full fit in (x, c)
        elif k >= self.dx + 1:
            used = self.dx      # too few rows for the context too: slopes in x only
        else:
            used = 0            # under-determined: the weighted mean
        h = dist.max(axis=1, keepdims=True)
        w = np.exp(-np.square(dist / np.where(h > 0, h, 1.0)))
        a = np.empty((q, k, used + 1))
        a[:, :, 0] = 1.0
        a[:, :, 1:] = (self._data[nb, :used] - z[:, None, :used]) * inv[:used]
        theta = self._solve(a, w, y_nb, used)
        if self.robust_iterations and k > used + 1:
            # The residual scale floor keeps neighbours that a fit matches to rounding error
            # (duplicated rows) from making every other neighbour an outlier.
            floor = _ROBUST_FLOOR * np.maximum(
                np.sqrt(np.mean(np.square(y_nb), axis=(1, 2))), 1e-12)[:, None]
            for _ in range(self.robust_iterations):
                res = np.linalg.norm(np.matmul(a, theta) - y_nb, axis=2)
                s = np.maximum(np.median(res, axis=1, keepdims=True), floor)
                u = np.minimum(res / (ROBUST_CUTOFF * s), 1.0)
                # A vanishing (not null) weight keeps every fit well posed.
                theta = self._solve(a, w * np.maximum(np.square(1.0 - np.square(u)), 1e-6),
                                    y_nb, used)
        slopes = np.zeros((q, m, self.dy))
        slopes[:, :used] = theta[:, 1:]
        return _LocalFit(theta[:, 0], slopes)

    def _solve(self, a: np.ndarray, w: np.ndarray, y_nb: np.ndarray, used: int) -> np.ndarray:
        """The weighted ridge solution θ (Q, used + 1, dy) of y ≈ a·θ over each query's
        neighbours."""
        aw = a * w[:, :, None]
        gram = np.matmul(aw.transpose(0, 2, 1), a)
        rhs = np.matmul(aw.transpose(0, 2, 1), y_nb)
        diag = np.arange(1, used + 1)
        if used:  # each slope's penalty relative to its own spread: ridge bounds conditioning
            d = gram[:, diag, diag]
            d += self.ridge * d + 1e-9 * d.mean(axis=1, keepdims=True) + 1e-12
            gram[:, diag, diag] = d
        return np.linalg.solve(gram, rhs)

    def _jacobian_of(self, fit: _LocalFit) -> np.ndarray:
        sx = self._indexes[_FORWARD].scale.values[0]
        return fit.slopes[:, :self.dx].transpose(0, 2, 1) / sx

    # ------------------------------------------------------------------ inverse model
    def infer(self, y_goal: np.ndarray, c: np.ndarray | None = None, *,
              n_candidates: int | None = None) -> InverseResult:
        """Inverse model L_A: an input expected to produce the outcome `y_goal`.

        With a context `c` the stored outcomes are searched in (y, c), and candidates are
        scored in `c`; without, in y alone, each candidate scored in its neighbour's context.
        """
        self._require_data()
        key = ("infer", np.asarray(y_goal, dtype=np.float64).tobytes(),
               None if c is None else np.asarray(c, dtype=np.float64).tobytes(), n_candidates)
        known = self._remembered(key, lambda: self._infer(y_goal, c, n_candidates))
        return InverseResult(known.x.copy(), known.y_predicted.copy(), known.error,
                             known.context.copy(), known.neighbour_index)

    def _remembered(self, key: tuple, answer: Callable[[], Any]) -> Any:
        """The answer to the question `key`: the one remembered, else `answer()` (remembered;
        the least recently asked of `_KEPT_ANSWERS` forgotten)."""
        if self._answered_at != self._n:
            self._answers.clear()
            self._answered_at = self._n
        known = self._answers.pop(key, None)
        if known is None:
            known = answer()
            if len(self._answers) >= _KEPT_ANSWERS:
                self._answers.pop(next(iter(self._answers)))
        self._answers[key] = known
        return known

    def _infer(self, y_goal: np.ndarray, c: np.ndarray | None, n_candidates: int | None
               ) -> InverseResult:
        goal = self._rows(y_goal, self.dy, "y_goal")[0]
        k = min(n_candidates or self.k_inverse, self._n)
        ctx = self._contexts(c, 1) if c is not None and self.dc else None
        name = _OUTCOME if self.dc and ctx is None else _INVERSE
        query = goal[None] if ctx is None else np.concatenate([goal[None], ctx], axis=1)
        nb = self._query(name, query, k)[1][0]
        sy = self._indexes[name].scale.values[-1]
        rows = self._data[nb]
        x_i, c_i, y_i = rows[:, :self.dx], rows[:, self.dx:self.dx + self.dc], rows[:, -self.dy:]
        at_rows = self._fit_at(x_i, c_i)
        moved = self._clip(x_i + self._newton_steps(at_rows, goal - y_i, sy))
        cand = np.concatenate([moved, x_i])
        if ctx is None:  # the fits at the stored rows score the x_i candidates already
            cand_c = np.tile(c_i, (2, 1))
            fit = self._fit_at(moved, c_i)
            fit = _LocalFit(np.concatenate([fit.value, at_rows.value]),
                            np.concatenate([fit.slopes, at_rows.slopes]))
        else:
            cand_c = np.repeat(ctx, cand.shape[0], axis=0)
            fit = self._fit_at(cand, cand_c)
        err = np.linalg.norm(fit.value - goal, axis=1) / sy
        best = int(np.argmin(err))
        x_best, e_best = cand[best], float(err[best])
        best_fit = _LocalFit(fit.value[best:best + 1], fit.slopes[best:best + 1])
        for _ in range(self.refine_steps):
            step = self._newton_steps(best_fit, goal - best_fit.value, sy)[0]
            x_new = self._clip(x_best + step)
            new_fit = self._fit_at(x_new[None], cand_c[best:best + 1])
            e_new = float(np.linalg.norm(new_fit.value[0] - goal) / sy)
            if not e_new < e_best:
                break
            x_best, e_best, best_fit = x_new, e_new, new_fit
        chosen = int(nb[best % k])
        return InverseResult(x_best.copy(), best_fit.value[0].copy(), e_best,
                             self._data[chosen, self.dx:self.dx + self.dc].copy(), chosen)

    def _newton_steps(self, fit: _LocalFit, gap: np.ndarray, sy: float) -> np.ndarray:
        """Damped Gauss-Newton steps Δx = J⁺·gap, at most `trust_radius` input scales long."""
        sx = self._indexes[_FORWARD].scale.values[0]
        jn = fit.slopes[:, :self.dx].transpose(0, 2, 1) / sy       # (Q, dy, dx) normalised
        jt = jn.transpose(0, 2, 1)
        lhs = np.matmul(jt, jn) + self.damping * np.eye(self.dx)
        step = np.linalg.solve(lhs, np.matmul(jt, (gap / sy)[:, :, None]))[:, :, 0]
        length = np.linalg.norm(step, axis=1, keepdims=True)
        step *= np.minimum(1.0, self.trust_radius / np.maximum(length, 1e-300))
        return step * sx

    def _clip(self, x: np.ndarray) -> np.ndarray:
        if self.x_low is not None:
            x = np.maximum(x, self.x_low)
        if self.x_high is not None:
            x = np.minimum(x, self.x_high)
        return x

    # ------------------------------------------------------------------ neighbour search
    def forward_neighbours(self, x: np.ndarray, c: np.ndarray | None = None,
                           k: int | None = None) -> tuple[np.ndarray, np.ndarray]:
        """(distances, indices), each (Q, k), of the nearest rows in normalised (x, c)."""
        self._require_data()
        x = self._rows(x, self.dx, "x")
        z = np.concatenate([x, self._contexts(c, x.shape[0])], axis=1)
        return self._query(_FORWARD, z, min(k or self.k_forward, self._n))

    def inverse_neighbours(self, y: np.ndarray, c: np.ndarray | None = None,
                           k: int | None = None) -> tuple[np.ndarray, np.ndarray]:
        """(distances, indices), each (Q, k), of the nearest rows in normalised y or (y, c)."""
        self._require_data()
        y = self._rows(y, self.dy, "y")
        k = min(k or self.k_inverse, self._n)
        if c is None or self.dc == 0:
            return self._query(_INVERSE if self.dc == 0 else _OUTCOME, y, k)
        return self._query(_INVERSE, np.concatenate([y, self._contexts(c, y.shape[0])], 1), k)

    def index_scale(self, which: str = _FORWARD) -> SpaceScale | None:
        """The scales an index ("forward", "inverse", "outcome") normalises with (None if not
        built yet); they are the scales of the data at its last rebuild."""
        return self._indexes[which].scale

    def rebuild(self) -> None:
        """Rebuild every index that has been built, over all rows with the current scales."""
        for name, index in self._indexes.items():
            if index.n_built >= 0:
                self._build(name, self._n)

    def _query(self, name: str, z_raw: np.ndarray, k: int) -> tuple[np.ndarray, np.ndarray]:
        """k nearest rows of raw queries `z_raw` (columns of index `name`): tree ∪ buffer."""
        index = self._ensure(name)
        col_scale = index.scale.per_column()[index.columns]
        zq = z_raw / col_scale
        k_tree = min(k, index.n_built)
        dist, nb = index.tree.query(zq, k=k_tree)
        dist, nb = dist.reshape(-1, k_tree), nb.reshape(-1, k_tree).astype(np.int64, copy=False)
        if index.n_built == self._n:
            return dist, nb
        buf = self._buffer(index, col_scale)
        k_buf = min(k, buf.shape[0])
        if buf.shape[0] <= _BUFFER_TREE:
            b_dist, b_nb = _brute_knn(zq, buf, k_buf)
            return _merge(dist, nb, b_dist, b_nb + index.n_built, k)
        if index.buffer_tree is None:
            index.buffer_tree = cKDTree(buf)
        b_dist, b_nb, tie = _tree_knn(zq, buf, index.buffer_tree, k_buf)
        out_dist, out_nb = _merge(dist, nb, b_dist, b_nb + index.n_built, k)
        # The answer takes the buffer's `used` nearest; the scan orders exactly tied rows
        # otherwise than the tree's candidates, which matters only where the tie reaches them.
        used = np.count_nonzero(out_nb >= index.n_built, axis=1)
        redo = np.flatnonzero(tie < used)
        if redo.size:
            b_dist, b_nb = _brute_knn(zq[redo], buf, k_buf)
            out_dist[redo], out_nb[redo] = _merge(dist[redo], nb[redo], b_dist,
                                                  b_nb + index.n_built, k)
        return out_dist, out_nb

    def _buffer(self, index: _Index, col_scale: np.ndarray) -> np.ndarray:
        """Normalised rows [n_built, n) of the index's columns, extended as rows come in."""
        have = index.buffer.shape[0]
        if index.n_built + have < self._n:
            new = self._data[index.n_built + have:self._n][:, index.columns] / col_scale
            index.buffer = np.concatenate([index.buffer, new])
            index.buffer_tree = None
        return index.buffer

    def _ensure(self, name: str) -> _Index:
        index = self._indexes[name]
        buffer = self._n - index.n_built
        stale = index.n_built < 0 or buffer > max(_REBUILD_MIN, _REBUILD_FRACTION * self._n)
        # Scales move slowly: look for drift each time 1/32 more rows have come in.
        if not stale and buffer - index.checked >= max(1, index.n_built // 32):
            index.checked = buffer
            g = index.groups
            ratio = self.scales().values[g] / index.scale.values[g]
            stale = float(np.max(np.abs(np.log(ratio)))) > np.log1p(_DRIFT)
        if stale:
            self._build(name, self._n)
        return index

    def _build(self, name: str, n_rows: int, checked: int = 0) -> None:
        index = self._indexes[name]
        scale = SpaceScale.fit(self._data[:n_rows], self._dims, self._centred)
        index.scale = scale
        pts = self._data[:n_rows][:, index.columns] / scale.per_column()[index.columns]
        index.tree = cKDTree(pts)
        index.buffer = np.empty((0, index.columns.size))
        index.buffer_tree = None
        index.n_built, index.checked = n_rows, checked
        self._answers.clear()

    # ------------------------------------------------------------------ state
    def state(self) -> dict[str, np.ndarray]:
        """Arrays from which `from_state` rebuilds a model answering bit-identically."""
        x, c, y = self.data()
        empty = np.empty(0)
        return {
            "x": x.copy(), "c": c.copy(), "y": y.copy(),
            "dims": np.array([self.dx, self.dy, *self.context_dims], dtype=np.int64),
            "k": np.array([self.k_forward, self.k_inverse, self.refine_steps,
                           self.robust_iterations, self.k_fit, self._chosen_at], dtype=np.int64),
            "k_choices": np.array(self.k_choices, dtype=np.int64),
            "reals": np.array([self.ridge, self.trust_radius, self.damping]),
            "x_low": empty if self.x_low is None else self.x_low.copy(),
            "x_high": empty if self.x_high is None else self.x_high.copy(),
            "built": np.array([[self._indexes[n].n_built, self._indexes[n].checked]
                               for n in _INDEXES], dtype=np.int64),
        }

    @classmethod
    def from_state(cls, state: dict[str, np.ndarray], **params: Any) -> LocalLinearModel:
        """Rebuild a model saved by `state()`; `params` override the saved keyword parameters
        (dimensions always come from the state)."""
        if "frame" in state:
            raise ValueError("this model state has a frame: it is a FramedModel's")
        dims = [int(d) for d in state["dims"]]
        saved = cls.saved_params(state)
        saved.update(params)
        choices = saved.pop("k_choices", ())
        model = cls(dims[0], dims[1], dims[2:], **saved)  # no choice while the rows come back
        if state["x"].shape[0]:
            model.add(state["x"], state["c"], state["y"])
        model.restore_indexes(state["built"])
        model.restore_choice(choices, state)
        return model

    def restore_choice(self, choices: Sequence[int], state: dict[str, np.ndarray]) -> None:
        """Take back the neighbourhood `state()` saved as chosen, and the `choices` to choose
        among from then on."""
        self.k_choices = tuple(int(k) for k in choices)
        k = state["k"]
        self._answers.clear()
        # States saved before neighbourhoods were chosen hold four values or fewer.
        if k.size > 5:
            self.k_fit, self._chosen_at = int(k[4]), int(k[5])

    @staticmethod
    def saved_params(state: dict[str, np.ndarray]) -> dict[str, Any]:
        """The keyword parameters saved in a `state()`."""
        k, reals = state["k"], state["reals"]
        return {
            "k_forward": int(k[0]), "k_inverse": int(k[1]), "refine_steps": int(k[2]),
            # States saved before robust fits existed hold three values.
            "robust_iterations": int(k[3]) if k.size > 3 else 0,
            "ridge": float(reals[0]), "trust_radius": float(reals[1]), "damping": float(reals[2]),
            "x_low": state["x_low"] if state["x_low"].size else None,
            "x_high": state["x_high"] if state["x_high"].size else None,
            "k_choices": tuple(int(v) for v in state.get("k_choices", ())),
        }

    def restore_indexes(self, built: np.ndarray) -> None:
        """Rebuild each index over the rows it held when `state()` saved `built` (its "built"
        array): the next adds then rebuild them exactly when the saved model would have."""
        for name, (n_built, checked) in zip(_INDEXES, built, strict=True):
            if n_built >= 0:
                self._build(name, int(n_built), int(checked))

    # ------------------------------------------------------------------ helpers
    def _require_data(self) -> None:
        if self._n == 0:
            raise ValueError("the model holds no data yet")

    @staticmethod
    def _rows(a: np.ndarray, d: int, name: str) -> np.ndarray:
        return as_rows(a, d, name)

    def _contexts(self, c: np.ndarray | None, q: int) -> np.ndarray:
        if self.dc == 0:
            if c is not None and np.asarray(c).size:
                raise ValueError("this model has no context space, but a context was given")
            return np.empty((q, 0))
        if c is None:
            raise ValueError(f"this model needs a context of {self.dc} columns")
        return as_rows(c, self.dc, "c", q)


def as_rows(a: np.ndarray, d: int, name: str, q: int | None = None) -> np.ndarray:
    """`a` as a float matrix of `d` columns (a vector is one row); with `q`, exactly `q` rows,
    a single row repeated. Raises ValueError naming `name` otherwise."""
    a = np.asarray(a, dtype=np.float64)
    if a.ndim == 1:
        a = a[None]
    if a.ndim != 2 or a.shape[1] != d:
        raise ValueError(f"{name} must have {d} columns, got shape {a.shape}")
    if q is not None and a.shape[0] != q:
        if a.shape[0] != 1:
            raise ValueError(f"expected {q} rows of {name}, got {a.shape[0]}")
        a = np.repeat(a, q, axis=0)
    return a


def _brute_knn(q: np.ndarray, pts: np.ndarray, k: int) -> tuple[np.ndarray, np.ndarray]:
    """Exact k nearest rows of `pts` for each row of `q`, sorted by distance (chunked)."""
    n_q, n_p = q.shape[0], pts.shape[0]
    dist = np.empty((n_q, k))
    idx = np.empty((n_q, k), dtype=np.int64)
    step = max(1, _CHUNK // max(1, n_p * max(1, q.shape[1])))
    for lo in range(0, n_q, step):
        diff = q[lo:lo + step, None, :] - pts[None, :, :]
        d2 = np.einsum("qpd,qpd->qp", diff, diff)
        part = np.argpartition(d2, k - 1, axis=1)[:, :k] if k < n_p else \
            np.broadcast_to(np.arange(n_p), d2.shape)
        rows = np.arange(d2.shape[0])[:, None]
        d_part = d2[rows, part]
        order = np.argsort(d_part, axis=1, kind="stable")
        idx[lo:lo + step] = part[rows, order]
        dist[lo:lo + step] = np.sqrt(d_part[rows, order])
    return dist, idx


def _merge(dist: np.ndarray, nb: np.ndarray, b_dist: np.ndarray, b_nb: np.ndarray, k: int
           ) -> tuple[np.ndarray, np.ndarray]:
    """The k nearest of a tree's answer (`dist`, `nb`) and a buffer's, the tree's first among
    equal distances."""
    dist = np.concatenate([dist, b_dist], axis=1)
    nb = np.concatenate([nb, b_nb], axis=1)
    order = np.argsort(dist, axis=1, kind="stable")[:, :k]
    rows = np.arange(order.shape[0])[:, None]
    return dist[rows, order], nb[rows, order]


def _tree_knn(q: np.ndarray, pts: np.ndarray, tree: cKDTree, k: int
              ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The k nearest rows of `pts` by `tree` (over `pts`), and per query the first place
    j < k whose row is exactly as far as the next (k if none): where the answer may differ from
    `_brute_knn(q, pts, k)`'s. The tree proposes its k + `_SLACK` nearest, whose distances are
    then computed as `_brute_knn` computes them, so the answer is the scan's bit for bit up to
    that place. Rows at exactly equal distances (duplicated rows are common: an object that did
    not move) come out of `_brute_knn` in the order its partition leaves them, which only a
    scan of all rows reproduces: the distances are the scan's, and so are the rows before the
    tie's place; a caller that uses more of a query's rows asks the scan (`_query`)."""
    n_q = q.shape[0]
    kc = min(k + _SLACK, pts.shape[0])
    cand = tree.query(q, k=kc)[1].reshape(n_q, kc)
    near = pts[cand]
    if pts.strides[0] < pts.strides[1]:
        # `pts` column-major (a buffer is: rows gathered by column), so `_brute_knn`'s
        # differences are too, and einsum sums each row's squares in another order than over
        # row-major ones: the candidates take the same layout, for the same roundings.
        near = np.ascontiguousarray(near.transpose(0, 2, 1)).transpose(0, 2, 1)
    diff = q[:, None, :] - near
    d2 = np.einsum("qpd,qpd->qp", diff, diff)
    order = np.argsort(d2, axis=1, kind="stable")[:, :k + 1]
    rows = np.arange(n_q)[:, None]
    d2, cand = d2[rows, order], cand[rows, order]
    dist, idx = np.sqrt(d2[:, :k]), cand[:, :k]
    equal = d2[:, 1:] == d2[:, :-1]
    tie = np.where(equal.any(axis=1), np.argmax(equal, axis=1), k)
    return dist, idx, tie


def _benchmark() -> None:  # pragma: no cover, no mutate block - manual timing, not behaviour
    import time

    rng = np.random.default_rng(0)
    a, b = rng.normal(size=(2, 2)), rng.normal(size=(2, 2))
    x, c = rng.uniform(-1, 1, (5000, 2)), rng.uniform(-1, 1, (5000, 2))
    y = x @ a.T + c @ b.T
    model = LocalLinearModel(2, 2, [2])
    t = time.perf_counter()
    model.add(x, c, y)
    model.predict(x[:1], c[:1])
    print(f"add 5000 rows + build forward index: {1e3 * (time.perf_counter() - t):.2f} ms")
    q = rng.uniform(-1, 1, (1000, 2))
    t = time.perf_counter()
    model.predict(q, q)
    print(f"predict 1000 queries on 5000 rows: {1e3 * (time.perf_counter() - t):.2f} ms")
    t = time.perf_counter()
    model.predict_loo()
    print(f"predict_loo over 5000 rows: {1e3 * (time.perf_counter() - t):.2f} ms")
    model.infer(y[0], c[0])
    model.infer(y[0])
    t = time.perf_counter()
    for i in range(200):
        model.infer(y[i], c[i])
    print(f"infer with context: {1e3 * (time.perf_counter() - t) / 200:.3f} ms/goal")
    t = time.perf_counter()
    for i in range(200):
        model.infer(y[i])
    print(f"infer without context: {1e3 * (time.perf_counter() - t) / 200:.3f} ms/goal")
    t = time.perf_counter()
    for i in range(2000):
        model.add(x[i:i + 1], c[i:i + 1], y[i:i + 1])
        model.predict(x[i:i + 1], c[i:i + 1])
    print(f"add 1 row + predict 1 (amortised rebuilds): "
          f"{1e3 * (time.perf_counter() - t) / 2000:.3f} ms")


if __name__ == "__main__":  # pragma: no cover
    _benchmark()
