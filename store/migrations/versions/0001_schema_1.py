"""Schema 1: the tables of the first release.

Runs, D by episode, the affordance timeline, stats, interest-region snapshots, checkpoints and
their items (every checkpoint whole), evaluations, and meta. A store is never created through
this revision (a new store is made from models.py and stamped with the head); it records what
schema 1 is, so that an empty database can be brought to any version (the tests compare the
result with models.py and with a store written by schema 1).

Revision ID: 0001
Revises:
"""

from __future__ import annotations

import sqlalchemy as sa
from alembic import op

revision = "0001"
down_revision = None
branch_labels = None
depends_on = None
automatic = True

_SEED = sa.Integer().with_variant(sa.BigInteger(), "postgresql")


def _run_id() -> sa.Column:
    return sa.Column("run_id", sa.Integer, sa.ForeignKey("runs.id", ondelete="CASCADE"),
                     nullable=False)


def _per_episode(name: str, *columns: sa.Column) -> None:
    """A table of rows written with an episode, indexed by (run_id, iteration)."""
    op.create_table(name, sa.Column("id", sa.Integer, primary_key=True), _run_id(),
                    sa.Column("episode_index", sa.Integer, nullable=False),
                    sa.Column("iteration", sa.Integer, nullable=False), *columns)
    op.create_index(f"ix_{name}_run_iteration", name, ["run_id", "iteration"])


def upgrade() -> None:
    meta = op.create_table(
        "meta",
        sa.Column("key", sa.String(64), primary_key=True),
        sa.Column("value", sa.Text, nullable=False),
    )
    op.bulk_insert(meta, [{"key": "application", "value": "hadim"},
                          {"key": "schema_version", "value": "1"}])
    op.create_table(
        "runs",
        sa.Column("id", sa.Integer, primary_key=True),
        sa.Column("name", sa.String(64), nullable=False, unique=True),
        sa.Column("status", sa.String(16), nullable=False),
        sa.Column("seed", _SEED, nullable=False),
        sa.Column("config_json", sa.Text, nullable=False),
        sa.Column("parent_id", sa.Integer, sa.ForeignKey("runs.id", ondelete="SET NULL")),
        sa.Column("fork_iteration", sa.Integer),
        sa.Column("versions_json", sa.Text, nullable=False),
        sa.Column("iterations", sa.Integer, nullable=False),
        sa.Column("created_at", sa.DateTime, nullable=False),
        sa.Column("updated_at", sa.DateTime, nullable=False),
        sa.Column("lock_owner", sa.String(128)),
        sa.Column("lock_pid", sa.Integer),
        sa.Column("lock_host", sa.String(255)),
        sa.Column("lock_heartbeat", sa.Float),
    )
    op.create_table(
        "episodes",
        sa.Column("id", sa.Integer, primary_key=True),
        _run_id(),
        sa.Column("episode_index", sa.Integer, nullable=False),
        sa.Column("first_iteration", sa.Integer, nullable=False),
        sa.Column("n_iterations", sa.Integer, nullable=False),
        sa.Column("array_codec", sa.String(16), nullable=False),
        sa.Column("actions", sa.LargeBinary, nullable=False),
        sa.Column("contexts", sa.LargeBinary, nullable=False),
        sa.Column("outcomes", sa.LargeBinary, nullable=False),
        sa.Column("extra_json", sa.Text, nullable=False),
        sa.UniqueConstraint("run_id", "episode_index", name="uq_episodes_run_index"),
    )
    op.create_index("ix_episodes_run_first_iteration", "episodes", ["run_id", "first_iteration"])
    _per_episode(
        "affordance_events",
        sa.Column("affordance_id", sa.Integer, nullable=False),
        sa.Column("kind", sa.String(32), nullable=False),
        sa.Column("input_space", sa.String(64), nullable=False),
        sa.Column("output_space", sa.String(64), nullable=False),
        sa.Column("context_json", sa.Text, nullable=False),
        sa.Column("competence", sa.Float),
        sa.Column("detail_json", sa.Text, nullable=False),
    )
    _per_episode(
        "affordance_stats",
        sa.Column("affordance_id", sa.Integer, nullable=False),
        sa.Column("competence", sa.Float),
        sa.Column("n_data", sa.Integer, nullable=False),
        sa.Column("interest", sa.Float),
    )
    _per_episode(
        "interest_regions",
        sa.Column("affordance_id", sa.Integer, nullable=False),
        sa.Column("region_id", sa.Integer, nullable=False),
        sa.Column("parent_id", sa.Integer),
        sa.Column("low_json", sa.Text, nullable=False),
        sa.Column("high_json", sa.Text, nullable=False),
        sa.Column("n_goals", sa.Integer, nullable=False),
        sa.Column("interest", sa.Float, nullable=False),
    )
    op.create_table(
        "checkpoints",
        sa.Column("id", sa.Integer, primary_key=True),
        _run_id(),
        sa.Column("iteration", sa.Integer, nullable=False),
        sa.Column("episode_index", sa.Integer, nullable=False),
        sa.Column("created_at", sa.DateTime, nullable=False),
        sa.UniqueConstraint("run_id", "iteration", name="uq_checkpoints_run_iteration"),
    )
    op.create_table(
        "checkpoint_items",
        sa.Column("id", sa.Integer, primary_key=True),
        sa.Column("checkpoint_id", sa.Integer,
                  sa.ForeignKey("checkpoints.id", ondelete="CASCADE"), nullable=False),
        sa.Column("key", sa.String(255), nullable=False),
        sa.Column("kind", sa.String(16), nullable=False),
        sa.Column("data", sa.LargeBinary),
        sa.Column("text", sa.Text),
        sa.UniqueConstraint("checkpoint_id", "key", name="uq_checkpoint_items_key"),
    )
    op.create_table(
        "evaluations",
        sa.Column("id", sa.Integer, primary_key=True),
        _run_id(),
        sa.Column("iteration", sa.Integer, nullable=False),
        sa.Column("task", sa.String(128), nullable=False),
        sa.Column("score", sa.Float, nullable=False),
        sa.Column("points_json", sa.Text, nullable=False),
        sa.Column("created_at", sa.DateTime, nullable=False),
    )
    op.create_index("ix_evaluations_run_iteration", "evaluations", ["run_id", "iteration"])


def downgrade() -> None:
    raise NotImplementedError("hadim stores are not downgraded: keep a copy from before")
