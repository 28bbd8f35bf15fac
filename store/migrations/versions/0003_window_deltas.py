"""Schema 3: a delta may keep a window of its base (bounded buffers).

``checkpoint_items.skip`` (NULL: a delta's kept rows are its base's first ``prefix`` rows; else
they are its base's rows from ``skip`` on), so that a first-in-first-out buffer that is full —
its oldest rows dropped, new ones appended — is written as its new rows. NULL is exactly what
every schema-2 item is, so existing rows need no change: one ``ADD COLUMN``, instant on any
size of store, hence applied automatically when a schema-2 store is opened.

Revision ID: 0003
Revises: 0002
"""

from __future__ import annotations

import sqlalchemy as sa
from alembic import op

revision = "0003"
down_revision = "0002"
branch_labels = None
depends_on = None
automatic = True


def upgrade() -> None:
    op.add_column("checkpoint_items", sa.Column("skip", sa.Integer, nullable=True))


def downgrade() -> None:
    raise NotImplementedError("hadim stores are not downgraded: keep a copy from before")
