"""${message}

Revision ID: ${up_revision}
Revises: ${down_revision | comma,n}
Created: ${create_date}
"""

from __future__ import annotations

import sqlalchemy as sa
from alembic import op
${imports if imports else ""}
revision = ${repr(up_revision)}
down_revision = ${repr(down_revision)}
branch_labels = None
depends_on = None
# True: applied when a store is opened (cheap and additive, e.g. a nullable column). False:
# only by `hadim store upgrade` (a table rebuild, a long data copy): opening refuses meanwhile.
automatic = False


def upgrade() -> None:
    ${upgrades if upgrades else "pass"}


def downgrade() -> None:
    raise NotImplementedError("hadim stores are not downgraded: keep a copy from before")
