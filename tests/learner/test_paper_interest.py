"""`learner.paper_interest`: the interest maps as the paper has them (§4.4, Algorithm 1's
UpdateInterestMaps), on hand-built data (`handmade.Room`).

A map records every non-null outcome a learning episode reached in its affordance's output
space — goal babbling or random — at the value reached, with the competence of the forward
model's estimate: 1 − min(1, ‖ω_e − ω_r‖ / the output's range). Goal attempts are not recorded
as such.
"""

from __future__ import annotations

import numpy as np
import pytest
from handmade import ROBOT_HEADING, ROBOT_POSITION, Room

from hadim_cli.learner.affordance import per_model
from hadim_cli.learner.competence import range_scale
from hadim_cli.learner.explorer import Mode
from hadim_cli.learner.goals import Attempt
from hadim_cli.learner.interest import Progress
from hadim_cli.learner.spaces import Rows


def _recorded(aff) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(goals, competences, iterations) of a map, in time order."""
    a = aff.interest.state()[1]
    order = np.argsort(a["iterations"], kind="stable")
    return a["goals"][order], a["competences"][order], a["iterations"][order]


def test_a_paper_map_records_each_outcome_reached_with_the_forward_models_error():
    room = Room(paper_interest=True)
    rng = np.random.default_rng(0)
    trained = room.moves(rng, 200)
    knows = room.affordance(trained, (ROBOT_HEADING,))  # the drive depends on the heading
    blind = room.affordance(trained, ())
    assert knows.interest.measure is Progress.PAPER
    room.episode()
    t = room.moves(rng, 10)
    for _ in range(3):  # actions that move nothing: no outcome reached
        room.dataset.append(np.zeros(2), room.obs.copy(), room.obs.copy())
        t = np.concatenate([t, room.moves(rng, 10)])
    t = np.arange(t[0], len(room.dataset))
    room.learner.update_interest_maps(t)

    d = room.dataset
    rows = Rows(t, np.full(t.size, -1), np.full(t.size, -1))
    before = room.fitter.reader.read(ROBOT_POSITION, d.contexts, rows)
    moved = room.fitter.reader.read(ROBOT_POSITION, d.outcomes, rows)
    reached = np.linalg.norm(moved, axis=1) > room.config.zero_eps
    assert reached.sum() == t.size - 3
    for aff in (knows, blind):
        goals, comps, iters = _recorded(aff)
        assert np.array_equal(iters, t[reached])
        assert np.allclose(goals, (before + moved)[reached])  # where the robot got to
        s = room.fitter.values(aff.input, aff.output, aff.contexts, rows)
        scale = per_model(aff.model, ("range", room.config.zero_eps),
                          lambda y: range_scale(y, room.config.zero_eps))
        error = np.linalg.norm(aff.model.predict(s.x, s.c if s.c.shape[1] else None) - s.y,
                               axis=1) / scale
        assert np.allclose(comps, 1.0 - np.minimum(error, 1.0)[reached])
    assert _recorded(knows)[1].mean() > 0.9 > 0.1 + _recorded(blind)[1].mean()


class _RoomActuator:
    """Every primitive action appends one hand-built move to D."""

    def __init__(self, room: Room, rng: np.random.Generator):
        self.room, self.rng = room, rng
        self.exhausted = False

    @property
    def obs(self) -> np.ndarray:
        return self.room.obs.copy()

    def act(self, action: np.ndarray) -> np.ndarray:
        self.room.moves(self.rng, 1)
        return self.obs


@pytest.mark.parametrize("paper", [True, False])
def test_every_learning_episode_updates_the_paper_maps_before_adaptation(paper, monkeypatch):
    """With the option, UpdateInterestMaps runs after every learning episode that acted (goal
    babbling and random alike), on that episode's iterations, before Algorithm 2; a goal
    attempt's own (goal, competence) is not recorded. Without it, only goal attempts are."""
    room = Room(sigma=0.5, paper_interest=paper)
    rng = np.random.default_rng(2)
    aff = room.affordance(room.moves(rng, 100), (ROBOT_HEADING,))
    assert aff.interest.measure is (Progress.PAPER if paper else Progress.HALF_WINDOW)
    learner = room.learner
    order: list[tuple[str, int, int]] = []
    update = learner.update_interest_maps

    def recording_update(t):
        order.append(("maps", int(t[0]), int(t[-1]) + 1))
        update(t)

    adapt = learner.adaptation.run

    def recording_adapt(t0, t1, *args):
        order.append(("adapt", t0, t1))
        return adapt(t0, t1, *args)

    def reach(a, binding, goal, actuator, budget):
        for _ in range(3):
            actuator.act(np.zeros(2))
        return Attempt(1.0, 0.5, 3)

    monkeypatch.setattr(learner, "update_interest_maps", recording_update)
    monkeypatch.setattr(learner.adaptation, "run", recording_adapt)
    monkeypatch.setattr(learner.controller, "reach", reach)
    actuator = _RoomActuator(room, rng)
    episodes = [learner.learning_episode(actuator, rng) for _ in range(16)]
    modes = {e.mode for e in episodes}
    assert Mode.GOAL in modes and modes - {Mode.GOAL}  # goal babbling and random
    goals = [e for e in episodes if e.mode is Mode.GOAL and e.affordance_id == aff.id]
    if paper:
        expected = []
        for e in episodes:
            expected += [("maps", e.start, e.stop), ("adapt", e.start, e.stop)]
        assert order == expected
        assert 0.5 not in _recorded(aff)[1].tolist()  # no attempt's competence
        assert aff.interest.n_goals > len(goals)
    else:
        assert order == [("adapt", e.start, e.stop) for e in episodes]
        assert _recorded(aff)[1].tolist() == [0.5] * len(goals)


@pytest.mark.scenario
def test_the_option_reaches_the_learner_from_the_command_line_and_is_stored(tmp_path):
    """`hadim train --set learner.paper_interest=true`: the run's stored config holds it and
    the session restored from its checkpoint has paper maps that recorded outcomes."""
    from typer.testing import CliRunner

    from hadim_cli.app import app
    from hadim_cli.runs import restore_session
    from hadim_store.api import Store

    store = tmp_path / "s.sqlite"
    for name, value in (("paper", "true"), ("half", "false")):
        result = CliRunner().invoke(app, [
            "train", "--iterations", "150", "--name", name, "--eval-every", "0",
            "--set", "world.episode_length=50", "--set", f"learner.paper_interest={value}",
            "--store", str(store)])
        assert result.exit_code == 0, (result.stderr, result.exception)
    with Store.open(store, create=False) as st:
        for name, paper in (("paper", True), ("half", False)):
            run = st.get_run(name)
            assert run.config["learner"]["paper_interest"] is paper
            learner = restore_session(st, run).learner
            assert learner.config.paper_interest is paper
            maps = [aff.interest for aff in learner.hierarchy]
            assert maps and all(m.measure is (Progress.PAPER if paper else
                                              Progress.HALF_WINDOW) for m in maps)
            if paper:
                assert sum(m.n_goals for m in maps) > 50
