"""Schema 2: delta checkpoints.

``checkpoints.base_iteration`` (NULL: a full snapshot; else the iteration of the checkpoint
this one continues) and ``checkpoint_items.prefix`` (NULL: the value is whole; else the first
``prefix`` rows of the base's item come first). NULL in both is exactly what every schema-1
checkpoint is, so existing rows need no change: two ``ADD COLUMN``s, instant on any size of
store, hence applied automatically when a schema-1 store is opened.

Revision ID: 0002
Revises: 0001
"""

from __future__ import annotations

import sqlalchemy as sa
from alembic import op

revision = "0002"
down_revision = "0001"
branch_labels = None
depends_on = None
automatic = True


def upgrade() -> None:
    op.add_column("checkpoints", sa.Column("base_iteration", sa.Integer, nullable=True))
    op.add_column("checkpoint_items", sa.Column("prefix", sa.Integer, nullable=True))


def downgrade() -> None:
    raise NotImplementedError("hadim stores are not downgraded: keep a copy from before")
