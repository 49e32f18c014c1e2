"""Jobs name the process that holds them and the time before which a retry waits.

``holder`` (host, process id and process start time of the taker) lets a
restarted worker or batch on the same host take back at once the jobs of a
process that is gone, instead of waiting for their lease; ``not_before``
spaces the retries of a job that failed for a passing reason.

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


def upgrade() -> None:
    with op.batch_alter_table("jobs") as batch:
        batch.add_column(sa.Column("holder", sa.String(300), nullable=False, server_default=""))
        batch.add_column(sa.Column("not_before", sa.DateTime(timezone=True), nullable=True))


def downgrade() -> None:
    with op.batch_alter_table("jobs") as batch:
        batch.drop_column("not_before")
        batch.drop_column("holder")
