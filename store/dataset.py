"""D as the store returns it: the stored episodes' arrays stacked, and its digest. Shared by
`Store` and `StoreReader`, which read the episodes each their own way."""

from __future__ import annotations

import hashlib
from collections.abc import Sequence
from typing import NamedTuple

import numpy as np

from hadim_store.errors import StoreError
from hadim_store.records import EpisodeRecord

_DIGEST_PREFIX = b"hadim-dataset-sha256-v1\n"


class DatasetArrays(NamedTuple):
    """D as three arrays with one row per iteration."""

    actions: np.ndarray
    contexts: np.ndarray
    outcomes: np.ndarray


def stack(name: str, episodes: Sequence[EpisodeRecord], upto: int | None) -> DatasetArrays:
    """The rows of `episodes` (those that begin before `upto`, in order) concatenated; with
    `upto`, the first `upto` rows. No episode gives three empty float64 arrays of shape (0,)."""
    if not episodes:
        return DatasetArrays(*(np.empty((0,), dtype=np.float64) for _ in range(3)))
    parts = []
    for key in DatasetArrays._fields:
        try:
            array = np.concatenate([getattr(episode, key) for episode in episodes])
        except ValueError as exc:
            raise StoreError(f"run {name!r}: episodes' {key} do not stack: {exc}") from exc
        if upto is not None:
            array = array[: max(upto - episodes[0].first_iteration, 0)]
        array.flags.writeable = False
        parts.append(array)
    return DatasetArrays(*parts)


def digest(dataset: DatasetArrays) -> str:
    """A digest of D (dtype, shape and bytes of actions, contexts, outcomes, in that order):
    equal data sets give equal digests however they were split into episodes."""
    found = hashlib.sha256(_DIGEST_PREFIX)
    for key, array in zip(DatasetArrays._fields, dataset, strict=True):
        array = np.ascontiguousarray(array)
        found.update(f"{key}|{array.dtype.str}|{array.shape}\n".encode())
        found.update(array.tobytes())
    return found.hexdigest()
