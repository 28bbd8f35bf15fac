"""`hadim bench train`: wall time of a learning session, per block of iterations.

Evaluation is off. With `with_store`, every episode is written to a fresh SQLite file exactly
as `hadim train` writes it (D's rows, events, stats, interest regions, a checkpoint), so the
difference between the two measures what storing and checkpointing cost. Each block also
reports the store's size on disk and the process's resident memory at its end, so a long bench
shows whether either grows faster than the run.
"""

from __future__ import annotations

import os
import tempfile
import time
from dataclasses import asdict, dataclass
from pathlib import Path

from hadim_cli.config import Config
from hadim_cli.session import EpisodeLog, Session


@dataclass(frozen=True)
class TrainBench:
    iterations: int
    wall_s: float
    iterations_per_s: float
    blocks: list[dict[str, float]]
    """Per block: first and last iteration (`start`, `stop`), `seconds`, `iterations_per_s`,
    `affordances`, `store_bytes` (0 without a store) and `rss_bytes` at its end."""
    store: bool
    store_bytes: int
    store_s: float
    """Seconds spent writing episodes and checkpoints to the store."""
    affordances: int

    def to_dict(self) -> dict:
        return asdict(self)


def rss_bytes() -> int:
    """Resident memory of this process now (Linux /proc; peak RSS elsewhere)."""
    try:
        with open("/proc/self/statm") as handle:
            pages = int(handle.read().split()[1])
        return pages * os.sysconf("SC_PAGE_SIZE")
    except (OSError, ValueError, IndexError):
        import resource

        return int(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss) * 1024


def file_bytes(path: Path) -> int:
    """Bytes of a SQLite store on disk: the file and its -wal and -shm companions."""
    return sum(p.stat().st_size for p in path.parent.glob(path.name + "*") if p.is_file())


def bench_train(config: Config, iterations: int, seed: int = 0, block: int = 500,
                with_store: bool = False) -> TrainBench:
    from hadim_cli import runs

    session = Session(config, seed)
    marks: list[tuple[int, float, int, int, int]] = [(0, 0.0, 0, 0, rss_bytes())]
    store_s = 0.0
    tmp = tempfile.TemporaryDirectory() if with_store else None
    store = None
    name = None
    path = None if tmp is None else Path(tmp.name) / "bench.sqlite"
    if path is not None:
        store = runs.open_store(str(path))
        name = runs.new_run(store, config, seed, None).name
    start = time.perf_counter()

    def after(log: EpisodeLog) -> None:
        nonlocal store_s
        if store is not None:
            t0 = time.perf_counter()
            store.write_episode(name, runs.episode_write(session, log))
            store_s += time.perf_counter() - t0
        now = time.perf_counter() - start
        if session.iteration // block > marks[-1][0] // block or session.iteration >= iterations:
            size = 0 if path is None else file_bytes(path)
            marks.append((session.iteration, now, len(session.learner.hierarchy), size,
                          rss_bytes()))

    try:
        session.run(iterations, after)
        wall = time.perf_counter() - start
        size = 0
        if tmp is not None:
            store.close()
            size = file_bytes(path)
    finally:
        if tmp is not None:
            tmp.cleanup()
    blocks = []
    for (i0, t0, *_), (i1, t1, n_aff, size_at, rss_at) in zip(marks, marks[1:], strict=False):
        blocks.append({"start": i0, "stop": i1, "seconds": round(t1 - t0, 3),
                       "iterations_per_s": round((i1 - i0) / max(t1 - t0, 1e-9), 1),
                       "affordances": n_aff, "store_bytes": size_at, "rss_bytes": rss_at})
    return TrainBench(session.iteration, round(wall, 3),
                      round(session.iteration / max(wall, 1e-9), 1), blocks, with_store, size,
                      round(store_s, 3), len(session.learner.hierarchy))
