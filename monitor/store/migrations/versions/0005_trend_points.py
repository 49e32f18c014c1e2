"""Trend points: the quantities of each stored diagnosis, one row each, at the recording's time.

``trend_points`` holds, for every diagnosis result, the quantities an engine's
condition is followed by (see :mod:`monitor.trends`), indexed by fleet, engine,
quantity and recording time, so that a trend is one range read of an index.
The rows of results stored before this revision are filled in by
:meth:`monitor.store.Store.fill_trend_points` (the product's extraction, which
a migration should not freeze), on the first trend read.

Revision ID: 0005
Revises: 0004
"""

from __future__ import annotations

import sqlalchemy as sa
from alembic import op

revision = "0005"
down_revision = "0004"
branch_labels = None
depends_on = None


def upgrade() -> None:
    op.create_table(
        "trend_points",
        sa.Column("id", sa.Integer, primary_key=True),
        sa.Column(
            "recording_id", sa.Integer, sa.ForeignKey("recordings.id", ondelete="CASCADE"), nullable=False
        ),
        sa.Column("analysis_version", sa.String(32), nullable=False),
        sa.Column("fleet_id", sa.Integer, sa.ForeignKey("fleets.id", ondelete="CASCADE"), nullable=False),
        sa.Column("engine_id", sa.String(200), nullable=False),
        sa.Column("recorded_at", sa.DateTime(timezone=True), nullable=False),
        sa.Column("quantity", sa.String(200), nullable=False),
        sa.Column("value", sa.Float, nullable=False),
        sa.Column("standard_error", sa.Float, nullable=True),
        sa.Column("unit", sa.String(32), nullable=False, server_default=""),
        sa.UniqueConstraint(
            "recording_id", "analysis_version", "quantity", name="uq_trend_points_recording_version_quantity"
        ),
    )
    op.create_index(
        "ix_trend_points_engine_quantity_time",
        "trend_points",
        ["fleet_id", "engine_id", "quantity", "recorded_at"],
    )


def downgrade() -> None:
    op.drop_index("ix_trend_points_engine_quantity_time", table_name="trend_points")
    op.drop_table("trend_points")
