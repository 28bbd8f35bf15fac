"""Keeping a run's lock alive from a thread while a process trains it."""

from __future__ import annotations

import threading
from collections.abc import Iterator
from contextlib import contextmanager


@contextmanager
def keep_alive(store, run_name: str, owner: str) -> Iterator[None]:
    """Refresh the run's lock from a thread: a long episode or evaluation must not let another
    process take the lock over as stale (no heartbeat for `store.lock_timeout` seconds)."""
    from hadim_store.errors import RunLocked

    stop = threading.Event()

    def beat() -> None:
        while not stop.wait(max(store.lock_timeout / 4, 0.05)):
            try:
                store.heartbeat(run_name, owner)
            except RunLocked:
                return  # lost: the next write_episode refuses and says so
            except Exception:  # noqa: BLE001 — a busy store: try again at the next beat
                continue

    thread = threading.Thread(target=beat, name=f"hadim-heartbeat-{run_name}", daemon=True)
    thread.start()
    try:
        yield
    finally:
        stop.set()
        thread.join()
