"""Periodic evaluations run beside training (`evaluation.beside`, through `runs.train`): the
scores and points stored are those of the learner evaluated in the training process at the
same iteration; an interrupted run still stores the evaluation it started; a failing one is
one error naming its iteration."""

from __future__ import annotations

import json

import pytest

from hadim_cli import runs
from hadim_cli.config import load_config, with_overrides
from hadim_cli.errors import HadimError
from hadim_cli.evaluation.runner import evaluate
from hadim_cli.evaluation.tasks import load_task
from hadim_cli.session import Session
from hadim_store.api import Store

SEED = 4
EPISODE = 50
TASKS = ("move-robot", "push-object")


def config():
    return with_overrides(load_config(), [f"world.episode_length={EPISODE}"])


def test_stored_evaluations_are_those_of_the_learner_in_the_training_process(
        tmp_path):
    store = Store.open(tmp_path / "s.sqlite", create=True)
    run = runs.new_run(store, config(), SEED, None)
    runs.train(store, run.name, Session(config(), SEED), 4 * EPISODE,
               eval_every=2 * EPISODE, tasks=TASKS)
    stored = [(e.iteration, e.task, e.score, e.points) for e in store.evaluations(run.name)]
    store.close()

    here = Session(config(), SEED)
    expected = []
    for stop in (2 * EPISODE, 4 * EPISODE):
        here.run(stop)
        for task in TASKS:
            result = evaluate(here.learner, here.config.world, load_task(task))
            points = json.loads(json.dumps(result.to_dict()["points"]))  # as stored: lists
            expected.append((stop, task, result.score, points))
    assert stored == expected
    assert any(score > 0.5 for _, _, score, _ in stored)  # it measured something


def test_an_interrupted_run_stores_the_evaluation_it_started(tmp_path):
    store = Store.open(tmp_path / "s.sqlite", create=True)
    run = runs.new_run(store, config(), SEED, None)
    session = Session(config(), SEED)
    runs.train(store, run.name, session, 6 * EPISODE, eval_every=EPISODE, tasks=TASKS,
               should_stop=lambda: session.iteration >= 2 * EPISODE)
    assert session.iteration == 2 * EPISODE
    assert [(e.iteration, e.task) for e in store.evaluations(run.name)] == \
        [(i * EPISODE, t) for i in (1, 2) for t in TASKS]
    store.close()


def test_a_failing_evaluation_is_one_error_naming_its_iteration():
    with pytest.raises(HadimError, match=rf"^the evaluation at iteration {EPISODE} failed: "
                                         r"HadimError: unknown task 'no-such-task'"):
        runs.train(None, None, Session(config(), SEED), 2 * EPISODE, eval_every=EPISODE,
                   tasks=("no-such-task",))


def test_each_episodes_progress_carries_the_last_scores_handed_back_and_their_iteration():
    """After the first episode the evaluation it started is still under way: no scores yet.
    After the last, the evaluation started there has been waited for: its scores, and the
    iteration they measured, are those of the learner evaluated in the training process."""
    seen = []
    runs.train(None, None, Session(config(), SEED), 2 * EPISODE, eval_every=EPISODE,
               tasks=TASKS[:1], on_progress=seen.append)
    assert [p.iteration for p in seen] == [EPISODE, 2 * EPISODE]
    assert seen[0].scores == {} and seen[0].scored_at is None
    here = Session(config(), SEED)
    here.run(2 * EPISODE)
    score = evaluate(here.learner, here.config.world, load_task(TASKS[0])).score
    assert seen[1].scores == {TASKS[0]: score} and seen[1].scored_at == 2 * EPISODE
