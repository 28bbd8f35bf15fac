"""Episodes, D, the learner's timeline and checkpoints (contract suite, every backend)."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from hadim_store import CodecError, EpisodeWrite, Store, StoreError


def _count(store, table: str) -> int:
    with store.engine.connect() as conn:
        return conn.exec_driver_sql(f"SELECT count(*) FROM {table}").scalar_one()


def test_episode_round_trip_is_bit_identical(store, make_episode):
    store.create_run(config={}, seed=1)
    written = [make_episode(0, 0, 4), make_episode(1, 4, 3)]
    for episode in written:
        store.write_episode("run-1", episode)
    read = store.episodes("run-1")
    assert [e.index for e in read] == [0, 1]
    for stored, original in zip(read, written, strict=True):
        assert stored.first_iteration == original.first_iteration
        assert stored.n_iterations == original.n_iterations
        assert stored.extra == original.extra
        for key in ("actions", "contexts", "outcomes"):
            got, want = getattr(stored, key), getattr(original, key)
            assert got.dtype == want.dtype and got.shape == want.shape
            assert got.tobytes() == want.tobytes()
            assert not got.flags.writeable
    assert store.get_run("run-1").iterations == 7


def test_uncompressed_store_reads_the_same(tmp_path, make_episode):
    with Store.open(tmp_path / "raw.db", compress=False) as raw:
        raw.create_run(config={}, seed=1)
        raw.write_episode("run-1", make_episode(0, 0))
    with Store.open(tmp_path / "raw.db") as compressed:  # mixed codecs in one store are fine
        compressed.write_episode("run-1", make_episode(1, 4))
        episodes = compressed.episodes("run-1")
    assert np.array_equal(episodes[0].actions, make_episode(0, 0).actions)
    assert np.array_equal(episodes[1].outcomes, make_episode(1, 4).outcomes)


def test_duplicate_and_non_contiguous_episodes_refused(store, make_episode):
    store.create_run(config={}, seed=1)
    store.write_episode("run-1", make_episode(0, 0))
    with pytest.raises(StoreError, match="already has episode 0"):
        store.write_episode("run-1", make_episode(0, 4))
    with pytest.raises(StoreError, match="not contiguous"):
        store.write_episode("run-1", make_episode(2, 4))
    with pytest.raises(StoreError, match="starts at iteration 5"):
        store.write_episode("run-1", make_episode(1, 5))
    assert _count(store, "episodes") == 1
    assert _count(store, "affordance_events") == 1
    assert _count(store, "checkpoints") == 1
    assert store.get_run("run-1").iterations == 4


def test_failed_checkpoint_item_leaves_nothing(store, make_episode):
    store.create_run(config={}, seed=1)
    store.write_episode("run-1", make_episode(0, 0))
    bad = dataclasses.replace(
        make_episode(1, 4), checkpoint_arrays={"bad": np.array([object()], dtype=object)}
    )
    with pytest.raises(CodecError, match="object"):
        store.write_episode("run-1", bad)
    _assert_only_first_episode(store)
    store.write_episode("run-1", make_episode(1, 4))  # the run is still writable
    assert store.get_run("run-1").iterations == 8


def test_failure_after_rows_flushed_rolls_back(store, make_episode, monkeypatch):
    store.create_run(config={}, seed=1)
    store.write_episode("run-1", make_episode(0, 0))

    def explode(*_args, **_kwargs):
        raise RuntimeError("disk on fire")

    # Fails after the episode, events, stats and regions rows were sent to the database.
    monkeypatch.setattr(Store, "_add_checkpoint", explode)
    with pytest.raises(RuntimeError, match="disk on fire"):
        store.write_episode("run-1", make_episode(1, 4))
    _assert_only_first_episode(store)


def _assert_only_first_episode(store):
    assert [e.index for e in store.episodes("run-1")] == [0]
    assert {e.affordance_id for e in store.events("run-1")} == {0}
    assert {s.iteration for s in store.stats("run-1")} == {4}
    assert store.checkpoint_iterations("run-1") == [4]
    assert store.get_run("run-1").iterations == 4


def test_invalid_episodes_refused(store, make_episode):
    store.create_run(config={}, seed=1)
    good = make_episode(0, 0)
    with pytest.raises(StoreError, match="same number"):
        store.write_episode("run-1", dataclasses.replace(good, outcomes=good.outcomes[:2]))
    with pytest.raises(StoreError, match="outside episode"):
        event = dataclasses.replace(good.events[0], iteration=99)
        store.write_episode("run-1", dataclasses.replace(good, events=[event]))
    with pytest.raises(CodecError, match="finite"):
        stat = dataclasses.replace(good.stats[0], competence=float("nan"))
        store.write_episode("run-1", dataclasses.replace(good, stats=[stat]))
    assert store.episodes("run-1") == []


def test_dataset_and_upto(store, fill):
    store.create_run(config={}, seed=1)
    fill(store, "run-1", 3, n=4)
    actions, contexts, outcomes = store.dataset("run-1")
    assert actions.shape == (12, 2) and contexts.dtype == np.float32 and outcomes.dtype == np.int16
    part = store.dataset("run-1", upto_iteration=6)
    assert part.actions.shape[0] == 6
    assert np.array_equal(part.outcomes, outcomes[:6])
    assert store.dataset("run-1", upto_iteration=0).actions.shape[0] == 0
    assert [e.index for e in store.episodes("run-1", upto_iteration=6)] == [0]
    assert [e.index for e in store.episodes("run-1", upto_iteration=8)] == [0, 1]
    store.create_run(config={}, seed=1)
    assert store.dataset("run-2").actions.shape == (0,)


def test_dataset_sha256_stable_and_sensitive(store, fill, make_episode):
    store.create_run(config={}, seed=1, name="a")
    store.create_run(config={}, seed=1, name="b")
    store.create_run(config={}, seed=1, name="c")
    fill(store, "a", 3)
    fill(store, "b", 3)
    fill(store, "c", 2)
    digest = store.dataset_sha256("a")
    assert len(digest) == 64 and digest == store.dataset_sha256("a") == store.dataset_sha256("b")
    assert store.dataset_sha256("a", upto_iteration=8) == store.dataset_sha256("c")
    assert store.dataset_sha256("a", upto_iteration=7) != store.dataset_sha256("c")
    changed = make_episode(2, 8)
    flipped = changed.actions.copy()
    flipped[0, 0] = np.nextafter(flipped[0, 0], 2.0)  # one ulp
    store.write_episode("c", dataclasses.replace(changed, actions=flipped))
    assert store.dataset_sha256("c") != digest


def test_sha256_independent_of_episode_split(store, make_episode):
    whole = make_episode(0, 0, 6)
    store.create_run(config={}, seed=1, name="one")
    store.write_episode("one", whole)
    store.create_run(config={}, seed=1, name="two")
    for index, rows in enumerate((slice(0, 2), slice(2, 6))):
        store.write_episode(
            "two",
            EpisodeWrite(
                index=index,
                first_iteration=rows.start,
                actions=whole.actions[rows],
                contexts=whole.contexts[rows],
                outcomes=whole.outcomes[rows],
            ),
        )
    assert store.dataset_sha256("one") == store.dataset_sha256("two")


def test_timeline_queries_upto(store, fill):
    store.create_run(config={}, seed=1)
    fill(store, "run-1", 3, n=4)
    events = store.events("run-1")
    assert [(e.iteration, e.affordance_id, e.kind) for e in events] == [
        (0, 0, "created"),
        (4, 1, "created"),
        (8, 2, "created"),
    ]
    assert events[0].context == ("robot_position",) and events[0].detail == {"why": "test"}
    assert len(store.events("run-1", upto_iteration=4)) == 2
    assert [e.affordance_id for e in store.events("run-1", affordance_id=1)] == [1]
    assert {s.iteration for s in store.stats("run-1", upto_iteration=8)} == {4, 8}
    assert [s.n_data for s in store.stats("run-1", affordance_id=0)] == [0, 10, 20]


def test_interest_regions_latest_snapshot(store, fill):
    store.create_run(config={}, seed=1)
    assert store.interest_regions("run-1") == []
    fill(store, "run-1", 3, n=4)
    latest = store.interest_regions("run-1")
    assert {r.iteration for r in latest} == {12} and len(latest) == 6
    at_9 = store.interest_regions("run-1", iteration=9)
    assert {r.iteration for r in at_9} == {8} and len(at_9) == 4
    assert store.interest_regions("run-1", iteration=3) == []
    one = store.interest_regions("run-1", affordance_id=1)
    assert [(r.affordance_id, r.region_id, r.parent_id) for r in one] == [
        (1, 0, None),
        (1, 1, 0),
        (1, 2, 0),
    ]
    assert one[0].low == (0.0,) and one[0].high == (1.0,)


def test_checkpoints(store, fill, make_episode):
    store.create_run(config={}, seed=1)
    assert store.checkpoint("run-1") is None
    fill(store, "run-1", 2, n=4)
    store.write_episode("run-1", make_episode(2, 8, checkpoint=False))
    assert store.checkpoint_iterations("run-1") == [4, 8]
    latest = store.checkpoint("run-1")
    assert (latest.iteration, latest.episode_index) == (8, 1)
    want = make_episode(1, 4)
    assert latest.json == dict(want.checkpoint_json)
    for key, array in want.checkpoint_arrays.items():
        assert latest.arrays[key].tobytes() == array.tobytes()
        assert latest.arrays[key].dtype == array.dtype and latest.arrays[key].shape == array.shape
    assert store.checkpoint("run-1", at_or_before=7).iteration == 4
    assert store.checkpoint("run-1", at_or_before=3) is None


def test_checkpoint_key_clash_refused(store, make_episode):
    store.create_run(config={}, seed=1)
    episode = dataclasses.replace(
        make_episode(0, 0), checkpoint_arrays={"x": np.zeros(1)}, checkpoint_json={"x": 1}
    )
    with pytest.raises(StoreError, match="both"):
        store.write_episode("run-1", episode)
    assert store.episodes("run-1") == []
