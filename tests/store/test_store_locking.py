"""Run locks: one live owner at a time, stale locks recovered (contract suite)."""

from __future__ import annotations

import subprocess
import sys
import time

import pytest
from sqlalchemy import text

from hadim_store import RunLocked, StoreError


def _dead_pid() -> int:
    child = subprocess.Popen([sys.executable, "-c", "pass"])
    child.wait()  # reaped: the pid no longer exists
    return child.pid


def _set_holder(store, name, *, pid, heartbeat, host=None, owner="someone-else"):
    from hadim_store.locking import this_host

    with store.engine.begin() as conn:
        conn.execute(
            text("UPDATE runs SET lock_owner = :owner, lock_pid = :pid, lock_host = :host,"
                 " lock_heartbeat = :heartbeat WHERE name = :name"),
            {"owner": owner, "pid": pid, "host": host or this_host(), "heartbeat": heartbeat,
             "name": name},
        )


def test_second_owner_refused(store):
    import os

    store.create_run(config={}, seed=1)
    assert store.acquire_lock("run-1", "alpha") is None
    assert store.acquire_lock("run-1", "alpha") is None  # re-entrant
    with pytest.raises(RunLocked, match=f"pid {os.getpid()} on "):
        store.acquire_lock("run-1", "beta")
    lock = store.get_run("run-1").lock
    assert lock.owner == "alpha" and lock.pid == os.getpid()
    assert store.release_lock("run-1", "beta") is False
    assert store.release_lock("run-1", "alpha") is True
    assert store.get_run("run-1").lock is None
    assert store.acquire_lock("run-1", "beta") is None


def test_stale_lock_of_dead_pid_recovered(store):
    store.create_run(config={}, seed=1)
    dead = _dead_pid()
    _set_holder(store, "run-1", pid=dead, heartbeat=time.time())
    replaced = store.acquire_lock("run-1", "me")
    assert replaced is not None and replaced.pid == dead and replaced.owner == "someone-else"
    assert store.get_run("run-1").lock.owner == "me"


def test_lock_without_heartbeat_recovered(store):
    store.create_run(config={}, seed=1)
    # A live pid (ours) on another host: only the heartbeat age can free it.
    _set_holder(store, "run-1", pid=1, host="elsewhere", heartbeat=time.time())
    with pytest.raises(RunLocked, match="pid 1 on elsewhere"):
        store.acquire_lock("run-1", "me")
    _set_holder(store, "run-1", pid=1, host="elsewhere", heartbeat=time.time() - 61)
    assert store.acquire_lock("run-1", "me").host == "elsewhere"


def test_a_live_holder_is_refused_without_writing(store):
    """`refuse_if_locked`: acquire_lock's refusal of a live holder, with nothing taken."""
    store.create_run(config={}, seed=1)
    store.refuse_if_locked("run-1")  # free
    _set_holder(store, "run-1", pid=1, host="elsewhere", heartbeat=time.time())
    with pytest.raises(RunLocked, match="run 'run-1' is in use: locked by pid 1 on elsewhere"):
        store.refuse_if_locked("run-1")
    for pid, heartbeat in ((_dead_pid(), time.time()), (1, time.time() - 61)):
        host = None if heartbeat > time.time() - 1 else "elsewhere"
        _set_holder(store, "run-1", pid=pid, host=host, heartbeat=heartbeat)
        store.refuse_if_locked("run-1")  # stale: passes, and stays as it was
        assert store.get_run("run-1").lock.pid == pid


def test_heartbeat_and_lost_lock(store):
    store.create_run(config={}, seed=1)
    store.acquire_lock("run-1", "me")
    before = store.get_run("run-1").lock.heartbeat
    time.sleep(0.01)
    store.heartbeat("run-1", "me")
    assert store.get_run("run-1").lock.heartbeat > before
    _set_holder(store, "run-1", pid=_dead_pid(), heartbeat=time.time(), owner="thief")
    with pytest.raises(RunLocked, match="no longer locked by 'me'"):
        store.heartbeat("run-1", "me")


def test_write_with_owner_requires_lock(store, make_episode):
    store.create_run(config={}, seed=1)
    with pytest.raises(RunLocked, match="not locked by 'me'"):
        store.write_episode("run-1", make_episode(0, 0), owner="me")
    store.acquire_lock("run-1", "me")
    store.write_episode("run-1", make_episode(0, 0), owner="me")
    assert store.get_run("run-1").iterations == 4


def test_delete_refused_while_locked(store):
    store.create_run(config={}, seed=1)
    store.acquire_lock("run-1", "me")
    with pytest.raises(RunLocked, match="cannot delete"):
        store.delete_run("run-1")
    store.release_lock("run-1", "me")
    store.delete_run("run-1")


def test_owner_validated(store):
    store.create_run(config={}, seed=1)
    with pytest.raises(StoreError, match="owner"):
        store.acquire_lock("run-1", "")
