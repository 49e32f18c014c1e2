"""Reads that cost a key lookup: the recordings list indexed as it is sorted, results with their digest.

- ``ix_recordings_fleet_uploaded``: ``(fleet_id, uploaded_at, id)``, the order of
  ``GET /recordings`` (newest first, the id breaking ties) and of its keyset
  pages, so a page is read from the index instead of sorting the fleet's
  recordings for each request;
- ``results.digest``: the SHA-256 (hex) of a result document's stored JSON
  text, written with it: the HTTP entity tag of ``/diagnosis`` and
  ``/spectrum``, so a read answers the stored text as it is, and a client that
  holds it gets 304 without the text being read at all. The results already
  stored get the digest of their stored text here; none is rewritten.

Revision ID: 0004
Revises: 0003
"""

from __future__ import annotations

import hashlib

import sqlalchemy as sa
from alembic import op

revision = "0004"
down_revision = "0003"
branch_labels = None
depends_on = None

BATCH = 500  # results read and updated at a time when digests are filled in


def upgrade() -> None:
    op.create_index("ix_recordings_fleet_uploaded", "recordings", ["fleet_id", "uploaded_at", "id"])
    with op.batch_alter_table("results") as batch:
        batch.add_column(sa.Column("digest", sa.String(64), nullable=False, server_default=""))
    results = sa.table(
        "results", sa.column("id", sa.Integer), sa.column("document", sa.Text), sa.column("digest", sa.String)
    )
    connection = op.get_bind()
    last = 0
    while True:
        rows = connection.execute(
            sa.select(results.c.id, sa.cast(results.c.document, sa.Text).label("text"))
            .where(results.c.id > last)
            .order_by(results.c.id)
            .limit(BATCH)
        ).all()
        if not rows:
            break
        connection.execute(
            sa.update(results)
            .where(results.c.id == sa.bindparam("row_id"))
            .values(digest=sa.bindparam("sha")),
            [{"row_id": r.id, "sha": hashlib.sha256(r.text.encode("utf-8")).hexdigest()} for r in rows],
        )
        last = rows[-1].id


def downgrade() -> None:
    with op.batch_alter_table("results") as batch:
        batch.drop_column("digest")
    op.drop_index("ix_recordings_fleet_uploaded", "recordings")
