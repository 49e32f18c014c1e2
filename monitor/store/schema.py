"""The results store's tables (SQLAlchemy Core): one schema for SQLite and PostgreSQL.

- ``fleets``: who owns engines and recordings;
- ``api_keys``: a fleet's keys, stored as SHA-256 digests (the keys are random
  tokens of 256 bits, so a fast digest suffices; the key itself is never stored);
  their ids are never reused, so a revoked key's id never names another;
- ``engines``: a fleet's engine descriptions (the validated TOML as JSON);
- ``recordings``: stored recordings by content hash (the same content is
  stored once per fleet), the file's place in the recording folder, and the
  file name it was first registered under;
- ``recording_names``: every file name a recording was given (a batch's
  copies of one content, an upload of it again under another name), once
  each: several names may share one stored content;
- ``jobs``: one analysis of one recording at one analysis version, with its
  state (queued, running, done, failed, set_aside), attempts, last error,
  the token and process of its current taker, and the time before which a
  retry waits;
- ``results``: the documents an analysis wrote, at most one per recording,
  analysis version and kind, each with the SHA-256 of its stored JSON text
  (the entity tag the service answers it with; a result is never rewritten);
  a diagnosis records the file of the plot it kept, relative to the data
  folder (``plots/NAME.png``; NULL: none kept), so the plot is found by the
  recording's id alone, never by a file name;
- ``trend_points``: the quantities of each stored diagnosis an engine's
  condition is followed by (speed, load, each cylinder's strength, each bearing
  sensor's order deviations, impact score and rms velocity), one row each, at
  the recording's time (:mod:`monitor.diagnosis.trends`), written with the result;
- ``baselines``: a fleet's baseline of an engine (``POST /engines/{id}/baseline``),
  one per fleet and engine: the calibration document (``engine-monitor
  calibrate``'s JSON), the stored recording it was calibrated on, and the
  analysis version that calibrated it; later analyses of that engine's
  recordings compare their bearing orders through it;
- ``webhooks``: a fleet's alert receivers (``POST /webhooks``): the URL, the
  secret its events are signed with, and whether it is still active (a deleted
  one is kept inactive, with its delivery log);
- ``webhook_deliveries``: the outbox and delivery log of alerts
  (:mod:`monitor.report.events`, :mod:`monitor.jobs.delivery`): one row per webhook and
  event, written in the transaction that stores the diagnosis that made the
  event (at most one per webhook and event id), with the body as it is sent,
  its state (pending, delivered, failed, cancelled), the attempts, the time of
  the next one, and the last answer or error.

Each read of the service is one indexed query: a key by its digest (unique),
a recording by id, its job and results by their unique keys, and a fleet's
recordings newest first by ``ix_recordings_fleet_uploaded``.

Changes to these tables go through migrations (``monitor/store/migrations``).
"""

from __future__ import annotations

import sqlalchemy as sa

__all__ = [
    "DELIVERY_STATES",
    "JOB_STATES",
    "api_keys",
    "baselines",
    "engines",
    "fleets",
    "jobs",
    "metadata",
    "recording_names",
    "recordings",
    "results",
    "trend_points",
    "webhook_deliveries",
    "webhooks",
]

JOB_STATES = ("queued", "running", "done", "failed", "set_aside")
DELIVERY_STATES = ("pending", "delivered", "failed", "cancelled")

metadata = sa.MetaData()

fleets = sa.Table(
    "fleets",
    metadata,
    sa.Column("id", sa.Integer, primary_key=True),
    sa.Column("name", sa.String(200), nullable=False, unique=True),
    sa.Column("created_at", sa.DateTime(timezone=True), nullable=False),
)

api_keys = sa.Table(
    "api_keys",
    metadata,
    sa.Column("id", sa.Integer, primary_key=True),
    sa.Column("fleet_id", sa.Integer, sa.ForeignKey("fleets.id", ondelete="CASCADE"), nullable=False),
    sa.Column("digest", sa.String(64), nullable=False, unique=True),
    sa.Column("label", sa.String(200), nullable=False, server_default=""),
    sa.Column("created_at", sa.DateTime(timezone=True), nullable=False),
    sqlite_autoincrement=True,  # a revoked key's id is never a later key's (as PostgreSQL's sequences)
)

engines = sa.Table(
    "engines",
    metadata,
    sa.Column("id", sa.Integer, primary_key=True),
    sa.Column("fleet_id", sa.Integer, sa.ForeignKey("fleets.id", ondelete="CASCADE"), nullable=False),
    sa.Column("engine_id", sa.String(200), nullable=False),
    sa.Column("description", sa.JSON, nullable=False),
    sa.Column("created_at", sa.DateTime(timezone=True), nullable=False),
    sa.Column("updated_at", sa.DateTime(timezone=True), nullable=False),
    sa.UniqueConstraint("fleet_id", "engine_id", name="uq_engines_fleet_engine"),
)

recordings = sa.Table(
    "recordings",
    metadata,
    sa.Column("id", sa.Integer, primary_key=True),
    sa.Column("fleet_id", sa.Integer, sa.ForeignKey("fleets.id", ondelete="CASCADE"), nullable=False),
    sa.Column("content_hash", sa.String(64), nullable=False),
    sa.Column("engine_id", sa.String(200), nullable=False),
    sa.Column("filename", sa.String(255), nullable=False),
    sa.Column("path", sa.String(1024), nullable=False),
    sa.Column("size_bytes", sa.BigInteger, nullable=False),
    sa.Column("recorded_at", sa.String(64), nullable=False, server_default=""),
    sa.Column("uploaded_at", sa.DateTime(timezone=True), nullable=False),
    sa.UniqueConstraint("fleet_id", "content_hash", name="uq_recordings_fleet_content"),
    sa.Index("ix_recordings_fleet_engine_uploaded", "fleet_id", "engine_id", "uploaded_at"),
    sa.Index("ix_recordings_fleet_uploaded", "fleet_id", "uploaded_at", "id"),
)

jobs = sa.Table(
    "jobs",
    metadata,
    sa.Column("id", sa.Integer, primary_key=True),
    sa.Column("recording_id", sa.Integer, sa.ForeignKey("recordings.id", ondelete="CASCADE"), nullable=False),
    sa.Column("analysis_version", sa.String(32), nullable=False),
    sa.Column("state", sa.String(16), nullable=False),
    sa.Column("attempts", sa.Integer, nullable=False, server_default="0"),
    sa.Column("error", sa.Text, nullable=False, server_default=""),
    sa.Column("created_at", sa.DateTime(timezone=True), nullable=False),
    sa.Column("updated_at", sa.DateTime(timezone=True), nullable=False),
    sa.Column("token", sa.String(32), nullable=False, server_default=""),
    sa.Column("holder", sa.String(300), nullable=False, server_default=""),
    sa.Column("not_before", sa.DateTime(timezone=True), nullable=True),
    sa.UniqueConstraint("recording_id", "analysis_version", name="uq_jobs_recording_version"),
    sa.CheckConstraint(f"state IN ({', '.join(repr(s) for s in JOB_STATES)})", name="ck_jobs_state"),
    sa.Index("ix_jobs_state", "state"),
)

results = sa.Table(
    "results",
    metadata,
    sa.Column("id", sa.Integer, primary_key=True),
    sa.Column("recording_id", sa.Integer, sa.ForeignKey("recordings.id", ondelete="CASCADE"), nullable=False),
    sa.Column("analysis_version", sa.String(32), nullable=False),
    sa.Column("kind", sa.String(32), nullable=False),
    sa.Column("status", sa.String(16), nullable=False, server_default=""),
    sa.Column("document", sa.JSON, nullable=False),
    sa.Column("created_at", sa.DateTime(timezone=True), nullable=False),
    sa.Column("digest", sa.String(64), nullable=False, server_default=""),
    sa.Column("plot", sa.String(1024), nullable=True),
    sa.UniqueConstraint("recording_id", "analysis_version", "kind", name="uq_results_recording_version_kind"),
)

recording_names = sa.Table(
    "recording_names",
    metadata,
    sa.Column("id", sa.Integer, primary_key=True),
    sa.Column("recording_id", sa.Integer, sa.ForeignKey("recordings.id", ondelete="CASCADE"), nullable=False),
    sa.Column("filename", sa.String(255), nullable=False),
    sa.Column("created_at", sa.DateTime(timezone=True), nullable=False),
    sa.UniqueConstraint("recording_id", "filename", name="uq_recording_names_recording_filename"),
)

trend_points = sa.Table(
    "trend_points",
    metadata,
    sa.Column("id", sa.Integer, primary_key=True),
    sa.Column("recording_id", sa.Integer, sa.ForeignKey("recordings.id", ondelete="CASCADE"), nullable=False),
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
    sa.Index("ix_trend_points_engine_quantity_time", "fleet_id", "engine_id", "quantity", "recorded_at"),
)

baselines = sa.Table(
    "baselines",
    metadata,
    sa.Column("id", sa.Integer, primary_key=True),
    sa.Column("fleet_id", sa.Integer, sa.ForeignKey("fleets.id", ondelete="CASCADE"), nullable=False),
    sa.Column("engine_id", sa.String(200), nullable=False),
    sa.Column("recording_id", sa.Integer, sa.ForeignKey("recordings.id", ondelete="CASCADE"), nullable=False),
    sa.Column("analysis_version", sa.String(32), nullable=False),
    sa.Column("document", sa.JSON, nullable=False),
    sa.Column("created_at", sa.DateTime(timezone=True), nullable=False),
    sa.UniqueConstraint("fleet_id", "engine_id", name="uq_baselines_fleet_engine"),
)

webhooks = sa.Table(
    "webhooks",
    metadata,
    sa.Column("id", sa.Integer, primary_key=True),
    sa.Column("fleet_id", sa.Integer, sa.ForeignKey("fleets.id", ondelete="CASCADE"), nullable=False),
    sa.Column("url", sa.String(2048), nullable=False),
    sa.Column("secret", sa.String(256), nullable=False),
    sa.Column("created_at", sa.DateTime(timezone=True), nullable=False),
    sa.Column("active", sa.Boolean, nullable=False, server_default=sa.true()),
    sa.Index("ix_webhooks_fleet", "fleet_id"),
)

webhook_deliveries = sa.Table(
    "webhook_deliveries",
    metadata,
    sa.Column("id", sa.Integer, primary_key=True),
    sa.Column("webhook_id", sa.Integer, sa.ForeignKey("webhooks.id", ondelete="CASCADE"), nullable=False),
    sa.Column("event_id", sa.String(64), nullable=False),
    sa.Column("event_type", sa.String(64), nullable=False),
    sa.Column("body", sa.Text, nullable=False),
    sa.Column("state", sa.String(16), nullable=False),
    sa.Column("attempts", sa.Integer, nullable=False, server_default="0"),
    sa.Column("next_attempt_at", sa.DateTime(timezone=True), nullable=False),
    sa.Column("last_attempt_at", sa.DateTime(timezone=True), nullable=True),
    sa.Column("last_status", sa.Integer, nullable=True),
    sa.Column("last_error", sa.Text, nullable=False, server_default=""),
    sa.Column("created_at", sa.DateTime(timezone=True), nullable=False),
    sa.Column("delivered_at", sa.DateTime(timezone=True), nullable=True),
    sa.UniqueConstraint("webhook_id", "event_id", name="uq_webhook_deliveries_webhook_event"),
    sa.CheckConstraint(
        f"state IN ({', '.join(repr(s) for s in DELIVERY_STATES)})", name="ck_webhook_deliveries_state"
    ),
    sa.Index("ix_webhook_deliveries_due", "state", "next_attempt_at"),
)
