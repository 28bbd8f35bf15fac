"""Autonomous affordance adaptation (paper Algorithm 2), run after each learning episode.

For each space whose outcome was non-null during the episode (in random order): every
affordance predicting that space takes the episode's rows; if they lower its competence by more
than `match_tolerance` (they do not *match*), context changes are tried — adding, replacing or
removing one context space among every observed space of the bound entities — and the best is
kept when its competence reaches τ_modification and improves by `context_gain` (a context
about an entity the affordance neither acts with nor on counts as one more context); rows that
no change makes fit are given back (the paper's rule). Then new affordances are
tried for the space with every candidate input (A ∪ Ω_controllable) not yet used for it, with
no context or the best single context (kept only if it gains `context_gain` over none); the
best reaching τ_creation joins H.
p_A of every affordance with the same output is taught the same examples (pooled): the
objects that moved (positives) and the robot and, for the object-moving affordances, the
objects that refused the robot (negatives, `_refused`).

Three switches give the rest of the paper's loop (off by default, docs/algorithm.md for what
they measured):
`paper_picks` picks a space k times with replacement instead of each once; `paper_matching`
also matches the picked space's data against the affordances of other outputs, and a match
there stands for creation (`matches_other_output`); `paper_match_adds` adds the data to each
affordance of another output that matches, or is made to match by a context (`_borrow`).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from hadim_cli.config import LearnerConfig
from hadim_cli.learner.affordance import Affordance, Fitter, Sample, typical_step
from hadim_cli.learner.hierarchy import Event, EventKind, Hierarchy
from hadim_cli.learner.spaces import (
    ACTION,
    OPEN_OUTPUT_SPACES,
    OUTPUT_SPACES,
    Property,
    Role,
    RoleSpace,
    Rows,
    borrowed_space,
    context_candidates,
)


@dataclass
class CreationBackoff:
    """Failed creation trials of (input, output) wait 1, 2, 4 … 16 learning episodes."""

    next_try: dict[str, int] = field(default_factory=dict)
    wait: dict[str, int] = field(default_factory=dict)

    @staticmethod
    def key(inp: RoleSpace, out: RoleSpace) -> str:
        return f"{inp.name}>{out.name}"

    def ready(self, inp: RoleSpace, out: RoleSpace, episode: int) -> bool:
        return self.next_try.get(self.key(inp, out), 0) <= episode

    def failed(self, inp: RoleSpace, out: RoleSpace, episode: int) -> None:
        key = self.key(inp, out)
        wait = min(16, 2 * self.wait.get(key, 1))
        self.wait[key] = wait
        self.next_try[key] = episode + wait


OBJECT_POSITION = RoleSpace(Role.TARGET, Property.POSITION)
ROBOT_POSITION = RoleSpace(Role.ROBOT, Property.POSITION)
TARGET_ROBOT = RoleSpace(Role.TARGET, Property.POSITION, Role.ROBOT)


def own_entities(inp: RoleSpace, out: RoleSpace) -> frozenset[Role]:
    """The entities an affordance acts with and on: its input's and output's roles, and the
    robot for primitive actions (the robot's own commands)."""
    roles = inp.roles | out.roles
    return roles | {Role.ROBOT} if inp is ACTION else roles


def foreign_penalty(inp: RoleSpace, out: RoleSpace, contexts: tuple[RoleSpace, ...],
                    config: LearnerConfig) -> float:
    """`context_gain` when a context is about an entity the affordance neither acts with nor
    acts on (the robot's relation to the target, or its heading, for a push through a tool):
    bringing in another entity counts as one more context. Such a relation predicts about as
    well while the entity trails the affordance's input (the robot behind the tool), but the
    controller cannot establish it through that input (docs/algorithm.md)."""
    own = own_entities(inp, out)
    return config.context_gain if any(c.roles - own for c in contexts) else 0.0


def required_gain(n_before: int, n_after: int, context_gain: float) -> float:
    """Competence a context change must add: `context_gain` to add a context, half of it to
    replace one (no more complex, but a change must beat the noise of the estimates), none to
    remove one (as good and simpler). An affordance created early on scarce data with a weak
    context can so take the right one once the data show it."""
    if n_after > n_before:
        return context_gain
    return 0.5 * context_gain if n_after == n_before else 0.0


class Adaptation:
    """Runs Algorithm 2 over H after each learning episode."""

    def __init__(self, hierarchy: Hierarchy, fitter: Fitter, config: LearnerConfig):
        self.h = hierarchy
        self.fitter = fitter
        self.config = config
        self.backoff = CreationBackoff()

    def context_candidates(self, roles: frozenset[Role]) -> tuple[RoleSpace, ...]:
        """`spaces.context_candidates` of `roles`, with the properties this world's actor
        has."""
        return context_candidates(roles, self.fitter.reader.actor_contexts)

    def non_null_spaces(self, t: np.ndarray) -> list[RoleSpace]:
        outputs = OPEN_OUTPUT_SPACES if self.config.open_outputs else OUTPUT_SPACES
        return [space for space in outputs if self.fitter.reader.declares(space)
                and self.fitter.changed(space, t)[1].any()]

    def pick_spaces(self, spaces: list[RoleSpace],
                    rng: np.random.Generator) -> list[RoleSpace]:
        """The spaces Algorithm 2 adapts H to, in order. With `paper_picks`, PickSpace k
        times (k = len(spaces), with replacement: the same number of picks, drawn as the
        paper draws them); otherwise each space once, in random order."""
        if not spaces:
            return []
        if self.config.paper_picks:
            drawn = rng.integers(len(spaces), size=len(spaces))
        else:
            drawn = rng.permutation(len(spaces))
        return [spaces[int(i)] for i in drawn]

    def run(self, t0: int, t1: int, iteration: int, episode: int,
            rng: np.random.Generator) -> list[Event]:
        """Adapt H to the learning episode made of iterations [t0, t1)."""
        start = len(self.h.events)
        t = np.arange(t0, t1, dtype=np.int64)
        spaces = self.non_null_spaces(t)
        adapted: set[RoleSpace] = set()
        for space in self.pick_spaces(spaces, rng):
            if space in adapted:
                continue  # (paper picks) drawn again: its data are in its affordances already
            adapted.add(space)
            self._teach_pooled(self.h.with_output(space), t, rng)
            for aff in self.h.with_output(space):
                self._update(aff, t, iteration, rng)
            if self.config.paper_matching and self._explained_elsewhere(space, t, iteration,
                                                                        rng):
                continue  # the paper creates an affordance only when none matched
            self._try_create(space, iteration, episode, rng)
        if OBJECT_POSITION not in adapted:
            # A push into a fixed object moves nothing, yet p_A has something to learn from it.
            self._teach_pooled(self.h.with_output(OBJECT_POSITION), t, rng)
        self._delete_false(iteration)
        return self.h.events[start:]

    # ------------------------------------------------------------------ existing affordances
    def _explained_elsewhere(self, space: RoleSpace, t: np.ndarray, iteration: int,
                             rng: np.random.Generator) -> bool:
        """With `paper_matching`: whether the data of `space` at iterations `t` match an
        affordance of another output (`matches_other_output`), in H's order. Without
        `paper_match_adds`, the first match settles it; with it, every affordance is tried, as
        the paper's loop over H does, and each that matches (or is made to match by a
        context, `_borrow`) takes the data in."""
        if not self.config.paper_match_adds:
            return any(self.matches_other_output(aff, space, t, rng)
                       for aff in self.h if aff.output != space)
        matched = False
        for aff in list(self.h):
            if aff.output != space:
                matched |= self._borrow(aff, space, t, iteration, rng)
        return matched

    def _other_output_rows(self, aff: Affordance, space: RoleSpace, t: np.ndarray,
                           rng: np.random.Generator) -> Rows | None:
        """The rows of iterations `t` whose data of `space` an affordance `aff` of another
        output is matched against (see `matches_other_output`); None when there are none."""
        f = self.fitter
        out = aff.output
        if borrowed_space(out) != space or aff.model.n < 3:
            return None  # (a position for a position: nothing else is another output's)
        sample = f.values(aff.input, space, aff.contexts, f.bindings(aff.roles | space.roles, t))
        keep = np.ones(len(sample.rows), dtype=bool)
        if aff.input is not ACTION:
            keep &= f.nonzero(sample.x)
        if space.role is Role.TARGET:
            # S is one object's space in the paper: objects that never moved are not picked.
            seen, changed = f.changed(space, t)
            keep &= np.isin(sample.rows.target, seen.target[changed])
        sample = sample.take(np.flatnonzero(keep))
        if not f.nonzero(sample.y).any():
            return None
        return f.select_rows(sample, rng)

    def _competence_with(self, aff: Affordance, contexts: tuple[RoleSpace, ...], rows: Rows,
                         rng: np.random.Generator) -> float:
        """Held-out competence of `aff` with `contexts`, fitted on its rows and on `rows` of
        another output (read as borrowed: in that output's space)."""
        f = self.fitter
        if contexts == aff.contexts:
            model = f.new_model(aff.input, aff.output, contexts, trial=True)
            model.add(*aff.model.data())
        else:
            model = f.fit(aff.input, aff.output, contexts, aff.rows, trial=True)
        s = f.values(aff.input, aff.output, contexts, rows.lending())
        model.add(s.x, s.c, s.y)
        return f.competence(model, rng)

    def matches_other_output(self, aff: Affordance, space: RoleSpace, t: np.ndarray,
                             rng: np.random.Generator) -> bool:
        """The paper's Matches(A, a, ω_S) for an affordance whose output is not S: A's model,
        given the rows of iterations `t` in its domain (its input changed; every row for the
        action input) with S's outcome in place of its own — for S an object's position, the
        rows of the objects that moved in `t` (the paper's spaces are an object's; one that
        never moved is no picked space) — all non-null ones and a bounded share of null ones
        (`Fitter.select_rows`), keeps its held-out competence within
        `match_tolerance`. Only an output of the same property can (a position for a
        position): another kind of quantity is not A's to predict. Nothing is added to A
        here (`_borrow` does, with `paper_match_adds`)."""
        rows = self._other_output_rows(aff, space, t, rng)
        return rows is not None and self._keeps_competence(aff, rows, rng)

    def _keeps_competence(self, aff: Affordance, rows: Rows, rng: np.random.Generator) -> bool:
        """Matches: `aff` given the borrowed `rows` keeps its held-out competence within
        `match_tolerance`."""
        return (self._competence_with(aff, aff.contexts, rows, rng)
                >= aff.competence - self.config.match_tolerance)

    def _borrow(self, aff: Affordance, space: RoleSpace, t: np.ndarray, iteration: int,
                rng: np.random.Generator) -> bool:
        """Algorithm 2's body for an affordance `aff` of another output than `space`, as the
        paper writes it (`paper_match_adds`): when the data match, they are added to `aff`
        (as borrowed rows, `Rows.borrowed`); when not, k' context spaces are picked at random
        among `aff`'s candidates (k' = their number, with replacement) and the first with
        which `aff` holds the data at competence ≥ τ_modification is added to its contexts,
        the data with it. Returns whether `aff` matched."""
        rows = self._other_output_rows(aff, space, t, rng)
        if rows is None:
            return False
        if self._keeps_competence(aff, rows, rng):
            self._take_in(aff, aff.contexts, rows, iteration, rng)
            return True
        every = self.context_candidates(aff.input.roles | aff.output.roles)
        candidates = [c for c in every if c not in aff.contexts]
        for _ in range(len(candidates)):
            c = candidates[int(rng.integers(len(candidates)))]
            contexts = (*aff.contexts, c)
            if self._competence_with(aff, contexts, rows, rng) >= self.config.tau_modification:
                self._take_in(aff, contexts, rows, iteration, rng)
                self.h.record(aff, EventKind.CONTEXT_ADDED, iteration, added=c.name,
                              borrowed=space.name)
                return True
        return False

    def _take_in(self, aff: Affordance, contexts: tuple[RoleSpace, ...], rows: Rows,
                 iteration: int, rng: np.random.Generator) -> None:
        """Add `rows` of another output to `aff` (borrowed) with `contexts`, and refit."""
        f = self.fitter
        aff.rows = aff.rows.concat(rows.lending())
        if contexts == aff.contexts:
            s = f.values(aff.input, aff.output, contexts, rows.lending())
            aff.model.add(s.x, s.c, s.y)
        else:
            aff.contexts = contexts
            aff.model = f.fit(aff.input, aff.output, contexts, aff.rows)
        aff.competence = f.competence(aff.model, rng)
        aff.history.append((iteration, aff.competence))

    def _accept_mask(self, aff: Affordance, sample: Sample) -> np.ndarray | None:
        if aff.classifier is None or aff.classifier.n_positive == 0:
            return None
        return aff.classifier.accepts(self.fitter.target_features(sample.rows))

    def _update(self, aff: Affordance, t: np.ndarray, iteration: int,
                rng: np.random.Generator) -> None:
        f = self.fitter
        sample = f.candidate_rows(aff.input, aff.output, t)
        if len(sample.rows) == 0:
            return
        rows = f.select_rows(sample, rng, self._accept_mask(aff, sample))
        if len(rows) == 0:
            return
        before, old_rows = aff.competence, aff.rows
        s = f.values(aff.input, aff.output, aff.contexts, rows)
        aff.model.add(s.x, s.c, s.y)
        aff.rows = aff.rows.concat(rows)
        aff.competence = f.competence(aff.model, rng)
        matched = aff.competence >= before - self.config.match_tolerance
        review = len(aff.history) % self.config.context_review_every == 0
        if not matched or review:
            self._adapt_context(aff, iteration, rng)
        if aff.competence < before - self.config.match_tolerance:
            # The paper: data no context makes fit are not this affordance's.
            aff.rows = old_rows
            aff.model = f.fit(aff.input, aff.output, aff.contexts, old_rows)
            aff.competence = f.competence(aff.model, rng)
        aff.history.append((iteration, aff.competence))
        low = aff.competence < self.config.tau_deletion
        aff.low_streak = aff.low_streak + 1 if low else 0

    def _context_options(self, aff: Affordance) -> list[tuple[EventKind, tuple[RoleSpace, ...],
                                                            dict[str, str]]]:
        roles = aff.input.roles | aff.output.roles
        current = aff.contexts
        every = self.context_candidates(roles)
        candidates = [c for c in every if c not in current]
        options: list[tuple[EventKind, tuple[RoleSpace, ...], dict[str, str]]] = []
        for c in candidates:
            options.append((EventKind.CONTEXT_ADDED, (*current, c), {"added": c.name}))
        if len(current) >= 2:
            # Restarts from one context let the search leave a local optimum that needs two
            # single changes, each too small to pass `context_gain` on its own.
            for c in every:
                options.append((EventKind.CONTEXT_REPLACED, (c,),
                                {"removed": ", ".join(x.name for x in current if x != c),
                                 "added": "" if c in current else c.name}))
        for old in current:
            rest = tuple(x for x in current if x != old)
            options.append((EventKind.CONTEXT_REMOVED, rest, {"removed": old.name}))
            for c in candidates:
                options.append((EventKind.CONTEXT_REPLACED, (*rest, c),
                                {"removed": old.name, "added": c.name}))
        return options

    def _subsample(self, rows: Rows, rng: np.random.Generator) -> Rows:
        n = self.config.creation_rows
        if len(rows) <= n:
            return rows
        return rows.take(np.sort(rng.choice(len(rows), size=n, replace=False)))

    def _adapt_context(self, aff: Affordance, iteration: int, rng: np.random.Generator) -> None:
        f, cfg = self.fitter, self.config
        rows = self._subsample(aff.rows, rng)
        seed = int(rng.integers(2**63 - 1))

        def score(contexts: tuple[RoleSpace, ...]) -> float:
            return f.trial(aff.input, aff.output, contexts, rows, np.random.default_rng(seed))

        def penalty(contexts: tuple[RoleSpace, ...]) -> float:
            return foreign_penalty(aff.input, aff.output, contexts, cfg)

        baseline = score(aff.contexts)
        scored = [(score(contexts), kind, contexts, detail)
                  for kind, contexts, detail in self._context_options(aff)]
        if not scored:
            return
        margin, value, kind, contexts, detail = max(
            ((value - required_gain(len(aff.contexts), len(contexts), cfg.context_gain)
              - penalty(contexts), value, kind, contexts, detail)
             for value, kind, contexts, detail in scored),
            key=lambda option: option[0])
        if margin < baseline - penalty(aff.contexts):
            return
        if value < cfg.tau_modification:
            return
        aff.contexts = tuple(contexts)
        aff.model = f.fit(aff.input, aff.output, aff.contexts, aff.rows)
        aff.competence = f.competence(aff.model, rng)
        self.h.record(aff, kind, iteration, **detail)

    def _examples(self, aff: Affordance, sample: Sample) -> tuple[Rows, np.ndarray]:
        """p_A's examples from `aff`'s rows: the rows and their labels. Positives: targets
        that moved. Negatives: for an object-moving affordance none here (they are the objects
        that refused the robot, `_refused`); for another, targets it was applied to that did
        not respond.

        Applied to means touched by the actor (the robot, or the tool for a tool affordance)
        before an action the model predicts to move it clearly. The model's errors (the robot
        grazing or backing away from a pushable object) would still make negatives of objects
        that do respond, so an object that moved at any time of the environment episode is
        no negative of it: within an episode its properties are the same.
        """
        moved = self.fitter.nonzero(sample.y)
        if aff.output == OBJECT_POSITION:
            negative = np.zeros_like(moved)  # the negatives are `_refused`'s
        else:
            negative = self._applied_in_vain(aff, sample, moved)
        pick = moved | negative
        rows = sample.rows.take(np.flatnonzero(pick))
        return rows, moved[pick]

    def _teach_pooled(self, affs: list[Affordance], t: np.ndarray,
                      rng: np.random.Generator) -> None:
        """p_A of every affordance in `affs` (one output) learns the examples of all of them,
        and for the object-moving ones the objects that refused the robot (`_refused`).
        Whether an object's position can be changed is the object's (docs/algorithm.md, p_A):
        a fixed object stops the robot, so it is seldom a row of the affordance acting from the
        robot's position, yet the one acting from the actions sees it refuse to move."""
        affs = [a for a in affs if a.classifier is not None]
        rows, labels = Rows.empty(), np.zeros(0, dtype=bool)
        for aff in affs:
            sample = self.fitter.candidate_rows(aff.input, aff.output, t)
            if len(sample.rows) == 0:
                continue
            r, y = self._examples(aff, sample)
            rows, labels = rows.concat(r), np.concatenate([labels, y])
        if any(a.output == OBJECT_POSITION for a in affs):
            refused = self._refused(t)
            rows = rows.concat(refused)
            labels = np.concatenate([labels, np.zeros(len(refused), dtype=bool)])
        if len(rows) == 0:
            return
        for aff in affs:
            self._teach(aff, rows, labels, rng)

    def _teach(self, aff: Affordance, rows: Rows, labels: np.ndarray,
               rng: np.random.Generator) -> None:
        """Add one example per (entity, label) of `rows` and the robot (it cannot be the
        target of an affordance acting from it) to p_A's replay, then train it."""
        assert aff.classifier is not None
        if len(rows) == 0:
            return
        f = self.fitter
        features = f.target_features(rows)
        # One example per (entity, label) per episode keeps the replay balanced across objects.
        _, first = np.unique(np.stack([rows.target, labels.astype(np.int64)], axis=1), axis=0,
                             return_index=True)
        first = np.sort(first)
        features, labels = features[first], labels[first]
        robot = f.target_features(rows.take(np.zeros(1, dtype=np.int64)),
                                  entity=np.zeros(1, dtype=np.int64))
        features = np.concatenate([features, robot])
        labels = np.concatenate([labels, [False]])
        aff.classifier.add(features, labels)
        aff.classifier.train(rng, steps=self.config.classifier_steps)

    def _applied_in_vain(self, aff: Affordance, sample: Sample, moved: np.ndarray) -> np.ndarray:
        """Rows whose target the actor touched, the model predicted to move, and which did not
        move at all in the environment episode up to the end of `sample`."""
        f = self.fitter
        negative = np.zeros_like(moved)
        if aff.model.n < 3 or moved.all():
            return negative
        actor = Role.TOOL if aff.has_tool else Role.ROBOT
        idx = np.flatnonzero(~moved)
        idx = idx[f.touching(sample.rows.take(idx), actor, after=False)]
        if idx.size == 0:
            return negative
        full = f.values(aff.input, aff.output, aff.contexts, sample.rows.take(idx))
        predicted = np.linalg.norm(aff.model.predict(full.x, full.c), axis=1)
        # Only a clear predicted effect makes a negative: small errors must not.
        idx = idx[predicted > max(0.25 * typical_step(aff), 2 * self.config.zero_eps)]
        if idx.size == 0:
            return negative
        t_end = int(sample.rows.t.max()) + 1
        t = np.arange(f.dataset.episode_start(int(sample.rows.t.min())), t_end, dtype=np.int64)
        rows, changed = f.changed(aff.output, t)
        responded = np.unique(rows.target[changed])
        negative[idx[~np.isin(sample.rows.target[idx], responded)]] = True
        return negative

    def _refused(self, t: np.ndarray) -> Rows:
        """The objects that refused the robot at iterations `t`: the robot
        touched the object before the action, its motion model (the most competent controller
        of its position from the actions) meant to carry it at least half its step into the
        object, the robot moved less than half as far as it meant (it was stopped), and the
        object did not move in the environment episode up to the end of `t`. A fixed object
        stops the robot, so these rows are outside the pushing affordance's domain; a graze
        (moving along the object) or backing away is no refusal, whatever a pushing model
        expects of it, and neither is a move a young motion model (no heading context yet)
        misplaces: the robot went where it went. Rows bind the target only."""
        f = self.fitter
        movers = [a for a in self.h.controllers(ROBOT_POSITION) if a.input is ACTION]
        if not movers or movers[0].model.n < 3 or t.size == 0:
            return Rows.empty()
        rows = f.bindings(OBJECT_POSITION.roles, t)
        rows = rows.take(np.flatnonzero(f.touching(rows, Role.ROBOT, after=False)))
        if len(rows) == 0:
            return rows
        mover = movers[0]
        m = f.values(mover.input, mover.output, mover.contexts, rows)
        meant = mover.model.predict(m.x, m.c if m.c.shape[1] else None)
        d = f.dataset
        centre = f.reader.read(TARGET_ROBOT, d.contexts, rows, raw=True)  # target − robot
        contact = f.reader.contact(TARGET_ROBOT, d.contexts, rows)
        step = np.linalg.norm(meant, axis=1)
        depth = contact - np.linalg.norm(centre - meant, axis=1)
        went = np.linalg.norm(f.reader.read(ROBOT_POSITION, d.outcomes, rows), axis=1)
        moved = f.nonzero(f.reader.read(OBJECT_POSITION, d.outcomes, rows))
        into = (step > 2 * self.config.zero_eps) & (depth > 0.5 * step) & (went < 0.5 * step) \
            & ~moved
        rows = rows.take(np.flatnonzero(into))
        if len(rows) == 0:
            return rows
        episode = np.arange(d.episode_start(int(rows.t.min())), int(t.max()) + 1, dtype=np.int64)
        seen, changed = f.changed(OBJECT_POSITION, episode)
        still = ~np.isin(rows.target, np.unique(seen.target[changed]))
        return rows.take(np.flatnonzero(still))

    # ------------------------------------------------------------------ creation and deletion
    def _creation_rows(self, inp: RoleSpace, out: RoleSpace, rng: np.random.Generator) -> Rows:
        f = self.fitter
        sample = f.all_candidates(inp, out)  # candidate_rows over all of D, kept up to date
        rows = f.select_rows(sample, rng)
        return self._subsample(rows, rng)

    def _best_candidate(self, inp: RoleSpace, out: RoleSpace, rows: Rows,
                        rng: np.random.Generator) -> tuple[float, tuple[RoleSpace, ...]]:
        f = self.fitter
        seed = int(rng.integers(2**63 - 1))

        def score(contexts: tuple[RoleSpace, ...]) -> float:
            return f.trial(inp, out, contexts, rows, np.random.default_rng(seed))

        def rank(option: tuple[float, tuple[RoleSpace, ...]]) -> float:
            return option[0] - foreign_penalty(inp, out, option[1], self.config)

        bare = score(())
        options = [(bare, ())] + [(score((c,)), (c,))
                                  for c in self.context_candidates(inp.roles | out.roles)]
        best = max(options, key=rank)  # the first of equals: no context before any
        # A context must earn its place as in a context change: by `context_gain` over none.
        if best[1] and bare >= self.config.tau_creation \
                and rank(best) - bare < self.config.context_gain:
            return bare, ()
        return best

    def _try_create(self, out: RoleSpace, iteration: int, episode: int,
                    rng: np.random.Generator) -> None:
        best: tuple[float, RoleSpace, tuple[RoleSpace, ...], Rows] | None = None
        for inp in self.h.candidate_inputs(out):
            if not self.backoff.ready(inp, out, episode):
                continue
            rows = self._creation_rows(inp, out, rng)
            nonzero = self.fitter.nonzero(self.fitter.values(inp, out, (), rows).y).sum()
            if nonzero < 5:
                self.backoff.failed(inp, out, episode)
                continue
            value, contexts = self._best_candidate(inp, out, rows, rng)
            if value < self.config.tau_creation:
                self.backoff.failed(inp, out, episode)
                continue
            if best is None or value > best[0]:
                best = (value, inp, contexts, rows)
        if best is None:
            return
        _, inp, contexts, rows = best
        aff = self.fitter.new_affordance(self.h.allocate_id(), inp, out, contexts, rows,
                                         iteration, rng)
        self.h.add(aff, iteration)

    def _delete_false(self, iteration: int) -> None:
        for aff in list(self.h):
            if aff.low_streak >= self.config.deletion_patience and self.h.deletable(aff):
                self.h.delete(aff, iteration)

