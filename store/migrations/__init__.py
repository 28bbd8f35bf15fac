"""The store's schema versions, as an alembic environment shipped inside the package.

``versions/`` holds one alembic revision per schema version, linear: revision ``0001`` is
schema 1 (the tables of the first release), ``0002`` schema 2, and so on — the revision id is
the version on four digits, and ``meta.schema_version`` follows the revision at every step
(``env.py``), so a hadim from before alembic still reads the version it understands.
``hadim_store.schema`` drives them: a new store is created from ``models.py`` and stamped with the
head; an older one is upgraded in one transaction. This module imports nothing heavy: opening
a store of the current schema never loads alembic.

To change the schema: edit ``models.py``, bump ``SCHEMA_VERSION``, and add the revision
(``python -m hadim_store.migrations revision "what changes"``; docs/store.md).
"""

from __future__ import annotations

import re
from pathlib import Path

APPLICATION = "hadim"
SCHEMA_VERSION = 3
# alembic's own table (one row, the revision id); the name alembic uses by default.
VERSION_TABLE = "alembic_version"
SCRIPT_LOCATION = Path(__file__).resolve().parent
# Where revisions are read from: this package's versions/ (tests add a folder of their own).
VERSION_LOCATIONS: list[Path] = [SCRIPT_LOCATION / "versions"]

_REVISION_RE = re.compile(r"\d{4}")


def revision_id(version: int) -> str:
    """The alembic revision id of a schema version: ``2`` → ``"0002"``."""
    return f"{version:04d}"


def version_of(revision: str) -> int | None:
    """The schema version a revision id names; None if it is not one of hadim's ids."""
    return int(revision) if _REVISION_RE.fullmatch(revision) else None
