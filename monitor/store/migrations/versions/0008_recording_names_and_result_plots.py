"""A recording's every file name, and each diagnosis' plot file, so that artefacts are found by id.

- ``recording_names``: every file name a recording was given, once each (a
  batch's copies of one content under several names, an upload of the same
  bytes again under another name). The recordings stored before this revision
  get the name they were registered under.
- ``results.plot``: the diagnosis plot's file, relative to the data folder
  (``plots/NAME.png``), written with the diagnosis; NULL where none was kept.
  The service serves a recording's plot from there alone, never from a file
  found by a name (which another fleet's file could have). The diagnoses
  stored before this revision get the name the batch and the service's worker
  gave their plots until now, computed here as they computed it then (the
  rule is frozen in this file: the product's may change, the names already
  written do not). A plot never kept there (a batch run without a data folder)
  is simply not found, and answered 404.

Revision ID: 0008
Revises: 0007
"""

from __future__ import annotations

import re
from pathlib import PurePath

import sqlalchemy as sa
from alembic import op

revision = "0008"
down_revision = "0007"
branch_labels = None
depends_on = None

BATCH = 500  # results updated at a time when their plots are filled in


def _stem(filename: str) -> str:
    """A file name's stem as the plots were named until this revision (ASCII letters, digits, ``.``,
    ``_``, ``-``, any other character ``_``; not hidden; at most 120 characters)."""
    stem = re.sub(r"[^A-Za-z0-9._-]", "_", PurePath(filename).stem)[:120]
    return "_" + stem[1:] if stem.startswith(".") else stem or "recording"


def _plot_stems(rows: list[tuple[int, str]]) -> dict[int, str]:
    """Each recording's plot stem until this revision: its file's stem, with ``+ID`` added when a
    recording of a lower id has the same stem (compared ignoring case)."""
    first: dict[str, int] = {}
    for recording_id, filename in rows:
        first.setdefault(_stem(filename).casefold(), recording_id)
    stems = {}
    for recording_id, filename in rows:
        stem = _stem(filename)
        stems[recording_id] = stem if first[stem.casefold()] == recording_id else f"{stem}+{recording_id}"
    return stems


def upgrade() -> None:
    op.create_table(
        "recording_names",
        sa.Column("id", sa.Integer, primary_key=True),
        sa.Column(
            "recording_id", sa.Integer, sa.ForeignKey("recordings.id", ondelete="CASCADE"), nullable=False
        ),
        sa.Column("filename", sa.String(255), nullable=False),
        sa.Column("created_at", sa.DateTime(timezone=True), nullable=False),
        sa.UniqueConstraint("recording_id", "filename", name="uq_recording_names_recording_filename"),
    )
    with op.batch_alter_table("results") as batch:
        batch.add_column(sa.Column("plot", sa.String(1024), nullable=True))

    recordings = sa.table(
        "recordings",
        sa.column("id", sa.Integer),
        sa.column("filename", sa.String),
        sa.column("uploaded_at", sa.DateTime(timezone=True)),
    )
    names = sa.table(
        "recording_names",
        sa.column("recording_id", sa.Integer),
        sa.column("filename", sa.String),
        sa.column("created_at", sa.DateTime(timezone=True)),
    )
    results = sa.table(
        "results",
        sa.column("id", sa.Integer),
        sa.column("recording_id", sa.Integer),
        sa.column("analysis_version", sa.String),
        sa.column("kind", sa.String),
        sa.column("plot", sa.String),
    )
    connection = op.get_bind()
    connection.execute(
        sa.insert(names).from_select(
            ["recording_id", "filename", "created_at"],
            sa.select(recordings.c.id, recordings.c.filename, recordings.c.uploaded_at),
        )
    )
    rows = connection.execute(sa.select(recordings.c.id, recordings.c.filename).order_by(recordings.c.id))
    stems = _plot_stems([(int(r.id), str(r.filename)) for r in rows])
    last = 0
    while True:
        diagnoses = connection.execute(
            sa.select(results.c.id, results.c.recording_id, results.c.analysis_version)
            .where((results.c.kind == "diagnosis") & (results.c.id > last))
            .order_by(results.c.id)
            .limit(BATCH)
        ).all()
        if not diagnoses:
            break
        connection.execute(
            sa.update(results)
            .where(results.c.id == sa.bindparam("row_id"))
            .values(plot=sa.bindparam("file")),
            [
                {"row_id": r.id, "file": f"plots/{stems[r.recording_id]}-v{r.analysis_version}.png"}
                for r in diagnoses
            ],
        )
        last = diagnoses[-1].id


def downgrade() -> None:
    with op.batch_alter_table("results") as batch:
        batch.drop_column("plot")
    op.drop_table("recording_names")
