"""The store contract suite runs against every backend: in-memory SQLite, file SQLite and a
real PostgreSQL server (started once per test session by tests/conftest.py's `postgres`)."""

from __future__ import annotations

import sys
from collections.abc import Iterator
from pathlib import Path

# Plain `pytest` puts tests/ on sys.path, where this folder would shadow the `store` package as
# a namespace package; the repository root on the path lets the real package win.
_ROOT = str(Path(__file__).resolve().parents[2])
if _ROOT not in sys.path:
    sys.path.append(_ROOT)
if getattr(sys.modules.get("store"), "__file__", "") is None:
    del sys.modules["store"]

import numpy as np  # noqa: E402
import pytest  # noqa: E402

from hadim_store import (  # noqa: E402
    AffordanceEvent,
    AffordanceStat,
    EpisodeWrite,
    InterestRegion,
    Store,
)

BACKENDS = ["memory", "file", "postgresql"]


def open_backend(kind: str, request: pytest.FixtureRequest, tmp_path: Path, **options) -> Store:
    if kind == "memory":
        return Store.open("sqlite://", **options)
    if kind == "postgresql":
        return Store.open(request.getfixturevalue("postgres_url"), **options)
    return Store.open(tmp_path / "store.db", **options)


@pytest.fixture(params=BACKENDS)
def store(request: pytest.FixtureRequest, tmp_path: Path) -> Iterator[Store]:
    with open_backend(request.param, request, tmp_path) as opened:
        yield opened


@pytest.fixture
def file_store(tmp_path: Path) -> Iterator[Store]:
    with Store.open(tmp_path / "store.db") as opened:
        yield opened


def make_episode(
    index: int,
    first_iteration: int,
    n: int = 4,
    *,
    seed: int = 0,
    checkpoint: bool = True,
) -> EpisodeWrite:
    """A small, deterministic episode whose values depend on (seed, index)."""
    rng = np.random.default_rng([seed, index])
    end = first_iteration + n
    return EpisodeWrite(
        index=index,
        first_iteration=first_iteration,
        actions=rng.uniform(-1, 1, (n, 2)),
        contexts=rng.uniform(-1, 1, (n, 6)).astype(np.float32),
        outcomes=rng.integers(0, 100, (n, 3), dtype=np.int16),
        extra={"mode": ["goal" if i % 2 else "random" for i in range(n)], "episode": index},
        events=[
            AffordanceEvent(
                iteration=first_iteration,
                affordance_id=index,
                kind="created",
                input_space="robot_motor",
                output_space="robot_position",
                context=("robot_position",),
                competence=None,
                detail={"why": "test"},
            )
        ],
        stats=[AffordanceStat(end, aid, 0.5 + 0.01 * index, 10 * index, 0.1) for aid in range(2)],
        regions=[
            InterestRegion(end, aid, region, None if region == 0 else 0, (0.0,), (1.0,), 3, 0.2)
            for aid in range(2)
            for region in range(index + 1)
        ],
        checkpoint_arrays={"weights": rng.normal(size=(3, 3)), "counter": np.array(end)}
        if checkpoint
        else None,
        checkpoint_json={"iteration": end, "rng": {"state": [1, 2, 3]}} if checkpoint else None,
    )


def fill(store: Store, name: str, episodes: int, n: int = 4, *, seed: int = 0) -> None:
    for index in range(episodes):
        store.write_episode(name, make_episode(index, index * n, n, seed=seed))


@pytest.fixture(name="make_episode")
def make_episode_fixture():
    return make_episode


@pytest.fixture(name="fill")
def fill_fixture():
    return fill
