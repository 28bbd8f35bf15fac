"""Frozen records the store takes and returns; never ORM rows.

Arrays inside records returned by the store are read-only (``flags.writeable`` is False):
copy them (``arr.copy()``) before changing them in place.
"""

from __future__ import annotations

import enum
import numbers
import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from datetime import datetime
from typing import Any

import numpy as np

from hadim_store.errors import StoreError

_NAME_RE = re.compile(r"[A-Za-z0-9][A-Za-z0-9._-]{0,63}")


def check_name(name: str) -> str:
    """A run's (or sweep's) name a caller passes: 1-64 letters, digits, '.', '_' or '-'."""
    if not isinstance(name, str) or not _NAME_RE.fullmatch(name):
        raise StoreError(
            f"invalid run name {name!r}: use 1-64 letters, digits, '.', '_' or '-', "
            "starting with a letter or digit"
        )
    return name


def check_iteration(value: int | None, what: str) -> int | None:
    """An iteration (or index) a caller passes: None, or a non-negative integer."""
    if value is None:
        return None
    if isinstance(value, bool) or not isinstance(value, numbers.Integral) or value < 0:
        raise StoreError(f"{what} must be a non-negative integer, got {value!r}")
    return int(value)


class RunStatus(enum.StrEnum):
    """Where a run is in its life. A new run is ``paused`` until a session starts it."""

    RUNNING = "running"
    PAUSED = "paused"
    FINISHED = "finished"
    FAILED = "failed"


@dataclass(frozen=True)
class LockInfo:
    """Who holds a run's lock, as last recorded."""

    owner: str
    pid: int
    host: str
    heartbeat: datetime


@dataclass(frozen=True)
class RunRecord:
    """One run: its identity, resolved config and how far it got."""

    name: str
    status: RunStatus
    seed: int
    config: dict[str, Any]
    parent: str | None
    """Name of the run it was forked from (None if not a fork, or the parent was deleted)."""
    fork_iteration: int | None
    """Iteration of the parent's checkpoint it was forked from."""
    versions: dict[str, Any]
    iterations: int
    """Iterations stored so far (= first_iteration + n_iterations of the last episode)."""
    created_at: datetime
    updated_at: datetime
    lock: LockInfo | None = None


@dataclass(frozen=True)
class EpisodeRecord:
    """One stored episode: rows first_iteration .. first_iteration + n_iterations - 1 of D."""

    index: int
    first_iteration: int
    actions: np.ndarray
    contexts: np.ndarray
    outcomes: np.ndarray
    extra: dict[str, Any]

    @property
    def n_iterations(self) -> int:
        return int(self.actions.shape[0])


@dataclass(frozen=True)
class AffordanceEvent:
    """A change in the set of affordances (the timeline). ``kind`` is the learner's enum value."""

    iteration: int
    affordance_id: int
    kind: str
    input_space: str
    output_space: str
    context: tuple[str, ...] = ()
    competence: float | None = None
    detail: dict[str, Any] = field(default_factory=dict)


@dataclass(frozen=True)
class AffordanceStat:
    """One affordance's numbers at the end of an episode."""

    iteration: int
    affordance_id: int
    competence: float | None
    n_data: int
    interest: float | None


@dataclass(frozen=True)
class InterestRegion:
    """One leaf of an affordance's interest map in a snapshot."""

    iteration: int
    affordance_id: int
    region_id: int
    parent_id: int | None
    low: tuple[float, ...]
    high: tuple[float, ...]
    n_goals: int
    interest: float


@dataclass(frozen=True)
class Checkpoint:
    """Everything stored to continue a run bit-identically from ``iteration``."""

    iteration: int
    episode_index: int
    created_at: datetime
    arrays: dict[str, np.ndarray]
    json: dict[str, Any]


@dataclass(frozen=True)
class Evaluation:
    """A score of the run on a task at some iteration; ``points`` are per-target details."""

    iteration: int
    task: str
    score: float
    points: list[Any]
    created_at: datetime


@dataclass(frozen=True)
class EpisodeWrite:
    """What one episode writes, all in one transaction.

    ``actions``, ``contexts`` and ``outcomes`` have one row per iteration (same first
    dimension, at least 1). Every event, stat and region ``iteration`` must lie in
    ``[first_iteration, first_iteration + n_iterations]``. ``regions`` must be a complete
    snapshot of every live affordance's interest-map leaves (an affordance absent from the
    latest snapshot is taken as gone). A checkpoint is stored, at iteration
    ``first_iteration + n_iterations``, when ``checkpoint_arrays`` or ``checkpoint_json`` is
    not None.
    """

    index: int
    first_iteration: int
    actions: np.ndarray
    contexts: np.ndarray
    outcomes: np.ndarray
    extra: Mapping[str, Any] = field(default_factory=dict)
    events: Sequence[AffordanceEvent] = ()
    stats: Sequence[AffordanceStat] = ()
    regions: Sequence[InterestRegion] = ()
    checkpoint_arrays: Mapping[str, np.ndarray] | None = None
    checkpoint_json: Mapping[str, Any] | None = None

    @property
    def n_iterations(self) -> int:
        return int(np.shape(self.actions)[0]) if np.ndim(self.actions) else 0

    @property
    def end_iteration(self) -> int:
        """Iterations done once this episode is stored (the checkpoint's iteration)."""
        return self.first_iteration + self.n_iterations
