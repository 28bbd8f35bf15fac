"""Long sessions (issue #13): delta checkpoints restore exactly across full-snapshot boundaries,
a store written by schema 1 (fixtures/store_v1.sqlite) opens and resumes, and everything a
learner's checkpoint holds that grows with the run grows at its end (so deltas stay small)."""

from __future__ import annotations

import json
import shutil
import sqlite3
from pathlib import Path

import numpy as np
import pytest

from hadim_cli import runs
from hadim_cli.app import app
from hadim_cli.config import load_config
from hadim_cli.session import Session
from hadim_store import SCHEMA_VERSION, Store

SEED = 5
N = 300
SHORT_EPISODES = ("--set", "world.episode_length=50")
FIXTURE = Path(__file__).parent / "fixtures" / "store_v1.sqlite"


def ok(runner, *args: object):
    result = runner.invoke(app, [str(a) for a in args])
    assert result.exit_code == 0, (args, result.stderr, result.exception)
    return result


def train(runner, store: Path, iterations: int, *extra: object) -> str:
    out = ok(runner, "train", "--iterations", iterations, "--eval-every", 0, "--store", store,
             "--seed", SEED, *SHORT_EPISODES, *extra).stdout
    return out.strip().splitlines()[0]


def _toml(value: object) -> str:
    """`value` as `--set` reads it: a list as an array, a bool in lower case."""
    if isinstance(value, tuple | list):
        return "[" + ", ".join(_toml(v) for v in value) + "]"
    return str(value).lower()


def show(runner, store: Path, run: str) -> dict:
    return json.loads(ok(runner, "runs", "show", run, "--json", "--store", store).stdout)


def affordances(runner, store: Path, run: str) -> list:
    return json.loads(ok(runner, "affordances", run, "--json", "--store", store).stdout)


def full_snapshots(store: Path, run: str) -> list[int]:
    con = sqlite3.connect(store)
    try:
        return [it for (it,) in con.execute(
            "SELECT c.iteration FROM checkpoints c JOIN runs r ON r.id = c.run_id "
            "WHERE r.name = ? AND c.base_iteration IS NULL ORDER BY c.iteration", (run,))]
    finally:
        con.close()


def test_resume_and_fork_are_exact_across_snapshot_boundaries(runner, tmp_path, monkeypatch):
    monkeypatch.setenv(runs.SNAPSHOT_ENV, "2")
    store = tmp_path / "s.sqlite"
    whole = train(runner, store, N)
    assert full_snapshots(store, whole) == [50, 150, 250]
    half = train(runner, store, 150)
    ok(runner, "resume", half, "--iterations", N, "--eval-every", 0, "--store", store)
    # The resumed process starts a chain of its own: a full snapshot first.
    assert full_snapshots(store, half) == [50, 150, 200, 300]
    child = ok(runner, "fork", whole, "--at", 200, "--store", store).stdout.strip()  # a delta
    ok(runner, "resume", child, "--iterations", N, "--eval-every", 0, "--store", store)
    digests = {show(runner, store, r)["dataset_sha256"] for r in (whole, half, child)}
    assert len(digests) == 1
    h = affordances(runner, store, whole)
    assert h and h == affordances(runner, store, half) == affordances(runner, store, child)

    # Every checkpoint of the delta-chained run holds what a store of full snapshots holds.
    monkeypatch.setenv(runs.SNAPSHOT_ENV, "1")
    plain_store = tmp_path / "plain.sqlite"
    plain = train(runner, plain_store, N)
    assert full_snapshots(plain_store, plain) == list(range(50, N + 1, 50))
    with Store.open(store) as a, Store.open(plain_store) as b:
        for it in range(50, N + 1, 50):
            x, y = a.checkpoint(whole, it), b.checkpoint(plain, it)
            assert x.json == y.json
            assert sorted(x.arrays) == sorted(y.arrays)
            for key, value in x.arrays.items():
                assert value.dtype == y.arrays[key].dtype, key
                assert value.tobytes() == y.arrays[key].tobytes(), key


def test_a_full_p_a_replay_is_written_as_its_new_rows_and_resumes_exactly(runner, tmp_path,
                                                                          monkeypatch):
    """p_A's replay is first-in-first-out: once full, each example added drops the oldest.
    With a replay of 2 examples it is full within the first p_A examples; a delta checkpoint
    then writes the examples added since its base (a window of the base's value, then them;
    whole only when all of it is new), and a resume or fork across such deltas is exact."""
    from hadim_cli.learner.classifier import VisualClassifier
    from hadim_store import codecs

    monkeypatch.setitem(VisualClassifier.__init__.__kwdefaults__, "replay_size", 2)
    monkeypatch.setenv(runs.SNAPSHOT_ENV, "4")
    store, n = tmp_path / "s.sqlite", 800
    whole = train(runner, store, n)
    con = sqlite3.connect(store)
    try:
        items = con.execute(
            "SELECT c.iteration, c.base_iteration, i.key, i.prefix, i.skip, i.data, i.kind "
            "FROM checkpoint_items i JOIN checkpoints c ON c.id = i.checkpoint_id "
            "JOIN runs r ON r.id = c.run_id WHERE r.name = ? AND i.key LIKE '%.replay.%' "
            "AND c.base_iteration IS NOT NULL", (whole,)).fetchall()
    finally:
        con.close()
    windows = 0
    with Store.open(store) as st:
        for it, base, key, _prefix, skip, data, kind in items:
            column = 0 if key.endswith("positive") else 1
            counters = key.rsplit(".replay.", 1)[0] + ".counters"
            before = st.checkpoint(whole, base).arrays.get(counters)
            if before is None:  # p_A new since the base: written whole
                continue
            added = [int(before[column]), int(st.checkpoint(whole, it).arrays[counters][column])]
            written = 0 if data is None else codecs.decode_array(data, kind).shape[0]
            assert written <= min(2, added[1] - added[0]), (it, key)  # whole if all new
            windows += skip is not None
    assert windows >= 2  # replays full and changed between two checkpoints
    half = train(runner, store, 250)
    ok(runner, "resume", half, "--iterations", n, "--eval-every", 0, "--store", store)
    child = ok(runner, "fork", whole, "--at", 400, "--store", store).stdout.strip()  # a delta
    ok(runner, "resume", child, "--iterations", n, "--eval-every", 0, "--store", store)
    assert len({show(runner, store, r)["dataset_sha256"] for r in (whole, half, child)}) == 1
    assert affordances(runner, store, whole) == affordances(runner, store, child)


def test_a_bad_snapshot_interval_is_one_error_line(runner, tmp_path, monkeypatch):
    monkeypatch.setenv(runs.SNAPSHOT_ENV, "0")
    result = runner.invoke(app, ["train", "--iterations", "50", "--store",
                                 str(tmp_path / "s.sqlite")])
    assert result.exit_code == 2
    assert result.stderr.strip().startswith(f"error: {runs.SNAPSHOT_ENV}=")


def test_a_schema_1_store_opens_and_resumes_exactly(runner, tmp_path):
    """fixtures/store_v1.sqlite: `hadim train --iterations 100 --seed 5 --eval-every 0 --set
    world.episode_length=50`, written by commit 11078ae (schema 1, checkpoint format 1: models
    with their rows). Migrated on open, it resumes as if it had never stopped."""
    store = tmp_path / "old.sqlite"
    shutil.copyfile(FIXTURE, store)
    con = sqlite3.connect(store)
    assert con.execute("SELECT value FROM meta WHERE key = 'schema_version'").fetchone() == ("1",)
    con.close()
    assert show(runner, store, "run-1")["iterations"] == 100
    stored = show(runner, store, "run-1")["dataset_sha256"]
    again = tmp_path / "again.sqlite"
    shutil.copyfile(store, again)
    # Resumed with the installed controller (the code that turns goals into actions; its D,
    # H and models as stored): twice the same course, the stored 100 iterations kept.
    for where in (store, again):
        ok(runner, "resume", "run-1", "--iterations", 200, "--eval-every", 0, "--store", where)
    assert show(runner, store, "run-1")["dataset_sha256"] == \
        show(runner, again, "run-1")["dataset_sha256"]
    assert affordances(runner, store, "run-1") == affordances(runner, again, "run-1")
    from hadim_store import Store

    with Store.open(store, create=False) as st:
        assert st.dataset_sha256("run-1", upto_iteration=100) == stored
    con = sqlite3.connect(store)
    try:
        assert con.execute("SELECT value FROM meta WHERE key = 'schema_version'"
                           ).fetchone() == (str(SCHEMA_VERSION),)
        keys = {k for (k,) in con.execute(
            "SELECT i.key FROM checkpoint_items i JOIN checkpoints c ON c.id = i.checkpoint_id "
            "JOIN runs r ON r.id = c.run_id WHERE r.name = 'run-1' AND c.iteration = 100")}
    finally:
        con.close()
    assert "aff0.model.x" in keys  # the old checkpoint, read as it was written


# Keys of a learner checkpoint that may change other than at their end: small fixed-size state
# (p_A's weights, optimiser and replay; an interest tree's nodes; a model's dimensions,
# parameters and index sizes) and an interest map's goal→region column, rewritten when a
# region splits.
_REWRITTEN = (".classifier.", ".interest.node_", ".interest.goal_region", ".model.")


@pytest.mark.parametrize("paper_interest", [False, True])
def test_a_learner_checkpoint_grows_only_at_its_end(paper_interest):
    """Also with the paper's interest maps, which record several goals of one iteration:
    listed by leaf or by iteration alone, a split reordered them."""
    cfg = load_config(None, ["world.episode_length=50", "learner.interest_max_goals=4",
                             f"learner.paper_interest={str(paper_interest).lower()}"])
    session = Session(cfg, SEED)
    previous: dict[str, np.ndarray] = {}
    extended = set()

    def check(_log) -> None:
        meta, arrays = runs.session_state(session)
        assert not any(k.split(".")[-1] in ("x", "c", "y") and ".model." in k for k in arrays)
        for key, now in arrays.items():
            before = previous.get(key)
            if before is None or now.ndim == 0 or any(part in key for part in _REWRITTEN):
                continue
            assert now.shape[0] >= before.shape[0], key
            assert now[:before.shape[0]].tobytes() == before.tobytes(), key
            if now.shape[0] > before.shape[0]:
                extended.add(key.split(".", 1)[1])
        previous.clear()
        previous.update({k: v.copy() for k, v in arrays.items()})
        assert isinstance(meta["events"], list) and "events" not in meta["learner"]

    session.run(400, check)
    assert {"rows.t", "history", "interest.goals"} <= extended


@pytest.mark.parametrize("every", ["x", "-3"])
def test_snapshot_interval_must_be_a_positive_integer(every, monkeypatch):
    monkeypatch.setenv(runs.SNAPSHOT_ENV, every)
    with pytest.raises(runs.HadimError, match=runs.SNAPSHOT_ENV):
        runs.snapshot_every()


def test_bench_train_reports_store_bytes_and_memory_per_block(runner):
    out = ok(runner, "bench", "train", "--iterations", 100, "--block", 50, "--store", "--json",
             *SHORT_EPISODES).stdout
    result = json.loads(out)
    assert result["iterations"] == 100 and result["wall_s"] > 0
    assert result["iterations_per_s"] > 0
    blocks = result["blocks"]
    assert [(b["start"], b["stop"]) for b in blocks] == [(0, 50), (50, 100)]
    assert 0 < blocks[0]["store_bytes"] < blocks[1]["store_bytes"]
    assert result["store_bytes"] > 0
    assert all(b["rss_bytes"] > 10_000_000 for b in blocks)  # a Python with numpy and torch
    table = ok(runner, "bench", "train", "--iterations", 50, *SHORT_EPISODES).stdout
    assert "RSS MB" in table and "store MB" in table


def _same(a: np.ndarray, b: np.ndarray) -> bool:
    return a.shape == b.shape and a.dtype == b.dtype and a.tobytes() == b.tobytes()


def test_kept_candidate_rows_are_those_read_from_all_of_d():
    """Creation trials read the candidate rows of all of D; the Fitter keeps them and reads
    only the iterations added since. The kept rows must be the full read, bit for bit."""
    from hadim_cli.learner.spaces import ACTION, Role, RoleSpace
    from hadim_cli.world.layout import Property

    cfg = load_config(None, ["world.episode_length=50"])
    session = Session(cfg, SEED)
    fitter = session.learner.fitter
    pairs = [(ACTION, RoleSpace(Role.ROBOT, Property.POSITION)),
             (ACTION, RoleSpace(Role.TARGET, Property.POSITION)),
             (RoleSpace(Role.TOOL, Property.POSITION), RoleSpace(Role.TARGET, Property.POSITION))]
    seen: list[int] = []  # the robot's motion rows (the first pair), episode by episode

    def check(_log) -> None:
        t = np.arange(len(session.learner.dataset), dtype=np.int64)
        for inp, out in pairs:
            kept, fresh = fitter.all_candidates(inp, out), fitter.candidate_rows(inp, out, t)
            for a, b in ((kept.rows.t, fresh.rows.t), (kept.rows.target, fresh.rows.target),
                         (kept.rows.tool, fresh.rows.tool), (kept.x, fresh.x), (kept.y, fresh.y)):
                assert _same(a, b)
            if inp is ACTION and out.role is Role.ROBOT:
                seen.append(len(kept.rows))

    session.run(200, check)
    assert seen[-1] > seen[0] > 0


def test_a_models_step_size_is_kept_until_it_has_new_rows():
    from hadim_cli.learner.affordance import per_model
    from hadim_cli.learner.models import LocalLinearModel

    rng = np.random.default_rng(0)
    model = LocalLinearModel(2, 2)
    model.add(rng.normal(size=(30, 2)), None, rng.normal(size=(30, 2)))
    calls = []

    def top(y: np.ndarray) -> float:
        calls.append(len(y))
        return float(np.abs(y).max())

    first = per_model(model, ("top",), top)
    assert per_model(model, ("top",), top) == first and calls == [30]
    model.add(np.zeros((1, 2)), None, np.full((1, 2), 100.0))
    assert per_model(model, ("top",), top) == 100.0 and calls == [30, 31]
    other = LocalLinearModel(2, 2)
    other.add(np.zeros((3, 2)), None, np.ones((3, 2)))
    assert per_model(other, ("top",), top) == 1.0  # per model, not shared
