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

Engines come from the fleet's descriptions in the store, else the bundled
ones; baselines (``--baseline B.json``, one per engine) make the bearing
comparisons.

The summary covers the run's scope (the files under ``PATH``, or the store's
recordings since ``DATE``): each file with its diagnosis, made by this run
or found already made, or with why it has none. A file is reported under its
own name, with its recording's id: copies of one content share the id and the
result, each under its name (with ``--since``, a recording is reported under
every name it was stored under). Its exit status, as
``compare``'s, is the worst over the scope: 0 healthy, 1 warning, 2 alarm, 3
inconclusive or not diagnosed (a job that failed or was set aside, a file that
is not a readable recording). A run again on the same scope says the same.

With a data folder, each diagnosis plot is kept in its ``plots/`` folder,
named after its recording's file (:func:`plot_names`), for people browsing the
folder; the store records that file with the diagnosis, and a plot is found by
the recording's id through the store (:meth:`monitor.store.Store.plot`), never
by a name.
"""

from __future__ import annotations

import hashlib
import os
import re
import time
from collections import Counter, defaultdict
from collections.abc import Callable, Iterable, Iterator
from concurrent.futures import FIRST_COMPLETED, Executor, Future, wait
from contextlib import contextmanager
from dataclasses import dataclass, field, replace
from datetime import datetime, timedelta
from pathlib import Path, PurePath
from typing import Any

from monitor.errors import MonitorError
from monitor.jobs.delivery import DeliveryPolicy, deliver_due
from monitor.runtime.processes import analysis_pool
from monitor.store import Job, Store

__all__ = [
    "EXIT_STATUS",
    "RECORDING_SUFFIXES",
    "BatchSummary",
    "RecordingOutcome",
    "content_hash",
    "diagnose_file",
    "plot_names",
    "recording_plot",
    "register",
    "run_batch",
]

RECORDING_SUFFIXES = (".h5", ".hdf5", ".mcap")
DIAGNOSIS = "diagnosis"  # the kind of result a job writes


PLOTS = "plots"  # the data folder's folder of diagnosis plots
PLOT_STEM_CHARACTERS = 120  # a plot's name keeps this much of its recording's stem


def _safe_stem(filename: str) -> str:
    """A file name's stem as a plot's name may hold it: ASCII letters, digits, ``.``, ``_`` and ``-``
    (any other character becomes ``_``), not hidden, at most :data:`PLOT_STEM_CHARACTERS` long."""
    stem = re.sub(r"[^A-Za-z0-9._-]", "_", PurePath(filename).stem)[:PLOT_STEM_CHARACTERS]
    return "_" + stem[1:] if stem.startswith(".") else stem or "recording"


def plot_names(recordings: Iterable[tuple[int, str]]) -> dict[int, str]:
    """The diagnosis plots' file names of recordings, named after their files' stems.

    A recording's plot is named ``STEM-vVERSION.png`` (the analysis version) when no recording of
    a lower id has the same stem, else ``STEM+ID-vVERSION.png``. Stems are compared as a
    case-insensitive file system would, after the characters a plot's name leaves out are replaced.
    ``+`` is one of those, so an id added to a stem can never make another recording's name: the names
    never collide. A recording's name depends only on the recordings registered before it, so it is
    the same on every run.

    Parameters
    ----------
    recordings : iterable of (int, str)
        Every recording whose plot shares the folder: its id in the store and its file name (as
        registered).

    Returns
    -------
    dict of int to str
        The plot's file name, by recording id.
    """
    from monitor.diagnosis import ANALYSIS_VERSION

    listed = sorted(recordings)
    first: dict[str, int] = {}
    for recording_id, filename in listed:
        first.setdefault(_safe_stem(filename).casefold(), recording_id)
    names = {}
    for recording_id, filename in listed:
        stem = _safe_stem(filename)
        if first[stem.casefold()] != recording_id:
            stem = f"{stem}+{recording_id}"
        names[recording_id] = f"{stem}-v{ANALYSIS_VERSION}.png"
    return names


def _plot_files(store: Store) -> dict[int, str]:
    """The plot file of every recording in the store (of every fleet: they share the data folder),
    relative to the data folder, by recording id (:func:`plot_names`)."""
    return {i: f"{PLOTS}/{name}" for i, name in plot_names(store.registered_filenames()).items()}


def recording_plot(store: Store, recording_id: int) -> str:
    """Where a recording's diagnosis plot is to be kept, relative to the data folder: ``plots/NAME``,
    named after the recording's file (:func:`plot_names`).

    The batch and the service's worker write the plot there and record it with the diagnosis
    (:meth:`monitor.store.Store.complete`); a reader finds it through the store
    (:meth:`monitor.store.Store.plot`), never by this name.

    Parameters
    ----------
    store : Store
        The store the recording is registered in.
    recording_id : int
        The recording's id in the store.

    Raises
    ------
    MonitorError
        If no recording has that id.
    """
    files = _plot_files(store)
    if recording_id not in files:
        raise MonitorError(f"recording {recording_id}: no such recording in the store")
    return files[recording_id]


def content_hash(path: str | Path) -> str:
    """SHA-256 of a file's bytes (hex), read in 1 MiB blocks.

    Parameters
    ----------
    path : str or Path

    Returns
    -------
    str
    """
    digest = hashlib.sha256()
    with open(path, "rb") as fh:
        for block in iter(lambda: fh.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


def register(store: Store, fleet_id: int, path: Path) -> tuple[int, bool]:
    """Register a recording file in the store: ``(recording id, created)``.

    Parameters
    ----------
    store : Store
    fleet_id : int
    path : Path
        A recording (HDF5 or MCAP); its engine and start time are read from it.

    Raises
    ------
    MonitorError
        If the file is not a recording the product can read.
    """
    recording_id, created, _ = _register(store, fleet_id, path)
    return recording_id, created


def _register(store: Store, fleet_id: int, path: Path) -> tuple[int, bool, bool]:
    """:func:`register`, and whether the file was cut short (an MCAP file read to its last whole chunk)."""
    from monitor.io import open_recording

    with open_recording(path) as recording:
        engine_id, recorded_at, truncated = recording.engine_id, recording.start_time, recording.truncated
    row, created = store.add_recording(
        fleet_id,
        content_hash=content_hash(path),
        engine_id=engine_id,
        filename=path.name,
        path=str(path.resolve()),
        size_bytes=path.stat().st_size,
        recorded_at=recorded_at,
    )
    return row.id, created, truncated


def recording_engine(recording: Any, engine_description: dict[str, Any] | None) -> Any:
    """The engine a recording names: the fleet's description of it, else the bundled one.

    Parameters
    ----------
    recording : Recording
    engine_description : dict or None
        The fleet's engine file content (from the store), if it has one.

    Returns
    -------
    Engine

    Raises
    ------
    DiagnosisError
        When the fleet has no description and no bundled engine has that id.
    """
    from monitor.errors import DiagnosisError
    from monitor.model.engine import bundled_engines, load_engine, parse_engine

    if engine_description is not None:
        return parse_engine(engine_description, origin=f"engine {recording.engine_id} of the store")
    if recording.engine_id in bundled_engines():
        return load_engine(bundled_engines()[recording.engine_id])
    raise DiagnosisError(
        f"engine {recording.engine_id!r} is neither in the fleet's engines nor bundled: add its description"
    )


def diagnose_file(
    path: str,
    engine_description: dict[str, Any] | None,
    baseline_document: dict[str, Any] | None,
    plot: str | None = None,
    name: str | None = None,
) -> dict[str, tuple[str, dict[str, Any]]]:
    """Diagnose one recording file (run in a worker process).

    Returns the result documents by kind: ``"diagnosis"`` (the ``compare --json`` document) and
    ``"spectrum"`` (the measured order spectra of every channel), each with the status. With
    ``plot``, the diagnosis plot is also written there as PNG (through a temporary file).

    Parameters
    ----------
    path : str
        The recording file.
    engine_description : dict or None
        The engine file's content (a fleet's description from the store); None: the bundled engine.
    baseline_document : dict or None
        A baseline (``engine-monitor calibrate``) for the bearing comparisons.
    plot : str, optional
        Where to write the diagnosis plot (PNG).
    name : str, optional
        The recording's name in the documents (default: the file's).
    """

    from monitor.diagnosis import Baseline, diagnose
    from monitor.io import open_recording
    from monitor.report.diagnosis import diagnosis_document, spectrum_document

    with open_recording(path) as recording:
        engine = recording_engine(recording, engine_description)
        baseline = Baseline.from_document(baseline_document) if baseline_document is not None else None
        diagnosis = diagnose(recording, engine, baseline=baseline)
    name = name or Path(path).name
    spectrum = spectrum_document(diagnosis, recording=name)
    if plot is not None:
        from monitor.report.plots import plot_diagnosis

        target = Path(plot)
        partial = target.with_name(target.stem + ".partial.png")
        plot_diagnosis(diagnosis, partial, title=f"{name}: {engine.id} at {diagnosis.speed_rpm:.1f} rpm")
        partial.replace(target)
    return {
        DIAGNOSIS: (diagnosis.status, diagnosis_document(diagnosis, recording=name)),
        "spectrum": (diagnosis.status, spectrum),
    }


EXIT_STATUS = {"healthy": 0, "warning": 1, "alarm": 2, "inconclusive": 3}
"""The exit status of each diagnosis status, as ``compare``'s; anything not diagnosed counts 3."""

NOT_DIAGNOSED = 3  # a failed or set-aside job, an unreadable file: the batch could not diagnose it


@dataclass(frozen=True)
class RecordingOutcome:
    """Where one file of a batch's scope stands once the run is over: its recording's.

    Attributes
    ----------
    id : int
        The recording's id in the store (files of one content share it, and all that follows but
        ``filename`` and ``path``).
    filename : str
        The file's own name, as given to the run (with ``--since``: one of the names the recording
        was stored under).
    engine_id : str
    recorded_at : str
        When it was recorded (ISO 8601, as the recording says; "" when it does not).
    status : str
        The diagnosis' status ("healthy", "warning", "alarm", "inconclusive"), else the job's state:
        "failed" (to be retried by the next run), "set_aside" (failed too often), or "running"
        (another run still holds it).
    diagnosed : str
        Who diagnosed it: "this run", "another run" (while this one waited for it), "before" (an
        earlier run or the service); "" when it is not diagnosed.
    findings : list of dict
        The diagnosis' findings: kind, subject, severity, summary.
    error : str
        Why its job failed ("" when it did not).
    plot : str
        The diagnosis plot's path, when one is kept ("" otherwise).
    truncated : bool
        Whether the file was cut short (diagnosed on what it holds).
    path : str
        The file's path as given to the run ("" with ``--since``).
    """

    id: int
    filename: str
    engine_id: str
    recorded_at: str
    status: str
    diagnosed: str = ""
    findings: list[dict[str, str]] = field(default_factory=list)
    error: str = ""
    plot: str = ""
    truncated: bool = False
    path: str = ""

    @property
    def exit_status(self) -> int:
        """0 healthy, 1 warning, 2 alarm, 3 inconclusive or not diagnosed."""
        return EXIT_STATUS.get(self.status, NOT_DIAGNOSED)

    def document(self) -> dict[str, Any]:
        """The recording's entry in ``batch --json``."""
        return {
            "id": self.id,
            "file": self.filename,
            "path": self.path or None,
            "engine_id": self.engine_id,
            "recorded_at": self.recorded_at or None,
            "status": self.status,
            "diagnosed": self.diagnosed or None,
            "findings": self.findings,
            "error": self.error or None,
            "plot": self.plot or None,
            "truncated": self.truncated,
        }


@dataclass
class BatchSummary:
    """What a batch run did.

    Attributes
    ----------
    registered, known : int
        Recording files newly registered, and already in the store.
    unreadable : list of (str, str)
        Files that are not readable recordings, with the reason (one line).
    truncated : list of str
        Files cut short, read to their last whole chunk: diagnosed on what they hold.
    diagnosed : int
        Jobs completed in this run.
    failed : list of (str, str, str)
        Jobs that failed: the recording's names in the scope (:func:`_joined`), reason, new state
        ("queued" to retry, "set_aside").
    requeued : int
        Jobs an earlier, interrupted run had left running, taken back and run by this one.
    held : int
        Jobs another run (a batch, a worker) was running when this one started; this run waited for
        them: they finished there (``finished_elsewhere``), or that run died and they were taken back.
    finished_elsewhere : int
        Of the held jobs, those the other run finished (done, or set aside).
    waited_s : float
        How long this run waited for held jobs after its own [s].
    by_engine : dict of str to Counter
        Per engine, the statuses of the diagnoses of this run.
    findings : dict of str to list of str
        Per engine, the findings' summaries of this run (prefixed with the recording's names).
    recordings : list of RecordingOutcome
        Every file of the run's scope, as its recording stands once the run is over, diagnosed in
        this run or before it: files of one content share a recording, each under its own name.
    """

    registered: int = 0
    known: int = 0
    unreadable: list[tuple[str, str]] = field(default_factory=list)
    truncated: list[str] = field(default_factory=list)
    diagnosed: int = 0
    failed: list[tuple[str, str, str]] = field(default_factory=list)
    requeued: int = 0
    held: int = 0
    finished_elsewhere: int = 0
    waited_s: float = 0.0
    by_engine: dict[str, Counter[str]] = field(default_factory=lambda: defaultdict(Counter))
    findings: dict[str, list[str]] = field(default_factory=lambda: defaultdict(list))
    recordings: list[RecordingOutcome] = field(default_factory=list)

    @property
    def exit_status(self) -> int:
        """The worst over the scope: each recording's (:attr:`RecordingOutcome.exit_status`), diagnosed
        in this run or before it, and 3 for an unreadable file; 0 for an empty scope."""
        worst = max((r.exit_status for r in self.recordings), default=0)
        return max(worst, NOT_DIAGNOSED) if self.unreadable else worst

    def by_recording(self) -> dict[int, list[RecordingOutcome]]:
        """The scope's files by recording (files of one content share one), in the order given."""
        files: dict[int, list[RecordingOutcome]] = {}
        for outcome in self.recordings:
            files.setdefault(outcome.id, []).append(outcome)
        return files

    def text(self) -> str:
        """The summary for people: per engine, counts by status and the findings, each recording under
        the names its files were given."""
        files = self.by_recording()
        names = {i: _joined(r.filename for r in outcomes) for i, outcomes in files.items()}
        lines = [
            f"batch: {self.registered} recording(s) registered, {self.known} already known, "
            f"{self.diagnosed} diagnosed, {len(self.failed)} failed"
            + (f", {len(self.unreadable)} unreadable" if self.unreadable else "")
            + (f", {self.requeued} resumed from an interrupted run" if self.requeued else "")
        ]
        if self.held:
            lines.append(
                f"  {self.held} job(s) were running in another process when this run started: "
                f"{self.finished_elsewhere} finished there, {self.held - self.finished_elsewhere} taken "
                f"back and run here (waited {self.waited_s:.0f} s)"
            )
        for engine_id in sorted(self.by_engine):
            counts = self.by_engine[engine_id]
            status = ", ".join(f"{counts[s]} {s}" for s in EXIT_STATUS if counts[s])
            lines.append(f"  {engine_id}: {status}")
            lines += [f"    {line}" for line in self.findings.get(engine_id, [])]
        before = [outcomes[0] for outcomes in files.values() if outcomes[0].diagnosed == "before"]
        if before:
            counts = Counter(r.status for r in before)
            lines.append(
                f"  diagnosed before this run: {len(before)} ("
                + ", ".join(f"{counts[s]} {s}" for s in EXIT_STATUS if counts[s])
                + ")"
            )
            lines += [f"    {names[r.id]}: {f['summary']}" for r in before for f in r.findings]
        for recording_id, outcomes in files.items():
            if len(outcomes) > 1:
                lines.append(
                    f"  one content, {len(outcomes)} files: {names[recording_id]} (recording {recording_id})"
                )
        for name, reason in self.unreadable:
            lines.append(f"  not a readable recording: {name}: {reason}")
        for name in self.truncated:
            lines.append(f"  cut short, read to its last whole chunk: {name}")
        for name, reason, state in self.failed:
            again = "set aside (too many attempts)" if state == "set_aside" else "will be retried"
            lines.append(f"  failed: {name}: {reason} ({again})")
        failed_now = {name for name, _, _ in self.failed}
        for outcomes in files.values():  # jobs set aside by an earlier run, left alone by this one
            r = outcomes[0]
            if r.status not in EXIT_STATUS and names[r.id] not in failed_now:
                lines.append(f"  not diagnosed ({r.status.replace('_', ' ')}): {names[r.id]}: {r.error}")
        lines.append(
            f"exit status {self.exit_status}: the worst over {len(files)} recording(s) in scope"
            + (f" ({len(self.recordings)} files)" if len(self.recordings) != len(files) else "")
            + (f" and {len(self.unreadable)} unreadable file(s)" if self.unreadable else "")
            + " (0 healthy, 1 warning, 2 alarm, 3 inconclusive or not diagnosed)"
        )
        return "\n".join(lines)

    def document(self) -> dict[str, Any]:
        """The summary for programs (``batch --json``, described in docs/service.md)."""
        from monitor.diagnosis import ANALYSIS_VERSION

        return {
            "analysis_version": ANALYSIS_VERSION,
            "exit_status": self.exit_status,
            "totals": {
                "registered": self.registered,
                "known": self.known,
                "diagnosed": self.diagnosed,
                "failed": len(self.failed),
                "unreadable": len(self.unreadable),
                "truncated": len(self.truncated),
                "requeued": self.requeued,
                "held": self.held,
                "finished_elsewhere": self.finished_elsewhere,
                "waited_s": self.waited_s,
                "by_engine": {e: dict(self.by_engine[e]) for e in sorted(self.by_engine)},
                "by_status": dict(Counter(outcomes[0].status for outcomes in self.by_recording().values())),
            },
            "recordings": [r.document() for r in self.recordings],
            "unreadable": [{"file": name, "error": reason} for name, reason in self.unreadable],
        }


def _joined(names: Iterable[str]) -> str:
    """A recording's names in a summary line: each once, in the order given, joined by commas."""
    return ", ".join(dict.fromkeys(names))


def _one_line(reason: str) -> str:
    """A reason on one line, for the summary and the store."""
    return " ".join(reason.split())


def _files(root: Path) -> list[Path]:
    if root.is_file():
        return [root]
    if not root.is_dir():
        raise MonitorError(f"{root}: no such file or folder")
    return sorted(p for p in root.rglob("*") if p.is_file() and p.suffix.lower() in RECORDING_SUFFIXES)


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
    from monitor.diagnosis import ANALYSIS_VERSION

    summary = BatchSummary()
    given: list[tuple[int, str, str]] = []  # each file in scope: its recording's id, its name, its path
    cut_short: set[int] = set()
    if path is not None:
        for file in _files(path):
            try:
                recording_id, created, truncated = _register(store, fleet_id, file)
            except (MonitorError, OSError) as error:
                summary.unreadable.append((file.name, _one_line(str(error))))
                continue
            except Exception as error:  # a reader's failure on one file is recorded, never fatal to the batch
                summary.unreadable.append((file.name, _one_line(f"{type(error).__name__}: {error}")))
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
    plots = _plot_files(store) if data_dir is not None else {}
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
    from monitor.diagnosis import ANALYSIS_VERSION

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
    from monitor.diagnosis import ANALYSIS_VERSION

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
                    _joined(self.names.get(row.id, [row.filename])),
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
                    reason = _one_line(f"{type(error).__name__}: {error}")
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
