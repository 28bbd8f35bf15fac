"""Checkpoints as deltas: each item written as what changed since the run's previous checkpoint.

A checkpoint is a set of items, key → array or JSON value. Most of a learner's state grows by
appending (rows of data, goals, a timeline), so an item whose previous value is a prefix of its
new one (the first rows of an array, the first elements of a JSON list, byte for byte) is
written as that prefix's length and the rows after it; an unchanged item is a length and no
data. A bounded first-in-first-out buffer (p_A's replay once full: its oldest rows dropped,
new ones appended) keeps a window of its previous value: an array whose new first rows are
its previous value's rows from some row `skip` on is written as `skip`, the window's length
and the rows after it (schema 3), so a full buffer costs its new rows, not all of them.
Everything else is written whole. A checkpoint written so names the checkpoint it
continues (`base_iteration`); one that names none is a full snapshot.

Every `snapshot_every`-th checkpoint a `Store` writes for a run is a full snapshot (and so is
the first after the store is opened, e.g. on resume): the store then grows with what the run
adds plus one snapshot per `snapshot_every` episodes, and reading a checkpoint reads one
snapshot and at most `snapshot_every - 1` deltas. (Per episode, the deltas are dominated by
what changes everywhere at once — p_A's weights and optimiser moments — so a rule "snapshot
when the deltas outweigh one" would snapshot at nearly every episode.)

This module holds the pure parts: diffing against the previous state, and rebuilding a value
from its chain. `hadim_store.api` owns the transactions.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from datetime import datetime
from typing import Any

import numpy as np

from hadim_store import codecs
from hadim_store.errors import StoreError

DEFAULT_SNAPSHOT_EVERY = 50
"""One checkpoint in this many is a full snapshot (bounds what a restore reads)."""


@dataclass
class ItemRow:
    """One checkpoint item as stored: `prefix` None means `data`/`text` is the whole value;
    else the value is the base's rows `skip` … `skip + prefix` (skip None: 0), then `data`."""

    key: str
    kind: str
    data: bytes | None
    text: str | None
    prefix: int | None
    skip: int | None = None

    @property
    def size(self) -> int:
        return len(self.data or b"") + len(self.text or "")


@dataclass
class LastWritten:
    """What a `Store` remembers of the last checkpoint it wrote for a run: the base of the
    next delta. Only valid while that checkpoint is still the run's latest."""

    run_created: datetime
    checkpoint_id: int
    iteration: int
    arrays: dict[str, np.ndarray]
    elements: dict[str, list[str]]
    """JSON lists: each element's encoding (prefixes are compared on these, exactly)."""
    texts: dict[str, str]
    """Other JSON values: their encoding."""
    chain: int = 0
    """Deltas written since the last full snapshot."""


@dataclass
class Encoded:
    """A checkpoint's items, encoded either whole or as a delta against `LastWritten`."""

    rows: list[ItemRow]
    memory: LastWritten
    delta: bool


MAX_SKIP_CANDIDATES = 64
"""Rows of the previous value equal to the new first row that are tried as a window's start
(a buffer of many identical rows needs the first only; this bounds a pathological search)."""


def _array_window(new: np.ndarray, old: np.ndarray | None) -> tuple[int, int] | None:
    """(skip, keep) such that `new[:keep]` is `old[skip:skip + keep]` byte for byte, with
    `skip + keep` = len(old) (the previous value's end): 0 and len(old) if it is a prefix,
    else the smallest skip ≥ 1 that gives a non-empty window; None if there is none."""
    if (old is None or new.ndim == 0 or old.ndim != new.ndim or old.dtype != new.dtype
            or old.shape[1:] != new.shape[1:]):
        return None
    n_old, n_new = old.shape[0], new.shape[0]
    width = int(np.prod(new.shape[1:], dtype=np.int64))
    old_b = np.ascontiguousarray(old).reshape(n_old, width).view(np.uint8)
    new_b = np.ascontiguousarray(new).reshape(n_new, width).view(np.uint8)
    if n_old <= n_new and old_b.tobytes() == new_b[:n_old].tobytes():
        return 0, n_old
    if n_old < 2 or n_new == 0 or old_b.shape[1] == 0:
        return None
    # A window starts at a row of old equal to new's first, and ends at old's end.
    starts = np.flatnonzero((old_b[1:] == new_b[0]).all(axis=1)) + 1
    starts = starts[n_old - starts <= n_new][:MAX_SKIP_CANDIDATES]
    for skip in starts.tolist():
        keep = n_old - skip
        if old_b[skip:].tobytes() == new_b[:keep].tobytes():
            return skip, keep
    return None


def encode(arrays: Mapping[str, np.ndarray], texts: Mapping[str, Any], *, compress: bool,
           base: LastWritten | None) -> tuple[list[ItemRow], dict, dict, dict]:
    """Items of a checkpoint, as deltas against `base` where they can be (whole if None);
    also the new memory (arrays, list elements, other texts) for the next delta."""
    kind = codecs.NPY_ZLIB if compress else codecs.NPY
    rows: list[ItemRow] = []
    mem_arrays: dict[str, np.ndarray] = {}
    mem_elements: dict[str, list[str]] = {}
    mem_texts: dict[str, str] = {}
    for key, value in arrays.items():
        value = np.asarray(value)
        window = None if base is None else _array_window(value, base.arrays.get(key))
        if window is None:
            rows.append(ItemRow(key, kind, codecs.encode_array(value, compress=compress), None,
                                None))
        else:
            skip, keep = window
            tail = value[keep:]
            data = codecs.encode_array(tail, compress=compress) if tail.shape[0] else None
            rows.append(ItemRow(key, kind, data, None, keep, skip or None))
        mem_arrays[key] = value.copy()
    for key, value in texts.items():
        if isinstance(value, list | tuple):
            elements = [codecs.encode_json(v) for v in value]
            old = None if base is None else base.elements.get(key)
            mem_elements[key] = elements
            if old is not None and elements[:len(old)] == old:
                tail = elements[len(old):]
                text = "[" + ",".join(tail) + "]" if tail else None
                rows.append(ItemRow(key, "json", None, text, len(old)))
                continue
            rows.append(ItemRow(key, "json", None, "[" + ",".join(elements) + "]", None))
        else:
            text = codecs.encode_json(value)
            mem_texts[key] = text
            rows.append(ItemRow(key, "json", None, text, None))
    return rows, mem_arrays, mem_elements, mem_texts


def checkpoint_items(arrays: Mapping[str, np.ndarray], texts: Mapping[str, Any], *,
                     compress: bool, base: LastWritten | None, snapshot_every: int,
                     run_created: datetime, iteration: int) -> Encoded:
    """Encode a checkpoint against `base`, or whole when there is none or the chain since the
    last full snapshot is `snapshot_every - 1` deltas long. The caller sets the memory's
    checkpoint_id once the row exists."""
    if base is not None and base.chain + 1 < snapshot_every:
        rows, a, e, t = encode(arrays, texts, compress=compress, base=base)
        return Encoded(rows, LastWritten(run_created, -1, iteration, a, e, t, base.chain + 1),
                       True)
    rows, a, e, t = encode(arrays, texts, compress=compress, base=None)
    return Encoded(rows, LastWritten(run_created, -1, iteration, a, e, t, 0), False)


# ---------------------------------------------------------------------------- reading
def _tail_value(row: ItemRow) -> Any:
    if row.kind == "json":
        return codecs.decode_json(row.text) if row.text is not None else []
    return codecs.decode_array(row.data, row.kind) if row.data is not None else None


def chain_to(last: int, bases: Mapping[int, int | None], run: str) -> list[int]:
    """The iterations of the checkpoints read to restore the one at ``last``, oldest (its full
    snapshot) first, following each delta's base (``bases``: each checkpoint's, None for a
    snapshot); a base that is missing or not older is a `StoreError` naming ``run``."""
    chain = [last]
    while (base := bases[chain[-1]]) is not None:
        if base not in bases or base >= chain[-1]:
            raise StoreError(f"run {run!r}: checkpoint at {chain[-1]} continues a missing "
                             f"checkpoint ({base})")
        chain.append(base)
    chain.reverse()
    return chain


def resolve(chain: Sequence[Mapping[str, ItemRow]]) -> tuple[dict[str, np.ndarray],
                                                              dict[str, Any]]:
    """The values of the newest checkpoint of `chain` (oldest first, a full snapshot first):
    each key of the newest, its prefix taken from older ones as far as needed."""
    arrays: dict[str, np.ndarray] = {}
    texts: dict[str, Any] = {}
    for key, newest in chain[-1].items():
        value = _resolve_key(chain, key)
        if newest.kind == "json":
            texts[key] = value
        else:
            arrays[key] = value
    return arrays, texts


def _resolve_key(chain: Sequence[Mapping[str, ItemRow]], key: str) -> Any:
    parts: list[Any] = []
    # The rows [lo, hi) of this level's value are wanted (hi None: to its end). A delta's
    # value is its base's rows [skip, skip + prefix), then its tail.
    lo, hi = 0, None
    for level in range(len(chain) - 1, -1, -1):
        row = chain[level].get(key)
        if row is None:
            raise StoreError(f"corrupt checkpoint chain: item {key!r} has no base")
        if row.prefix is None:  # a full value is read even if none is wanted (its dtype)
            tail = _tail_value(row)
            parts.append(tail if (lo, hi) == (0, None) else tail[lo:hi])
            break
        keep, skip = row.prefix, row.skip or 0
        if hi is None or hi > keep:
            tail = _tail_value(row)
            if tail is not None:
                parts.append(tail[max(lo, keep) - keep:None if hi is None else hi - keep])
        top = keep if hi is None else min(hi, keep)
        lo, hi = (skip + lo, skip + top) if lo < top else (0, 0)
    else:
        raise StoreError(f"corrupt checkpoint chain: item {key!r} has no full value")
    parts.reverse()
    if chain[-1][key].kind == "json":
        if len(parts) == 1 and not isinstance(parts[0], list):
            return parts[0]
        return [v for p in parts for v in p]
    if len(parts) == 1:
        return parts[0]
    out = np.concatenate(parts)
    out.flags.writeable = False
    return out
