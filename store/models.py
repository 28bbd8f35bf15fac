"""The store's tables as a SQLAlchemy 2 ORM, and nothing else.

Every table below ``runs`` cascades on delete from it. Arrays are ``.npy`` bytes (see
``hadim_store.codecs``), structures are JSON text, times are naive UTC.
"""

from __future__ import annotations

from datetime import datetime

from sqlalchemy import (
    BigInteger,
    DateTime,
    Float,
    ForeignKey,
    Index,
    Integer,
    LargeBinary,
    String,
    Text,
    UniqueConstraint,
)
from sqlalchemy.orm import DeclarativeBase, Mapped, mapped_column

_RUN_FK = "runs.id"


class Base(DeclarativeBase):
    pass


class Meta(Base):
    """Key/value facts about the store: ``application`` = 'hadim', ``schema_version``."""

    __tablename__ = "meta"

    key: Mapped[str] = mapped_column(String(64), primary_key=True)
    value: Mapped[str] = mapped_column(Text)


class Run(Base):
    __tablename__ = "runs"

    id: Mapped[int] = mapped_column(Integer, primary_key=True)
    name: Mapped[str] = mapped_column(String(64), unique=True)
    status: Mapped[str] = mapped_column(String(16))
    # 64-bit seeds: BIGINT on servers; SQLite's INTEGER is 64-bit already (DDL unchanged).
    seed: Mapped[int] = mapped_column(Integer().with_variant(BigInteger(), "postgresql"))
    config_json: Mapped[str] = mapped_column(Text)
    parent_id: Mapped[int | None] = mapped_column(ForeignKey(_RUN_FK, ondelete="SET NULL"))
    fork_iteration: Mapped[int | None] = mapped_column(Integer)
    versions_json: Mapped[str] = mapped_column(Text)
    iterations: Mapped[int] = mapped_column(Integer, default=0)
    created_at: Mapped[datetime] = mapped_column(DateTime)
    updated_at: Mapped[datetime] = mapped_column(DateTime)
    lock_owner: Mapped[str | None] = mapped_column(String(128))
    lock_pid: Mapped[int | None] = mapped_column(Integer)
    lock_host: Mapped[str | None] = mapped_column(String(255))
    lock_heartbeat: Mapped[float | None] = mapped_column(Float)  # unix time, seconds


class Episode(Base):
    __tablename__ = "episodes"
    __table_args__ = (
        UniqueConstraint("run_id", "episode_index", name="uq_episodes_run_index"),
        Index("ix_episodes_run_first_iteration", "run_id", "first_iteration"),
    )

    id: Mapped[int] = mapped_column(Integer, primary_key=True)
    run_id: Mapped[int] = mapped_column(ForeignKey(_RUN_FK, ondelete="CASCADE"))
    episode_index: Mapped[int] = mapped_column(Integer)
    first_iteration: Mapped[int] = mapped_column(Integer)
    n_iterations: Mapped[int] = mapped_column(Integer)
    array_codec: Mapped[str] = mapped_column(String(16))  # 'npy' or 'npy+zlib'
    actions: Mapped[bytes] = mapped_column(LargeBinary)
    contexts: Mapped[bytes] = mapped_column(LargeBinary)
    outcomes: Mapped[bytes] = mapped_column(LargeBinary)
    extra_json: Mapped[str] = mapped_column(Text)


class AffordanceEventRow(Base):
    __tablename__ = "affordance_events"
    __table_args__ = (Index("ix_affordance_events_run_iteration", "run_id", "iteration"),)

    id: Mapped[int] = mapped_column(Integer, primary_key=True)
    run_id: Mapped[int] = mapped_column(ForeignKey(_RUN_FK, ondelete="CASCADE"))
    episode_index: Mapped[int] = mapped_column(Integer)
    iteration: Mapped[int] = mapped_column(Integer)
    affordance_id: Mapped[int] = mapped_column(Integer)
    kind: Mapped[str] = mapped_column(String(32))
    input_space: Mapped[str] = mapped_column(String(64))
    output_space: Mapped[str] = mapped_column(String(64))
    context_json: Mapped[str] = mapped_column(Text)
    competence: Mapped[float | None] = mapped_column(Float)
    detail_json: Mapped[str] = mapped_column(Text)


class AffordanceStatRow(Base):
    __tablename__ = "affordance_stats"
    __table_args__ = (Index("ix_affordance_stats_run_iteration", "run_id", "iteration"),)

    id: Mapped[int] = mapped_column(Integer, primary_key=True)
    run_id: Mapped[int] = mapped_column(ForeignKey(_RUN_FK, ondelete="CASCADE"))
    episode_index: Mapped[int] = mapped_column(Integer)
    iteration: Mapped[int] = mapped_column(Integer)
    affordance_id: Mapped[int] = mapped_column(Integer)
    competence: Mapped[float | None] = mapped_column(Float)
    n_data: Mapped[int] = mapped_column(Integer)
    interest: Mapped[float | None] = mapped_column(Float)


class InterestRegionRow(Base):
    __tablename__ = "interest_regions"
    __table_args__ = (Index("ix_interest_regions_run_iteration", "run_id", "iteration"),)

    id: Mapped[int] = mapped_column(Integer, primary_key=True)
    run_id: Mapped[int] = mapped_column(ForeignKey(_RUN_FK, ondelete="CASCADE"))
    episode_index: Mapped[int] = mapped_column(Integer)
    iteration: Mapped[int] = mapped_column(Integer)
    affordance_id: Mapped[int] = mapped_column(Integer)
    region_id: Mapped[int] = mapped_column(Integer)
    parent_id: Mapped[int | None] = mapped_column(Integer)
    low_json: Mapped[str] = mapped_column(Text)
    high_json: Mapped[str] = mapped_column(Text)
    n_goals: Mapped[int] = mapped_column(Integer)
    interest: Mapped[float] = mapped_column(Float)


class CheckpointRow(Base):
    __tablename__ = "checkpoints"
    __table_args__ = (UniqueConstraint("run_id", "iteration", name="uq_checkpoints_run_iteration"),)

    id: Mapped[int] = mapped_column(Integer, primary_key=True)
    run_id: Mapped[int] = mapped_column(ForeignKey(_RUN_FK, ondelete="CASCADE"))
    iteration: Mapped[int] = mapped_column(Integer)
    episode_index: Mapped[int] = mapped_column(Integer)
    created_at: Mapped[datetime] = mapped_column(DateTime)
    # NULL: a full snapshot; else the iteration of the run's checkpoint this one continues.
    base_iteration: Mapped[int | None] = mapped_column(Integer, nullable=True)


class CheckpointItem(Base):
    __tablename__ = "checkpoint_items"
    __table_args__ = (UniqueConstraint("checkpoint_id", "key", name="uq_checkpoint_items_key"),)

    id: Mapped[int] = mapped_column(Integer, primary_key=True)
    checkpoint_id: Mapped[int] = mapped_column(ForeignKey("checkpoints.id", ondelete="CASCADE"))
    key: Mapped[str] = mapped_column(String(255))
    kind: Mapped[str] = mapped_column(String(16))  # 'npy', 'npy+zlib' or 'json'
    data: Mapped[bytes | None] = mapped_column(LargeBinary)  # arrays
    text: Mapped[str | None] = mapped_column(Text)  # JSON
    # NULL: data/text is the whole value; else the value is `prefix` rows (list items) of the
    # base checkpoint's item of the same key, from its row `skip` on (NULL: its first rows),
    # followed by data/text (if any).
    prefix: Mapped[int | None] = mapped_column(Integer, nullable=True)
    skip: Mapped[int | None] = mapped_column(Integer, nullable=True)


class EvaluationRow(Base):
    __tablename__ = "evaluations"
    __table_args__ = (Index("ix_evaluations_run_iteration", "run_id", "iteration"),)

    id: Mapped[int] = mapped_column(Integer, primary_key=True)
    run_id: Mapped[int] = mapped_column(ForeignKey(_RUN_FK, ondelete="CASCADE"))
    iteration: Mapped[int] = mapped_column(Integer)
    task: Mapped[str] = mapped_column(String(128))
    score: Mapped[float] = mapped_column(Float)
    points_json: Mapped[str] = mapped_column(Text)
    created_at: Mapped[datetime] = mapped_column(DateTime)
