"""The results of the store's jobs: written once, with their job's completion, and read back as stored.

Every write is a transaction: a result is stored whole or not at all, and the
unique keys make a second write of the same result (same recording, analysis
version and kind) a no-op, so a resumed batch or a restarted worker never
duplicates one. A result is written once and never changed: its JSON text is
stored with the text's SHA-256, so a read hands out the stored text as it is
(:meth:`ResultStore.stored_result`), tagged by that digest, without parsing it.
The transaction that stores a diagnosis also stores its trend points
(:mod:`monitor.store.trends`) and queues the alerts of its new findings for
the fleet's webhooks (:mod:`monitor.store.alerts`).
"""

from __future__ import annotations

import hashlib
import json
from dataclasses import dataclass
from typing import Any

import sqlalchemy as sa
from sqlalchemy.engine import Connection, CursorResult

from monitor.errors import StoreError
from monitor.store.alerts import enqueue_events
from monitor.store.base import StoreBase
from monitor.store.jobs import Job, finish, view_job
from monitor.store.queries import STORED
from monitor.store.schema import recordings, results
from monitor.store.sql import insert_new, now
from monitor.store.trends import DIAGNOSIS_KIND, write_trend_points

__all__ = ["ResultRead", "ResultStore", "StoredResult", "document_text"]


def document_text(document: dict[str, Any]) -> str:
    """A result document's stored form: JSON text, written as the store always wrote its documents.

    Parameters
    ----------
    document : dict
    """
    return json.dumps(document)


def _text_digest(text: str) -> str:
    return hashlib.sha256(text.encode("utf-8")).hexdigest()


@dataclass(frozen=True)
class StoredResult:
    """A result document as stored: its JSON text and the SHA-256 (hex) of that text's UTF-8 bytes."""

    text: str
    digest: str


@dataclass(frozen=True)
class ResultRead:
    """What a read of one result found for a fleet's recording: its job and the stored result (None
    while the analysis has not written it)."""

    job: Job | None
    result: StoredResult | None


def _plot_file(relative: str) -> bool:
    """Whether a recorded plot is a plain file name in the data folder's ``plots/`` (nothing that
    reaches elsewhere: no other folder, no ``..``, not absolute)."""
    folder, slash, name = relative.partition("/")
    return (
        folder == "plots"
        and bool(slash)
        and name not in ("", ".", "..")
        and "/" not in name
        and "\\" not in name
        and "\x00" not in name
    )


def _the_result(recording_id: int, analysis_version: str, kind: str) -> Any:
    """The result of a recording at an analysis version of a kind (its unique key)."""
    return (
        (results.c.recording_id == recording_id)
        & (results.c.analysis_version == analysis_version)
        & (results.c.kind == kind)
    )


def _document_value(c: Connection, text: str) -> Any:
    """The stored JSON text as the value of a ``document`` column: as it is (SQLite keeps JSON as text;
    PostgreSQL's ``json`` keeps the exact text it is given)."""
    value = sa.literal(text, sa.Text)
    return sa.cast(value, sa.JSON) if c.dialect.name == "postgresql" else value


class ResultStore(StoreBase):
    """The results of a :class:`monitor.store.Store` (see the module docstring)."""

    def complete(
        self, job: Job, documents: dict[str, tuple[str, dict[str, Any]]], *, plot: str | None = None
    ) -> bool:
        """Store a job's results (``kind -> (status, document)``) and mark it done, in one transaction.

        A result already stored for the same recording, version and kind is kept as it is. Returns
        False if the job had been taken back from this taker meanwhile (its results are kept all the
        same: they are the analysis of the same recording at the same version).

        Parameters
        ----------
        job : Job
            As its taker got it (:meth:`monitor.store.jobs.JobQueue.claim`,
            :meth:`monitor.store.jobs.JobQueue.claim_job`).
        documents : dict of str to (str, dict)
            The results by kind: their status and document.
        plot : str, optional
            The diagnosis plot the analysis kept, relative to the data folder (``plots/NAME.png``),
            recorded with the diagnosis (:meth:`plot`); None: none was kept.
        """
        if plot is not None and not _plot_file(plot):
            raise StoreError(f"plot {plot!r}: expected a file name under plots/ of the data folder")
        texts = {kind: document_text(document) for kind, (_, document) in documents.items()}
        with self.transaction() as c:
            created = set()
            for kind, (status, _) in documents.items():
                if insert_new(
                    c,
                    results,
                    {
                        "recording_id": job.recording_id,
                        "analysis_version": job.analysis_version,
                        "kind": kind,
                        "status": status,
                        "document": _document_value(c, texts[kind]),
                        "digest": _text_digest(texts[kind]),
                        "plot": plot if kind == DIAGNOSIS_KIND else None,
                        "created_at": now(),
                    },
                    ["recording_id", "analysis_version", "kind"],
                ):
                    created.add(kind)
            if DIAGNOSIS_KIND in documents:  # its quantities, for the engine's trends
                write_trend_points(c, job.recording_id, job.analysis_version, documents[DIAGNOSIS_KIND][1])
            if DIAGNOSIS_KIND in created:  # its new findings' alerts, queued once: with the diagnosis
                enqueue_events(c, job.recording_id, job.analysis_version, documents[DIAGNOSIS_KIND][1])
            return finish(c, job)

    def result(self, recording_id: int, analysis_version: str, kind: str) -> dict[str, Any] | None:
        """A stored result document, or None."""
        with self.db.connect() as c:
            row = c.execute(
                sa.select(results.c.document).where(_the_result(recording_id, analysis_version, kind))
            ).first()
        return None if row is None else dict(row.document)

    def stored_result(
        self, fleet_id: int, recording_id: int, analysis_version: str, kind: str
    ) -> ResultRead | None:
        """A fleet's recording's result as stored (its JSON text, never parsed) and its job, in one
        query; None for a recording the fleet does not have.

        Parameters
        ----------
        fleet_id, recording_id : int
        analysis_version, kind : str
        """
        values = {
            "fleet_id": fleet_id,
            "recording_id": recording_id,
            "version": analysis_version,
            "kind": kind,
        }
        row = self.read_pool.read(STORED, values, CursorResult.first)
        if row is None:
            return None
        stored = None
        if row.result_id is not None:
            stored = StoredResult(row.text, row.digest or _text_digest(row.text))
        return ResultRead(view_job(row, analysis_version), stored)

    def plot(self, fleet_id: int, recording_id: int, analysis_version: str) -> str | None:
        """The plot file a fleet's recording's diagnosis kept, relative to the data folder; None while
        there is no diagnosis, when it kept none, or for another fleet's recording.

        Parameters
        ----------
        fleet_id, recording_id : int
        analysis_version : str
        """
        with self.db.connect() as c:
            row = c.execute(
                sa.select(results.c.plot)
                .join(recordings, recordings.c.id == results.c.recording_id)
                .where(
                    (recordings.c.id == recording_id)
                    & (recordings.c.fleet_id == fleet_id)
                    & (results.c.analysis_version == analysis_version)
                    & (results.c.kind == DIAGNOSIS_KIND)
                )
            ).first()
        return None if row is None or row.plot is None or not _plot_file(row.plot) else str(row.plot)

    def result_status(self, recording_id: int, analysis_version: str, kind: str) -> str | None:
        """The status stored with a result (healthy, warning, alarm), or None."""
        with self.db.connect() as c:
            row = c.execute(
                sa.select(results.c.status).where(_the_result(recording_id, analysis_version, kind))
            ).first()
        return None if row is None else str(row.status)
