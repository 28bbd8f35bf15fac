"""Schema versions and the steps from each one to the next.

Bump ``SCHEMA_VERSION`` whenever the tables change, and append a :class:`Migration` from the
previous version. A store is upgraded in place, in order, in one transaction when opened; a
store newer than ``SCHEMA_VERSION`` is refused.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

from sqlalchemy import Connection, text

APPLICATION = "hadim"
SCHEMA_VERSION = 2


@dataclass(frozen=True)
class Migration:
    """Upgrades a store from ``from_version`` to ``from_version + 1``."""

    from_version: int
    description: str
    apply: Callable[[Connection], None]


def _delta_checkpoints(conn: Connection) -> None:
    # Existing checkpoints are full snapshots: NULL in both new columns says exactly that.
    conn.execute(text("ALTER TABLE checkpoints ADD COLUMN base_iteration INTEGER"))
    conn.execute(text("ALTER TABLE checkpoint_items ADD COLUMN prefix INTEGER"))


MIGRATIONS: list[Migration] = [
    Migration(1, "delta checkpoints: checkpoints.base_iteration, checkpoint_items.prefix",
              _delta_checkpoints),
]


def plan(current: int, target: int, migrations: list[Migration]) -> list[Migration]:
    """The migrations taking ``current`` to ``target``, in order; raises if one is missing."""
    by_version = {m.from_version: m for m in migrations}
    steps = []
    for version in range(current, target):
        if version not in by_version:
            raise LookupError(f"no migration from schema version {version} to {version + 1}")
        steps.append(by_version[version])
    return steps
