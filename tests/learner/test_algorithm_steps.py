"""Each step of Algorithms 1 and 2 on hand-built data: a one-line bug in any of them fails a
test here (docs/testing.md lists the behaviours and the mutation run that measures them).

The data (`handmade.Room`): a differential drive whose displacement is a function of the
action *and the heading*; or, with a fixed heading, of the action alone; or noise.
"""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest
from handmade import (
    ROBOT_HEADING,
    ROBOT_LIDAR,
    ROBOT_POSITION,
    STEP,
    TARGET_POSITION,
    TARGET_ROBOT,
    TOOL_POSITION,
    Room,
)

from hadim_cli.learner.adaptation import CreationBackoff
from hadim_cli.learner.affordance import Affordance
from hadim_cli.learner.competence import model_competence, range_scale
from hadim_cli.learner.explorer import Fallback, Mode
from hadim_cli.learner.goals import Attempt
from hadim_cli.learner.hierarchy import EventKind
from hadim_cli.learner.spaces import ACTION, Role, RoleSpace, Rows
from hadim_cli.world.layout import Property


# ---------------------------------------------------------------------- competence
def test_competence_is_scored_on_held_out_rows():
    """Noise has nothing to learn. A model fitted on few neighbours (k = 1 or 3) reproduces
    each row it was fitted on: scored in-sample it would look perfect; held out, it misses."""
    for k in (1, 3):
        room = Room(k_forward=k)
        t = room.moves(np.random.default_rng(0), 200, noise=True)
        assert room.fitter.trial(ACTION, ROBOT_POSITION, (), room.rows(t),
                                 np.random.default_rng(1)) < 0.1
    room = Room()
    t = room.moves(np.random.default_rng(0), 200)
    assert room.fitter.trial(ACTION, ROBOT_POSITION, (ROBOT_HEADING,), room.rows(t),
                             np.random.default_rng(1)) > 0.6


# ---------------------------------------------------------------------- context changes
@pytest.mark.parametrize(("fixed_heading", "start", "kind", "end"), [
    (False, (), EventKind.CONTEXT_ADDED, (ROBOT_HEADING,)),
    (False, (ROBOT_POSITION,), EventKind.CONTEXT_REPLACED, (ROBOT_HEADING,)),
    (False, (ROBOT_HEADING, ROBOT_POSITION), None, (ROBOT_HEADING,)),
    (True, (ROBOT_POSITION,), EventKind.CONTEXT_REMOVED, ()),
])
def test_a_context_change_reaches_the_context_the_data_need(fixed_heading, start, kind, end):
    """Add the heading a drive needs, replace a useless context by it, drop a useless one
    (with a fixed heading the action alone says where the robot goes)."""
    room = Room()
    t = room.moves(np.random.default_rng(0), 200, heading=0.4 if fixed_heading else None)
    aff = room.affordance(t, start)
    before = aff.competence
    room.adaptation._adapt_context(aff, 500, np.random.default_rng(2))
    assert aff.contexts == end
    assert aff.competence >= before
    last = room.hierarchy.events[-1]
    if kind is not None:
        assert last.kind == kind and last.affordance_id == aff.id
    assert last.contexts == tuple(c.name for c in end)
    # The model was refitted with the new contexts.
    assert aff.model.data()[1].shape[1] == 2 * len(end)


def test_the_right_context_is_kept():
    """No change earns its gain over the heading: nothing changes, no event."""
    room = Room()
    t = room.moves(np.random.default_rng(0), 200)
    aff = room.affordance(t, (ROBOT_HEADING,))
    n_events = len(room.hierarchy.events)
    room.adaptation._adapt_context(aff, 500, np.random.default_rng(2))
    assert aff.contexts == (ROBOT_HEADING,)
    assert len(room.hierarchy.events) == n_events


def test_a_context_that_does_not_earn_its_gain_is_not_added():
    """The LIDAR says nothing here; with τ_modification out of reach nothing is kept either."""
    room = Room(tau_modification=1.01)
    t = room.moves(np.random.default_rng(0), 200)
    aff = room.affordance(t, ())
    room.adaptation._adapt_context(aff, 500, np.random.default_rng(2))
    assert aff.contexts == ()
    # One heading throughout: the heading adds nothing, and the LIDAR says nothing.
    room = Room(context_gain=0.9)
    t = room.moves(np.random.default_rng(0), 200, heading=0.0)
    aff = room.affordance(t, (ROBOT_LIDAR,))
    room.adaptation._adapt_context(aff, 500, np.random.default_rng(2))
    assert aff.contexts in ((ROBOT_LIDAR,), ())  # replacing it needs 0.45: removing is free


def test_a_replacement_short_of_half_the_gain_is_not_made(monkeypatch):
    """A replacement of one context by another must beat the current contexts by half
    `context_gain` on the held-out split: 0.03 better is not enough for 0.1."""
    room = Room(context_gain=0.1)
    t = room.moves(np.random.default_rng(0), 200)
    aff = room.affordance(t, (ROBOT_LIDAR,))

    lead = {"share": 0.0}  # of `context_gain`, by which the heading beats the LIDAR

    def trial(inp, out, contexts, rows, rng):
        if contexts == (ROBOT_HEADING,):
            return 0.63 + room.config.context_gain * lead["share"]
        return 0.63 if contexts == (ROBOT_LIDAR,) else 0.0

    monkeypatch.setattr(room.fitter, "trial", trial)
    monkeypatch.setattr(room.fitter, "fit", lambda *a, **k: aff.model)
    monkeypatch.setattr(room.fitter, "competence", lambda *a, **k: 0.6)
    for lead["share"], replaced in ((0.3, False), (0.6, True)):
        room.adaptation._adapt_context(aff, 500, np.random.default_rng(2))
        assert (aff.contexts == (ROBOT_HEADING,)) is replaced


TARGET_TOOL = RoleSpace(Role.TARGET, Property.POSITION, Role.TOOL)


def _tool_scores(robot_lead: float):
    """Held-out scores of a tool affordance's contexts: the tool's relation to the target
    0.66, the robot's `robot_lead` above it, none 0.4, anything else 0.3."""
    def trial(inp, out, contexts, rows, rng):
        if contexts == (TARGET_TOOL,):
            return 0.66
        if contexts == (TARGET_ROBOT,):
            return 0.66 + robot_lead
        return 0.4 if contexts == () else 0.3
    return trial


@pytest.mark.parametrize(("robot_lead", "chosen"), [
    (0.07, TARGET_TOOL),    # the robot's relation leads by less than the gain
    (0.12, TARGET_ROBOT),   # … by more: it has earned its place
])
def test_a_tool_affordance_is_created_with_the_tools_relation_unless_the_robots_earns_it(
        robot_lead, chosen, monkeypatch):
    """A context about an entity a push through a tool neither acts with nor on (the robot,
    trailing the tool) counts as one more context, so must beat the others by
    `context_gain` when the affordance is created: seed 17 created its tool affordance with
    the robot's relation to the target (still 0.02 ahead of the tool's on its 133 rows at
    2000), and its tool level placed the robot for 1200 iterations (push-with-tool 0.00 at
    2000)."""
    room = Room(context_gain=0.1)
    monkeypatch.setattr(room.fitter, "trial", _tool_scores(robot_lead))
    rows = room.rows(np.zeros(0, dtype=np.int64))
    value, contexts = room.adaptation._best_candidate(TOOL_POSITION, TARGET_POSITION, rows,
                                                      np.random.default_rng(0))
    assert contexts == (chosen,)
    assert value == _tool_scores(robot_lead)(None, None, contexts, None, None)


@pytest.mark.parametrize(("start", "robot_lead", "end"), [
    (TARGET_ROBOT, 0.02, TARGET_TOOL),    # 0.02 < 0.1 (robot) − 0.05 (replacement)
    (TARGET_ROBOT, 0.08, TARGET_ROBOT),   # 0.08 > 0.05: the robot's earns its place
    (TARGET_TOOL, 0.12, TARGET_TOOL),     # 0.12 < 0.05 (replacement) + 0.1 (robot)
    (TARGET_TOOL, 0.16, TARGET_ROBOT),    # 0.16 > 0.15
])
def test_a_tool_affordance_holds_the_robots_relation_only_while_it_earns_it(
        start, robot_lead, end, monkeypatch):
    """A context review of a tool affordance: the robot's relation to the target is given up
    for the tool's when it leads by less than `context_gain` less a replacement's margin
    (half of it), and taken over the tool's only when it leads by both."""
    room = Room(context_gain=0.1)
    t = room.moves(np.random.default_rng(0), 50)
    aff = room.affordance(t, (start,), inp=TOOL_POSITION, out=TARGET_POSITION)
    monkeypatch.setattr(room.fitter, "trial", _tool_scores(robot_lead))
    monkeypatch.setattr(room.fitter, "fit", lambda *a, **k: aff.model)
    monkeypatch.setattr(room.fitter, "competence", lambda *a, **k: 0.6)
    n_events = len(room.hierarchy.events)
    room.adaptation._adapt_context(aff, 500, np.random.default_rng(2))
    assert aff.contexts == (end,)
    assert len(room.hierarchy.events) == n_events + (end != start)


def test_only_a_relation_to_an_entity_outside_the_affordance_is_held_back():
    """The robot's relation to the target is the push's own, from the robot's position or
    from its wheel commands; through a tool it is another entity's, as the robot's heading
    is. The tool's relation and the objects' own properties are the tool affordance's."""
    from hadim_cli.learner.adaptation import foreign_penalty

    cfg = Room(context_gain=0.1).config
    for inp, out, contexts, penalty in [
            (ACTION, TARGET_POSITION, (TARGET_ROBOT,), 0.0),
            (ROBOT_POSITION, TARGET_POSITION, (TARGET_ROBOT,), 0.0),
            (ACTION, ROBOT_POSITION, (ROBOT_HEADING,), 0.0),
            (TOOL_POSITION, TARGET_POSITION, (TARGET_TOOL,), 0.0),
            (TOOL_POSITION, TARGET_POSITION, (RoleSpace(Role.TOOL, Property.RADIUS),), 0.0),
            (TOOL_POSITION, TARGET_POSITION, (TARGET_ROBOT,), 0.1),
            (TOOL_POSITION, TARGET_POSITION, (TARGET_TOOL, ROBOT_HEADING), 0.1)]:
        assert foreign_penalty(inp, out, contexts, cfg) == pytest.approx(penalty)


# ---------------------------------------------------------------------- match
def _recorded_context_trials(room: Room, monkeypatch) -> list[int]:
    calls: list[int] = []
    monkeypatch.setattr(room.adaptation, "_adapt_context",
                        lambda aff, iteration, rng: calls.append(aff.id))
    return calls


@pytest.mark.parametrize("noise", [False, True])
def test_rows_that_do_not_match_trigger_a_context_search(noise, monkeypatch):
    """An episode like the affordance's data matches (no search, its rows absorbed); noise
    does not (search; what no context makes fit is given back, see below)."""
    room = Room(context_review_every=1000)
    rng = np.random.default_rng(0)
    aff = room.affordance(room.moves(rng, 150), (ROBOT_HEADING,))
    calls = _recorded_context_trials(room, monkeypatch)
    start = room.episode()
    t = room.moves(rng, 60, noise=noise)
    n_rows = len(aff.rows)
    room.adaptation._update(aff, t, len(room.dataset), rng)
    if not noise:
        assert len(aff.rows) == n_rows + len(t)
        assert int(aff.rows.t.min()) == 0 and int(aff.rows.t.max()) == len(room.dataset) - 1
    assert calls == ([aff.id] if noise else [])
    assert aff.history[-1] == (len(room.dataset), aff.competence)
    assert start == int(t[0])


def test_rows_that_no_context_makes_fit_are_given_back(monkeypatch):
    """The paper's Algorithm 2: noise that lowers the affordance's competence and no context
    change mends is not kept; a matching episode is."""
    room = Room(context_review_every=1000)
    rng = np.random.default_rng(0)
    aff = room.affordance(room.moves(rng, 150), (ROBOT_HEADING,))
    _recorded_context_trials(room, monkeypatch)  # no context change can help
    before = aff.competence
    room.episode()
    n_rows = len(aff.rows)
    room.adaptation._update(aff, room.moves(rng, 60, noise=True), len(room.dataset), rng)
    assert len(aff.rows) == n_rows
    assert aff.model.n == len(aff.rows)
    assert aff.competence >= before - room.config.match_tolerance
    room.episode()
    room.adaptation._update(aff, room.moves(rng, 20), len(room.dataset), rng)
    assert len(aff.rows) == n_rows + 20


def test_contexts_are_reviewed_every_few_updates_even_when_rows_match(monkeypatch):
    room = Room(context_review_every=3)
    rng = np.random.default_rng(0)
    aff = room.affordance(room.moves(rng, 150), (ROBOT_HEADING,))
    calls = _recorded_context_trials(room, monkeypatch)
    for _ in range(6):
        room.episode()
        room.adaptation._update(aff, room.moves(rng, 10), len(room.dataset), rng)
    # history holds the creation, then one entry per update: reviews at lengths 3 and 6.
    assert calls == [aff.id, aff.id]


# ---------------------------------------------------------------------- creation
def test_creation_finds_the_drive_and_its_context():
    room = Room()
    rng = np.random.default_rng(0)
    room.episode()
    t = room.moves(rng, 200)
    events = room.adaptation.run(int(t[0]), int(t[-1]) + 1, len(room.dataset), 0, rng)
    created = [e for e in events if e.kind is EventKind.CREATED]
    assert [(e.input, e.output) for e in created] == [("action", "robot.position"),
                                                     ("action", "robot.heading")]
    mover = room.hierarchy.with_output(ROBOT_POSITION)[0]
    assert mover.contexts == (ROBOT_HEADING,)  # born with the context its data need
    assert mover.competence >= room.config.tau_creation
    assert len(mover.rows) > 0 and mover.model.n == len(mover.rows)


def test_nothing_is_created_from_noise_and_the_trial_backs_off():
    room = Room()
    rng = np.random.default_rng(0)
    room.episode()
    room.moves(rng, 40, noise=True)
    room.adaptation._try_create(ROBOT_POSITION, len(room.dataset), 7, rng)
    assert len(room.hierarchy) == 0
    backoff = room.adaptation.backoff
    assert not backoff.ready(ACTION, ROBOT_POSITION, 8)
    assert backoff.ready(ACTION, ROBOT_POSITION, 9)
    # Learnable data arrive, but the trial waits for its turn.
    room.moves(rng, 800)
    room.adaptation._try_create(ROBOT_POSITION, len(room.dataset), 8, rng)
    assert len(room.hierarchy) == 0
    room.adaptation._try_create(ROBOT_POSITION, len(room.dataset), 9, rng)
    assert len(room.hierarchy) == 1


@pytest.mark.parametrize(("moving", "created"), [(4, False), (5, True)])
def test_creation_is_tried_from_five_rows_where_the_output_moved(moving, created):
    """Fewer than five rows where the output moved are too few to try an affordance: the
    trial backs off. From five it is tried (here with τ_creation 0, so a trial creates)."""
    room = Room(tau_creation=0.0)
    rng = np.random.default_rng(0)
    room.episode()
    room.set("robot", Property.HEADING, [1.0, 0.0])
    room.set("robot", Property.LIDAR, [1.0] * 4)  # clear of everything
    for action in ([0.5, 0.9], [0.9, 0.3], [-0.6, -0.8], [0.4, 0.4], [-0.9, -0.2])[:moving]:
        before = room.obs.copy()
        here = before[room.layout.space("robot", Property.POSITION).slice]
        room.place("robot", here + (STEP * np.mean(action), 0.0))
        room.dataset.append(np.array(action), before, room.obs.copy())
    for _ in range(30):  # nothing moves
        still = room.obs.copy()
        room.dataset.append(rng.uniform(-1.0, 1.0, 2), still, still)
    room.adaptation.run(0, len(room.dataset), len(room.dataset), 0, rng)
    made = [a for a in room.hierarchy if a.output == ROBOT_POSITION]
    assert len(made) == int(created)
    assert room.adaptation.backoff.ready(ACTION, ROBOT_POSITION, 1) is created


def test_creation_offers_no_input_that_closes_a_cycle_and_the_tool_only_for_an_object():
    """The inputs creation may try for an output: the actions and the controllable spaces the
    output does not already drive through H (A(heading → position) beside A(position →
    heading) would close a cycle), and the tool's position, once something pushes objects,
    for an object's output only."""
    room = Room()
    rng = np.random.default_rng(0)
    t = room.moves(rng, 60)
    room.affordance(t, out=ROBOT_HEADING)
    assert room.hierarchy.candidate_inputs(ROBOT_POSITION) == [ACTION, ROBOT_HEADING]
    room.affordance(t, inp=ROBOT_POSITION, out=ROBOT_HEADING)
    assert room.hierarchy.candidate_inputs(ROBOT_POSITION) == [ACTION]
    assert TOOL_POSITION not in room.hierarchy.candidate_inputs(TARGET_POSITION)
    room.affordance(t, inp=ROBOT_POSITION, out=TARGET_POSITION)
    assert TOOL_POSITION in room.hierarchy.candidate_inputs(TARGET_POSITION)
    assert TOOL_POSITION not in room.hierarchy.candidate_inputs(ROBOT_LIDAR)


def test_an_affordances_competence_measures_its_errors_against_the_range_of_its_outputs():
    """C(e) expects errors of a few percent of the output's range (docs/algorithm.md): the
    fitter scores a model with the range scale, not the outputs' RMS norm."""
    room = Room()
    rng = np.random.default_rng(0)
    t = np.concatenate([room.moves(rng, 100), room.moves(rng, 50, noise=True)])
    aff = room.affordance(t, (ROBOT_HEADING,))
    cfg = room.config
    y = aff.model.data()[2]

    def scored(scale):
        return model_competence(aff.model, zero_eps=cfg.zero_eps,
                                sharpness=cfg.competence_sharpness,
                                max_rows=cfg.competence_rows, rng=np.random.default_rng(3),
                                scale=scale, neighbours=cfg.k_forward).competence

    ranged = scored(range_scale(y, cfg.zero_eps))
    assert abs(ranged - scored(None)) > 0.01  # the premise: the two scales score apart
    assert room.fitter.competence(aff.model, np.random.default_rng(3)) == pytest.approx(ranged)


def test_a_competence_is_scored_with_the_trials_neighbourhood_whatever_the_models_own():
    """Every competence leaves rows out with `k_forward` neighbours, the context trials'
    neighbourhood: a model that chose a wider one to predict with scores as the same rows
    fitted with `k_forward` do, and its predictions are its own neighbourhood's."""
    room = Room()
    t = room.moves(np.random.default_rng(1), 300)
    wide = room.affordance(t, (ROBOT_HEADING,), add=False)
    narrow = room.fitter.fit(wide.input, wide.output, wide.contexts, room.rows(t), trial=True)
    inner = wide.model.inner
    inner.k_fit = 60
    assert narrow.params()["k_choices"] == () and room.config.k_forward == 10
    score = room.fitter.competence
    assert score(wide.model, np.random.default_rng(2)) == \
        score(narrow, np.random.default_rng(2))
    assert not np.allclose(wide.model.predict_loo(), narrow.predict_loo())


def test_the_candidate_rows_of_a_growing_d_are_those_of_the_whole_d():
    """The fitter keeps the candidate rows of every iteration and extends them as D grows:
    after each growth they are, field by field, the rows read from all of D at once."""
    room = Room()
    rng = np.random.default_rng(0)
    for n in (30, 12, 1):
        room.moves(rng, n)
        kept = room.fitter.all_candidates(ACTION, ROBOT_POSITION)
        whole = room.fitter.candidate_rows(ACTION, ROBOT_POSITION,
                                           np.arange(len(room.dataset), dtype=np.int64))
        np.testing.assert_array_equal(kept.rows.t, whole.rows.t)
        for got, want in ((kept.x, whole.x), (kept.c, whole.c), (kept.y, whole.y)):
            np.testing.assert_array_equal(got, want)


def test_back_off_doubles_up_to_sixteen_episodes():
    b = CreationBackoff()
    episode, waits = 0, []
    for _ in range(6):
        b.failed(ACTION, ROBOT_POSITION, episode)
        nxt = b.next_try[CreationBackoff.key(ACTION, ROBOT_POSITION)]
        waits.append(nxt - episode)
        assert not b.ready(ACTION, ROBOT_POSITION, nxt - 1) and b.ready(ACTION, ROBOT_POSITION,
                                                                         nxt)
        episode = nxt
    assert waits == [2, 4, 8, 16, 16, 16]
    assert b.ready(ACTION, ROBOT_HEADING, 0)  # other pairs are not held back


def test_an_input_already_used_for_an_output_is_not_created_again():
    room = Room()
    rng = np.random.default_rng(0)
    room.affordance(room.moves(rng, 200), (ROBOT_HEADING,))
    room.adaptation._try_create(ROBOT_POSITION, len(room.dataset), 0, rng)
    assert len(room.hierarchy.with_output(ROBOT_POSITION)) == 1


# ---------------------------------------------------------------------- deletion
def test_a_false_affordance_is_deleted_after_its_patience():
    """Low competence for `deletion_patience` updates in a row: deleted, with an event."""
    room = Room(deletion_patience=3, context_review_every=1000)
    rng = np.random.default_rng(0)
    aff = room.affordance(room.moves(rng, 100, noise=True), ())
    assert aff.competence < room.config.tau_deletion
    for k in range(3):
        assert aff.id in room.hierarchy.affordances
        start = room.episode()
        room.moves(rng, 30, noise=True)
        room.adaptation.backoff.next_try["action>robot.position"] = 10**9  # no re-creation
        room.adaptation.backoff.next_try["action>robot.heading"] = 10**9
        room.adaptation.run(start, len(room.dataset), len(room.dataset), k, rng)
        assert aff.low_streak == k + 1
    assert aff.id not in room.hierarchy.affordances
    last = room.hierarchy.events[-1]
    assert (last.kind, last.affordance_id) == (EventKind.DELETED, aff.id)


def test_a_good_update_resets_the_low_streak_and_a_needed_affordance_stays():
    room = Room(deletion_patience=2)
    rng = np.random.default_rng(0)
    aff = room.affordance(room.moves(rng, 200), (ROBOT_HEADING,))
    aff.low_streak = 5
    room.episode()
    room.adaptation._update(aff, room.moves(rng, 20), len(room.dataset), rng)
    assert aff.low_streak == 0
    # The only controller of another affordance's input is never deleted.
    aff.low_streak = 5
    user = room.affordance(np.zeros(0, dtype=np.int64), (), inp=ROBOT_POSITION,
                           out=TARGET_POSITION)
    room.adaptation._delete_false(len(room.dataset))
    assert aff.id in room.hierarchy.affordances
    assert user.low_streak == 0 and user.id in room.hierarchy.affordances


# ---------------------------------------------------------------------- Algorithm 1
class FakeActuator:
    """Counts primitive actions; never runs out."""

    def __init__(self, obs: np.ndarray):
        self.obs = obs
        self.exhausted = False
        self.actions = 0

    def act(self, action: np.ndarray) -> np.ndarray:
        self.actions += 1
        return self.obs


def _planner_that_tries(room: Room, monkeypatch, actions: int = 1) -> list:
    tried: list = []

    def reach(aff, binding, goal, actuator, budget):
        tried.append((aff.id, np.asarray(goal).copy()))
        return Attempt(1.0, 0.5, actions)

    monkeypatch.setattr(room.learner.controller, "reach", reach)
    return tried


@pytest.mark.parametrize("sigma", [0.0, 0.7, 1.0])
def test_sigma_is_the_share_of_goal_babbling(sigma, monkeypatch):
    room = Room(sigma=sigma)
    rng = np.random.default_rng(0)
    room.affordance(room.moves(rng, 100), (ROBOT_HEADING,))
    _planner_that_tries(room, monkeypatch)
    actuator = FakeActuator(room.obs.copy())
    modes = [room.learner.learning_episode(actuator, rng).mode for _ in range(300)]
    share = modes.count(Mode.GOAL) / len(modes)
    assert abs(share - sigma) < 0.08
    # With H empty there is nothing to babble goals for.
    empty = Room(sigma=1.0)
    assert empty.learner.learning_episode(actuator, rng).mode is Mode.RANDOM_ACTION


def test_goal_babbling_picks_affordances_by_interest_and_records_the_attempt(monkeypatch):
    """AffordanceSelection in proportion to interest (ε = 0.2 uniform): with one map at
    interest 0.5 and the other at 0, the first is taken ≈ 90 % of the time. Every attempt is
    recorded in the map of the affordance tried (the interest update)."""
    room = Room(sigma=1.0)
    rng = np.random.default_rng(0)
    t = room.moves(rng, 100)
    keen = room.affordance(t, (ROBOT_HEADING,))
    dull = room.affordance(t, (), out=ROBOT_HEADING)
    for i in range(20):  # a leaf whose competence jumped half-way: learning progress 0.5
        keen.interest.add([0.0, 0.0], 0.0 if i < 10 else 0.5, i)
        dull.interest.add([0.0, 0.0], 0.3, i)
    tried = _planner_that_tries(room, monkeypatch)
    recorded: list[tuple[int, float]] = []
    for aff in (keen, dull):  # record the updates, keep the maps as they are
        monkeypatch.setattr(aff.interest, "add", lambda goal, c, it, aid=aff.id:
                            recorded.append((aid, c)))
    actuator = FakeActuator(room.obs.copy())
    episodes = [room.learner.learning_episode(actuator, rng) for _ in range(300)]
    share = sum(aid == keen.id for aid, _ in tried) / len(tried)
    assert 0.82 < share < 0.97
    assert recorded == [(aid, 0.5) for aid, _ in tried]  # Attempt(1.0, 0.5, …): 1 − 0.5
    # Each episode reports the affordance tried and the competence its attempt reached; the
    # stand-in controller acted on nothing, so there were no rows to adapt H to.
    assert [(e.affordance_id, e.competence) for e in episodes] == [(a, 0.5) for a, _ in tried]
    assert all(e.events == () for e in episodes)


def test_a_goal_attempt_that_cannot_be_planned_falls_back_to_random_babbling(monkeypatch):
    room = Room(sigma=1.0)
    rng = np.random.default_rng(0)
    aff = room.affordance(room.moves(rng, 100), (ROBOT_HEADING,))
    _planner_that_tries(room, monkeypatch, actions=0)
    actuator = FakeActuator(room.obs.copy())
    episodes = [room.learner.learning_episode(actuator, rng) for _ in range(20)]
    assert all(e.mode is not Mode.GOAL and e.drawn is Mode.GOAL for e in episodes)
    assert actuator.actions > 0  # the episodes still explore
    assert aff.interest.n_goals == 0  # nothing was attempted: nothing recorded
    # Each fallback is on record: goal babbling, then (a random controllable value, as
    # unplannable) a random action; or a random primitive sequence straight away.
    assert {e.fallbacks for e in episodes} == {
        (Fallback.GOAL_NO_PLAN,), (Fallback.GOAL_NO_PLAN, Fallback.RANDOM_NO_PLAN)}
    assert all(e.mode is Mode.RANDOM_ACTION for e in episodes)


def test_goal_babbling_without_an_object_to_bind_is_a_recorded_fallback(monkeypatch):
    room = Room(sigma=1.0)
    rng = np.random.default_rng(0)
    room.affordance(np.zeros(0, dtype=np.int64), (), inp=ROBOT_POSITION, out=TARGET_POSITION)
    monkeypatch.setattr(room.learner, "select_binding", lambda aff, obs: None)
    episode = room.learner.learning_episode(FakeActuator(room.obs.copy()), rng)
    assert episode.drawn is Mode.GOAL
    assert episode.fallbacks[0] is Fallback.GOAL_NO_OBJECT


# ---------------------------------------------------------------------- p_A labels
def _pushing_room(rng: np.random.Generator) -> tuple[Room, Affordance]:
    """The robot's motion model (free moves) and a pushing affordance (robot.position →
    target.position | target-robot) from pushes of the green obj1 in every direction; p_A's
    examples are recorded instead of learned."""
    room = Room()
    room.episode()
    room.affordance(room.moves(rng, 300), (ROBOT_HEADING,))
    start = len(room.dataset)
    for a in np.linspace(0, 2 * np.pi, 30, endpoint=False):
        room_push(room, "obj1", a, moves=True)
    t = np.arange(start, len(room.dataset), dtype=np.int64)
    rows = Rows(t, np.full(t.size, 1), np.full(t.size, -1))
    push = room.fitter.new_affordance(room.hierarchy.allocate_id(), ROBOT_POSITION,
                                      TARGET_POSITION, (TARGET_ROBOT,), rows,
                                      len(room.dataset), rng)
    room.hierarchy.add(push, len(room.dataset))
    push.taught = []
    push.classifier.add = lambda f, y: push.taught.append((f.copy(), y.copy()))
    push.classifier.train = lambda rng, steps: 0.0
    return room, push


def test_p_a_is_taught_movers_as_positives_the_robot_and_refusals_as_negatives():
    """After a learning episode (Algorithm 2's step): the object that moved is a positive;
    the robot and the object that stopped the robot — touched, the motion model meaning to
    drive into it, neither moving — are negatives; an object never touched is no example."""
    rng = np.random.default_rng(0)
    room, push = _pushing_room(rng)
    start = room.episode()
    room_push(room, "obj1", 0.0, moves=True)   # green, moves
    room_push(room, "obj2", 0.0, moves=False, blocked=True)  # red: stops the robot
    room.adaptation.run(start, len(room.dataset), len(room.dataset), 1, rng)
    features, labels = push.taught[-1]
    reader = room.learner.reader
    by_entity = {e: reader.visual_features(room.obs, e) for e in range(4)}

    def label_of(entity: int) -> list[bool]:
        return [bool(y) for f, y in zip(features, labels, strict=True)
                if np.allclose(f, by_entity[entity])]

    assert label_of(1) == [True]
    assert label_of(2) == [False]
    assert label_of(0) == [False]  # the robot
    assert label_of(3) == []  # never touched: no example


def room_push(room: Room, obj: str, angle: float, moves: bool, blocked: bool = False) -> None:
    """The robot at the origin, in contact behind `obj`, drives 0.1 m along `angle` (or,
    `blocked`, tries to: neither moves)."""
    u = np.array([np.cos(angle), np.sin(angle)])
    room.place("robot", [0.0, 0.0])
    room.set("robot", Property.HEADING, u)
    parked = room.obs[room.layout.space(obj, Property.POSITION).slice].copy()
    room.place(obj, 0.27 * u)
    before = room.obs.copy()
    room.place("robot", 0.0 if blocked else 0.1 * u)
    room.place(obj, 0.27 * u + (0.09 * u if moves else 0.0))
    room.dataset.append(np.array([1.0, 1.0]), before, room.obs.copy())
    room.place(obj, parked)


def test_object_selection_takes_the_closest_object_p_a_accepts():
    """The closest object while p_A knows nothing; then the closest it accepts. Through a
    tool: the object nearest the target among those the tool's controller accepts."""
    room = Room()
    for name, xy in (("obj1", [0.5, 0.0]), ("obj2", [0.3, 0.3]), ("obj3", [-0.8, 0.0])):
        room.place(name, xy)
    room.place("robot", [0.0, 0.0])
    push = room.affordance(np.zeros(0, dtype=np.int64), (), inp=ROBOT_POSITION,
                           out=TARGET_POSITION)
    assert room.learner.select_binding(push, room.obs).target == 2
    push.classifier = SimpleNamespace(n_positive=1, accepts=lambda f: f[:, 3] > 0.5)  # green
    assert room.learner.select_binding(push, room.obs).target == 1
    tool = room.affordance(np.zeros(0, dtype=np.int64), (), inp=TOOL_POSITION,
                           out=TARGET_POSITION)
    tool.classifier = SimpleNamespace(n_positive=1, accepts=lambda f: f[:, 0] < 0.45)  # small
    binding = room.learner.select_binding(tool, room.obs)
    assert (binding.target, binding.tool) == (3, 1)  # obj2, red, is no tool of the pusher's


def test_object_selection_through_a_tool_takes_the_shortest_chain():
    """The (target, tool) pair whose chain — the robot's way to the tool plus the tool's way
    to the target — is shortest: obj1 (0.4 m away) pushed into obj2 (1.4 m in all), not obj3
    pushed into obj2 (0.5 m apart, but 1.5 m away: 2 m), nor the closest target obj1 with the
    only other green object, obj3 (2.6 m)."""
    room = Room()
    for name, xy in (("obj1", [0.4, 0.0]), ("obj2", [1.4, 0.0]), ("obj3", [1.4, 0.5])):
        room.place(name, xy)
    room.place("robot", [0.0, 0.0])
    push = room.affordance(np.zeros(0, dtype=np.int64), (), inp=ROBOT_POSITION,
                           out=TARGET_POSITION)
    push.classifier = SimpleNamespace(n_positive=1, accepts=lambda f: f[:, 3] > 0.5)  # green
    tool = room.affordance(np.zeros(0, dtype=np.int64), (), inp=TOOL_POSITION,
                           out=TARGET_POSITION)
    binding = room.learner.select_binding(tool, room.obs)
    assert (binding.target, binding.tool) == (2, 1)


def test_the_effective_share_of_goal_babbling_counts_the_fallbacks():
    from hadim_cli.runs import goal_babbling_share

    def le(drawn, mode, *fallbacks):
        return {"drawn": drawn, "mode": mode, "fallbacks": list(fallbacks)}

    extras = [{"learning_episodes": [le("goal", "goal"), le("goal", "random-action",
                                                           "goal-no-plan", "random-no-plan")]},
              {"learning_episodes": [le("random-controllable", "random-action"),
                                     le("goal", "random-controllable", "goal-no-object")]}]
    share = goal_babbling_share(extras, 0.7)
    assert share == {"sigma": 0.7, "learning_episodes": 4, "drawn": 0.75, "effective": 0.25,
                     "fallbacks": {"goal-no-object": 1, "goal-no-plan": 1,
                                   "random-no-plan": 1}}
    # Episodes stored before the draw was recorded: the effective share only.
    old = [{"learning_episodes": [{"mode": "goal"}, {"mode": "random-action"}]}]
    assert goal_babbling_share(old, 0.7) == {"sigma": 0.7, "learning_episodes": 2,
                                             "drawn": None, "effective": 0.5,
                                             "fallbacks": None}


def test_a_refusal_in_an_episode_where_nothing_moved_still_teaches_p_a():
    """Nothing moved in the learning episode (the robot drove into a red object): no output
    space is non-null, no affordance is updated, and p_A still gets its negative."""
    rng = np.random.default_rng(0)
    room, push = _pushing_room(rng)
    start = room.episode()
    room_push(room, "obj2", 0.0, moves=False, blocked=True)
    room.adaptation.run(start, len(room.dataset), len(room.dataset), 1, rng)
    assert [y.tolist() for _, y in push.taught] == [[False, False]]  # the red object, the robot


def test_creation_keeps_the_best_of_the_qualifying_inputs():
    """Every candidate input that clears τ_creation is tried and the one of highest
    competence is created: with τ_creation at 0 both the wheel commands and the (controllable)
    heading qualify for the robot's position, and the wheels, which drive it, win."""
    room = Room(tau_creation=0.0)
    rng = np.random.default_rng(0)
    room.episode()
    room.affordance(room.moves(rng, 200), out=ROBOT_HEADING)
    t = room.moves(rng, 200)
    by_input = {inp: room.fitter.trial(inp, ROBOT_POSITION, (ROBOT_HEADING,) if inp is ACTION
                                       else (), room.rows(t), np.random.default_rng(1))
                for inp in (ACTION, ROBOT_HEADING)}
    assert by_input[ACTION] > by_input[ROBOT_HEADING] + 0.2  # the premise
    assert room.hierarchy.candidate_inputs(ROBOT_POSITION) == [ACTION, ROBOT_HEADING]
    events = room.adaptation.run(int(t[0]), int(t[-1]) + 1, len(room.dataset), 0, rng)
    created = [(e.input, e.output) for e in events if e.kind is EventKind.CREATED]
    assert created == [("action", "robot.position")]


class RecordingActuator(FakeActuator):
    """Keeps every primitive action it is given."""

    def __init__(self, obs: np.ndarray):
        super().__init__(obs)
        self.given: list[np.ndarray] = []

    def act(self, action: np.ndarray) -> np.ndarray:
        self.given.append(np.array(action, dtype=float))
        return super().act(action)


def test_random_babbling_draws_sequences_of_actions_uniform_in_the_action_box():
    """Random babbling in the primitive space: `random_sequence_length` actions per learning
    episode, each uniform in [-1, 1]² (mean 0, variance 1/3, every quadrant a quarter, the
    two wheels independent)."""
    room = Room(random_sequence_length=5)
    rng = np.random.default_rng(0)
    actuator = RecordingActuator(room.obs.copy())
    episodes = [room.learner.learning_episode(actuator, rng) for _ in range(400)]
    assert {e.mode for e in episodes} == {Mode.RANDOM_ACTION}
    a = np.stack(actuator.given)
    assert a.shape == (5 * 400, 2)
    assert np.all(np.abs(a) <= 1.0) and np.all(a.min(axis=0) < -0.98) \
        and np.all(a.max(axis=0) > 0.98)
    np.testing.assert_allclose(a.mean(axis=0), 0.0, atol=0.05)
    np.testing.assert_allclose(a.var(axis=0), 1 / 3, atol=0.03)
    quadrants = np.bincount(2 * (a[:, 0] > 0) + (a[:, 1] > 0), minlength=4) / len(a)
    np.testing.assert_allclose(quadrants, 0.25, atol=0.03)
    assert abs(np.corrcoef(a.T)[0, 1]) < 0.06
    assert room.learner.learning_episodes == 400


def test_random_babbling_draws_a_controllable_space_uniformly_and_a_goal_uniform_in_it(
        monkeypatch):
    """With H not empty, random babbling picks the primitive space or a controllable space
    with equal odds, and in a controllable space a goal uniform over the space's bounds
    (no salient goals here), handed to the planner with the affordance that controls it."""
    room = Room(sigma=0.0, salient_goals=0.0, random_sequence_length=1)
    rng = np.random.default_rng(0)
    aff = room.affordance(room.moves(rng, 100), (ROBOT_HEADING,))
    tried = _planner_that_tries(room, monkeypatch)
    actuator = RecordingActuator(room.obs.copy())
    episodes = [room.learner.learning_episode(actuator, rng) for _ in range(600)]
    modes = [e.mode for e in episodes]
    assert abs(modes.count(Mode.RANDOM_CONTROLLABLE) / len(modes) - 0.5) < 0.06
    assert len(actuator.given) == modes.count(Mode.RANDOM_ACTION)
    assert {aid for aid, _ in tried} == {aff.id}
    goals = np.stack([g for _, g in tried])
    low, high = room.layout.space("robot", Property.POSITION).low, \
        room.layout.space("robot", Property.POSITION).high
    assert np.all(goals >= low) and np.all(goals <= high)
    span = np.asarray(high) - np.asarray(low)
    np.testing.assert_allclose(goals.mean(axis=0), (np.asarray(low) + high) / 2,
                               atol=0.08 * span.max())
    np.testing.assert_allclose(goals.std(axis=0), span / np.sqrt(12), rtol=0.12)
    assert all(e.goal == tuple(g) for e, g in zip(
        [e for e in episodes if e.mode is Mode.RANDOM_CONTROLLABLE], goals, strict=True))
