"""``python -m hadim_store.migrations "what changes"``: a new revision file in ``versions/``, from
``script.py.mako``, numbered after the head (then bump ``SCHEMA_VERSION``; docs/store.md)."""

from __future__ import annotations

import sys
from pathlib import Path


def new_revision(message: str, folder: Path | None = None) -> Path:
    """Write the next revision's file (``000N_message.py``) and return its path."""
    from alembic import command

    from hadim_store import migrations, schema

    script = command.revision(
        schema._config(None), message=message,
        rev_id=migrations.revision_id(migrations.SCHEMA_VERSION + 1),
        version_path=str(folder or migrations.VERSION_LOCATIONS[0]))
    return Path(script.path)


if __name__ == "__main__":
    if len(sys.argv) != 2 or not sys.argv[1].strip():
        sys.exit('usage: python -m hadim_store.migrations "what the revision changes"')
    print(new_revision(sys.argv[1]))
