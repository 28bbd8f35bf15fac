"""`learner.paper_picks` and `learner.paper_matching`: Algorithm 2's loop as the paper writes
it (issue 16, item 3) — PickSpace k times among the non-null spaces, and the picked space's
data matched against every affordance of H, not only those with that output
(docs/algorithm.md, "Adaptation").

The data (`handmade.Room`): the hand-built drive, and an object the robot carries (it moves
exactly as the robot does) or one that jitters at random (nothing the drive explains).
"""

from __future__ import annotations

import numpy as np
import pytest
from handmade import ROBOT_HEADING, ROBOT_POSITION, STEP, TARGET_POSITION, Room

from hadim_cli.learner.affordance import Affordance
from hadim_cli.learner.spaces import Property


def _carry(room: Room, rng: np.random.Generator, n: int, *, jitter: bool = False) -> np.ndarray:
    """`n` drive moves during which obj1 moves with the robot (or, with `jitter`, at random);
    the other objects stay parked. Returns the iterations."""
    start = len(room.dataset)
    for _ in range(n):
        theta = rng.uniform(-np.pi, np.pi)
        room.place("robot", rng.uniform((-1.5, -1.5), (1.5, 1.0)))
        room.set("robot", Property.HEADING, [np.cos(theta), np.sin(theta)])
        here = room.obs[room.layout.space("robot", Property.POSITION).slice].copy()
        room.place("obj1", here + (0.3, 0.0))
        action = rng.uniform(-1.0, 1.0, 2)
        before = room.obs.copy()
        step = STEP * action.mean() * np.array([np.cos(theta), np.sin(theta)])
        moved = rng.uniform(-STEP, STEP, 2) if jitter else step
        room.place("robot", here + step)
        room.place("obj1", here + (0.3, 0.0) + moved)
        turned = theta + 0.3 * (action[1] - action[0])
        room.set("robot", Property.HEADING, [np.cos(turned), np.sin(turned)])
        room.dataset.append(action, before, room.obs.copy())
    return np.arange(start, len(room.dataset), dtype=np.int64)


def _drive(paper: bool = True) -> tuple[Room, np.random.Generator, Affordance]:
    """A room whose H holds the drive A(action → robot.position | robot.heading)."""
    room = Room(paper_picks=paper, paper_matching=paper)
    rng = np.random.default_rng(0)
    drive = room.affordance(room.moves(rng, 200), (ROBOT_HEADING,))
    room.episode()
    return room, rng, drive


# ---------------------------------------------------------------------- (b) PickSpace k times
def test_paper_picks_draw_k_spaces_with_replacement_and_the_default_each_once():
    spaces = [ROBOT_POSITION, ROBOT_HEADING, TARGET_POSITION]
    for paper in (False, True):
        adaptation = Room(paper_picks=paper).adaptation
        draws = [adaptation.pick_spaces(spaces, np.random.default_rng(seed))
                 for seed in range(200)]
        assert all(len(d) == len(spaces) and set(d) <= set(spaces) for d in draws)
        distinct = [len(set(d)) for d in draws]
        if paper:  # 3 draws of 3: all distinct with probability 6/27
            assert min(distinct) == 1 and 20 < distinct.count(3) < 70
        else:
            assert distinct == [3] * 200
    assert Room().adaptation.pick_spaces([], np.random.default_rng(0)) == []


def test_a_space_picked_twice_is_adapted_once(monkeypatch):
    """The second pick of a space adds nothing: its affordances hold the episode's rows."""
    room, rng, _ = _drive()
    calls: list[tuple[str, object]] = []
    adaptation = room.adaptation
    monkeypatch.setattr(adaptation, "pick_spaces", lambda spaces, rng: [ROBOT_POSITION] * 3)
    monkeypatch.setattr(adaptation, "_update",
                        lambda aff, t, it, rng: calls.append(("update", aff.id)))
    monkeypatch.setattr(adaptation, "_try_create",
                        lambda space, it, ep, rng: calls.append(("create", space)))
    t = room.moves(rng, 20)
    adaptation.run(int(t[0]), int(t[-1]) + 1, len(room.dataset), 1, rng)
    assert calls == [("update", 0), ("create", ROBOT_POSITION)]


# ---------------------------------------------------------------------- (a) every affordance
def test_data_of_another_output_match_an_affordance_that_explains_them():
    """An object carried by the robot moves as the drive predicts the robot does: its data
    match the drive; an object that jitters at random does not; a heading is no position."""
    room, rng, drive = _drive()
    carried = _carry(room, rng, 40)
    assert room.adaptation.matches_other_output(drive, TARGET_POSITION, carried, rng)
    room.episode()
    jitter = _carry(room, rng, 40, jitter=True)
    assert not room.adaptation.matches_other_output(drive, TARGET_POSITION, jitter, rng)
    turning = room.affordance(room.moves(rng, 100), (), out=ROBOT_HEADING)
    assert not room.adaptation.matches_other_output(turning, TARGET_POSITION, carried, rng)
    assert drive.model.n == 200  # matching does not add the other output's rows


def test_only_objects_that_moved_are_the_picked_space():
    """Parked objects did not move in the episode: their null rows are not S's data. With
    them, the drive would predict a move for each and no carried object would match."""
    room, rng, drive = _drive()
    carried = _carry(room, rng, 40)
    f = room.fitter
    rows, changed = f.changed(TARGET_POSITION, carried)
    assert set(rows.target[changed].tolist()) == {1}
    assert room.adaptation.matches_other_output(drive, TARGET_POSITION, carried, rng)


@pytest.mark.parametrize(("paper", "jitter", "created"), [
    (True, False, False), (True, True, True), (False, False, True)])
def test_a_match_with_another_output_stands_for_creation(paper, jitter, created, monkeypatch):
    """With the option, the carried object's motion is explained by the drive and no
    affordance is tried for `target.position` (the paper creates only when none matched);
    without it, or when nothing matches, creation is tried. (Every space picked once.)"""
    room, rng, _ = _drive(paper)
    tried: list[object] = []
    monkeypatch.setattr(room.adaptation, "pick_spaces", lambda spaces, rng: list(spaces))
    monkeypatch.setattr(room.adaptation, "_try_create",
                        lambda space, it, ep, rng: tried.append(space))
    t = _carry(room, rng, 40, jitter=jitter)
    room.adaptation.run(int(t[0]), int(t[-1]) + 1, len(room.dataset), 1, rng)
    assert (TARGET_POSITION in tried) == created


@pytest.mark.scenario
@pytest.mark.parametrize(("picks", "matching"), [(True, False), (False, True)])
def test_the_options_reach_the_learner_from_the_command_line_and_are_stored(tmp_path, picks,
                                                                            matching):
    """`hadim train --set learner.paper_picks=… --set learner.paper_matching=…`: stored with
    the run and restored, each on its own; a run stored before them reads the defaults."""
    from typer.testing import CliRunner

    from hadim_cli.app import app
    from hadim_cli.config import stored_config
    from hadim_cli.runs import restore_session
    from hadim_store.api import Store

    store = tmp_path / "s.sqlite"
    result = CliRunner().invoke(app, [
        "train", "--iterations", "150", "--name", "r", "--eval-every", "0",
        "--set", "world.episode_length=50", "--set", f"learner.paper_picks={str(picks).lower()}",
        "--set", f"learner.paper_matching={str(matching).lower()}", "--store", str(store)])
    assert result.exit_code == 0, (result.stderr, result.exception)
    with Store.open(store, create=False) as st:
        run = st.get_run("r")
        stored = run.config["learner"]
        assert (stored["paper_picks"], stored["paper_matching"]) == (picks, matching)
        config = restore_session(st, run).learner.adaptation.config
        assert (config.paper_picks, config.paper_matching) == (picks, matching)
        old = {k: dict(v) if isinstance(v, dict) else v for k, v in run.config.items()}
    del old["learner"]["paper_picks"], old["learner"]["paper_matching"]
    earlier = stored_config(old).learner
    assert (earlier.paper_picks, earlier.paper_matching) == (False, False)


# ---------------------------------------------------------------------- (c) the data added
def _adds(**overrides) -> tuple[Room, np.random.Generator, Affordance]:
    room = Room(paper_matching=True, paper_match_adds=True, **overrides)
    rng = np.random.default_rng(0)
    drive = room.affordance(room.moves(rng, 200), (ROBOT_HEADING,))
    room.episode()
    return room, rng, drive


def test_with_adds_a_match_takes_the_other_outputs_data_in_as_borrowed_rows():
    """`paper_match_adds`: the drive that matches a carried object's moves takes them in —
    rows bound to the object, marked borrowed, whose outcome in the model is the object's
    displacement (not the robot's, though here they are the same: the jitter below is not)."""
    room, rng, drive = _adds()
    carried = _carry(room, rng, 40)
    assert room.adaptation._explained_elsewhere(TARGET_POSITION, carried, len(room.dataset), rng)
    lent = drive.rows.lent()
    assert lent.sum() == drive.model.n - 200 > 0 and not lent[:200].any()
    assert set(drive.rows.target[lent].tolist()) == {1}
    s = room.fitter.values(drive.input, TARGET_POSITION, drive.contexts, drive.rows.take(
        np.flatnonzero(lent)))
    np.testing.assert_allclose(drive.model.data()[2][200:], s.y, rtol=0, atol=1e-12)
    # Refitted from its rows (a context change, a checkpoint), the model reads them the same.
    again = room.fitter.fit(drive.input, drive.output, drive.contexts, drive.rows)
    np.testing.assert_array_equal(again.data()[2], drive.model.data()[2])


def test_a_borrowed_row_reads_the_other_outputs_outcome():
    """A row marked borrowed reads the object's displacement in an affordance of the robot's
    position, where the same row unmarked reads the robot's."""
    room, rng, drive = _adds()
    jitter = _carry(room, rng, 5, jitter=True)
    rows = room.fitter.bindings(TARGET_POSITION.roles, jitter)
    rows = rows.take(np.flatnonzero(rows.target == 1))
    own = room.fitter.values(drive.input, drive.output, drive.contexts, rows).y
    lent = room.fitter.values(drive.input, drive.output, drive.contexts, rows.lending()).y
    obj = room.fitter.values(drive.input, TARGET_POSITION, drive.contexts, rows).y
    np.testing.assert_array_equal(lent, obj)
    assert not np.allclose(own, obj)


@pytest.mark.parametrize("tau", [0.0, 1.0])
def test_without_a_match_a_context_is_searched_k_prime_times(tau):
    """The paper's else-branch: a drive the data do not match (made so by a competence it
    cannot keep) tries random context candidates and takes the first with which it holds them
    at τ_modification — with the data, recorded as a context added; at an unreachable
    τ_modification it keeps neither."""
    room, rng, drive = _adds(tau_modification=tau)
    drive.competence = 2.0  # no data keep that: the match fails
    contexts, n, events = drive.contexts, drive.model.n, len(room.hierarchy.events)
    carried = _carry(room, rng, 40)
    matched = room.adaptation._borrow(drive, TARGET_POSITION, carried, len(room.dataset), rng)
    assert matched == (tau == 0.0)
    if matched:
        assert len(drive.contexts) == len(contexts) + 1 and drive.model.n > n
        event = room.hierarchy.events[-1]
        assert event.kind.value == "context_added"
        assert event.detail["borrowed"] == TARGET_POSITION.name
    else:
        assert (drive.contexts, drive.model.n, len(room.hierarchy.events)) == (contexts, n,
                                                                               events)
        assert drive.rows.borrowed is None


def test_without_adds_a_match_adds_nothing():
    """`paper_matching` alone: the match stands for creation, the drive is unchanged."""
    room, rng, drive = _drive()
    carried = _carry(room, rng, 40)
    assert room.adaptation._explained_elsewhere(TARGET_POSITION, carried, len(room.dataset), rng)
    assert drive.model.n == 200 and drive.rows.borrowed is None


def test_adds_need_paper_matching():
    """`--set learner.paper_match_adds=true` alone is refused with one line."""
    from hadim_cli.config import load_config
    from hadim_cli.errors import ConfigError

    with pytest.raises(ConfigError, match="paper_match_adds.*needs learner.paper_matching"):
        load_config(overrides=["learner.paper_match_adds=true"])
    assert load_config(overrides=["learner.paper_match_adds=true",
                                  "learner.paper_matching=true"]).learner.paper_match_adds


def test_with_adds_every_matching_affordance_takes_the_data_in():
    """The paper's loop runs over every affordance of H: two drives that both explain the
    carried object's moves both take them in (not the first match only)."""
    room, rng, drive = _adds()
    plain = room.affordance(room.moves(rng, 200), ())
    room.episode()
    carried = _carry(room, rng, 40)
    assert room.adaptation._explained_elsewhere(TARGET_POSITION, carried, len(room.dataset), rng)
    assert drive.rows.lent().sum() > 0 and plain.rows.lent().sum() > 0


@pytest.mark.scenario
def test_the_paper_literal_config_turns_every_paper_switch_on_and_trains(tmp_path):
    """`configs/paper-literal.toml`: every switch that gives the paper's own rule is on (a
    switch added later and forgotten there fails this), and a short run trains with it,
    borrowed rows and all, through the command line."""
    from typer.testing import CliRunner

    from hadim_cli.app import app
    from hadim_cli.config import LearnerConfig, configs_dir, load_config
    from hadim_cli.runs import restore_session
    from hadim_store.api import Store

    path = configs_dir() / "paper-literal.toml"
    learner = load_config(path).learner
    switches = {name for name in LearnerConfig.__dataclass_fields__
                if name.startswith(("paper_", "open_"))}
    assert switches and all(getattr(learner, name) for name in switches)
    store = tmp_path / "s.sqlite"
    result = CliRunner().invoke(app, ["train", "--iterations", "200", "--name", "r",
                                      "--eval-every", "0", "-c", str(path),
                                      "--store", str(store)])
    assert result.exit_code == 0, (result.stderr, result.exception)
    with Store.open(store, create=False) as st:
        assert restore_session(st, st.get_run("r")).learner.config == learner
