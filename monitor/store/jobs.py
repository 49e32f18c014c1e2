"""The store's job queue: one analysis of one recording at one analysis version.

Jobs move ``queued -> running -> done``; a failure records why and puts the
job back in the queue until :data:`MAX_ATTEMPTS`, after which it is set aside.
A job whose taker stopped touching it (a crash), or whose taker was a process
of this host that is gone, is taken back by :meth:`JobQueue.requeue_stale`; only
its taker, by the token it got, may complete or fail a running job (it
completes it with its results, :meth:`monitor.store.results.ResultStore.complete`).
A job that failed for a passing reason waits before it is tried again, twice as
long after each attempt (:data:`RETRY_BACKOFF`).
"""

from __future__ import annotations

import os
import secrets
import socket
from dataclasses import dataclass
from datetime import datetime, timedelta
from pathlib import Path
from typing import Any

import sqlalchemy as sa
from sqlalchemy.engine import Connection

from monitor.store.base import StoreBase
from monitor.store.schema import jobs
from monitor.store.sql import insert_new, now, utc

__all__ = [
    "MAX_ATTEMPTS",
    "RETRY_BACKOFF",
    "Job",
    "JobQueue",
    "finish",
    "process_identity",
    "queue_job",
    "view_job",
]

MAX_ATTEMPTS = 3  # a job that failed this many times is set aside
#: The wait before the first retry of a job that failed for a passing reason; doubled after each attempt.
RETRY_BACKOFF = timedelta(seconds=10)


@dataclass(frozen=True)
class Job:
    """One analysis of one recording at one analysis version (``not_before``: a retry waits until then)."""

    id: int
    recording_id: int
    analysis_version: str
    state: str
    attempts: int
    error: str
    token: str = ""
    not_before: datetime | None = None


def _process_start(pid: int) -> str:
    """When a process started, in clock ticks since boot (Linux), so a reused process id is told
    apart; "" where the system does not say."""
    try:
        return Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[19]
    except (OSError, IndexError):
        return ""


def process_identity(pid: int | None = None) -> str:
    """``host:pid:start`` of a process, as a job's ``holder``.

    Parameters
    ----------
    pid : int, optional
        The process; this one when not given.

    Returns
    -------
    str
    """
    pid = os.getpid() if pid is None else pid
    return f"{socket.gethostname()}:{pid}:{_process_start(pid)}"


def _gone(holder: str) -> bool:
    """Whether a job's holder was a process of this host that no longer runs."""
    host, _, rest = holder.partition(":")
    pid_text, _, start = rest.partition(":")
    if not holder or host != socket.gethostname() or not pid_text.isdigit():
        return False  # another host's (or an older taker's): only its lease tells
    pid = int(pid_text)
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return True
    except PermissionError:
        pass  # it exists, under another user
    return bool(start) and _process_start(pid) not in ("", start)


def _job(row: Any) -> Job:
    return Job(
        row.id,
        row.recording_id,
        row.analysis_version,
        row.state,
        int(row.attempts),
        row.error,
        row.token,
        utc(row.not_before) if row.not_before is not None else None,
    )


def view_job(row: Any, analysis_version: str) -> Job | None:
    """The job in a row of a recording joined with its job (None where the join found none): the
    recording's id first, the job's columns (:data:`monitor.store.queries.JOB_COLUMNS`) from the
    tenth on, read by position as :func:`monitor.store.recordings._recording` reads.

    Parameters
    ----------
    row : Row
        A recording joined with its job.
    analysis_version : str
        The analysis the job runs.

    Returns
    -------
    Job or None
    """
    job_id, state, attempts, error, not_before = row[9:14]
    if job_id is None:
        return None
    return Job(
        job_id,
        row[0],
        analysis_version,
        state,
        int(attempts),
        error,
        "",  # a view never carries the taker's token
        utc(not_before) if not_before is not None else None,
    )


def queue_job(c: Connection, recording_id: int, analysis_version: str) -> Job:
    """The job of a recording at an analysis version, queued if it did not exist (in the caller's
    transaction).

    Parameters
    ----------
    c : Connection
        The caller's transaction.
    recording_id : int
    analysis_version : str
        The analysis the job runs.

    Returns
    -------
    Job
    """
    moment = now()
    insert_new(
        c,
        jobs,
        {
            "recording_id": recording_id,
            "analysis_version": analysis_version,
            "state": "queued",
            "attempts": 0,
            "error": "",
            "token": "",
            "created_at": moment,
            "updated_at": moment,
        },
        ["recording_id", "analysis_version"],
    )
    where = (jobs.c.recording_id == recording_id) & (jobs.c.analysis_version == analysis_version)
    return _job(c.execute(sa.select(jobs).where(where)).one())


def _take(c: Connection, job_id: int) -> Job | None:
    token = secrets.token_hex(16)
    taken = c.execute(
        sa.update(jobs)
        .where((jobs.c.id == job_id) & (jobs.c.state == "queued"))
        .values(
            state="running",
            attempts=jobs.c.attempts + 1,
            token=token,
            holder=process_identity(),
            not_before=None,
            updated_at=now(),
        )
    ).rowcount
    if taken != 1:
        return None
    return _job(c.execute(sa.select(jobs).where(jobs.c.id == job_id)).one())


def _mine(job: Job) -> Any:
    """The job, still running under this taker's token (not taken back meanwhile)."""
    return (jobs.c.id == job.id) & (jobs.c.state == "running") & (jobs.c.token == job.token)


def finish(c: Connection, job: Job) -> bool:
    """Mark a job done, in the transaction that stores its results. False if the job had been taken
    back from this taker meanwhile: it is done all the same (its results are the analysis of the same
    recording at the same version).

    Parameters
    ----------
    c : Connection
        In the transaction that stores the job's results.
    job : Job
        As its taker got it (:meth:`JobQueue.claim`, :meth:`JobQueue.claim_job`).
    """
    mine = c.execute(
        sa.update(jobs)
        .where(_mine(job))
        .values(state="done", error="", token="", holder="", updated_at=now())
    ).rowcount
    if mine != 1:  # taken back and maybe queued again: with its results stored, it is done
        c.execute(
            sa.update(jobs)
            .where((jobs.c.id == job.id) & (jobs.c.state == "queued"))
            .values(state="done", error="", updated_at=now())
        )
    return mine == 1


class JobQueue(StoreBase):
    """The analysis jobs of a :class:`monitor.store.Store` (see the module docstring)."""

    def enqueue(self, recording_id: int, analysis_version: str) -> Job:
        """The job of a recording at an analysis version, queued if it did not exist."""
        with self.transaction() as c:
            return queue_job(c, recording_id, analysis_version)

    def claim(self, analysis_version: str) -> Job | None:
        """Take the oldest queued job of this version that is due (marking it running), or None.

        A job waiting out its retry backoff is not due yet.

        Two workers never take the same job: the state changes only where it is still "queued", and
        the taker's token (in the returned job) is what later updates of the job must show.
        """
        while True:
            with self.transaction() as c:
                due = jobs.c.not_before.is_(None) | (jobs.c.not_before <= now())
                row = c.execute(
                    sa.select(jobs.c.id)
                    .where((jobs.c.state == "queued") & (jobs.c.analysis_version == analysis_version) & due)
                    .order_by(jobs.c.id)
                    .limit(1)
                ).first()
                if row is None:
                    return None
                job = _take(c, row.id)
                if job is not None:
                    return job

    def claim_job(self, job_id: int) -> Job | None:
        """Take one job if it is still queued (marking it running), else None; a batch asks for it
        by name, so a retry backoff does not hold it."""
        with self.transaction() as c:
            return _take(c, job_id)

    def fail(self, job: Job, error: str, *, permanent: bool = False, backoff: timedelta | None = None) -> str:
        """Record why a job failed; queue it again, or set it aside after :data:`MAX_ATTEMPTS`.

        A ``permanent`` failure (the input itself is wrong: trying again gives the same answer) is
        set aside at once; another is queued again, not before ``backoff`` (default
        :data:`RETRY_BACKOFF`) doubled for each attempt after the first. Returns the job's new state
        (its current one, unchanged, if it was taken back meanwhile).
        """
        wait = (RETRY_BACKOFF if backoff is None else backoff) * 2 ** max(0, job.attempts - 1)
        with self.transaction() as c:
            state = "set_aside" if permanent or job.attempts >= MAX_ATTEMPTS else "queued"
            changed = c.execute(
                sa.update(jobs)
                .where(_mine(job))
                .values(
                    state=state,
                    error=error[:4000],
                    token="",
                    holder="",
                    not_before=now() + wait if state == "queued" else None,
                    updated_at=now(),
                )
            ).rowcount
            if changed != 1:
                return str(c.execute(sa.select(jobs.c.state).where(jobs.c.id == job.id)).scalar_one())
            return state

    def touch(self, job: Job) -> bool:
        """A running job's heartbeat: its taker is alive. False if the job was taken back."""
        with self.transaction() as c:
            return c.execute(sa.update(jobs).where(_mine(job)).values(updated_at=now())).rowcount == 1

    def requeue_stale(
        self, analysis_version: str, older_than: timedelta, *, recording_ids: list[int] | None = None
    ) -> int:
        """Take back the running jobs whose taker died; how many.

        A taker is dead when it has not touched its job for ``older_than`` (takers touch their
        running jobs, :meth:`touch`, more often than that), or at once when it was a process of
        this host that no longer runs (a killed server, worker or batch restarted). Its jobs are
        queued again, or set aside once they have been tried :data:`MAX_ATTEMPTS` times (a
        recording that kills its worker).
        """
        cutoff = now() - older_than
        running = (jobs.c.state == "running") & (jobs.c.analysis_version == analysis_version)
        if recording_ids is not None:
            running &= jobs.c.recording_id.in_(recording_ids)
        with self.transaction() as c:
            held = c.execute(
                sa.select(jobs.c.id, jobs.c.holder).where(running & (jobs.c.updated_at >= cutoff))
            )
            gone = [
                (jobs.c.id == row.id) & (jobs.c.holder == row.holder) for row in held if _gone(row.holder)
            ]
        where = running & ((jobs.c.updated_at < cutoff) | sa.or_(sa.false(), *gone))
        lost = "its worker stopped answering while it ran (killed, or out of memory)"
        with self.transaction() as c:
            aside = c.execute(
                sa.update(jobs)
                .where(where & (jobs.c.attempts >= MAX_ATTEMPTS))
                .values(state="set_aside", error=lost, token="", holder="", updated_at=now())
            ).rowcount
            again = c.execute(
                sa.update(jobs).where(where).values(state="queued", token="", holder="", updated_at=now())
            ).rowcount
            return int(aside + again)

    def job(self, recording_id: int, analysis_version: str) -> Job | None:
        """The job of a recording at a version, or None."""
        with self.db.connect() as c:
            row = c.execute(
                sa.select(jobs).where(
                    (jobs.c.recording_id == recording_id) & (jobs.c.analysis_version == analysis_version)
                )
            ).first()
        return None if row is None else _job(row)

    def jobs_by_state(self, analysis_version: str) -> dict[str, int]:
        """How many jobs of an analysis version are in each state (the states with none left out)."""
        with self.db.connect() as c:
            rows = c.execute(
                sa.select(jobs.c.state, sa.func.count())
                .where(jobs.c.analysis_version == analysis_version)
                .group_by(jobs.c.state)
            )
            return {str(state): int(n) for state, n in rows}
