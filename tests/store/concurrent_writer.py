"""One of the concurrency test's writer processes (run as a script, see test_store_concurrency).

Waits for the go file, then at once: creates an auto-named run, tries to take the lock of the
shared run `contended`, and writes its episodes into its own run under its lock. The process
that won `contended` keeps it until every writer has tried, so exactly one may win.
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

sys.path[:0] = [str(Path(__file__).resolve().parents[2]), str(Path(__file__).resolve().parent)]

from conftest import make_episode  # noqa: E402

from hadim_store import RunLocked, Store  # noqa: E402


def main(url: str, workdir: str, index: int, episodes: int, writers: int) -> None:
    folder = Path(workdir)
    owner = f"writer-{index}"
    with Store.open(url, create=False) as store:
        store.list_runs()  # connected and warm: then every writer starts at the same moment
        (folder / f"ready-{index}").touch()
        while not (folder / "go").exists():
            time.sleep(0.002)
        name = store.create_run(config={"writer": index}, seed=index).name
        try:
            store.acquire_lock("contended", owner)
            won = True
        except RunLocked:
            won = False
        (folder / f"tried-{index}").write_text("won" if won else "refused")
        store.acquire_lock(name, owner)
        for k in range(episodes):
            store.write_episode(name, make_episode(k, 4 * k, seed=index), owner=owner)
        store.release_lock(name, owner)
        if won:  # hold `contended` until everyone has tried it
            while len(list(folder.glob("tried-*"))) < writers:
                time.sleep(0.01)
            store.release_lock("contended", owner)
    print(name, "won" if won else "refused")


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2], *map(int, sys.argv[3:6]))
