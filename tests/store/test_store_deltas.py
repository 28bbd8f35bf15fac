"""Checkpoints written as deltas (store/deltas.py): exact read-back across snapshot boundaries,
forks and rewinds of delta chains, and bytes per checkpoint that do not grow with the run."""

from __future__ import annotations

import sqlite3

import numpy as np
import pytest

from hadim_store import EpisodeWrite, Store, StoreError


def _state(i: int) -> tuple[dict[str, np.ndarray], dict]:
    """Checkpoint i of a made-up learner: things that grow at the end, change in place,
    shrink, change dtype, appear and disappear."""
    arrays = {
        "rows": np.arange(10 * (i + 1), dtype=np.int64),            # grows at its end
        "goals": np.arange(6 * (i + 1), dtype=np.float64).reshape(-1, 2) * 0.5,
        "weights": np.full((4, 3), float(i), dtype=np.float32),     # changes everywhere
        "scalar": np.array(i),
        "empty": np.zeros((0, 3)),
        "shrinks": np.arange(max(0, 8 - i)),
        "dtype": np.arange(3, dtype=np.int64 if i % 2 else np.int32),
    }
    if i % 3 == 0:
        arrays["sometimes"] = np.arange(i + 1)
    # A first-in-first-out buffer of 12 rows, 5 new per checkpoint (full from the third on),
    # with repeated rows (several candidate windows) and none new at every fourth checkpoint.
    stream = np.array([[j // 3, -0.0 if j % 7 == 0 else 0.0] for j in range(5 * (i + 1))])
    arrays["fifo"] = stream[:len(stream) - 5 * (i % 4 == 3)][-12:]
    arrays["rows"][:1] = i // 4  # a change at the front every 4 checkpoints: written whole
    texts = {"events": [{"i": j, "z": -0.0 if j == i else 0.0} for j in range(i + 1)],
             "meta": {"i": i}, "flat": [1, 2] if i % 2 else [1]}
    return arrays, texts


def open_backend(kind: str, tmp_path, **options) -> Store:
    return Store.open("sqlite://" if kind == "memory" else tmp_path / "store.db", **options)


def _write(store: Store, name: str, i: int) -> None:
    arrays, texts = _state(i)
    store.write_episode(name, EpisodeWrite(
        index=i, first_iteration=i, actions=np.zeros((1, 2)), contexts=np.zeros((1, 3)),
        outcomes=np.zeros((1, 3)), checkpoint_arrays=arrays, checkpoint_json=texts))


def _assert_reads_back(store: Store, name: str, i: int) -> None:
    cp = store.checkpoint(name, i + 1)
    arrays, texts = _state(i)
    assert cp.iteration == i + 1
    assert sorted(cp.arrays) == sorted(arrays)
    for key, value in arrays.items():
        got = cp.arrays[key]
        assert got.dtype == value.dtype and got.shape == value.shape, key
        assert got.tobytes() == value.tobytes(), key
    assert not cp.arrays["rows"].flags.writeable
    assert cp.json == texts
    # -0.0 and 0.0 are equal but not the same value: a prefix must match exactly.
    assert [np.copysign(1, e["z"]) for e in cp.json["events"]] == \
        [np.copysign(1, e["z"]) for e in texts["events"]]


def _kinds(store: Store, name: str) -> list[bool]:
    """Per checkpoint, whether it is a full snapshot."""
    with store.session_scope(write=False) as s:
        from hadim_store.models import CheckpointRow

        rows = s.query(CheckpointRow).order_by(CheckpointRow.iteration).all()
        return [r.base_iteration is None for r in rows if r.run_id == store_run_id(s, name)]


def store_run_id(session, name: str) -> int:
    from hadim_store.models import Run

    return session.query(Run).filter(Run.name == name).one().id


@pytest.mark.parametrize("kind", ["memory", "file"])
def test_every_checkpoint_reads_back_exactly_across_snapshot_boundaries(kind, tmp_path):
    with open_backend(kind, tmp_path, snapshot_every=3) as store:
        store.create_run(config={}, seed=1, name="r")
        for i in range(10):
            _write(store, "r", i)
        assert _kinds(store, "r") == [True, False, False] * 3 + [True]
        for i in range(10):
            _assert_reads_back(store, "r", i)


def test_reopened_store_starts_with_a_full_snapshot(tmp_path):
    path = tmp_path / "s.db"
    with Store.open(path, snapshot_every=10) as store:
        store.create_run(config={}, seed=1, name="r")
        for i in range(3):
            _write(store, "r", i)
    with Store.open(path, snapshot_every=10) as store:
        for i in range(3, 5):
            _write(store, "r", i)
        assert _kinds(store, "r") == [True, False, False, True, False]
        for i in range(5):
            _assert_reads_back(store, "r", i)


def test_fork_and_rewind_keep_delta_chains_whole(tmp_path):
    with open_backend("file", tmp_path, snapshot_every=4) as store:
        store.create_run(config={}, seed=1, name="r")
        for i in range(7):
            _write(store, "r", i)
        child = store.fork("r", at_iteration=6, config={}, seed=1, name="c")
        assert child.iterations == 6
        for i in range(6):
            _assert_reads_back(store, "c", i)
        store.rewind("r", to_checkpoint=3)  # the middle of a chain
        _assert_reads_back(store, "r", 2)
        for i in range(3, 6):
            _write(store, "r", i)  # continues after a rewind: a fresh base
        for i in range(6):
            _assert_reads_back(store, "r", i)
        store.delete_run("r")
        for i in range(6):
            _assert_reads_back(store, "c", i)  # the fork's chain is its own


def test_a_broken_chain_is_an_error_not_a_wrong_state(tmp_path):
    path = tmp_path / "s.db"
    with Store.open(path, snapshot_every=5) as store:
        store.create_run(config={}, seed=1, name="r")
        for i in range(3):
            _write(store, "r", i)
    con = sqlite3.connect(path)
    con.execute("PRAGMA foreign_keys = ON")
    con.execute("DELETE FROM checkpoints WHERE iteration = 1")
    con.commit()
    con.close()
    with Store.open(path) as store, pytest.raises(StoreError, match="missing checkpoint"):
        store.checkpoint("r")


def _checkpoint_bytes(path) -> list[tuple[bool, int]]:
    con = sqlite3.connect(path)
    try:
        return [(base is None, size) for base, size in con.execute(
            "SELECT c.base_iteration, sum(coalesce(length(i.data), 0) + "
            "coalesce(length(i.text), 0)) FROM checkpoints c JOIN checkpoint_items i "
            "ON i.checkpoint_id = c.id GROUP BY c.id ORDER BY c.iteration")]
    finally:
        con.close()


def test_delta_bytes_do_not_grow_with_the_run(tmp_path):
    """A state growing by 50 rows per checkpoint: full snapshots grow with it, deltas not."""
    path = tmp_path / "s.db"
    rng = np.random.default_rng(0)
    data = rng.normal(size=(50 * 40, 3))
    with Store.open(path, snapshot_every=10) as store:
        store.create_run(config={}, seed=1, name="r")
        for i in range(40):
            store.write_episode("r", EpisodeWrite(
                index=i, first_iteration=i, actions=np.zeros((1, 2)),
                contexts=np.zeros((1, 3)), outcomes=np.zeros((1, 3)),
                checkpoint_arrays={"rows": data[:50 * (i + 1)], "w": rng.normal(size=20)},
                checkpoint_json={"n": i}))
    sizes = _checkpoint_bytes(path)
    fulls = [s for full, s in sizes if full]
    deltas = [s for full, s in sizes if not full]
    assert len(fulls) == 4 and fulls == sorted(fulls) and fulls[-1] > 2 * fulls[1]
    assert max(deltas) < 1.2 * min(deltas)
    assert max(deltas) < fulls[1]


def test_a_full_fifo_buffer_costs_its_new_rows(tmp_path):
    """A buffer that drops its oldest rows as new ones come (p_A's replay once full) is
    written as a window of its previous value and its new rows: its deltas do not hold it
    whole, and it reads back exactly (every checkpoint, across full snapshots)."""
    path = tmp_path / "s.db"
    rng = np.random.default_rng(0)
    stream = rng.normal(size=(30 * 25, 4))
    with Store.open(path, snapshot_every=8, compress=False) as store:
        store.create_run(config={}, seed=1, name="r")
        for i in range(25):
            store.write_episode("r", EpisodeWrite(
                index=i, first_iteration=i, actions=np.zeros((1, 2)),
                contexts=np.zeros((1, 3)), outcomes=np.zeros((1, 3)),
                checkpoint_arrays={"replay": stream[:30 * (i + 1)][-200:]},
                checkpoint_json={}))
        for i in range(25):
            assert store.checkpoint("r", i + 1).arrays["replay"].tobytes() == \
                stream[:30 * (i + 1)][-200:].tobytes()
    sizes = _checkpoint_bytes(path)
    deltas = [size for full, size in sizes if not full]
    fulls = [size for full, size in sizes if full]
    row = stream[:1].nbytes
    assert all(size < 30 * row + 200 for size in deltas)  # 30 rows and an npy header
    assert min(fulls[1:]) > 200 * row
