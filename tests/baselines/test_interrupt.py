"""Ctrl-C on a real `hadim baseline train` process: the run stops at its next checkpoint, is
paused with its lock released, and `hadim resume` continues it bit-identically (the state an
uninterrupted run reaches at the same iteration)."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from typer.testing import CliRunner

from hadim_cli.app import app
from hadim_store.api import Store
from hadim_store.errors import StoreError

ROOT = Path(__file__).resolve().parents[2]
# DQN (networks, optimiser, replay buffer, ε schedule) learning from iteration 30 on, a
# checkpoint every 20 iterations, no evaluation; the horizon fixes the schedule whatever the
# total, so the interrupted and the straight run share it.
ARGS = ("--algo", "dqn", "--task", "push-object", "--reward", "guided", "--seed", "4",
        "--horizon", "400", "--episode-length", "30", "--eval-every", "0",
        "--checkpoint-every", "20")
LONG = 4000


def _stored(store: Path) -> int:
    try:
        with Store.open(store, create=False) as st:
            return st.get_run("run-1").iterations
    except StoreError:  # not created yet
        return 0


def _interrupt_after(store: Path, proc: subprocess.Popen, iterations: int) -> tuple[str, str]:
    deadline = time.monotonic() + 240
    try:
        while _stored(store) < iterations:
            assert proc.poll() is None, proc.communicate()
            if time.monotonic() > deadline:
                pytest.fail(f"run-1 did not reach {iterations} iterations")
            time.sleep(0.1)
        proc.send_signal(signal.SIGINT)
        return proc.communicate(timeout=120)
    finally:
        if proc.poll() is None:
            proc.kill()


def test_ctrl_c_checkpoints_and_resume_continues_bit_identically(tmp_path):
    store = tmp_path / "s.sqlite"
    proc = subprocess.Popen(
        [sys.executable, "-m", "hadim_cli.app", "baseline", "train", *ARGS,
         "--iterations", str(LONG), "--store", str(store)],
        cwd=tmp_path, env=dict(os.environ, PYTHONPATH=str(ROOT)), text=True,
        stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    out, err = _interrupt_after(store, proc, 60)
    assert proc.returncode == 130, err
    assert "Traceback" not in err
    assert f"continue with: hadim resume run-1 --store {store}" in err
    assert out.strip() == "run-1"
    with Store.open(store, create=False) as st:
        record = st.get_run("run-1")
        assert record.status == "paused" and record.lock is None
        paused = record.iterations
        assert paused % 20 == 0 and 60 <= paused < LONG
        assert st.checkpoint("run-1").iteration == paused  # stopped at its checkpoint
    total = paused + 40
    runner = CliRunner()
    resumed = runner.invoke(app, ["resume", "run-1", "--iterations", str(total),
                                  "--store", str(store)])
    assert resumed.exit_code == 0, resumed.output
    straight = runner.invoke(app, ["baseline", "train", *ARGS, "--iterations", str(total),
                                   "--name", "straight", "--store", str(store)])
    assert straight.exit_code == 0, straight.output
    with Store.open(store, create=False) as st:
        a, b = st.checkpoint("run-1"), st.checkpoint("straight")
        assert a.iteration == b.iteration == total
        assert a.json == b.json
        assert sorted(a.arrays) == sorted(b.arrays)
        for key in a.arrays:
            assert a.arrays[key].tobytes() == b.arrays[key].tobytes(), key
        assert a.json["agent"]["counters"]["_n_updates"] > 0  # it did learn
        assert st.dataset_sha256("run-1") == st.dataset_sha256("straight")
        assert st.get_run("run-1").status == "finished"
