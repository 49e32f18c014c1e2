"""A fleet's recordings in the store: registered once per content, with every name they were given,
and read one at a time or a page of a listing at a time, with their analysis' state.

A recording is stored once per fleet and content, and keeps every file name it
was given (:meth:`RecordingStore.recording_names`). Its artefacts are found by
its id: a diagnosis records the plot file it kept
(:meth:`monitor.store.results.ResultStore.plot`), relative to the data folder,
and no reader looks for a plot by a file name.
"""

from __future__ import annotations

from dataclasses import dataclass
from datetime import UTC, datetime
from typing import Any, NamedTuple

import sqlalchemy as sa
from sqlalchemy.engine import CursorResult

from monitor.errors import StoreError
from monitor.store.base import StoreBase
from monitor.store.jobs import Job, queue_job, view_job
from monitor.store.queries import ONE_VIEW, listing
from monitor.store.schema import recording_names as name_rows
from monitor.store.schema import recordings
from monitor.store.sql import insert_new, now, utc

__all__ = ["RecordingRow", "RecordingStore", "RecordingSummary", "RecordingView"]


@dataclass(frozen=True)
class RecordingRow:
    """A stored recording."""

    id: int
    fleet_id: int
    content_hash: str
    engine_id: str
    filename: str
    path: str
    size_bytes: int
    recorded_at: str
    uploaded_at: datetime


@dataclass(frozen=True)
class RecordingView:
    """A recording as a reader sees it: the row, its job at one analysis version (None before one is
    queued), and the status stored with its diagnosis ("" before there is one)."""

    recording: RecordingRow
    job: Job | None
    diagnosis_status: str


class RecordingSummary(NamedTuple):
    """A recording with the state of its analysis, flat, as a reader is answered: the fields of a
    :class:`RecordingView` that a client sees, in one tuple, a third of the cost of a view's three
    objects to build (which counts in a page of a listing).

    ``status`` is the job's state ("none" before one is queued); ``retry_after`` the time before
    which a queued job that failed is not tried again; ``diagnosis_status`` the stored diagnosis'
    status once the job is done, else "".
    """

    id: int
    engine_id: str
    filename: str
    content_hash: str
    size_bytes: int
    recorded_at: str
    uploaded_at: datetime
    status: str
    attempts: int
    error: str
    retry_after: datetime | None
    diagnosis_status: str


def _summary(row: Any) -> RecordingSummary:
    """The summary in a row of :data:`monitor.store.queries.VIEWS`, read by position (as
    :func:`_recording` and :func:`monitor.store.jobs.view_job` read)."""
    id_, _, content_hash, engine_id, filename, _, size_bytes, recorded_at, uploaded_at = row[:9]
    job_id, state, attempts, error, not_before, diagnosis_status = row[9:15]
    if job_id is None:
        state, attempts, error, diagnosis_status = "none", 0, "", ""
    elif state != "done":
        diagnosis_status = ""
    retry_after = utc(not_before) if state == "queued" and not_before is not None else None
    return RecordingSummary(
        id_,
        engine_id,
        filename,
        content_hash,
        int(size_bytes),
        recorded_at,
        utc(uploaded_at),
        state,
        int(attempts),
        error,
        retry_after,
        diagnosis_status or "",
    )


def _recording(row: Any) -> RecordingRow:
    """The recording in a row that begins with the ``recordings`` table's columns, in their order (the
    fields of :class:`RecordingRow`): read by position, several times faster than by name, which
    counts in a page of a listing."""
    id_, fleet_id, content_hash, engine_id, filename, path, size_bytes, recorded_at, uploaded_at = row[:9]
    return RecordingRow(
        id_,
        fleet_id,
        content_hash,
        engine_id,
        filename,
        path,
        int(size_bytes),
        recorded_at,
        utc(uploaded_at),
    )


def _view(row: Any, analysis_version: str) -> RecordingView:
    job = view_job(row, analysis_version)
    status = row.diagnosis_status if job is not None and job.state == "done" else None
    return RecordingView(_recording(row), job, status or "")


class RecordingStore(StoreBase):
    """The recordings of a :class:`monitor.store.Store` (see the module docstring)."""

    def add_recording(
        self,
        fleet_id: int,
        *,
        content_hash: str,
        engine_id: str,
        filename: str,
        path: str,
        size_bytes: int,
        recorded_at: str = "",
        queue: str | None = None,
    ) -> tuple[RecordingRow, bool]:
        """Store a recording's row, or find the one with the same content: ``(row, created)``.

        Concurrent uploads of the same content store one row (the unique key decides, atomically). The
        row keeps the file name the content was first given; every name it is given is kept besides
        (:meth:`recording_names`), in the same transaction. With ``queue`` (an analysis version)
        its analysis job is queued, if it has none at that version, in the same transaction: a recording is
        never stored without its job.
        """
        if len(engine_id) > 200 or len(filename) > 255 or "\x00" in engine_id + filename:
            raise StoreError(
                "a recording's engine id must be at most 200 characters and its file name 255, without NUL"
            )
        with self.transaction() as c:
            created = insert_new(
                c,
                recordings,
                {
                    "fleet_id": fleet_id,
                    "content_hash": content_hash,
                    "engine_id": engine_id,
                    "filename": filename,
                    "path": path,
                    "size_bytes": size_bytes,
                    "recorded_at": recorded_at,
                    "uploaded_at": now(),
                },
                ["fleet_id", "content_hash"],
            )
            where = (recordings.c.fleet_id == fleet_id) & (recordings.c.content_hash == content_hash)
            row = _recording(c.execute(sa.select(recordings).where(where)).one())
            insert_new(
                c,
                name_rows,
                {"recording_id": row.id, "filename": filename, "created_at": now()},
                ["recording_id", "filename"],
            )
            if queue is not None:
                queue_job(c, row.id, queue)
            return row, created

    def recording_names(self, fleet_id: int, recording_ids: list[int]) -> dict[int, list[str]]:
        """Every file name each of a fleet's recordings was given, in the order they were first given.

        Parameters
        ----------
        fleet_id : int
        recording_ids : list of int
            Another fleet's ids, and unknown ones, are left out of the answer.

        Returns
        -------
        dict of int to list of str
            The names, by recording id; the first is the name the recording was registered under.
        """
        with self.db.connect() as c:
            rows = c.execute(
                sa.select(name_rows.c.recording_id, name_rows.c.filename)
                .join(recordings, recordings.c.id == name_rows.c.recording_id)
                .where((recordings.c.fleet_id == fleet_id) & recordings.c.id.in_(recording_ids))
                .order_by(name_rows.c.recording_id, name_rows.c.id)
            )
            names: dict[int, list[str]] = {}
            for recording_id, filename in rows:
                names.setdefault(int(recording_id), []).append(str(filename))
            return names

    def registered_filenames(self) -> list[tuple[int, str]]:
        """Every recording of every fleet, by id: its id and the file name it was registered under (the
        batch names the plots of a shared data folder after them, :func:`monitor.jobs.plots.plot_names`)."""
        with self.db.connect() as c:
            rows = c.execute(sa.select(recordings.c.id, recordings.c.filename).order_by(recordings.c.id))
            return [(int(r.id), str(r.filename)) for r in rows]

    def content_stored(self, content_hash: str) -> bool:
        """Whether any fleet's recording has this content (its file in the data folder is in use).

        Parameters
        ----------
        content_hash : str
            The SHA-256 (hex) of the file.
        """
        with self.db.connect() as c:
            found = c.execute(
                sa.select(recordings.c.id).where(recordings.c.content_hash == content_hash).limit(1)
            ).first()
        return found is not None

    def recording(self, fleet_id: int, recording_id: int) -> RecordingRow | None:
        """A fleet's recording by id (another fleet's answers None, as an unknown one)."""
        with self.db.connect() as c:
            row = c.execute(
                sa.select(recordings).where(
                    (recordings.c.id == recording_id) & (recordings.c.fleet_id == fleet_id)
                )
            ).first()
        return None if row is None else _recording(row)

    def recording_by_id(self, recording_id: int) -> RecordingRow | None:
        """A recording by id, whatever its fleet (for workers, never for answers to a key)."""
        with self.db.connect() as c:
            row = c.execute(sa.select(recordings).where(recordings.c.id == recording_id)).first()
        return None if row is None else _recording(row)

    def _stored_time(self, moment: datetime) -> datetime:
        """A time as the store compares it: UTC (a time without a zone is UTC), without a zone on SQLite,
        which keeps none."""
        moment = utc(moment).astimezone(UTC)
        return moment.replace(tzinfo=None) if self.dialect == "sqlite" else moment

    def _page(
        self,
        views: bool,
        fleet_id: int,
        engine_id: str | None,
        since: datetime | None,
        until: datetime | None,
        after: tuple[datetime, int] | None,
        offset: int,
        limit: int,
        **more: Any,
    ) -> list[Any]:
        """The rows of one page of a fleet's listing (see :meth:`recordings`)."""
        query = listing(views, engine_id is not None, since is not None, until is not None, after is not None)
        values = {"fleet_id": fleet_id, "engine_id": engine_id, "offset": offset, "limit": limit, **more}
        if since is not None:
            values["since"] = self._stored_time(since)
        if until is not None:
            values["until"] = self._stored_time(until)
        if after is not None:
            values["after_time"], values["after_id"] = self._stored_time(after[0]), after[1]
        return list(self.read_pool.read(query, values, CursorResult.all))

    def recordings(
        self,
        fleet_id: int,
        *,
        engine_id: str | None = None,
        since: datetime | None = None,
        until: datetime | None = None,
        after: tuple[datetime, int] | None = None,
        offset: int = 0,
        limit: int = 100,
    ) -> list[RecordingRow]:
        """A fleet's recordings, newest first, filtered by engine and upload time, a page at a time.

        Parameters
        ----------
        fleet_id : int
        engine_id : str, optional
        since, until : datetime, optional
            Uploaded at or after ``since``, before ``until`` (UTC where they have no zone).
        after : (datetime, int), optional
            The upload time and id of the last recording of the previous page: the page after it
            (keyset paging: read off the index however deep the page).
        offset, limit : int, optional
            Rows skipped (after ``after``), rows at most.
        """
        rows = self._page(False, fleet_id, engine_id, since, until, after, offset, limit)
        return [_recording(r) for r in rows]

    def recording_view(self, fleet_id: int, recording_id: int, analysis_version: str) -> RecordingView | None:
        """A fleet's recording with its job and diagnosis status, in one query (another fleet's: None).

        Parameters
        ----------
        fleet_id, recording_id : int
        analysis_version : str
        """
        values = {"fleet_id": fleet_id, "recording_id": recording_id, "version": analysis_version}
        row = self.read_pool.read(ONE_VIEW, values, CursorResult.first)
        return None if row is None else _view(row, analysis_version)

    def recording_views(
        self,
        fleet_id: int,
        analysis_version: str,
        *,
        engine_id: str | None = None,
        since: datetime | None = None,
        until: datetime | None = None,
        after: tuple[datetime, int] | None = None,
        offset: int = 0,
        limit: int = 100,
    ) -> list[RecordingView]:
        """A page of :meth:`recordings` with each one's job and diagnosis status, in one query.

        Parameters are those of :meth:`recordings`, and the analysis version of the jobs.
        """
        rows = self._page(
            True, fleet_id, engine_id, since, until, after, offset, limit, version=analysis_version
        )
        return [_view(r, analysis_version) for r in rows]

    def recording_summary(
        self, fleet_id: int, recording_id: int, analysis_version: str
    ) -> RecordingSummary | None:
        """:meth:`recording_view` as a :class:`RecordingSummary` (another fleet's: None)."""
        values = {"fleet_id": fleet_id, "recording_id": recording_id, "version": analysis_version}
        row = self.read_pool.read(ONE_VIEW, values, CursorResult.first)
        return None if row is None else _summary(row)

    def recording_summaries(
        self,
        fleet_id: int,
        analysis_version: str,
        *,
        engine_id: str | None = None,
        since: datetime | None = None,
        until: datetime | None = None,
        after: tuple[datetime, int] | None = None,
        offset: int = 0,
        limit: int = 100,
    ) -> list[RecordingSummary]:
        """:meth:`recording_views` as :class:`RecordingSummary` tuples, in one query (the listing's page).

        Parameters are those of :meth:`recording_views`.
        """
        rows = self._page(
            True, fleet_id, engine_id, since, until, after, offset, limit, version=analysis_version
        )
        return [_summary(r) for r in rows]
