"""Background analysis: a worker takes queued jobs from the store and runs them in a process.

The job state lives in the store, so it survives the server: at start, and
then every heartbeat, the worker takes back the jobs whose worker has not
been heard of for :data:`LEASE` (a server killed mid-analysis), and while a
job runs its worker touches it every :data:`HEARTBEAT` (or a third of the
lease). Only the job's taker may complete or fail it (its token). The
analysis runs in a separate process: its crash fails the job and a fresh
process takes the next, never stopping the worker. The result is written
with the job's completion in one transaction, once. A job that fails records
why. The diagnosis plot is kept in the data folder's ``plots/``, named as the
batch names it, and recorded with the diagnosis: the service finds it by the
recording's id, through the store. The fleet's baseline of the recording's engine, if it set one
(``POST /engines/{id}/baseline``), is the reference of the bearing
comparisons, as ``batch --baseline`` gives one. A failure of the input
itself (:func:`input_fault`: a file the reader refuses, an engine nobody
described, a recording the diagnosis cannot use) is permanent and set aside
at once, the reason in its status in the product's words; any other (a
process killed, a disk full, the store away) is retried after a backoff
that doubles with each attempt, then set aside
(:data:`monitor.store.MAX_ATTEMPTS`). Every change of a job's state is one
log line of ``key=value`` fields.

The store unreachable a while (:func:`monitor.store.outage.store_fault`) is
ridden out: the worker looks again, less and less often (up to every
:data:`OUTAGE_WAIT` s), an analysis that runs meanwhile runs on, and its
result, or its failure, is written once the store is back; one log line when
the outage begins and one when it ends (:class:`monitor.store.outage.Outage`,
shared with the service's requests), not a traceback per look. A job taken
before the outage stays its taker's, so it is neither lost nor run twice
(unless the outage outlasts the lease, when another worker may take it back
and the first result written is kept).

Analyses run at a lower CPU priority than the server (:data:`NICE`): the
server answers reads in milliseconds, an analysis takes seconds, so where
both want the same core the reads go first and the analysis takes what is
left; on an idle machine nothing changes.
"""

from __future__ import annotations

import logging
import os
import threading
import time
from collections.abc import Callable
from concurrent.futures import CancelledError, Future, ProcessPoolExecutor, TimeoutError
from concurrent.futures.process import BrokenProcessPool
from datetime import timedelta
from functools import partial
from pathlib import Path
from typing import Any, TypeVar

from monitor.diagnosis import ANALYSIS_VERSION
from monitor.errors import MonitorError, OutputFolderError, StoreError
from monitor.jobs.analyse import diagnose_file
from monitor.jobs.plots import recording_plot
from monitor.runtime.processes import NICE, analysis_pool, close_pool
from monitor.store import RETRY_BACKOFF, Job, Store
from monitor.store.outage import store_fault

__all__ = ["HEARTBEAT", "LEASE", "NICE", "Worker", "analyse", "input_fault"]

log = logging.getLogger("engine_monitor.worker")

HEARTBEAT = 5.0  # seconds between a running job's touches
LEASE = timedelta(seconds=30)  # a running job untouched this long has lost its worker
IDLE = 0.5  # seconds between looks at an empty queue
OUTAGE_WAIT = 5.0  # longest wait between looks at a store that does not answer [s]

T = TypeVar("T")


class _Stopped(Exception):
    """The worker was stopped while it waited for the store."""


def input_fault(error: BaseException) -> bool:
    """Whether an analysis failed by the recording's own content, so that trying again gives the same
    answer: an error the product raises on purpose (:class:`~monitor.errors.MonitorError`: a file its
    readers refuse, an engine nobody described, a recording the diagnosis cannot use), but not the
    store's nor a missing output folder's, which are the surroundings' and may pass.

    Parameters
    ----------
    error : BaseException
        What the analysis raised.

    Returns
    -------
    bool
    """
    return isinstance(error, MonitorError) and not isinstance(error, StoreError | OutputFolderError)


def analyse(*args: Any) -> dict[str, tuple[str, dict[str, Any]]]:
    """:func:`monitor.jobs.analyse.diagnose_file` in an analysis process, at niceness :data:`NICE` (set on the
    process's first analysis; a process can lower its own priority, never raise it again)."""
    if hasattr(os, "setpriority") and os.getpriority(os.PRIO_PROCESS, 0) < NICE:
        os.setpriority(os.PRIO_PROCESS, 0, NICE)
    return diagnose_file(*args)


class Worker:
    """A thread that runs queued analyses, ``processes`` at a time in child processes.

    Parameters
    ----------
    store : Store
    data_dir : Path
        The service's data folder (plots are written under it).
    processes : int, optional
    lease : timedelta, optional
        A running job untouched this long has lost its worker (touched three times as often).
    backoff : timedelta, optional
        Wait before a job that failed for a passing reason is tried again, doubled after each attempt.
    """

    def __init__(
        self,
        store: Store,
        data_dir: Path,
        processes: int = 1,
        *,
        lease: timedelta = LEASE,
        backoff: timedelta = RETRY_BACKOFF,
    ) -> None:
        self.store = store
        self.lease = lease
        self.backoff = backoff
        self.heartbeat = min(HEARTBEAT, lease.total_seconds() / 3)
        self.data_dir = data_dir
        self.processes = max(1, processes)
        self._stop = threading.Event()
        self._wake = threading.Event()
        self._threads: list[threading.Thread] = []
        self._pool: ProcessPoolExecutor | None = None
        self._closed = False  # set by stop(), under the lock: no pool is made or used after it
        self._lock = threading.Lock()

    def start(self) -> None:
        """Take back the jobs of dead workers, then start the loops."""
        self.store.requeue_stale(ANALYSIS_VERSION, self.lease)
        (self.data_dir / "plots").mkdir(parents=True, exist_ok=True)
        with self._lock:
            self._fresh_pool()
        for i in range(self.processes):
            thread = threading.Thread(target=self._loop, name=f"analysis-{i}", daemon=True)
            thread.start()
            self._threads.append(thread)

    def wake(self) -> None:
        """A job was queued: look now."""
        self._wake.set()

    def stop(self) -> None:
        """Stop taking jobs and end the analysis processes; a job that is running keeps its state and is
        taken back after the lease.

        The pool is taken from the worker under its lock, after which no thread makes or uses one, and
        ended here (:func:`~monitor.runtime.processes.close_pool`): its processes, its manager thread and
        its queues' semaphores are gone when this returns, whenever it is called (the server stopped while
        it starts, while a job is submitted, mid-analysis), rather than left to a daemon thread that the
        interpreter's exit may stop halfway. Safe to call more than once, and after a start that failed.
        """
        self._stop.set()
        self._wake.set()
        for thread in self._threads:
            thread.join(timeout=5)
        with self._lock:
            self._closed = True
            pool, self._pool = self._pool, None
        if pool is not None:
            close_pool(pool)

    def _loop(self) -> None:
        last_sweep = 0.0
        wait = IDLE  # between looks at a store that does not answer: doubled up to OUTAGE_WAIT
        while not self._stop.is_set():
            try:
                now = time.monotonic()
                if now - last_sweep > self.heartbeat:  # take back the jobs of workers that died since
                    self.store.requeue_stale(ANALYSIS_VERSION, self.lease)
                    last_sweep = now
                job = self.store.claim(ANALYSIS_VERSION)
                self.store.outage.back()
                wait = IDLE
                if job is None:
                    self._wake.wait(IDLE)
                    self._wake.clear()
                    continue
                _log_state(job, "running")
                self._run(job)
            except _Stopped:
                return
            except Exception as error:  # log, wait, go on; never stop the loop
                if store_fault(error) is None:
                    log.exception("analysis worker: an error outside an analysis; going on")
                else:  # the store down: logged once per outage, looked at less often
                    self.store.outage.failed(error)
                self._stop.wait(wait)
                wait = min(2 * wait, OUTAGE_WAIT)

    def _stored(self, function: Callable[..., T], *args: Any) -> T:
        """``function(*args)``, a call to the store, again and again while the store does not answer
        (waits doubled up to :data:`OUTAGE_WAIT`); :class:`_Stopped` if the worker stops meanwhile."""
        wait = IDLE
        while True:
            try:
                found = function(*args)
            except Exception as error:
                if store_fault(error) is None:
                    raise
                self.store.outage.failed(error)
                if self._stop.wait(wait):
                    raise _Stopped from None
                wait = min(2 * wait, OUTAGE_WAIT)
                continue
            self.store.outage.back()
            return found

    def _fresh_pool(self) -> ProcessPoolExecutor:
        """The pool, a new one in place of one that is broken (called with the lock held)."""
        if self._closed:
            raise _Stopped
        if self._pool is None or getattr(self._pool, "_broken", False):
            if self._pool is not None:
                close_pool(self._pool)
            self._pool = None
            self._pool = analysis_pool(self.processes)
        return self._pool

    def _submit(self, *args: Any) -> Future[dict[str, tuple[str, dict[str, Any]]]]:
        """:func:`analyse` of ``args`` submitted to the pool, in one step with respect to :meth:`stop`: a
        pool made here is the worker's before stop can look for it, and none is made or used after it
        (:class:`_Stopped`)."""
        with self._lock:
            return self._fresh_pool().submit(analyse, *args)

    def _run(self, job: Job) -> None:
        row = self._stored(self.store.recording_by_id, job.recording_id)
        if row is None:  # deleted meanwhile
            self._stored(self.store.fail, job, "the recording is no longer stored")
            return
        engine = self._stored(self.store.engine, row.fleet_id, row.engine_id)
        # the bearing comparisons' reference
        baseline = self._stored(self.store.baseline, row.fleet_id, row.engine_id)
        # named as the batch names it, recorded with the diagnosis
        plot = self._stored(recording_plot, self.store, row.id)
        # a pool broken by an earlier analysis is replaced before this one is submitted
        future = self._submit(
            row.path,
            engine,
            None if baseline is None else baseline.document,
            str(self.data_dir / plot),
            row.filename,
        )
        touched = time.monotonic()
        while True:
            try:  # looks at the stop every IDLE s, touches the job every heartbeat
                documents = future.result(timeout=min(IDLE, self.heartbeat))
            except TimeoutError:
                if self._stop.is_set():
                    return  # the lease hands the job to the next worker
                if time.monotonic() - touched < self.heartbeat:
                    continue
                touched = time.monotonic()
                try:
                    self.store.touch(job)
                except Exception as error:  # the store down: the analysis runs on, its result waits
                    if store_fault(error) is None:
                        raise
                    self.store.outage.failed(error)
                continue
            except (BrokenProcessPool, CancelledError):
                if self._stop.is_set():
                    return  # the process was ended by stop(): the lease hands the job on
                # the analysis process died (killed, out of memory): transient
                self._failed(job, "the analysis process died (killed, or out of memory)", permanent=False)
                with self._lock:
                    self._fresh_pool()
                return
            except Exception as error:  # the input's fault is permanent, any other transient
                permanent = input_fault(error)
                said = str(error).replace(row.path, row.filename)  # the reader names the file: as uploaded
                if not permanent:
                    said = f"the analysis failed unexpectedly ({type(error).__name__}: {said})"
                self._failed(job, said, permanent=permanent)
                return
            stored = self._stored(partial(self.store.complete, plot=plot), job, documents)
            _log_state(job, "done" if stored else "taken back")
            return

    def _failed(self, job: Job, reason: str, *, permanent: bool) -> None:
        state = self._stored(partial(self.store.fail, permanent=permanent, backoff=self.backoff), job, reason)
        _log_state(job, state, reason=reason, kind="permanent" if permanent else "transient")


def _log_state(job: Job, state: str, **fields: str) -> None:
    """One log line per change of a job's state, as ``key=value`` fields (values quoted)."""
    extra = " ".join(f"{key}={value!r}" for key, value in fields.items())
    log.info(
        "job=%d recording=%d attempt=%d state=%s%s",
        job.id,
        job.recording_id,
        job.attempts,
        state,
        f" {extra}" if extra else "",
    )
