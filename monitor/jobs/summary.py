"""What a batch run did: each file of its scope as it stands once the run is over, and the summary.

The summary covers the run's scope (the files under ``PATH``, or the store's
recordings since ``DATE``): each file with its diagnosis, made by this run
or found already made, or with why it has none. Its exit status, as
``compare``'s, is the worst over the scope: 0 healthy, 1 warning, 2 alarm, 3
inconclusive or not diagnosed. ``batch --json`` is described in docs/service.md.
"""

from __future__ import annotations

from collections import Counter, defaultdict
from collections.abc import Iterable
from dataclasses import dataclass, field
from typing import Any

from monitor.diagnosis import ANALYSIS_VERSION
from monitor.jobs.analyse import EXIT_STATUS

__all__ = ["NOT_DIAGNOSED", "BatchSummary", "RecordingOutcome", "joined", "one_line"]

NOT_DIAGNOSED = 3  # a failed or set-aside job, an unreadable file: the batch could not diagnose it (counts 3)


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
        Jobs that failed: the recording's names in the scope (:func:`joined`), reason, new state
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
        names = {i: joined(r.filename for r in outcomes) for i, outcomes in files.items()}
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


def joined(names: Iterable[str]) -> str:
    """A recording's names in a summary line: each once, in the order given, joined by commas.

    Parameters
    ----------
    names : iterable of str

    Returns
    -------
    str
    """
    return ", ".join(dict.fromkeys(names))


def one_line(reason: str) -> str:
    """A reason on one line, for the summary and the store.

    Parameters
    ----------
    reason : str

    Returns
    -------
    str
    """
    return " ".join(reason.split())
