"""Affordances A(C_i, Ω_j, Ω̃_k): spaces, training rows, models, competence, interest, p_A.

An affordance's data are *rows* of D (an iteration and a binding of its roles); its models are
fitted on the values its spaces take at those rows. Keeping rows rather than copies makes a
context change a refit over the same rows, and a checkpoint a list of integers.
"""

from __future__ import annotations

import weakref
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from hadim_cli.config import LearnerConfig
from hadim_cli.learner.classifier import VisualClassifier
from hadim_cli.learner.competence import model_competence, range_scale, split_zero
from hadim_cli.learner.dataset import Dataset
from hadim_cli.learner.frames import FramedModel, relation_frame
from hadim_cli.learner.interest import InterestMap, Progress
from hadim_cli.learner.models import LocalLinearModel, Model
from hadim_cli.learner.spaces import (
    ACTION,
    Role,
    RoleSpace,
    Rows,
    SpaceReader,
    borrowed_space,
)
from hadim_cli.world.layout import Property

CONTACT_MARGIN = 0.02
"""Bodies closer than the sum of their radii plus this (m) are taken to be in contact."""


@dataclass
class Affordance:
    """One affordance of H with its models, data, competence history, interest map and p_A."""

    id: int
    input: RoleSpace
    output: RoleSpace
    contexts: tuple[RoleSpace, ...]
    created_at: int
    rows: Rows
    model: Model
    interest: InterestMap
    classifier: VisualClassifier | None
    competence: float = 0.0
    history: list[tuple[int, float]] = field(default_factory=list)
    low_streak: int = 0

    @property
    def roles(self) -> frozenset[Role]:
        out = self.input.roles | self.output.roles
        for c in self.contexts:
            out |= c.roles
        return out

    @property
    def has_target(self) -> bool:
        return Role.TARGET in self.roles

    @property
    def has_tool(self) -> bool:
        return Role.TOOL in self.roles

    def describe(self) -> str:
        ctx = ", ".join(c.name for c in self.contexts) or "∅"
        return f"A{self.id}({self.input.name} → {self.output.name} | {ctx})"


@dataclass(frozen=True)
class Sample:
    """Rows with the values of an affordance's spaces at them."""

    rows: Rows
    x: np.ndarray
    c: np.ndarray
    y: np.ndarray

    def take(self, idx: np.ndarray) -> Sample:
        return Sample(self.rows.take(idx), self.x[idx], self.c[idx], self.y[idx])

    def concat(self, other: Sample) -> Sample:
        return Sample(self.rows.concat(other.rows), np.concatenate([self.x, other.x]),
                      np.concatenate([self.c, other.c]), np.concatenate([self.y, other.y]))


_BY_MODEL: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()
"""model → {(what, parameters): (rows, value)}: figures over a model's outcomes, which only
change when rows are added (a refit makes a new model)."""


def per_model(model: Model, key: tuple, compute: Callable[[np.ndarray], float]) -> float:
    """`compute(outcomes of model)`, computed again only when the model has new rows: the
    planner asks for a step size many times per learning episode, and each pass is O(rows)."""
    return per_model_rows(model, key, lambda m: compute(m.data()[2]))


def per_model_rows(model: Model, key: tuple, compute: Callable[[Model], Any]) -> Any:
    """`compute(model)` for a figure of the model's rows (`key` names it and every parameter
    it depends on), computed again only when the model has new rows."""
    memo = _BY_MODEL.setdefault(model, {})
    hit = memo.get(key)
    if hit is not None and hit[0] == model.n:
        return hit[1]
    value = compute(model)
    memo[key] = (model.n, value)
    return value


def _typical_step(y: np.ndarray, quantile: float, zero_eps: float) -> float:
    norms = np.linalg.norm(y, axis=1)
    norms = norms[norms > zero_eps]
    return float(np.quantile(norms, quantile)) if norms.size else 0.05


def typical_step(aff: Affordance, quantile: float = 0.9, zero_eps: float = 1e-9) -> float:
    """A high quantile of the norms of an affordance's non-null outcomes: one step of it."""
    return per_model(aff.model, ("step", quantile, zero_eps),
                     lambda y: _typical_step(y, quantile, zero_eps))


def output_bounds(space: RoleSpace, reader: SpaceReader) -> tuple[np.ndarray, np.ndarray]:
    """Bounds of the absolute values of an output space: the goal space of its interest map."""
    spec = reader.layout.space(reader.entity_name(space.role), space.prop or Property.POSITION)
    return np.asarray(spec.low, dtype=float), np.asarray(spec.high, dtype=float)


class Fitter:
    """Builds the rows, models and competences of affordances over the dataset D."""

    def __init__(self, dataset: Dataset, reader: SpaceReader, config: LearnerConfig):
        self.dataset = dataset
        self.reader = reader
        self.config = config
        self.n_entities = len(reader.layout.entities)
        # (input, output) → (iterations covered, candidate rows over them): see `all_candidates`.
        self._candidates: dict[tuple[str, str], tuple[int, Sample]] = {}

    # ------------------------------------------------------------------ rows and values
    def bindings(self, roles: frozenset[Role], t: np.ndarray) -> Rows:
        """Every binding of `roles` to objects, at every iteration of `t`."""
        objects = np.arange(1, self.n_entities, dtype=np.int64)
        minus = np.full(1, -1, dtype=np.int64)
        targets = objects if Role.TARGET in roles else minus
        tools = objects if Role.TOOL in roles else minus
        tg, tl = np.meshgrid(targets, tools, indexing="ij")
        keep = (tg != tl) | (tg < 0)
        tg, tl = tg[keep], tl[keep]
        n_b = tg.shape[0]
        return Rows(np.repeat(t, n_b), np.tile(tg, t.shape[0]), np.tile(tl, t.shape[0]))

    def values(self, inp: RoleSpace, out: RoleSpace, contexts: tuple[RoleSpace, ...],
               rows: Rows) -> Sample:
        d = self.dataset
        x = self.reader.read(inp, d.outcomes, rows, d.actions)
        c = self.reader.read_many(contexts, d.contexts, rows)
        y = self.reader.read(out, d.outcomes, rows)
        if rows.borrowed is not None and rows.borrowed.any():  # (None on every usual row set)
            other = borrowed_space(out)
            if other is None:
                raise ValueError(f"rows borrowed by an affordance of {out.name}, "
                                 "which can take in no other output's data")
            idx = np.flatnonzero(rows.borrowed)
            y[idx] = self.reader.read(other, d.outcomes, rows.take(idx))
        return Sample(rows, x, c, y)

    def candidate_rows(self, inp: RoleSpace, out: RoleSpace, t: np.ndarray) -> Sample:
        """Rows of iterations `t` in the domain of (inp → out): the input actually changed."""
        roles = inp.roles | out.roles
        rows = self.bindings(roles, t)
        sample = self.values(inp, out, (), rows)
        if inp is not ACTION:
            sample = sample.take(np.flatnonzero(self.nonzero(sample.x)))
        if inp is ACTION and out.role is Role.ROBOT:
            sample = sample.take(np.flatnonzero(self.moved_clear(sample.rows)))
        if Role.TOOL in roles:
            # Through a tool means not by the robot's own body: a target the robot touches is
            # the direct pushing affordance's outcome, and would hide the tool's relation.
            sample = sample.take(np.flatnonzero(~self.touching_robot(sample.rows)))
        return sample

    def all_candidates(self, inp: RoleSpace, out: RoleSpace) -> Sample:
        """`candidate_rows` over every iteration of D, kept and extended by the iterations
        added since the last call instead of read again from all of D. Bindings are made
        iteration by iteration and every test on them is row-wise, so the rows of [0, n) are
        those of [0, m) followed by those of [m, n): the same sample, bit for bit."""
        key = (inp.name, out.name)
        n = len(self.dataset)
        done, sample = self._candidates.get(key, (0, None))
        if sample is None or done > n:  # (D never shrinks; a new D means a new Fitter)
            done, sample = 0, None
        if done < n or sample is None:
            new = self.candidate_rows(inp, out, np.arange(done, n, dtype=np.int64))
            sample = new if sample is None else sample.concat(new)
            self._candidates[key] = (n, sample)
        return sample

    def moved_clear(self, rows: Rows) -> np.ndarray:
        """Rows whose action the actor took clear of everything (the actor's own motion is
        learnt from these only: pressed against a wall or an object it does not move as its
        commands say, and such rows bent the local fits round free moves):
        no object within contact plus `CONTACT_MARGIN` before or after the action, and, where
        the actor has a LIDAR, no ray (walls, objects) shorter than its radius plus that
        margin. An actor without one (the arm's effector) is judged by the objects alone: what
        else stops it (a wall, the arm's base, a joint's limit) shows in its data."""
        d = self.dataset
        objects = self.bindings(frozenset({Role.TARGET}), rows.t)  # every object, row by row
        touched = self.touching(objects, Role.ROBOT, after=True).reshape(len(rows), -1)
        lidar = RoleSpace(Role.ROBOT, Property.LIDAR)
        if not self.reader.declares(lidar):
            return ~touched.any(axis=1)
        before = self.reader.read(lidar, d.contexts, rows)
        after = before + self.reader.read(lidar, d.outcomes, rows)
        reach = self.reader.read(RoleSpace(Role.ROBOT, Property.RADIUS), d.contexts,
                                 rows)[:, 0] + CONTACT_MARGIN
        clear = (before.min(axis=1) > reach) & (after.min(axis=1) > reach)
        return clear & ~touched.any(axis=1)

    def touching_robot(self, rows: Rows) -> np.ndarray:
        """Rows whose target is in contact with the robot before or after the action."""
        return self.touching(rows, Role.ROBOT, after=True)

    def touching(self, rows: Rows, actor: Role, *, after: bool) -> np.ndarray:
        """Rows whose target is in contact with `actor` (the robot or the tool) before the
        action, or (with `after`) before or after it."""
        d = self.dataset
        rel = RoleSpace(Role.TARGET, Property.POSITION, actor)
        before = self.reader.read(rel, d.contexts, rows, raw=True)
        reach = self.reader.contact(rel, d.contexts, rows) + CONTACT_MARGIN
        out = np.linalg.norm(before, axis=1) <= reach
        if after:
            then = before + self.reader.read(rel, d.outcomes, rows, raw=True)
            out |= np.linalg.norm(then, axis=1) <= reach
        return out

    def changed(self, space: RoleSpace, t: np.ndarray) -> tuple[Rows, np.ndarray]:
        """Every binding of `space`'s roles at iterations `t`, and whether `space` changed."""
        rows = self.bindings(space.roles, t)
        return rows, self.nonzero(self.reader.read(space, self.dataset.outcomes, rows))

    def nonzero(self, y: np.ndarray) -> np.ndarray:
        """Rows where something moved: the complement of `competence.split_zero`, the one
        "nothing moved" rule (‖y‖ ≤ `zero_eps`)."""
        return ~split_zero(y, self.config.zero_eps)

    def select_rows(self, sample: Sample, rng: np.random.Generator,
                    accept: np.ndarray | None = None) -> Rows:
        """All non-null rows and a bounded random share of null ones (p_A-accepted targets)."""
        nz = self.nonzero(sample.y)
        zero_idx = np.flatnonzero(~nz & (accept if accept is not None else True))
        n_keep = min(zero_idx.size, max(4, int(np.ceil(self.config.zero_ratio * nz.sum()))))
        if n_keep < zero_idx.size:
            zero_idx = np.sort(rng.choice(zero_idx, size=n_keep, replace=False))
        idx = np.sort(np.concatenate([np.flatnonzero(nz), zero_idx]))
        return sample.rows.take(idx)

    def target_features(self, rows: Rows, entity: np.ndarray | None = None) -> np.ndarray:
        """p_A's input (`SpaceReader.features`) for each row's target (or `entity`) in D."""
        ent = rows.target if entity is None else entity
        return self.reader.features(self.dataset.contexts, Rows(rows.t, ent, rows.tool))

    def reached(self, aff: Affordance,
                t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """What iterations `t` reached in `aff`'s output space, for its interest map
        (`LearnerConfig.paper_interest`): (absolute values reached, competences, iterations),
        one per non-null outcome of a row in `aff`'s domain (`candidate_rows`: every binding
        of its roles whose input changed), in time order. The competence is 1 − min(1, e),
        e = ‖ω_e − ω_r‖ over the width of the output's range (as `competence` scales errors):
        ω_e the forward model's estimate for the controllable executed in that context, ω_r
        the outcome reached (paper §4.4)."""
        sample = self.candidate_rows(aff.input, aff.output, t)
        sample = sample.take(np.flatnonzero(self.nonzero(sample.y)))
        dim = self.reader.dim(aff.output)
        if len(sample.rows) == 0 or aff.model.n == 0:
            return np.zeros((0, dim)), np.zeros(0), np.zeros(0, dtype=np.int64)
        s = self.values(aff.input, aff.output, aff.contexts, sample.rows)
        estimate = aff.model.predict(s.x, s.c if s.c.shape[1] else None)
        eps = self.config.zero_eps
        scale = per_model(aff.model, ("range", eps), lambda y: range_scale(y, eps))
        error = np.linalg.norm(estimate - s.y, axis=1) / scale
        before = self.reader.read(aff.output, self.dataset.contexts, s.rows)
        order = np.argsort(s.rows.t, kind="stable")
        return ((before + s.y)[order], (1.0 - np.minimum(error, 1.0))[order],
                s.rows.t[order])

    # ------------------------------------------------------------------ models
    def new_model(self, inp: RoleSpace, out: RoleSpace,
                  contexts: tuple[RoleSpace, ...], trial: bool = False) -> Model:
        """An empty model of (inp → out | contexts): in the frame of its relation context when
        it has one, or of the robot's heading (`relation_frame`)."""
        dim = self.reader.dim
        low, high = self.reader.action_box() if inp is ACTION else (None, None)
        dims = (dim(inp), dim(out), [dim(c) for c in contexts])
        params = {"k_forward": self.config.k_forward, "k_inverse": self.config.k_inverse,
                  "robust_iterations": self.config.robust_fit, "x_low": low, "x_high": high,
                  # A trial model is scored once and dropped: it keeps `k_forward`, as every
                  # trial it is compared with (choosing cost 2.5x the learning time).
                  "k_choices": () if trial else self.config.k_choices}
        frame = relation_frame(inp, out, contexts)
        if frame is not None:
            return FramedModel(*dims, frame, **params)
        return LocalLinearModel(*dims, **params)

    def fit(self, inp: RoleSpace, out: RoleSpace, contexts: tuple[RoleSpace, ...],
            rows: Rows, trial: bool = False) -> Model:
        model = self.new_model(inp, out, contexts, trial)
        if len(rows):
            s = self.values(inp, out, contexts, rows)
            model.add(s.x, s.c, s.y)
        return model

    def competence(self, model: Model, rng: np.random.Generator) -> float:
        """Held-out competence of `model`, its rows left out one by one and predicted by fits
        of `k_forward` neighbours, the neighbourhood of every context trial: competences
        compare like with like, whatever neighbourhood each model predicts with (the one
        chosen on rows of other moments is wider, and its leave-one-out error larger, where
        rows repeat themselves; a change of it must not read as the data no longer
        matching)."""
        if model.n < 3:
            return 0.0
        # Errors relative to the width of the output's range: C(e) of the authors expects e of
        # a few percent for a good model (see docs/algorithm.md).
        eps = self.config.zero_eps
        scale = per_model(model, ("range", eps), lambda y: range_scale(y, eps))
        report = model_competence(model, zero_eps=self.config.zero_eps,
                                  sharpness=self.config.competence_sharpness,
                                  max_rows=self.config.competence_rows, rng=rng, scale=scale,
                                  neighbours=self.config.k_forward)
        return float(report.competence)

    def trial(self, inp: RoleSpace, out: RoleSpace, contexts: tuple[RoleSpace, ...],
              rows: Rows, rng: np.random.Generator) -> float:
        """Competence of a candidate affordance fitted on `rows`."""
        return self.competence(self.fit(inp, out, contexts, rows, trial=True), rng)

    def new_affordance(self, aid: int, inp: RoleSpace, out: RoleSpace,
                       contexts: tuple[RoleSpace, ...], rows: Rows, iteration: int,
                       rng: np.random.Generator) -> Affordance:
        low, high = output_bounds(out, self.reader)
        cfg = self.config
        measure = Progress.PAPER if cfg.paper_interest else Progress.HALF_WINDOW
        interest = InterestMap(low, high, max_goals_per_region=cfg.interest_max_goals,
                               window=cfg.interest_window, measure=measure)
        classifier = None
        if Role.TARGET in (inp.roles | out.roles):
            n_features = self.target_features(Rows.empty()).shape[1]
            classifier = VisualClassifier(n_features, hidden=cfg.classifier_hidden, rng=rng)
        model = self.fit(inp, out, contexts, rows)
        aff = Affordance(aid, inp, out, contexts, iteration, rows, model, interest, classifier)
        aff.competence = self.competence(model, rng)
        aff.history.append((iteration, aff.competence))
        return aff
