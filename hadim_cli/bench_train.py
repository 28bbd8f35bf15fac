"""`hadim bench train`: wall time of a learning session, per block of iterations.

Evaluation is off. With `with_store`, every episode is written to a fresh SQLite file exactly
as `hadim train` writes it (D's rows, events, stats, interest regions, a checkpoint), so the
difference between the two measures what storing and checkpointing cost.
"""

from __future__ import annotations

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
    """Per block: first and last iteration, seconds, iterations/s, affordances at its end."""
    store: bool
    store_bytes: int
    store_s: float
    """Seconds spent writing episodes and checkpoints to the store."""
    affordances: int

    def to_dict(self) -> dict:
        return asdict(self)


def bench_train(config: Config, iterations: int, seed: int = 0, block: int = 500,
                with_store: bool = False) -> TrainBench:
    from hadim_cli import runs

    session = Session(config, seed)
    marks: list[tuple[int, float, int]] = [(0, 0.0, 0)]
    store_s = 0.0
    tmp = tempfile.TemporaryDirectory() if with_store else None
    store = None
    name = None
    if tmp is not None:
        store = runs.open_store(str(Path(tmp.name) / "bench.sqlite"))
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
            marks.append((session.iteration, now, len(session.learner.hierarchy)))

    try:
        session.run(iterations, after)
        wall = time.perf_counter() - start
        size = 0
        if tmp is not None:
            store.close()
            size = sum(p.stat().st_size for p in Path(tmp.name).glob("bench.sqlite*"))
    finally:
        if tmp is not None:
            tmp.cleanup()
    blocks = []
    for (i0, t0, _), (i1, t1, n_aff) in zip(marks, marks[1:], strict=False):
        blocks.append({"start": i0, "stop": i1, "seconds": round(t1 - t0, 3),
                       "iterations_per_s": round((i1 - i0) / max(t1 - t0, 1e-9), 1),
                       "affordances": n_aff})
    return TrainBench(session.iteration, round(wall, 3),
                      round(session.iteration / max(wall, 1e-9), 1), blocks, with_store, size,
                      round(store_s, 3), len(session.learner.hierarchy))
