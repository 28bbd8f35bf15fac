"""Runs: create, get, list, status, delete (contract suite, every backend)."""

from __future__ import annotations

import pytest

from hadim_store import RunStatus, StoreError, UnknownRun


def test_auto_names_and_round_trip(store):
    config = {"learner": {"lr": 0.001, "layers": [64, 64]}, "name": "x", "flag": True}
    first = store.create_run(config=config, seed=7, versions={"hadim": "0.1.0"})
    second = store.create_run(config={}, seed=8)
    assert (first.name, second.name) == ("run-1", "run-2")
    got = store.get_run("run-1")
    assert got.config == config
    assert got.seed == 7
    assert got.versions == {"hadim": "0.1.0"}
    assert got.status is RunStatus.PAUSED
    assert got.iterations == 0
    assert got.parent is None and got.fork_iteration is None
    assert got.created_at.tzinfo is not None
    assert [run.name for run in store.list_runs()] == ["run-1", "run-2"]


def test_auto_name_follows_highest_number(store):
    store.create_run(config={}, seed=1, name="run-5")
    store.create_run(config={}, seed=1, name="baseline")
    assert store.create_run(config={}, seed=1).name == "run-6"


def test_names_unique_and_validated(store):
    store.create_run(config={}, seed=1, name="baseline")
    with pytest.raises(StoreError, match="already exists"):
        store.create_run(config={}, seed=1, name="baseline")
    for bad in ["", "has space", "-lead", "a/b", "x" * 65, "semi;colon"]:
        with pytest.raises(StoreError, match="invalid run name"):
            store.create_run(config={}, seed=1, name=bad)


def test_bad_seed_and_config_refused(store):
    with pytest.raises(StoreError, match="seed"):
        store.create_run(config={}, seed=-1)
    with pytest.raises(StoreError, match="seed"):
        store.create_run(config={}, seed=2**64)
    with pytest.raises(StoreError, match="JSON"):
        store.create_run(config={"x": float("nan")}, seed=1)
    assert store.list_runs() == []


def test_unknown_run_suggests_close_names(store):
    store.create_run(config={}, seed=1)
    with pytest.raises(UnknownRun, match="did you mean run-1"):
        store.get_run("run-11")
    with pytest.raises(UnknownRun, match="the store has 1 run"):
        store.get_run("zzz")


def test_status(store):
    store.create_run(config={}, seed=1)
    assert store.set_status("run-1", "running").status is RunStatus.RUNNING
    assert store.set_status("run-1", RunStatus.FINISHED).status is RunStatus.FINISHED
    assert store.get_run("run-1").status is RunStatus.FINISHED
    with pytest.raises(StoreError, match="unknown run status"):
        store.set_status("run-1", "exploded")


def test_delete_run_cascades(store, fill):
    store.create_run(config={}, seed=1)
    store.create_run(config={}, seed=1)
    fill(store, "run-1", 3)
    store.add_evaluation("run-1", 12, "move", 0.5, [1, 2])
    store.delete_run("run-1")
    with pytest.raises(UnknownRun):
        store.get_run("run-1")
    with store.engine.connect() as conn:
        counts = conn.exec_driver_sql(
            "SELECT (SELECT count(*) FROM episodes), (SELECT count(*) FROM affordance_events),"
            " (SELECT count(*) FROM checkpoints), (SELECT count(*) FROM checkpoint_items),"
            " (SELECT count(*) FROM evaluations), (SELECT count(*) FROM interest_regions)"
        ).one()
    assert counts == (0, 0, 0, 0, 0, 0)
    assert [run.name for run in store.list_runs()] == ["run-2"]


def test_evaluations(store):
    store.create_run(config={}, seed=1)
    store.add_evaluation("run-1", 100, "move-robot", 0.75, [{"target": [1, 2], "ok": True}])
    store.add_evaluation("run-1", 50, "push", 0.25)
    store.add_evaluation("run-1", 100, "push", 0.5, [])
    assert [(e.iteration, e.task) for e in store.evaluations("run-1")] == [
        (50, "push"),
        (100, "move-robot"),
        (100, "push"),
    ]
    (move,) = store.evaluations("run-1", task="move-robot")
    assert move.score == 0.75 and move.points == [{"target": [1, 2], "ok": True}]
    with pytest.raises(StoreError, match="finite"):
        store.add_evaluation("run-1", 1, "push", float("inf"))
