"""Baselines: a fleet's calibration of an engine on one of its stored recordings.

``baselines`` holds one baseline per fleet and engine (set again, it is
replaced): the document ``engine-monitor calibrate`` writes, the recording it
was calibrated on and the analysis version that calibrated it. The service's
analyses of that engine's recordings compare their bearing orders through it.

Revision ID: 0006
Revises: 0005
"""

from __future__ import annotations

import sqlalchemy as sa
from alembic import op

revision = "0006"
down_revision = "0005"
branch_labels = None
depends_on = None


def upgrade() -> None:
    op.create_table(
        "baselines",
        sa.Column("id", sa.Integer, primary_key=True),
        sa.Column("fleet_id", sa.Integer, sa.ForeignKey("fleets.id", ondelete="CASCADE"), nullable=False),
        sa.Column("engine_id", sa.String(200), nullable=False),
        sa.Column(
            "recording_id", sa.Integer, sa.ForeignKey("recordings.id", ondelete="CASCADE"), nullable=False
        ),
        sa.Column("analysis_version", sa.String(32), nullable=False),
        sa.Column("document", sa.JSON, nullable=False),
        sa.Column("created_at", sa.DateTime(timezone=True), nullable=False),
        sa.UniqueConstraint("fleet_id", "engine_id", name="uq_baselines_fleet_engine"),
    )


def downgrade() -> None:
    op.drop_table("baselines")
