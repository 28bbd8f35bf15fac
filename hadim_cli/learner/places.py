"""Where an affordance acts from: the context in which its data show a wanted outcome.

A push moves an object only from behind it; a tool moves the target only from the target's
far side. `needed_context` reads that place off the affordance's own rows: among the rows
whose outcome is nearest the one wanted (and whose fixed contexts, e.g. the object's radius,
are nearest the current ones), the value of the driven contexts (a relation such as
target-robot) where most of them agree — a kernel density mode, so that one push seen from
an odd place does not decide — fitted at the wanted outcome by a weighted linear fit. Rows
are first turned so that each outcome points along the one wanted (`frames.seen_where`), and
seen in a mirror across its line as well: round bodies behave the same on either side, so the
place fitted over both sides lies on the line.
"""

from __future__ import annotations

import numpy as np

from hadim_cli.learner.affordance import Affordance
from hadim_cli.learner.frames import is_vector, seen_where, turns_with_scene
from hadim_cli.world.layout import VISUAL_PROPERTIES


def context_slices(aff: Affordance) -> list[slice]:
    """The columns of each context space of `aff` in its context vectors."""
    out, offset = [], 0
    for dim in aff.model.context_dims:
        out.append(slice(offset, offset + dim))
        offset += dim
    return out


def needed_context(aff: Affordance, delta: np.ndarray, c: np.ndarray, driven: np.ndarray,
                   *, zero_eps: float, k: int, support: float, agreement: float
                   ) -> tuple[np.ndarray, np.ndarray | None]:
    """`c` with the columns of the context spaces `driven` (a mask over `aff.contexts`)
    replaced by the values from which `aff` usually produces the outcome `delta`, and the
    input those rows moved by (fitted like the place; None when the input is no 2-D vector
    of the room, e.g. the primitive action).

    `k`: rows voted over; `support`: relations further apart than this (in the model's
    scale) vote apart; `agreement`: rows within this of the densest relation are fitted."""
    _, x, ctx, y = seen_where(aff.model, zero_eps, along=delta)
    moves = is_vector(aff.input) and x.shape[1] == 2
    copies = 1
    mirrored = _mirrored(aff, ctx, y, delta)
    if mirrored is not None:
        ctx, y, flip = mirrored
        x = np.concatenate([x, x @ flip]) if moves else x
        copies = 2
    scale = aff.model.scales().per_column()
    x_cols = aff.model.dx
    ctx_scale = scale[x_cols:x_cols + ctx.shape[1]]
    y_scale = scale[x_cols + ctx.shape[1]:]
    free = np.repeat(driven, aff.model.context_dims)
    query = np.concatenate([(y - delta) / y_scale, ((ctx - c) / ctx_scale)[:, ~free]], 1)
    k = min(k * copies, max(3, y.shape[0] // 4), y.shape[0])
    dist2 = np.einsum("ij,ij->i", query, query)
    near = np.sort(np.argpartition(dist2, k - 1)[:k])
    closeness = np.exp(-dist2[near] / max(float(np.median(dist2[near])), 1e-12))
    rel = ctx[near][:, free] / ctx_scale[free]
    d2 = np.sum((rel[:, None, :] - rel[None, :, :]) ** 2, axis=2)
    votes = np.exp(-d2 / (2 * support) ** 2) @ closeness
    best = int(np.argmax(closeness * votes))
    weights = closeness * (d2[best] <= agreement ** 2)
    needed = c.copy()
    needed[free] = _fit_at((y[near] - delta) / y_scale, ctx[near][:, free], weights)
    if not moves or x.shape[0] != y.shape[0]:
        return needed, None
    return needed, _fit_at((y[near] - delta) / y_scale, x[near], weights)


def _fit_at(dy: np.ndarray, rel: np.ndarray, w: np.ndarray) -> np.ndarray:
    """The relation at the wanted outcome: the intercept of a weighted linear fit
    rel ≈ a + B·dy over rows with outcome offsets `dy` (their weighted mean when too few
    rows weigh)."""
    if int((w > 1e-6).sum()) < dy.shape[1] + 3:
        return (w @ rel) / max(float(w.sum()), 1e-12)
    sw = np.sqrt(w)[:, None]
    design = np.concatenate([np.ones((dy.shape[0], 1)), dy], axis=1)
    coef, *_ = np.linalg.lstsq(design * sw, rel * sw, rcond=None)
    return coef[0]


def _mirrored(aff: Affordance, ctx: np.ndarray, y: np.ndarray, delta: np.ndarray
              ) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
    """The rows followed by their mirror images across the line of `delta` (vectors
    reflected, sizes kept), with the reflection; None when a context has no mirror image
    (an absolute position, the LIDAR, the arm's joints: anything but a vector that turns
    with the scene and a look) or the outcome is no 2-D vector."""
    length = float(np.linalg.norm(delta))
    if delta.shape[0] != 2 or length < 1e-12 or not is_vector(aff.output):
        return None
    if not all(turns_with_scene(space) or space.prop in VISUAL_PROPERTIES
               for space in aff.contexts):
        return None
    u = delta / length
    flip = 2.0 * np.outer(u, u) - np.eye(2)
    image = ctx.copy()
    for space, sl in zip(aff.contexts, context_slices(aff), strict=True):
        if turns_with_scene(space):
            image[:, sl] = ctx[:, sl] @ flip
    return np.concatenate([ctx, image]), np.concatenate([y, y @ flip]), flip
