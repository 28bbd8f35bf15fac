"""alembic's environment for hadim stores.

Run by ``hadim_store.schema`` on the connection it passes in ``config.attributes["connection"]``,
inside the transaction it has begun (and, on SQLite, with foreign keys off so that a table
rebuild cascades nothing): alembic commits nothing itself, so the whole upgrade — every
revision, alembic's version row and ``meta.schema_version`` — is one transaction.
"""

from __future__ import annotations

from alembic import context
from sqlalchemy import update

from hadim_store import migrations
from hadim_store.models import Base, Meta


def _follow_revision(*, ctx, step, heads, run_args) -> None:  # noqa: ARG001 — alembic's signature
    """Keep ``meta.schema_version`` equal to alembic's revision after every step: it is what a
    hadim from before alembic reads, and what plain SQL shows."""
    (head,) = heads
    version = migrations.version_of(head)
    ctx.connection.execute(
        update(Meta).where(Meta.key == "schema_version").values(value=str(version)))


connection = context.config.attributes.get("connection")
if connection is None:
    raise RuntimeError("hadim stores are upgraded by hadim itself: `hadim store upgrade --store "
                       "URL` (see docs/store.md, 'Schema versions and migrations')")
context.configure(
    connection=connection,
    target_metadata=Base.metadata,
    version_table=migrations.VERSION_TABLE,
    transactional_ddl=True,
    render_as_batch=True,  # autogenerate writes SQLite-safe table rebuilds
    on_version_apply=_follow_revision,
)
with context.begin_transaction():
    context.run_migrations()
