"""The dataset D: one record per executed primitive action, grouped by environment episode.

A record is (action, context = every observable before the action, outcome = after − before).
Arrays grow by doubling so appending is amortised O(1) and reads are views.
"""

from __future__ import annotations

import hashlib
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class EpisodeSlice:
    index: int
    start: int
    stop: int


class Dataset:
    """D as three aligned arrays (actions, contexts, outcomes) plus episode boundaries."""

    def __init__(self, obs_size: int, action_size: int):
        self.obs_size = obs_size
        self.action_size = action_size
        self._n = 0
        self._actions = np.zeros((256, action_size))
        self._contexts = np.zeros((256, obs_size))
        self._outcomes = np.zeros((256, obs_size))
        self._episode_starts: list[int] = []

    def __len__(self) -> int:
        return self._n

    def _grow(self, needed: int) -> None:
        cap = self._actions.shape[0]
        if needed <= cap:
            return
        new_cap = max(needed, 2 * cap)
        for name in ("_actions", "_contexts", "_outcomes"):
            old = getattr(self, name)
            new = np.zeros((new_cap, old.shape[1]))
            new[: self._n] = old[: self._n]
            setattr(self, name, new)

    def start_episode(self) -> None:
        self._episode_starts.append(self._n)

    def append(self, action: np.ndarray, before: np.ndarray, after: np.ndarray) -> int:
        """Record one primitive action; returns its iteration index."""
        if not self._episode_starts:
            self.start_episode()
        self._grow(self._n + 1)
        i = self._n
        self._actions[i] = action
        self._contexts[i] = before
        self._outcomes[i] = after - before
        self._n += 1
        return i

    def extend(self, actions: np.ndarray, contexts: np.ndarray, outcomes: np.ndarray) -> None:
        """Append a whole stored episode (used when restoring from the store)."""
        self.start_episode()
        n = actions.shape[0]
        self._grow(self._n + n)
        self._actions[self._n:self._n + n] = actions
        self._contexts[self._n:self._n + n] = contexts
        self._outcomes[self._n:self._n + n] = outcomes
        self._n += n

    @property
    def actions(self) -> np.ndarray:
        return self._actions[: self._n]

    @property
    def contexts(self) -> np.ndarray:
        return self._contexts[: self._n]

    @property
    def outcomes(self) -> np.ndarray:
        return self._outcomes[: self._n]

    def episode_start(self, i: int) -> int:
        """First iteration of the environment episode holding iteration `i`."""
        k = int(np.searchsorted(self._episode_starts, i, side="right")) - 1
        return self._episode_starts[k] if k >= 0 else 0

    def episodes(self) -> list[EpisodeSlice]:
        stops = [*self._episode_starts[1:], self._n]
        return [EpisodeSlice(i, a, b) for i, (a, b) in enumerate(zip(self._episode_starts, stops,
                                                                   strict=True))]

    def sha256(self) -> str:
        return dataset_digest(self.actions, self.contexts, self.outcomes)


def dataset_digest(actions: np.ndarray, contexts: np.ndarray, outcomes: np.ndarray) -> str:
    """A digest of D: identical arrays (values, shapes) give identical digests."""
    h = hashlib.sha256()
    for arr in (actions, contexts, outcomes):
        arr = np.ascontiguousarray(arr, dtype=np.float64)
        h.update(str(arr.shape).encode())
        h.update(arr.tobytes())
    return h.hexdigest()
