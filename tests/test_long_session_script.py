"""scripts/long_session.py (issue #13's evidence): a sampled session, paused and resumed,
reported per block and drawn; and the rates' rules (no evaluation, pause or restore timed) on a
hand-made record."""

from __future__ import annotations

import importlib.util
import json
import os
import subprocess
import sys
from datetime import datetime, timedelta
from pathlib import Path

import pytest

from hadim_cli.app import app

ROOT = Path(__file__).resolve().parents[1]
_SPEC = importlib.util.spec_from_file_location("long_session", ROOT / "scripts" / "long_session.py")
assert _SPEC is not None and _SPEC.loader is not None
long_session = importlib.util.module_from_spec(_SPEC)
sys.modules["long_session"] = long_session  # NamedTuples defined in it need their module
_SPEC.loader.exec_module(long_session)

Sample, Record = long_session.Sample, long_session.Record


def _session(store: Path, iterations: int, *extra: str) -> None:
    # The CPU rate rests on the one interval (50, 100) of the first sitting that no evaluation
    # touches; its episode takes ~0.1 s, so samples every 0.1 s could miss it (seen once in CI).
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    cmd = [sys.executable, str(ROOT / "scripts" / "long_session.py"), "--store", str(store),
           "--iterations", str(iterations), "--eval-every", "150", "--sample-every", "0.02",
           "--nice", "0", "--seed", "5", *extra]
    done = subprocess.run(cmd, env=env, cwd=store.parent, capture_output=True, text=True,
                          timeout=300)
    assert done.returncode == 0, done.stderr


@pytest.fixture(scope="module")
def sampled(tmp_path_factory) -> Path:
    """A 300-iteration session in two sittings (a new process resumes it at 200)."""
    store = tmp_path_factory.mktemp("long") / "s.sqlite"
    _session(store, 200, "--set", "world.episode_length=50",
             "--set", 'evaluation.tasks=["move-robot"]')
    _session(store, 300)
    return store


def test_the_report_gives_each_block_what_the_store_says(sampled, runner, monkeypatch, capsys):
    monkeypatch.setattr(sys, "argv", ["long_session.py", "--store", str(sampled), "--report",
                                      "--json", "--block", "100"])
    long_session.main()
    out = json.loads(capsys.readouterr().out)
    assert out["iterations"] == 300
    blocks = out["blocks"]
    assert [(b["start"], b["stop"]) for b in blocks] == [(0, 100), (100, 200), (200, 300)]
    shown = json.loads(runner.invoke(app, ["runs", "show", "long", "--json", "--store",
                                           str(sampled)]).stdout)
    last = shown["scores"]["move-robot"]
    assert last["iteration"] == 300
    assert blocks[-1]["scores"] == {"move-robot": pytest.approx(last["score"])}
    assert [b["scores"] for b in blocks[:2]] == [{}, {}]  # evaluated at 150 and 300 only
    h = json.loads(runner.invoke(app, ["affordances", "long", "--json", "--store",
                                       str(sampled)]).stdout)
    assert blocks[-1]["affordances"] == len(h) > 0
    con = long_session._connect(sampled)
    try:
        timeline = long_session.read_record(con, sampled, "long").hierarchy
    finally:
        con.close()
    assert [it for it, _ in timeline] == list(range(50, 301, 50))  # one per episode
    assert timeline[-1] == (300, len(h))
    stored = [b["stored_bytes"] for b in blocks]
    assert 0 < stored[0] < stored[1] < stored[2] < out["file_bytes"]
    assert all(b["bytes_per_iteration"] == b["stored_bytes"] / b["stop"] for b in blocks)
    assert all(b["rss_bytes"] > 50e6 for b in blocks)  # a Python with numpy and torch
    samples = [json.loads(x) for x in Path(f"{sampled}.samples.jsonl").read_text().splitlines()]
    assert len({s["pid"] for s in samples}) == 2  # the resumed sitting sampled its own process
    rates = [b["iterations_per_cpu_s"] for b in blocks if b["iterations_per_cpu_s"]]
    assert rates and all(0 < x < 10_000 for x in rates)
    assert all(b["iterations_per_s"] > 0 for b in blocks)


def test_the_figure_is_drawn_beside_the_store_without_counting_as_the_store(
        sampled, monkeypatch, tmp_path):
    from matplotlib.image import imread

    out = Path(f"{sampled}.png")
    monkeypatch.setattr(sys, "argv", ["long_session.py", "--store", str(sampled), "--report",
                                      "--plot", str(out), "--plot-block", "50"])
    long_session.main()
    image = imread(out)
    assert image.shape[0] > 500 and image.shape[1] > 500
    assert image[..., :3].std() > 0.05  # something is drawn
    beside = long_session._file_bytes(sampled)
    out.rename(tmp_path / "moved.png")
    assert long_session._file_bytes(sampled) == beside > 0


def test_restore_is_timed_from_the_asked_checkpoint_and_writes_nothing(sampled, monkeypatch,
                                                                       capsys):
    def state() -> tuple:
        con = long_session._connect(sampled)
        try:
            return tuple(con.execute(f"SELECT count(*) FROM {table}").fetchone()[0]
                         for table in ("episodes", "checkpoints", "evaluations"))
        finally:
            con.close()

    before = state()
    monkeypatch.setattr(sys, "argv", ["long_session.py", "--store", str(sampled),
                                      "--time-restore", "--at", "220", "--then", "60"])
    long_session.main()
    out = json.loads(capsys.readouterr().out)
    assert out["iteration"] == 200  # the checkpoint at or before 220
    assert out["then_iterations"] == 100  # whole episodes of 50
    assert 0 < out["restore_s"] <= out["restore_to_first_iteration_s"]
    assert out["restore_cpu_s"] > 0
    assert out["then_cpu_s"] > 0 and out["iterations_per_cpu_s"] > 0
    assert state() == before
    # The rows it made are the run's own rows from 200 to 300 (the same code, resumed).
    from hadim_store import Store

    with Store.open(sampled, create=False) as store:
        assert out["dataset_sha256"] == store.dataset_sha256("long", 300)
        d = store.dataset("long", 300)
    assert out["new_rows_sha256"] == long_session._digest(*(a[200:] for a in d))


def test_a_report_of_a_run_not_in_the_store_is_one_error_line(sampled, monkeypatch):
    monkeypatch.setattr(sys, "argv", ["long_session.py", "--store", str(sampled), "--report",
                                      "--name", "nope"])
    with pytest.raises(SystemExit) as stop:
        long_session.main()
    assert str(stop.value).startswith("error: no run named 'nope'")


T0 = datetime(2026, 11, 24, 6, 0, 0)


def _record(stamps, samples, evals) -> Record:
    return Record("r", 1, 600, [(it, T0 + timedelta(seconds=s)) for it, s in stamps],
                  {e: {"move-robot": 0.5} for e in evals},
                  [Sample(0.0, it, 0, 0, cpu, pid) for pid, it, cpu in samples], [])


def test_wall_rates_leave_out_evaluations_and_pauses():
    # 100→200 and 300→400 take 1 s each, 500→600 2 s; 200→300 holds the evaluation at 200,
    # 400→500 a pause of 1000 s between two sittings.
    r = _record([(100, 0), (200, 1), (300, 31), (400, 32), (500, 1032), (600, 1034)], [], [200])
    assert long_session._wall_rate(r, 0, 600) == pytest.approx(300 / 4)
    assert long_session._wall_rate(r, 0, 250) == pytest.approx(100 / 1)
    assert long_session._wall_rate(r, 200, 300) is None


def test_cpu_rates_leave_out_a_processs_start_evaluations_and_other_processes():
    samples = [
        (1, 0, 0.0), (1, 0, 5.0),                  # imports: not timed
        (1, 100, 6.0), (1, 200, 7.0),              # 100 iterations in 1 CPU-s
        (1, 300, 8.0), (1, 400, 20.0),             # the evaluation at 300 ran in here
        (2, 400, 0.0), (2, 400, 4.0),              # a resumed process restores
        (2, 500, 5.0), (2, 500, 5.2), (2, 600, 5.5),  # 100 iterations in 0.5 CPU-s
    ]
    r = _record([], samples, [300])
    assert long_session._cpu_rate(r, 0, 600) == pytest.approx(200 / 1.5)
    assert long_session._cpu_rate(r, 0, 200) == pytest.approx(100 / 1.0)
    assert long_session._cpu_rate(r, 400, 600) == pytest.approx(100 / 0.5)
    assert long_session._cpu_rate(r, 200, 400) is None


def test_restore_timing_refuses_an_older_store_unchanged(tmp_path, monkeypatch):
    """A session of an older hadim may be writing to the store: timing a restore must not
    upgrade it under that session's feet (it would then refuse to resume)."""
    import shutil
    import sqlite3

    old = tmp_path / "v2.sqlite"
    shutil.copyfile(Path(__file__).parent / "fixtures" / "store_v2.sqlite", old)
    monkeypatch.setattr(sys, "argv", ["long_session.py", "--store", str(old), "--name", "run-1",
                                      "--time-restore"])
    with pytest.raises(SystemExit) as stop:
        long_session.main()
    assert str(stop.value).startswith("error: ") and "hadim store upgrade" in str(stop.value)
    con = sqlite3.connect(old)
    try:
        assert con.execute("SELECT value FROM meta WHERE key = 'schema_version'").fetchone() \
            == ("2",)
        columns = {row[1] for row in con.execute("PRAGMA table_info(checkpoint_items)")}
    finally:
        con.close()
    assert "prefix" in columns and "skip" not in columns


def test_delta_bytes_of_a_checkpoint_this_hadim_wrote_are_what_it_stored(sampled, monkeypatch,
                                                                         capsys):
    con = long_session._connect(sampled)
    try:
        deltas = [it for it, in con.execute(
            "SELECT c.iteration FROM checkpoints c JOIN runs r ON r.id = c.run_id WHERE "
            "r.name = 'long' AND c.base_iteration IS NOT NULL ORDER BY c.iteration")]
    finally:
        con.close()
    assert deltas
    monkeypatch.setattr(sys, "argv", ["long_session.py", "--store", str(sampled),
                                      "--delta-bytes", str(deltas[-1])])
    long_session.main()
    out = json.loads(capsys.readouterr().out)
    assert out["iteration"] == deltas[-1] and out["base_iteration"] < deltas[-1]
    assert out["delta_bytes"] == out["stored_bytes"] > 0
    assert out["delta_replay_bytes"] == out["stored_replay_bytes"]
