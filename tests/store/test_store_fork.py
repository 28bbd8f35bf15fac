"""Forking a run from a checkpoint (contract suite, every backend)."""

from __future__ import annotations

import pytest

from hadim_store import RunStatus, StoreError


def _snapshot(store, name):
    return (
        store.get_run(name).iterations,
        store.dataset_sha256(name),
        store.events(name),
        store.stats(name),
        store.interest_regions(name),
        store.checkpoint_iterations(name),
        [(e.iteration, e.task, e.score) for e in store.evaluations(name)],
    )


@pytest.fixture
def parent(store, fill):
    store.create_run(config={"lr": 1}, seed=3, name="parent")
    fill(store, "parent", 4, n=5)  # checkpoints at 5, 10, 15, 20
    store.add_evaluation("parent", 10, "move", 0.5)
    store.add_evaluation("parent", 20, "move", 0.9)
    return "parent"


def test_fork_copies_history_up_to_checkpoint(store, parent, make_episode):
    before = _snapshot(store, parent)
    child = store.fork(parent, at_iteration=12, config={"lr": 2}, seed=4, versions={"v": 1})
    assert child.name == "run-1" and child.parent == parent
    assert (child.fork_iteration, child.iterations) == (10, 10)
    assert child.status is RunStatus.PAUSED and child.config == {"lr": 2} and child.seed == 4
    assert store.dataset_sha256(child.name) == store.dataset_sha256(parent, upto_iteration=10)
    assert [e.index for e in store.episodes(child.name)] == [0, 1]
    assert store.events(child.name) == store.events(parent, upto_iteration=9)
    assert store.stats(child.name) == store.stats(parent, upto_iteration=10)
    assert store.interest_regions(child.name) == store.interest_regions(parent, iteration=10)
    assert store.checkpoint_iterations(child.name) == [5, 10]
    assert store.checkpoint(child.name).json == store.checkpoint(parent, at_or_before=10).json
    assert [(e.iteration, e.score) for e in store.evaluations(child.name)] == [(10, 0.5)]
    assert _snapshot(store, parent) == before
    store.write_episode(child.name, make_episode(2, 10, n=5, seed=9))  # the fork continues
    assert store.get_run(child.name).iterations == 15
    assert _snapshot(store, parent) == before


def test_fork_defaults_to_latest_checkpoint(store, parent):
    child = store.fork(parent, at_iteration=None, config={}, seed=1, name="tip")
    assert child.name == "tip" and child.fork_iteration == 20
    assert store.dataset_sha256("tip") == store.dataset_sha256(parent)


def test_fork_of_a_fork_and_parent_deletion(store, parent):
    store.fork(parent, at_iteration=15, config={}, seed=1, name="child")
    grandchild = store.fork("child", at_iteration=10, config={}, seed=1, name="grandchild")
    assert grandchild.parent == "child" and grandchild.iterations == 10
    store.delete_run("child")
    orphan = store.get_run("grandchild")
    assert orphan.parent is None and orphan.fork_iteration == 10
    assert store.checkpoint_iterations("grandchild") == [5, 10]


@pytest.mark.parametrize(
    ("at", "message"),
    [
        (-1, "non-negative"),
        (21, "only 20 iterations"),
        (4, "first checkpoint is at iteration 5"),
        (2.5, "non-negative integer"),
    ],
)
def test_bad_fork_iterations_refused(store, parent, at, message):
    with pytest.raises(StoreError, match=message):
        store.fork(parent, at_iteration=at, config={}, seed=1)
    assert [run.name for run in store.list_runs()] == [parent]


def test_fork_without_checkpoints_refused(store, make_episode):
    store.create_run(config={}, seed=1)
    store.write_episode("run-1", make_episode(0, 0, checkpoint=False))
    with pytest.raises(StoreError, match="no checkpoint to start from"):
        store.fork("run-1", config={}, seed=1)
    assert len(store.list_runs()) == 1


def test_fork_name_clash_leaves_nothing(store, parent):
    with pytest.raises(StoreError, match="already exists"):
        store.fork(parent, at_iteration=10, config={}, seed=1, name=parent)
    assert [run.name for run in store.list_runs()] == [parent]


def test_rewind_discards_after_checkpoint(store, parent, make_episode):
    store.write_episode(parent, make_episode(4, 20, n=5, checkpoint=False))  # 25 > last ckpt 20
    digest_at_20 = store.dataset_sha256(parent, upto_iteration=20)
    assert store.rewind(parent).iterations == 20
    assert store.dataset_sha256(parent) == digest_at_20
    store.write_episode(parent, make_episode(4, 20, n=5))  # resumes cleanly
    rewound = store.rewind(parent, to_checkpoint=12)
    assert rewound.iterations == 10
    assert store.checkpoint_iterations(parent) == [5, 10]
    assert [e.index for e in store.episodes(parent)] == [0, 1]
    assert max(e.iteration for e in store.events(parent)) <= 10
    assert {r.iteration for r in store.interest_regions(parent)} == {10}
    assert [e.iteration for e in store.evaluations(parent)] == [10]


def test_rewind_refused_while_locked(store, parent):
    store.acquire_lock(parent, "trainer")
    with pytest.raises(StoreError, match="cannot rewind"):
        store.rewind(parent)
    assert store.get_run(parent).iterations == 20
