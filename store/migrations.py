"""Schema versions and the steps from each one to the next.

Bump ``SCHEMA_VERSION`` whenever the tables change, and append a :class:`Migration` from the
previous version. A store is upgraded in place, in order, in one transaction when opened; a
store newer than ``SCHEMA_VERSION`` is refused.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

from sqlalchemy import Connection

APPLICATION = "hadim"
SCHEMA_VERSION = 1


@dataclass(frozen=True)
class Migration:
    """Upgrades a store from ``from_version`` to ``from_version + 1``."""

    from_version: int
    description: str
    apply: Callable[[Connection], None]


# Version 1 is the first schema: nothing to migrate from yet.
MIGRATIONS: list[Migration] = []


def plan(current: int, target: int, migrations: list[Migration]) -> list[Migration]:
    """The migrations taking ``current`` to ``target``, in order; raises if one is missing."""
    by_version = {m.from_version: m for m in migrations}
    steps = []
    for version in range(current, target):
        if version not in by_version:
            raise LookupError(f"no migration from schema version {version} to {version + 1}")
        steps.append(by_version[version])
    return steps
