"""The checkpoint/restore path of a stored run (`runs.episode_write` → the store →
`runs.restore_session`): a run restored at a checkpoint is the session that wrote it — its D,
H with every model, map and p_A, its counters and both random generators — and goes on as
it would have. The store's own tests guard its formats; the fixture replay test guards old
stores; these tests name what a restore must bring back. Also the rest of `runs`, on small
stores: the evaluations trained beside a run, the store a command opens and the run it reads,
the one line a damaged store gives (the CLI's tests run them through the commands too, but
outside the mutation run's selection)."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from test_state_round_trip import CACHES, assert_same

from hadim_cli import runs
from hadim_cli.config import with_overrides
from hadim_cli.session import Session
from hadim_store.api import Store

SEED = 3
EPISODE = 25


def _short_config():
    from hadim_cli.config import load_config

    return with_overrides(load_config(), [f"world.episode_length={EPISODE}"])


@pytest.fixture(scope="module")
def stored(tmp_path_factory, one_thread):
    """A run trained for 4 short episodes, a checkpoint after each; its session kept."""
    from hadim_cli.config import load_config

    config = with_overrides(load_config(),
                            [f"world.episode_length={EPISODE}", "evaluation.every=200"])
    store = Store.open(tmp_path_factory.mktemp("run") / "s.sqlite", create=True)
    run = runs.new_run(store, config, SEED, None)
    session = Session(config, SEED)
    runs.train(store, run.name, session, 4 * EPISODE)
    assert len(session.learner.hierarchy) > 0  # something in H to restore
    yield store, run, session
    store.close()


def test_a_restored_run_is_the_session_that_wrote_its_last_checkpoint(stored):
    store, run, session = stored
    back = runs.restore_session(store, store.get_run(run.name))
    assert back.iteration == session.iteration == 4 * EPISODE
    assert back.episodes_done == session.episodes_done == 4
    assert back.world_rng.bit_generator.state == session.world_rng.bit_generator.state
    assert back.learner_rng.bit_generator.state == session.learner_rng.bit_generator.state
    assert assert_same(session.learner, back.learner, ignore=CACHES) > 500


def test_a_run_restored_at_an_earlier_checkpoint_replays_the_same_episodes(stored):
    """Restored after its second episode, the run trains its third and fourth episodes
    again, action for action, and ends where the original ended."""
    store, run, session = stored
    back = runs.restore_session(store, store.get_run(run.name), at=2 * EPISODE + 5)
    assert back.iteration == 2 * EPISODE and back.episodes_done == 2
    assert len(back.learner.dataset.episodes()) == 2
    runs.train(None, None, back, 4 * EPISODE)
    d, e = session.learner.dataset, back.learner.dataset
    assert np.array_equal(d.actions, e.actions) and np.array_equal(d.outcomes, e.outcomes)
    assert back.learner.learning_episodes == session.learner.learning_episodes
    assert [a.id for a in back.learner.hierarchy] == [a.id for a in session.learner.hierarchy]
    assert [a.competence for a in back.learner.hierarchy] == \
        [a.competence for a in session.learner.hierarchy]


def test_a_fork_with_another_seed_draws_from_new_generators_of_that_seed_and_iteration(stored):
    store, run, session = stored
    other = replace(store.get_run(run.name), seed=SEED + 1)
    back = runs.restore_session(store, other, at=2 * EPISODE)
    world, learner = np.random.default_rng([SEED + 1, 2 * EPISODE]).spawn(2)
    assert back.world_rng.bit_generator.state == world.bit_generator.state
    assert back.learner_rng.bit_generator.state == learner.bit_generator.state
    same = runs.restore_session(store, store.get_run(run.name), at=2 * EPISODE)
    assert same.world_rng.bit_generator.state != world.bit_generator.state
    # The data and H are the checkpoint's either way.
    assert_same(same.learner, back.learner, ignore=CACHES)


def test_a_run_without_a_checkpoint_starts_afresh_and_an_early_one_is_refused(tmp_path):
    from hadim_cli.config import load_config
    from hadim_cli.errors import HadimError

    config = load_config()
    with Store.open(tmp_path / "s.sqlite", create=True) as store:
        run = runs.new_run(store, config, SEED, "empty")
        fresh = runs.restore_session(store, run)
        assert fresh.iteration == 0 and fresh.episodes_done == 0
        root = np.random.default_rng(SEED).spawn(2)
        assert fresh.world_rng.bit_generator.state == root[0].bit_generator.state
        assert runs.restore_session(store, run, at=0).iteration == 0
        for at in (1, 5):
            with pytest.raises(HadimError, match=f"no checkpoint at or before iteration {at}$"):
                runs.restore_session(store, run, at=at)


def test_the_stored_timeline_is_the_sessions_events(tmp_path):
    """`hadim timeline` reads H's changes from the store: each event of the session as it
    happened — iteration, affordance, kind, input and output spaces, contexts, competence.
    (Its own run, not the module's: mutmut credits a module fixture's work to the first test
    that uses it, and runs only that one on a mutant of it.)"""
    config = _short_config()
    with Store.open(tmp_path / "s.sqlite", create=True) as store:
        run = runs.new_run(store, config, SEED, None)
        session = Session(config, SEED)
        runs.train(store, run.name, session, 2 * EPISODE)
        kept = store.events(run.name)
    events = session.learner.hierarchy.events
    assert events  # the affordances of H were created on the way
    assert [(e.iteration, e.affordance_id, e.kind, e.input_space, e.output_space,
             tuple(e.context), e.competence) for e in kept] == \
        [(e.iteration, e.affordance_id, e.kind.value, e.input, e.output, e.contexts,
          e.competence) for e in events]


def test_a_run_records_the_versions_of_the_packages_its_numbers_depend_on():
    from importlib import metadata

    names = ("hadim", "numpy", "scipy", "torch", "pymunk", "sqlalchemy")
    assert runs.package_versions() == {name: metadata.version(name) for name in names}


def test_a_resumed_run_goes_on_to_the_iterations_it_was_last_driven_to(stored, tmp_path):
    """`hadim resume RUN` continues to the target its last stored episode records; a run
    with no episode stored yet takes the default."""
    from hadim_cli.config import load_config

    store, run, _ = stored
    assert runs.target_iterations(store, store.get_run(run.name), 7) == 4 * EPISODE
    with Store.open(tmp_path / "s.sqlite", create=True) as empty:
        fresh = runs.new_run(empty, load_config(), SEED, None)
        assert runs.target_iterations(empty, fresh, 7) == 7


def test_full_checkpoints_are_written_as_often_as_the_environment_says(monkeypatch):
    from hadim_cli.errors import HadimError
    from hadim_store.deltas import DEFAULT_SNAPSHOT_EVERY

    monkeypatch.delenv("HADIM_SNAPSHOT_EVERY", raising=False)
    assert runs.snapshot_every() == DEFAULT_SNAPSHOT_EVERY
    monkeypatch.setenv("HADIM_SNAPSHOT_EVERY", " 3 ")
    assert runs.snapshot_every() == 3
    for bad in ("0", "two"):
        monkeypatch.setenv("HADIM_SNAPSHOT_EVERY", bad)
        with pytest.raises(HadimError, match=f"HADIM_SNAPSHOT_EVERY='{bad}': give a whole"):
            runs.snapshot_every()


def test_a_run_of_another_version_or_config_says_so_once_restored(stored):
    """A run trained by this hadim with this config restores without a note; one trained by
    another version, or whose config lacks a key, gets one line saying which and what is
    done about it."""
    store, run, _ = stored
    record = store.get_run(run.name)
    installed = runs.package_versions()["hadim"]
    assert runs.version_note(record) is None
    older = replace(record, versions={**record.versions, "hadim": "0.0.1"})
    assert runs.version_note(older) == (
        f"note: run {run.name} was trained with hadim 0.0.1; hadim {installed} learns and "
        "acts for it (its D, H and models as stored, the installed code)")
    unknown = replace(record, versions={**record.versions, "hadim": "unknown"})
    assert runs.version_note(unknown) is None  # no version to compare with
    config = {**record.config, "planner": dict(record.config["planner"])}
    config["planner"].pop("beam")
    config["planner"].pop("horizon")
    lacking = replace(record, config=config)
    assert runs.version_note(lacking) == (
        f"note: run {run.name} is run by hadim {installed}; hadim {installed} learns and acts "
        "for it (its D, H and models as stored, the installed code); keys it lacks, at the "
        "installed defaults: planner.horizon, planner.beam")


def test_evaluations_beside_a_run_are_stored_and_each_episodes_progress_carries_the_last(
        tmp_path):
    """Trained two episodes, evaluated on move-robot after each: both scores are stored with
    their iteration, and the progress reported after the last episode carries the score
    measured there (the evaluation under way waited for) and that iteration."""
    config = _short_config()
    seen = []
    with Store.open(tmp_path / "s.sqlite", create=True) as store:
        run = runs.new_run(store, config, SEED, None)
        runs.train(store, run.name, Session(config, SEED), 2 * EPISODE, eval_every=EPISODE,
                   tasks=("move-robot",), on_progress=seen.append)
        stored = [(e.iteration, e.task, e.score) for e in store.evaluations(run.name)]
    assert [(it, task) for it, task, _ in stored] == [(EPISODE, "move-robot"),
                                                      (2 * EPISODE, "move-robot")]
    assert [p.iteration for p in seen] == [EPISODE, 2 * EPISODE]
    assert seen[-1].scores == {"move-robot": stored[-1][2]}
    assert seen[-1].scored_at == 2 * EPISODE


def test_tasks_without_an_interval_are_never_evaluated():
    seen = []
    runs.train(None, None, Session(_short_config(), SEED), 2 * EPISODE, tasks=("move-robot",),
               on_progress=seen.append)
    assert [(p.scores, p.scored_at) for p in seen] == [({}, None), ({}, None)]


def test_a_run_is_written_only_for_the_owner_of_its_lock(tmp_path):
    """Trained for an owner that does not hold the run's lock (another process took it), the
    first episode is refused and nothing is stored; for the holder, every episode is."""
    from hadim_store.errors import RunLocked

    config = _short_config()
    with Store.open(tmp_path / "s.sqlite", create=True) as store:
        run = runs.new_run(store, config, SEED, None)
        store.acquire_lock(run.name, "holder")
        with pytest.raises(RunLocked, match="is not locked by 'other'"):
            runs.train(store, run.name, Session(config, SEED), EPISODE, owner="other")
        assert store.get_run(run.name).iterations == 0
        runs.train(store, run.name, Session(config, SEED), EPISODE, owner="holder")
        assert store.get_run(run.name).iterations == EPISODE


def test_stored_observations_the_configs_world_cannot_read_are_refused_in_one_line(tmp_path):
    """An episode stored with one value per observation, or with fewer values than the
    config's world observes, is refused by name before anything is restored."""
    from hadim_cli.config import load_config
    from hadim_cli.errors import HadimError
    from hadim_store.records import EpisodeWrite

    size = Session(load_config(), SEED).learner.dataset.obs_size
    for contexts, width in ((np.zeros(3), None), (np.zeros((3, size - 1)), size - 1)):
        with Store.open(tmp_path / f"s{width}.sqlite", create=True) as store:
            run = runs.new_run(store, load_config(), SEED, "r")
            store.write_episode(run.name, EpisodeWrite(
                0, 0, np.zeros((3, 2)), contexts, np.zeros_like(contexts),
                checkpoint_json={"format": runs.STATE_FORMAT}))
            with pytest.raises(HadimError, match=rf"^run r: its stored observations have "
                                                 rf"{width} values but the config's world "
                                                 rf"observes {size};"):
                runs.restore_session(store, store.get_run("r"))


def test_a_new_run_is_refused_a_directory_for_its_store_or_a_name_taken(tmp_path):
    from hadim_cli.config import load_config
    from hadim_cli.errors import HadimError
    from hadim_store.errors import StoreError

    with pytest.raises(HadimError, match="is a directory, not a store file"):
        runs.refuse_new_run(str(tmp_path), None)
    path = tmp_path / "s.sqlite"
    with Store.open(path, create=True) as store:
        runs.new_run(store, load_config(), SEED, "taken")
        assert runs.unreadable(store, "taken") is None  # a sound run reads back whole
    with pytest.raises(StoreError, match="taken"):
        runs.refuse_new_run(str(path), "taken")
    runs.refuse_new_run(str(path), "free")
    runs.refuse_new_run(str(tmp_path / "new.sqlite"), "free")


def _damaged_meta(path):
    """A copy of the store file at `path` whose `meta` table (where the schema is read) has
    its root page overwritten with garbage."""
    import sqlite3

    with sqlite3.connect(f"{path.resolve().as_uri()}?mode=ro", uri=True) as con:
        root, = con.execute("SELECT rootpage FROM sqlite_master WHERE name = 'meta'").fetchone()
        page, = con.execute("PRAGMA page_size").fetchone()
    data = bytearray(path.read_bytes())
    data[(root - 1) * page:root * page] = bytes((7 * i + 3) % 251 for i in range(page))
    copy = path.with_name("damaged.sqlite")
    copy.write_bytes(bytes(data))
    return copy


def test_a_store_damaged_where_its_schema_is_read_is_refused_in_one_line(tmp_path):
    """Opened to write into a run, the store says the run is untouched; opened to read it,
    that the run cannot be read; both name the damage and the command that says more."""
    from hadim_cli.config import load_config
    from hadim_cli.errors import HadimError

    with Store.open(tmp_path / "s.sqlite", create=True) as store:
        runs.new_run(store, load_config(), SEED, "r")
    copy = _damaged_meta(tmp_path / "s.sqlite")
    tail = f"the store is damaged (database disk image is malformed); see `hadim store check " \
           f"--store {copy}`"
    for writes, head in ((True, "run r untouched: "), (False, "run r cannot be read: ")):
        with pytest.raises(HadimError) as refused:
            runs.open_store(str(copy), create=False, writes=writes, run="r")
        assert str(refused.value) == head + tail


def test_without_a_name_the_run_read_is_the_stores_most_recently_updated_and_said_so(
        tmp_path, capsys):
    from hadim_cli.config import load_config

    with Store.open(tmp_path / "s.sqlite", create=True) as store:
        runs.new_run(store, load_config(), SEED, "older")
        runs.new_run(store, load_config(), SEED, "newer")
        store.set_status("older", "paused")  # updated after "newer" was created
        capsys.readouterr()
        assert runs.chosen_run(store, None).name == "older"
        assert capsys.readouterr().err == \
            "run older (the store's most recent; name a run to read another)\n"
        assert runs.chosen_run(store, "newer").name == "newer"


def test_a_damage_line_shortens_the_reason_to_fit_its_length_and_keeps_the_rest_whole(
        monkeypatch):
    """At most 193 characters: the reason cut (an ellipsis) where the line would exceed it;
    a reason quoted from an error is its first 60 characters at most."""
    from hadim_cli.errors import HadimError

    monkeypatch.setattr(runs, "opened", ["s.sqlite"])  # the store this process opened
    head, tail = "run r cannot be read: the store is damaged (", "); see `hadim store check " \
        "--store s.sqlite`"
    line = runs.damage_line("r", "x" * 300)
    assert len(line) == 193 and line.startswith(head + "x") and line.endswith("…" + tail)
    assert runs.damage_line("r", "x" * 100) == head + "x" * 100 + tail
    assert runs.short_reason(HadimError("y" * 61)) == "y" * 59 + "…"
    assert runs.short_reason(HadimError("y" * 60)) == "y" * 60


def test_a_database_errors_reason_is_that_of_the_driver_error_it_wraps():
    """SQLAlchemy's error carries the statement and parameters after SQLite's message; the
    reason quoted is SQLite's own, from the error it wraps (`orig`)."""
    import sqlite3

    from sqlalchemy.exc import DatabaseError

    wrapped = DatabaseError("SELECT x FROM runs", None,
                            sqlite3.DatabaseError("database disk image is malformed"))
    assert runs.short_reason(wrapped) == "database disk image is malformed"
