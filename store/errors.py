"""Errors the store raises: each message is one line a user can act on.

The CLI prints the message of any :class:`StoreError` on one line and exits with status 2.
"""

from __future__ import annotations

import difflib
from collections.abc import Sequence


class StoreError(Exception):
    """Base of every error the store raises on purpose (bad input, unusable store)."""

    exit_code = 2


class UnknownRun(StoreError):
    """No run has the given name."""


def unknown_run(name: str, names: Sequence[str]) -> UnknownRun:
    """No run `name` among `names`: the closest names, or how many runs there are."""
    close = difflib.get_close_matches(str(name), list(names), n=3)
    if close:
        hint = f"; did you mean {', '.join(close)}?"
    else:
        hint = f" (the store has {len(names)} run{'s' if len(names) != 1 else ''})"
    return UnknownRun(f"no run named {name!r}{hint}")


def name_taken(name: str) -> StoreError:
    return StoreError(f"a run named {name!r} already exists")


class SchemaError(StoreError):
    """The file is not a hadim store, is corrupt, or has a schema this hadim cannot read."""


class RunLocked(StoreError):
    """Another live process holds the run's lock (or ours was taken over as stale)."""


class CodecError(StoreError):
    """A value cannot be encoded, or a stored blob is refused (not .npy, object dtype, bad JSON)."""


class DamagedStore(StoreError):
    """The database file fails SQLite's own checks (`PRAGMA quick_check`) or cannot be read."""

    finding: str = ""
    """What SQLite found, as it said it."""
