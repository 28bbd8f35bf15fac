"""Models read in the frame of a relation: what a push does does not depend on its bearing.

Physics in the room does not change when a scene is turned: the tool pushed straight into the
target moves it along the line between them, whichever way that line points. A
`LocalLinearModel` in room coordinates has to see pushes from every bearing to know that; with a
hundred rows of a tool affordance, it did not (a tool 20° off the line was pushed sideways).

`FramedModel` holds the same rows (x, c, y) in room coordinates, and fits its forward and
inverse models on them read in the frame of one relation context r (e.g. `target-tool`): every
2-D vector — the input and output changes when they are positions or headings, the other
relative positions and the heading in c — is turned so that r points along the first axis, and
r itself becomes its length. Answers are turned back. Everything the planner reads from the
data (`data`, `scales`) stays in room coordinates.

Which relation frames an affordance: `relation_frame` (docs/algorithm.md, "Relation frames").
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any, NamedTuple

import numpy as np

from hadim_cli.learner.competence import split_zero
from hadim_cli.learner.models import (
    InverseResult,
    LocalLinearModel,
    Model,
    SpaceScale,
    as_rows,
)
from hadim_cli.learner.spaces import ACTION, Role, RoleSpace
from hadim_cli.world.layout import Property

_ZERO_LENGTH = 1e-12
"""A relation shorter than this has no bearing: its frame is the room's."""
_NEAR = 1e-9
"""Outcomes whose stored norm is within this fraction of the null threshold have their turned
outcome measured (`FramedModel.turned_where`); a turn changes a norm by ~1e-16 of it."""


@dataclass(frozen=True)
class Frame:
    """Which parts of an affordance's rows turn with its framing relation."""

    axis: int
    """Index (among the context spaces) of the relation whose direction is the frame's first
    axis."""
    x: bool
    """Whether the input is a 2-D vector (a position or heading change), turned with it."""
    y: bool
    """Whether the output is one."""
    vectors: tuple[int, ...] = ()
    """Indices of the other context spaces that are 2-D vectors (relations, the heading)."""

    def to_array(self) -> np.ndarray:
        return np.array([self.axis, int(self.x), int(self.y), *self.vectors], dtype=np.int64)

    @classmethod
    def from_array(cls, a: np.ndarray) -> Frame:
        return cls(int(a[0]), bool(a[1]), bool(a[2]), tuple(int(v) for v in a[3:]))


BODY_DIRECTIONS = (Property.HEADING, Property.ORIENTATION)
"""The directions a world declares for its actor's body (the rover's heading, the arm's
orientation about its base): what a command does to the actor turns with them."""


def is_vector(space: RoleSpace) -> bool:
    """A space whose values turn with the scene: changes of positions and headings, relative
    positions and the heading as contexts (an absolute position is a place, not a vector)."""
    return space is not ACTION and space.prop in (Property.POSITION, Property.HEADING)


def turns_with_scene(space: RoleSpace) -> bool:
    """A context whose values turn (and mirror) with the scene: a relative position or a
    direction of the actor's body (`BODY_DIRECTIONS`); a size, a colour, a joint's bend or an
    absolute place does not."""
    return space.relative_to is not None or space.prop in BODY_DIRECTIONS


def relation_frame(inp: RoleSpace, out: RoleSpace,
                   contexts: Sequence[RoleSpace]) -> Frame | None:
    """The frame of an affordance: that of its context relating the output's owner to the
    input's (`target-tool` for a tool pushing the target), else of the first relating the
    output's owner to anything; None without such a relation, or when the output does not
    turn. The actor's own motion (primitive action → its position or heading) with a direction
    of its body as a context (`BODY_DIRECTIONS`: the rover's heading, the arm's orientation)
    is framed by it: a wheel command moves the robot the same way in its own frame whatever
    way it faces (up to its speed before the command, which no observation holds), a joint
    command moves the effector the same way in the frame of the first link whatever way the
    arm is turned about its base."""
    if not is_vector(out):
        return None
    heading = [i for i, c in enumerate(contexts)
               if c.role is Role.ROBOT and c.prop in BODY_DIRECTIONS and c.relative_to is None]
    relations = [i for i, c in enumerate(contexts)
                 if c.relative_to is not None and c.role is out.role]
    if inp is ACTION and out.role is Role.ROBOT and heading:
        axis = heading[0]
    elif relations:
        direct = [i for i in relations if contexts[i].relative_to is inp.role]
        axis = (direct or relations)[0]
    else:
        return None
    vectors = tuple(i for i, c in enumerate(contexts) if i != axis and turns_with_scene(c))
    return Frame(axis, is_vector(inp), is_vector(out), vectors)


def _turn(v: np.ndarray, u: np.ndarray) -> np.ndarray:
    """Vectors `v` (Q, 2) read in the frames whose first axes are the unit vectors `u` (Q, 2)."""
    return np.stack([v[:, 0] * u[:, 0] + v[:, 1] * u[:, 1],
                     v[:, 1] * u[:, 0] - v[:, 0] * u[:, 1]], axis=1)


def _unturn(v: np.ndarray, u: np.ndarray) -> np.ndarray:
    """Inverse of `_turn`: frame vectors back in room coordinates."""
    return np.stack([v[:, 0] * u[:, 0] - v[:, 1] * u[:, 1],
                     v[:, 0] * u[:, 1] + v[:, 1] * u[:, 0]], axis=1)


def _unit_vectors(v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Norms of the vectors `v` (Q, 2) and their directions (zero where no longer than
    `_ZERO_LENGTH`)."""
    norm = np.linalg.norm(v, axis=1)
    unit = np.zeros_like(v, dtype=float)
    ok = norm > _ZERO_LENGTH
    unit[ok] = v[ok] / norm[ok, None]
    return norm, unit


def _turns_to(want: np.ndarray, norm: np.ndarray, unit: np.ndarray) -> np.ndarray:
    """Per row, the turn (a unit vector) that takes the direction `unit` (of length `norm`)
    to that of `want`: want/|want| times unit conjugated; none (1, 0) for a row or a `want`
    too short to have a direction."""
    norm_want = float(np.linalg.norm(want))
    if not norm_want > _ZERO_LENGTH:
        return np.tile([1.0, 0.0], (norm.shape[0], 1))
    w, h0, h1 = want / norm_want, unit[:, 0], unit[:, 1]
    turn = np.empty((norm.shape[0], 2))
    turn[:, 0] = w[0] * h0 + w[1] * h1
    turn[:, 1] = w[1] * h0 - w[0] * h1
    turn[norm <= _ZERO_LENGTH] = (1.0, 0.0)
    return turn


class _Units(NamedTuple):
    """Per row of a `FramedModel`: what the turns of its rows are made of."""

    norm_y: np.ndarray
    """The norm of the outcome."""
    unit_y: np.ndarray
    """Its direction (zero for a null outcome)."""
    norm_r: np.ndarray
    """The length of the framing relation."""
    unit_r: np.ndarray
    """Its direction."""

    @classmethod
    def of(cls, y: np.ndarray, r: np.ndarray) -> _Units:
        """Of rows with outcomes `y` and framing relations `r` (2-D vectors: a model whose
        outcome does not turn has its norms, and directions it never reads)."""
        norm_y, unit_y = _unit_vectors(y) if y.shape[1] == 2 else \
            (np.linalg.norm(y, axis=1), np.zeros((y.shape[0], 2)))
        return cls(norm_y, unit_y, *_unit_vectors(r))


class FramedModel:
    """The rows of one affordance and a `LocalLinearModel` fitted on them in the frame of a
    relation (see the module docstring). Offers what the learner asks of a model: `add`,
    `data`, `scales`, `predict`, `predict_loo`, `infer`, `forward_neighbours`,
    `inverse_neighbours`, `state`/`from_state`; all in room coordinates."""

    def __init__(self, dx: int, dy: int, context_dims: Sequence[int], frame: Frame,
                 **params: Any):
        self.dx, self.dy = int(dx), int(dy)
        self.context_dims = tuple(int(d) for d in context_dims)
        self.dc = sum(self.context_dims)
        self.frame = frame
        if not 0 <= frame.axis < len(self.context_dims) or \
                self.context_dims[frame.axis] != 2:
            raise ValueError(f"the framing relation must be a 2-D context, got index "
                             f"{frame.axis} of context dims {self.context_dims}")
        for flag, d, name in ((frame.x, self.dx, "input"), (frame.y, self.dy, "output")):
            if flag and d != 2:
                raise ValueError(f"a turned {name} must be 2-D, got {d}")
        if any(self.context_dims[i] != 2 for i in frame.vectors):
            raise ValueError(f"turned contexts must be 2-D, got {frame.vectors} of "
                             f"{self.context_dims}")
        self._starts = np.concatenate([[0], np.cumsum(self.context_dims)]).astype(int)
        inner_dims = [1 if i == frame.axis else d for i, d in enumerate(self.context_dims)]
        self.inner = LocalLinearModel(dx, dy, inner_dims, **params)
        self._dims = (self.dx, *self.context_dims, self.dy)
        self._centred = (False, *([True] * len(self.context_dims)), False)
        self._room = np.empty((64, self.dx + self.dc + self.dy))
        """Rows [0, n) in room coordinates (grown by doubling, like the inner model's)."""
        self._scale_cache: tuple[int, SpaceScale] | None = None
        self._kept = _Units.of(np.empty((0, self.dy)), np.empty((0, 2)))
        """`_Units` of the rows known at the last `_units()`."""

    # ------------------------------------------------------------------ frames
    def _bearing(self, c: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Unit first axes (Q, 2) of the frames of contexts `c` (Q, dc), and the lengths."""
        s = self._starts[self.frame.axis]
        r = c[:, s:s + 2]
        length = np.linalg.norm(r, axis=1)
        u = np.tile([1.0, 0.0], (c.shape[0], 1))
        ok = length > _ZERO_LENGTH
        u[ok] = r[ok] / length[ok, None]
        return u, length

    def _context(self, c: np.ndarray, u: np.ndarray, length: np.ndarray) -> np.ndarray:
        parts = []
        for i, s in enumerate(self._starts[:-1]):
            block = c[:, s:s + self.context_dims[i]]
            if i == self.frame.axis:
                parts.append(length[:, None])
            elif i in self.frame.vectors:
                parts.append(_turn(block, u))
            else:
                parts.append(block)
        return np.concatenate(parts, axis=1)

    def _vector(self, v: np.ndarray, u: np.ndarray, turned: bool, back: bool = False
                ) -> np.ndarray:
        if not turned:
            return v
        return _unturn(v, u) if back else _turn(v, u)

    def _framed(self, x: np.ndarray | None, c: np.ndarray
                ) -> tuple[np.ndarray | None, np.ndarray, np.ndarray]:
        """(x, c) read in the frames of the contexts `c` (one context or one per x), and the
        frames' first axes; a single context serves every x."""
        c = as_rows(c, self.dc, "c")
        if x is not None:
            x = as_rows(x, self.dx, "x")
            q = max(x.shape[0], c.shape[0])
            x, c = as_rows(x, self.dx, "x", q), as_rows(c, self.dc, "c", q)
        u, length = self._bearing(c)
        fx = None if x is None else self._vector(x, u, self.frame.x)
        return fx, self._context(c, u, length), u

    # ------------------------------------------------------------------ data
    @property
    def n(self) -> int:
        return self.inner.n

    def params(self) -> dict[str, Any]:
        return {**self.inner.params(), "frame": self.frame}

    def add(self, x: np.ndarray, c: np.ndarray | None, y: np.ndarray) -> None:
        if c is None:
            raise ValueError(f"this model needs a context of {self.dc} columns")
        c = as_rows(c, self.dc, "c")
        x, y = as_rows(x, self.dx, "x"), as_rows(y, self.dy, "y")
        if not x.shape[0] == c.shape[0] == y.shape[0]:
            raise ValueError(f"x, c and y must have as many rows, got {x.shape[0]}, "
                             f"{c.shape[0]}, {y.shape[0]}")
        fx, fc, u = self._framed(x, c)
        n = self.n
        self.inner.add(fx, fc, self._vector(y, u, self.frame.y))
        if self.n > self._room.shape[0]:
            grown = np.empty((max(2 * self._room.shape[0], self.n), self._room.shape[1]))
            grown[:n] = self._room[:n]
            self._room = grown
        self._room[n:self.n] = np.concatenate([x, c, y], axis=1)

    def data(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Views (X, C, Y) of the stored rows in room coordinates."""
        d = self._room[:self.n]
        return d[:, :self.dx], d[:, self.dx:self.dx + self.dc], d[:, self.dx + self.dc:]

    def scales(self) -> SpaceScale:
        """Scales of the spaces (x, each context, y) over the rows in room coordinates."""
        if self._scale_cache is None or self._scale_cache[0] != self.n:
            self._scale_cache = (self.n, SpaceScale.fit(self._room[:self.n], self._dims,
                                                        self._centred))
        return self._scale_cache[1]

    def turned(self, *, along: np.ndarray | None = None, at: np.ndarray | None = None
               ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The rows (X, C, Y) in room coordinates, each scene turned about itself: so that its
        outcome points `along` a direction (rows with a null outcome stay as they are), or so
        that its framing relation has the bearing of the one in the context `at`. Each row
        reads as it would have there: where a push along `along` is made from, which rows
        act from near the relation of `at`."""
        x, c, y = self.data()
        turn = self._turns(along, at, y, c)
        if turn is None:
            return x, c, y
        return (*self._turn_rows(x, c, turn), self._vector(y, turn, self.frame.y, back=True))

    def turned_where(self, zero_eps: float, *, along: np.ndarray | None = None,
                     at: np.ndarray | None = None
                     ) -> tuple[np.ndarray | None, np.ndarray, np.ndarray, np.ndarray]:
        """(indices, X, C, Y): the rows whose turned outcome is not null (‖y‖ > `zero_eps`,
        `competence.split_zero`'s rule), turned as `turned` turns them, bit for bit — all
        rows (indices None) if none is.

        Only those rows are turned: a turn keeps a norm to a few units in the last place, so
        the stored outcome's norm decides for every row but those within `_NEAR` of
        `zero_eps`, whose turned outcome is measured. The norms and the unit vectors that
        turns are made of are kept per row (`_Units`), extended as rows come in: a call
        costs a comparison per row and the turning of the rows it returns."""
        if not zero_eps > 0:
            raise ValueError(f"zero_eps must be > 0, got {zero_eps}")
        if (along is None) == (at is None):
            raise ValueError("turn the rows either along an outcome or at a context")
        x, c, y = self.data()
        norm = self._units().norm_y
        turned = along is None or self.frame.y   # along an outcome that does not turn: as stored
        if turned and self.frame.y:
            mask = norm > zero_eps * (1.0 + _NEAR)
            near = np.flatnonzero(~mask & (norm >= zero_eps * (1.0 - _NEAR)))
            if near.size:
                mask[near] = ~split_zero(_unturn(y[near], self._turns_of(near, along, at)),
                                         zero_eps)
        else:
            mask = norm > zero_eps
        if not mask.any():
            return (None, *self.turned(along=along, at=at))
        rows = np.flatnonzero(mask)
        x, c, y = x[rows], c[rows], y[rows]
        if not turned:
            return rows, x, c, y
        turn = self._turns_of(rows, along, at)
        return (rows, *self._turn_rows(x, c, turn), self._vector(y, turn, self.frame.y,
                                                                  back=True))

    def _units(self) -> _Units:
        """`_Units` of rows [0, n), extended by the rows added since the last call."""
        have = self._kept.norm_y.size
        if have < self.n:
            _, c, y = self.data()
            s = self._starts[self.frame.axis]
            new = _Units.of(y[have:], c[have:, s:s + 2])
            self._kept = _Units(*(np.concatenate([old, part]) for old, part in
                                  zip(self._kept, new, strict=True)))
        return self._kept

    def _turns_of(self, rows: np.ndarray, along: np.ndarray | None,
                  at: np.ndarray | None) -> np.ndarray:
        """`_turns(along, at, …)` of the rows `rows`, bit for bit, from the kept `_Units`."""
        units = self._units()
        if along is not None:
            want, norm, unit = np.asarray(along, dtype=float), units.norm_y, units.unit_y
        else:
            s = self._starts[self.frame.axis]
            want = as_rows(at, self.dc, "c")[0, s:s + 2]
            norm, unit = units.norm_r, units.unit_r
        return _turns_to(want, norm[rows], unit[rows])

    def _turn_rows(self, x: np.ndarray, c: np.ndarray, turn: np.ndarray
                   ) -> tuple[np.ndarray, np.ndarray]:
        """Inputs and contexts of rows turned by `turn` (one unit vector per row)."""
        c = c.copy()
        for i in (self.frame.axis, *self.frame.vectors):
            s = self._starts[i]
            c[:, s:s + 2] = _unturn(c[:, s:s + 2], turn)
        return self._vector(x, turn, self.frame.x, back=True), c

    def _turns(self, along: np.ndarray | None, at: np.ndarray | None, y: np.ndarray,
               c: np.ndarray) -> np.ndarray | None:
        """The turn of each row (outcomes `y`, contexts `c`) as a unit vector, or None when
        rows are not turned (along an outcome that is not a vector of the frame)."""
        if (along is None) == (at is None):
            raise ValueError("turn the rows either along an outcome or at a context")
        if along is not None:
            if not self.frame.y:
                return None
            want, have = np.asarray(along, dtype=float), y
        else:
            s = self._starts[self.frame.axis]
            want, have = as_rows(at, self.dc, "c")[0, s:s + 2], c[:, s:s + 2]
        return _turns_to(want, *_unit_vectors(have))

    # ------------------------------------------------------------------ models
    def predict(self, x: np.ndarray, c: np.ndarray | None = None) -> np.ndarray:
        fx, fc, u = self._framed(x, self._require_context(c))
        return self._vector(self.inner.predict(fx, fc), u, self.frame.y, back=True)

    def predict_loo(self, indices: np.ndarray | Sequence[int] | None = None,
                    neighbours: int | None = None) -> np.ndarray:
        idx = np.arange(self.n) if indices is None else np.asarray(indices, dtype=np.int64)
        u, _ = self._bearing(self._room[idx, self.dx:self.dx + self.dc])
        return self._vector(self.inner.predict_loo(idx, neighbours), u, self.frame.y,
                            back=True)

    def infer(self, y_goal: np.ndarray, c: np.ndarray | None = None, *,
              n_candidates: int | None = None) -> InverseResult:
        """Inverse model in the frame of `c`; without a context, in that of each of the stored
        rows whose outcomes are nearest the goal, the best answer kept."""
        goal = as_rows(y_goal, self.dy, "y_goal")
        if c is None:
            _, nb = self.inverse_neighbours(goal, k=min(n_candidates or self.inner.k_inverse,
                                                        self.n))
            answers = [self.infer(goal, self._room[i, self.dx:self.dx + self.dc],
                                  n_candidates=n_candidates) for i in nb[0]]
            return min(answers, key=lambda a: a.error)
        _, fc, u = self._framed(None, c)
        got = self.inner.infer(self._vector(goal, u, self.frame.y)[0], fc,
                               n_candidates=n_candidates)
        return InverseResult(self._vector(got.x[None], u, self.frame.x, back=True)[0],
                             self._vector(got.y_predicted[None], u, self.frame.y, back=True)[0],
                             got.error,
                             self._room[got.neighbour_index, self.dx:self.dx + self.dc].copy(),
                             got.neighbour_index)

    def forward_neighbours(self, x: np.ndarray, c: np.ndarray | None = None,
                           k: int | None = None) -> tuple[np.ndarray, np.ndarray]:
        fx, fc, _ = self._framed(x, self._require_context(c))
        return self.inner.forward_neighbours(fx, fc, k)

    def inverse_neighbours(self, y: np.ndarray, c: np.ndarray | None = None,
                           k: int | None = None) -> tuple[np.ndarray, np.ndarray]:
        """Nearest rows in normalised (y, c) read in the frame of `c`; without a context, in
        room outcomes alone (a bearing is only known with a context)."""
        y = as_rows(y, self.dy, "y")
        k = min(k or self.inner.k_inverse, self.n)
        if c is not None:
            _, fc, u = self._framed(None, c)
            return self.inner.inverse_neighbours(self._vector(y, u, self.frame.y), fc, k)
        scale = self.scales().values[-1]
        d2 = np.einsum("qnd,qnd->qn", *(2 * [(y[:, None, :] - self.data()[2][None]) / scale]))
        nb = np.argsort(d2, axis=1, kind="stable")[:, :k]
        return np.sqrt(np.take_along_axis(d2, nb, axis=1)), nb

    def _require_context(self, c: np.ndarray | None) -> np.ndarray:
        if c is None:
            raise ValueError(f"this model needs a context of {self.dc} columns")
        return c

    # ------------------------------------------------------------------ state
    def state(self) -> dict[str, np.ndarray]:
        """The inner model's state with the rows in room coordinates, and the frame."""
        x, c, y = self.data()
        return {**self.inner.state(), "x": x.copy(), "c": c.copy(), "y": y.copy(),
                "dims": np.array([self.dx, self.dy, *self.context_dims], dtype=np.int64),
                "frame": self.frame.to_array()}

    @classmethod
    def from_state(cls, state: dict[str, np.ndarray], **params: Any) -> FramedModel:
        """Rebuild a model saved by `state()`, answering bit-identically; `params` override
        the saved keyword parameters (a `frame` must agree with the saved one)."""
        if "frame" not in state:
            raise ValueError("this model state has no frame: it is a LocalLinearModel's")
        frame = Frame.from_array(state["frame"])
        if params.get("frame", frame) != frame:
            raise ValueError(f"stored frame {frame} differs from the requested "
                             f"{params['frame']}")
        params["frame"] = frame
        saved = LocalLinearModel.saved_params(state)
        saved.update(params)
        choices = saved.pop("k_choices", ())
        dims = [int(d) for d in state["dims"]]
        model = cls(dims[0], dims[1], dims[2:], **saved)  # no choice while the rows come back
        if state["x"].shape[0]:
            model.add(state["x"], state["c"], state["y"])
        model.inner.restore_indexes(state["built"])
        model.inner.restore_choice(choices, state)
        return model


def seen(model: Model, *, along: np.ndarray | None = None, at: np.ndarray | None = None
         ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A model's rows (X, C, Y) as `FramedModel.turned` gives them; a model in room
    coordinates has no frame to turn, and gives them as stored."""
    if isinstance(model, FramedModel):
        return model.turned(along=along, at=at)
    return model.data()


def seen_where(model: Model, zero_eps: float, *, along: np.ndarray | None = None,
               at: np.ndarray | None = None
               ) -> tuple[np.ndarray | None, np.ndarray, np.ndarray, np.ndarray]:
    """(indices, X, C, Y): the rows of `seen(model, along=…, at=…)` whose outcome is not null
    (‖y‖ > `zero_eps`; all rows, indices None, if none is), the same values bit for bit; only
    those rows are turned (`FramedModel.turned_where`)."""
    if isinstance(model, FramedModel):
        return model.turned_where(zero_eps, along=along, at=at)
    x, c, y = model.data()
    mask = ~split_zero(y, zero_eps)
    if not mask.any():
        return None, x, c, y
    rows = np.flatnonzero(mask)
    return rows, x[rows], c[rows], y[rows]
