"""The nightly batch: diagnose every recording not yet diagnosed, idempotent and resumable.

``engine-monitor batch PATH`` registers every recording file under ``PATH``
(``.h5``, ``.hdf5``, ``.mcap``) in the store by its content hash (a file seen
before, under any name, is not registered twice: copies of one content are one
recording, which keeps each name it was given), queues a diagnosis job for
each recording that has no result at the current analysis version, and runs
the queued jobs in a local process pool. A file that is not a readable
recording (another format, damaged, or cut short before what a diagnosis
needs) is listed with its one-line reason and left out; the others go on. A
file cut short but readable (an MCAP file read to its last whole chunk) is
diagnosed on what it holds, and the summary says it was cut short. ``engine-monitor batch --since DATE``
does the same for the recordings already in the store (uploaded over HTTP)
since that date. With ``--scheduler tcp://host:8786`` the jobs run on a Dask
distributed cluster instead (the recordings' paths must be readable there).

Each job's result is written in one transaction with the job's completion,
and the store's unique keys refuse a second result for the same recording and
version, so the batch can be run again at any time, and after a crash: jobs a
killed batch left running are queued again, the rest are not redone. A job
that fails records why and is retried by the next run, up to
:data:`monitor.store.MAX_ATTEMPTS` times, then set aside.

Each recording is analysed as ``compare`` analyses it
(:func:`monitor.jobs.analyse.diagnose_file`): engines come from the fleet's
descriptions in the store, else the bundled ones; baselines (``--baseline
B.json``, one per engine) make the bearing comparisons.

The summary covers the run's scope (the files under ``PATH``, or the store's
recordings since ``DATE``): each file with its diagnosis, made by this run
or found already made, or with why it has none. A file is reported under its
own name, with its recording's id: copies of one content share the id and the
result, each under its name (with ``--since``, a recording is reported under
every name it was stored under; :mod:`monitor.jobs.summary`). Its exit status, as
``compare``'s, is the worst over the scope: 0 healthy, 1 warning, 2 alarm, 3
inconclusive or not diagnosed (a job that failed or was set aside, a file that
is not a readable recording). A run again on the same scope says the same.

With a data folder, each diagnosis plot is kept in its ``plots/`` folder,
named after its recording's file (:func:`monitor.jobs.plots.plot_names`), for people browsing the
folder; the store records that file with the diagnosis, and a plot is found by
the recording's id through the store (:meth:`monitor.store.Store.plot`), never
by a name.
"""

from __future__ import annotations

import os
import time
from collections import defaultdict
from collections.abc import Callable, Iterator
from concurrent.futures import FIRST_COMPLETED, Executor, Future, wait
from contextlib import contextmanager
from dataclasses import dataclass, field, replace
from datetime import datetime, timedelta
from pathlib import Path
from typing import Any

from monitor.diagnosis import ANALYSIS_VERSION
from monitor.errors import MonitorError
from monitor.jobs.analyse import DIAGNOSIS, diagnose_file
from monitor.jobs.delivery import DeliveryPolicy, deliver_due
from monitor.jobs.plots import PLOTS, plot_files
from monitor.jobs.registration import recording_files, register_file
from monitor.jobs.summary import BatchSummary, RecordingOutcome, joined, one_line
from monitor.runtime.processes import analysis_pool
from monitor.store import Job, Store

__all__ = ["run_batch"]


def run_batch(
    store: Store,
    fleet_id: int,
    *,
    path: Path | None = None,
    since: datetime | None = None,
    baselines: dict[str, dict[str, Any]] | None = None,
    workers: int | None = None,
    progress: Callable[[int, int], None] | None = None,
    scheduler: str | None = None,
    data_dir: Path | None = None,
    lease: timedelta = timedelta(seconds=30),
) -> BatchSummary:
    """Register, queue and diagnose (see the module docstring).

    Parameters
    ----------
    store : Store
    fleet_id : int
    path : Path, optional
        A recording file or a folder searched recursively.
    since : datetime, optional
        Instead of ``path``: the fleet's stored recordings uploaded since then.
    baselines : dict, optional
        Baseline documents (``engine-monitor calibrate``) by engine id.
    workers : int, optional
        Worker processes; default: one per core.
    progress : callable, optional
        Called with (jobs done, jobs in this run) after each job.
    scheduler : str, optional
        A Dask distributed scheduler's address (``tcp://host:8786``): the jobs run on its workers
        instead of a local process pool. A worker lost mid-batch has its tasks run again on the
        others (by the scheduler); a task that fails is recorded as any failure.
    data_dir : Path, optional
        The service's data folder: each diagnosis plot is kept there, as the service keeps it.
    lease : timedelta, optional
        Jobs in scope that have been running silently this long (a killed batch or worker) are
        taken back; this batch touches its own running jobs three times as often.

    Returns
    -------
    BatchSummary
    """
    summary = BatchSummary()
    given: list[tuple[int, str, str]] = []  # each file in scope: its recording's id, its name, its path
    cut_short: set[int] = set()
    if path is not None:
        for file in recording_files(path):
            try:
                recording_id, created, truncated = register_file(store, fleet_id, file)
            except (MonitorError, OSError) as error:
                summary.unreadable.append((file.name, one_line(str(error))))
                continue
            except Exception as error:  # a reader's failure on one file is recorded, never fatal to the batch
                summary.unreadable.append((file.name, one_line(f"{type(error).__name__}: {error}")))
                continue
            if truncated:
                summary.truncated.append(file.name)
                cut_short.add(recording_id)
            summary.registered += created
            summary.known += not created
            given.append((recording_id, file.name, str(file)))
    else:  # each recording under every name it was stored under
        offset = 0
        while page := store.recordings(fleet_id, since=since, offset=offset, limit=500):
            stored = store.recording_names(fleet_id, [r.id for r in page])
            given += [(r.id, name, "") for r in page for name in stored.get(r.id, [r.filename])]
            offset += len(page)
    scope = list(dict.fromkeys(i for i, _, _ in given))  # copies of one content are one recording
    names: dict[int, list[str]] = defaultdict(list)
    for recording_id, name, _ in given:
        names[recording_id].append(name)
    # jobs of a batch or worker that died (a process of this host that is gone, or silent for the
    # lease) are taken back at once; those of a live one are waited for, after this run's own
    summary.requeued = store.requeue_stale(ANALYSIS_VERSION, lease, recording_ids=scope)
    pending: list[Job] = []
    held: list[int] = []
    for recording_id in scope:
        job = store.enqueue(recording_id, ANALYSIS_VERSION)
        if job.state == "queued":
            pending.append(job)
        elif job.state == "running":
            held.append(recording_id)
    summary.held = len(held)
    plots = plot_files(store) if data_dir is not None else {}
    context = _Run(store, fleet_id, baselines or {}, data_dir, plots, names, lease, summary, progress)
    total = len(pending) + len(held)
    if total > 0:
        _run_jobs(context, scheduler, workers, pending, held, total)
    outcomes = {i: _outcome(store, i, context, truncated=i in cut_short) for i in scope}
    summary.recordings = [replace(outcomes[i], filename=name, path=file) for i, name, file in given]
    deliver_due(store, DeliveryPolicy(), fleet_id=fleet_id)  # the alerts its diagnoses made (docs/service.md)
    return summary


def _run_jobs(
    context: _Run, scheduler: str | None, workers: int | None, pending: list[Job], held: list[int], total: int
) -> None:
    """Run this run's jobs, then wait for those another run holds (see the module docstring)."""
    store, summary, lease = context.store, context.summary, context.lease
    with _executor(scheduler, workers, total) as (pool, count):
        held += context.run(pool, count, pending, total)
        started = time.monotonic()
        while held:  # another run holds them: it finishes them, or they are taken back after its lease
            time.sleep(context.beat)
            summary.requeued += store.requeue_stale(ANALYSIS_VERSION, lease, recording_ids=held)
            again: list[Job] = []
            still: list[int] = []
            for recording_id in held:
                now = store.job(recording_id, ANALYSIS_VERSION)
                if now is not None and now.state == "queued":
                    again.append(now)
                elif now is not None and now.state == "running":
                    still.append(recording_id)
                else:  # done or set aside by the run that held it
                    summary.finished_elsewhere += 1
                    context.elsewhere.add(recording_id)
                    context.count_done(total)
            held = still + context.run(pool, count, again, total)
            summary.waited_s = time.monotonic() - started


def _outcome(store: Store, recording_id: int, context: _Run, *, truncated: bool) -> RecordingOutcome:
    """Where a recording of the scope stands: its diagnosis (stored), else its job's state; its plot
    where the store says its diagnosis kept it, if that file is in this run's data folder."""
    row = store.recording(context.fleet_id, recording_id)
    assert row is not None  # in the scope: registered in this fleet
    kept = store.plot(context.fleet_id, recording_id, ANALYSIS_VERSION)
    plot = context.data_dir / kept if context.data_dir is not None and kept is not None else None
    outcome = RecordingOutcome(
        id=row.id,
        filename=row.filename,
        engine_id=row.engine_id,
        recorded_at=row.recorded_at,
        status="failed",
        plot=str(plot) if plot is not None and plot.is_file() else "",
        truncated=truncated,
    )
    document = store.result(recording_id, ANALYSIS_VERSION, DIAGNOSIS)
    if document is not None:
        if recording_id in context.mine:
            diagnosed = "this run"
        else:
            diagnosed = "another run" if recording_id in context.elsewhere else "before"
        findings = [
            {k: f[k] for k in ("kind", "subject", "severity", "summary")} for f in document["findings"]
        ]
        return replace(outcome, status=document["status"], diagnosed=diagnosed, findings=findings)
    job = store.job(recording_id, ANALYSIS_VERSION)
    if job is None:
        return replace(outcome, error="no job was queued")
    return replace(outcome, status="failed" if job.state == "queued" else job.state, error=job.error)


@dataclass
class _Run:
    """What one batch run's jobs share: where they come from, where they go, how they are counted."""

    store: Store
    fleet_id: int
    baselines: dict[str, dict[str, Any]]
    data_dir: Path | None  # where plots are kept (None: nowhere)
    plots: dict[int, str]  # where each recording's plot goes in the data folder (none: no plots kept)
    names: dict[int, list[str]]  # each recording's names in the scope
    lease: timedelta
    summary: BatchSummary
    progress: Callable[[int, int], None] | None
    engines: dict[str, dict[str, Any] | None] = field(default_factory=dict)
    done: int = 0
    mine: set[int] = field(default_factory=set)  # the recordings this run diagnosed
    elsewhere: set[int] = field(default_factory=set)  # those another run finished while this one waited

    def count_done(self, total: int) -> None:
        """One more job of this run's is over; tell the progress display."""
        self.done += 1
        if self.progress is not None:
            self.progress(self.done, total)

    @property
    def beat(self) -> float:
        """Seconds between the touches of this run's jobs (three per lease)."""
        return self.lease.total_seconds() / 3

    def run(self, pool: Executor, count: int, pending: list[Job], total: int) -> list[int]:
        """Run the jobs, ``2 * count`` in flight at a time, touching them, recording each outcome.

        Returns the recordings whose job another run took first (to be waited for).
        """
        store, summary, fleet_id, engines = self.store, self.summary, self.fleet_id, self.engines
        running: dict[Future[dict[str, tuple[str, dict[str, Any]]]], tuple[Job, str, str, str | None]] = {}
        queue = list(pending)
        taken: list[int] = []

        def submit() -> None:
            while queue and len(running) < 2 * count:
                job = queue.pop(0)
                claimed = store.claim_job(job.id)
                if claimed is None:  # another worker took it, or it is no longer queued
                    taken.append(job.recording_id)
                    continue
                row = store.recording(fleet_id, claimed.recording_id)
                assert row is not None
                if row.engine_id not in engines:
                    engines[row.engine_id] = store.engine(fleet_id, row.engine_id)
                plot = self.plots.get(row.id)  # relative to the data folder
                future = pool.submit(
                    diagnose_file,
                    row.path,
                    engines[row.engine_id],
                    self.baselines.get(row.engine_id),
                    None if plot is None or self.data_dir is None else str(self.data_dir / plot),
                    row.filename,  # the documents and the plot, one per content, name its first name
                )
                running[future] = (
                    claimed,
                    joined(self.names.get(row.id, [row.filename])),
                    row.engine_id,
                    plot,
                )

        if self.data_dir is not None and self.plots:
            (self.data_dir / PLOTS).mkdir(parents=True, exist_ok=True)
        submit()
        while running:
            finished, _ = wait(list(running), timeout=self.beat, return_when=FIRST_COMPLETED)
            for job, *_ in running.values():  # the heartbeat of the jobs this batch runs
                store.touch(job)
            for future in finished:
                job, name, engine_id, plot = running.pop(future)
                try:
                    documents = future.result()
                except Exception as error:  # a worker's failure is recorded, never fatal to the batch
                    reason = one_line(f"{type(error).__name__}: {error}")
                    summary.failed.append((name, reason, store.fail(job, reason)))
                else:
                    store.complete(job, documents, plot=plot)
                    self.mine.add(job.recording_id)
                    status, document = documents[DIAGNOSIS]
                    summary.diagnosed += 1
                    summary.by_engine[engine_id][status] += 1
                    summary.findings[engine_id] += [f"{name}: {f['summary']}" for f in document["findings"]]
                self.count_done(total)
            submit()
        return taken


@contextmanager
def _executor(scheduler: str | None, workers: int | None, total: int) -> Iterator[tuple[Executor, int]]:
    """A local process pool, or a Dask cluster's executor; with how many jobs to keep in flight each."""
    if scheduler is None:
        count = workers or os.cpu_count() or 1
        with analysis_pool(min(count, total), fork=True) as pool:  # a command: no socket to keep from them
            yield pool, count
        return
    try:
        from distributed import Client
    except ImportError as error:
        raise MonitorError("--scheduler needs Dask distributed: install engine-monitor[cluster]") from error
    try:
        client = Client(scheduler, timeout="10s")
    except OSError as error:
        raise MonitorError(f"Dask scheduler {scheduler}: cannot be reached ({error})") from error
    try:
        count = workers or max(1, sum(client.nthreads().values()))
        with client.get_executor(pure=False) as pool:
            yield pool, count
    finally:
        client.close()
