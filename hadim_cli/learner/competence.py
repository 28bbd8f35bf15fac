"""Competence of a model: pure functions (learning progress is `interest.learning_progress`).

Competence scores how well a forward model predicts outcomes it has *not* been fitted on
(leave-one-out over its rows; the authors' code scored in-sample predictions). An error is
normalised by the scale of the output space (the RMS norm of its non-zero outcomes) and mapped
through the authors' C(e) = clip((1 − e²)·exp(−sharpness·e), 0, 1). Rows where nothing moved
and rows where something moved are scored separately and the two scores averaged, so that a
model of "nothing ever moves" cannot look competent.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from hadim_cli.learner.models import Model, rms_scale


@dataclass(frozen=True)
class CompetenceReport:
    """Held-out competence of a model, overall and per kind of outcome."""

    competence: float
    """Mean of the two group scores (weighted by `zero_weight`; the present one alone if one
    is absent; 0 without any non-zero outcome). In [0, 1]."""
    nonzero_competence: float
    """Mean C(e) over evaluated rows whose outcome is non-zero (0 when there are none)."""
    zero_competence: float
    """Mean C(e) over evaluated rows whose outcome is (near) zero (0 when there are none)."""
    n_nonzero: int
    """Evaluated rows with a non-zero outcome."""
    n_zero: int
    """Evaluated rows with a (near) zero outcome."""


def competence_of_error(e: np.ndarray | float, sharpness: float = 20.0) -> np.ndarray:
    """C(e) = clip((1 − e²)·exp(−sharpness·e), 0, 1), elementwise, for normalised errors e ≥ 0.

    C(0) = 1, decreasing in e, 0 from e = 1 on.
    """
    e = np.asarray(e, dtype=np.float64)
    return np.clip((1.0 - e * e) * np.exp(-sharpness * e), 0.0, 1.0)


def normalised_errors(y_hat: np.ndarray, y: np.ndarray, scale: float) -> np.ndarray:
    """‖ŷ − y‖ / scale for each row."""
    return np.linalg.norm(np.asarray(y_hat) - np.asarray(y), axis=-1) / scale


def split_zero(y: np.ndarray, eps: float) -> np.ndarray:
    """Mask of the rows of `y` whose outcome is (near) zero: ‖y‖ ≤ eps."""
    return np.linalg.norm(np.asarray(y), axis=-1) <= eps


def evaluation_rows(zero: np.ndarray, max_rows: int | None,
                    rng: np.random.Generator | None) -> np.ndarray:
    """Rows to evaluate: all, or at most `max_rows` split evenly between the two groups.

    A group with fewer rows than its half gives its share to the other. The draw is random
    (without replacement) from `rng`, or evenly spaced without one; sorted either way.
    """
    n = zero.shape[0]
    if max_rows is None or n <= max_rows:
        return np.arange(n)
    groups = [np.flatnonzero(~zero), np.flatnonzero(zero)]
    first = min(groups[0].size, max(max_rows // 2, max_rows - groups[1].size, 1))
    picked = []
    for group, size in zip(groups, (first, max_rows - first), strict=True):
        if rng is None:
            take = group[np.linspace(0, group.size - 1, size).round().astype(np.int64)]
        else:
            take = rng.choice(group, size=size, replace=False)
        picked.append(take)
    return np.sort(np.concatenate(picked))


def model_competence(model: Model, *, zero_eps: float, sharpness: float = 20.0,
                     max_rows: int | None = None, rng: np.random.Generator | None = None,
                     zero_weight: float = 0.5, scale: float | None = None,
                     neighbours: int | None = None) -> CompetenceReport:
    """Held-out competence of `model`'s forward model (see the module docstring).

    `zero_eps`: outcomes with ‖y‖ ≤ zero_eps count as "nothing moved". `max_rows`: evaluate
    on at most that many rows (drawn by `evaluation_rows`, deterministic given `rng`).
    `zero_weight`: weight of the zero-outcome score when both groups are present (0.5: their
    mean). Note that with 0.5 a model that only knows when nothing moves still scores ≈ 0.5.
    `scale`: the length errors are divided by (default: the RMS norm of the non-zero outputs;
    `range_scale` gives the width of the space's range instead). `neighbours`: the forward
    fits' neighbourhood (default: the model's own).
    """
    _, _, y = model.data()
    zero = split_zero(y, zero_eps)
    if model.n < 2 or zero.all():
        return CompetenceReport(0.0, 0.0, 0.0, int((~zero).sum()), int(zero.sum()))
    rows = evaluation_rows(zero, max_rows, rng)
    if scale is None:
        scale = rms_scale(y[~zero])
    c = competence_of_error(normalised_errors(model.predict_loo(rows, neighbours), y[rows],
                                              scale), sharpness)
    z = zero[rows]
    n_zero, n_nonzero = int(z.sum()), int((~z).sum())
    nonzero_c = float(c[~z].mean()) if n_nonzero else 0.0
    zero_c = float(c[z].mean()) if n_zero else 0.0
    if n_nonzero and n_zero:
        overall = (1.0 - zero_weight) * nonzero_c + zero_weight * zero_c
    else:
        overall = nonzero_c if n_nonzero else 0.0
    return CompetenceReport(overall, nonzero_c, zero_c, n_nonzero, n_zero)


def range_scale(y: np.ndarray, zero_eps: float, quantile: float = 0.95) -> float:
    """Width of an output space's range: twice a high quantile of its non-null norms."""
    norms = np.linalg.norm(y, axis=1)
    norms = norms[norms > zero_eps]
    return 2.0 * float(np.quantile(norms, quantile)) if norms.size else 1.0


ERROR_QUANTILES = (50, 90, 99, 100)
"""Percentiles of `held_out_errors` (100: the largest)."""


def held_out_errors(model: Model) -> dict[str, float] | None:
    """The forward model's error on each of its own rows, left out of its own fit: the
    distance (in the output's units) between what it predicts for a row it never saw and what
    happened, as percentiles (`ERROR_QUANTILES`) over all rows; None under two rows."""
    if model.n < 2:
        return None
    _, _, y = model.data()
    e = np.linalg.norm(model.predict_loo() - y, axis=1)
    values = np.percentile(e, ERROR_QUANTILES)
    return {f"p{q}" if q < 100 else "max": float(v) for q, v in zip(ERROR_QUANTILES, values,
                                                                    strict=True)}
