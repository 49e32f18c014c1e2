"""The service's worker stopped while an analysis runs (monitor.jobs.worker.Worker.stop): the server's
SIGTERM while a job was just submitted, or mid-analysis. The pool is ended by the caller: its process,
its manager thread and the named semaphores of its queues are gone when ``stop`` returns. (Left to the
pool's manager thread, a daemon thread, the semaphores' release raced the interpreter's exit, and the
resource tracker sometimes reported one as leaked: tests/api/test_service_surface.py's flake.)"""

from __future__ import annotations

import shutil
import time
from concurrent.futures.process import _threads_wakeups  # the live pools' manager threads
from datetime import timedelta
from multiprocessing import util
from multiprocessing.synchronize import SemLock
from pathlib import Path
from typing import Any

import pytest

from monitor.diagnosis import ANALYSIS_VERSION
from monitor.jobs import worker as worker_module
from monitor.jobs.registration import register
from monitor.jobs.worker import Worker
from monitor.store import open_store

ROOT = Path(__file__).resolve().parents[2]
RECORDING = ROOT / "recordings" / "samples" / "7k98mc-misfire-cyl4.h5"
STOP_S = 10.0  # stop() may wait a heartbeat's look (0.5 s) and the process's end, never the analysis


def _slow_analysis(*args: Any) -> dict[str, Any]:
    """An analysis process's work that outlasts the test: says it began (beside the plot it was given)."""
    Path(args[3]).with_name("began").touch()
    time.sleep(600)
    return {}


def _semaphores() -> set[str]:
    """The named semaphores this process has yet to unlink (and unregister from the resource tracker)."""
    return {
        f._args[0]
        for f in list(util._finalizer_registry.values())  # type: ignore[attr-defined]
        if f._callback is SemLock._cleanup  # type: ignore[attr-defined]
    }


@pytest.mark.parametrize("moment", ["submitted", "mid-analysis"])
def test_a_worker_stopped_while_analysing_ends_its_pool_and_releases_its_semaphores(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, moment: str
) -> None:
    """``stop`` right after the job is taken (its submission racing the stop) or once its process runs
    it: within :data:`STOP_S` (the process is ended, not awaited), the pool's manager thread has ended
    and every semaphore its queues made is released, and the job stays running for the lease to hand
    on."""
    monkeypatch.setattr(worker_module, "analyse", _slow_analysis)
    data = tmp_path / "data"
    (data / "recordings").mkdir(parents=True)
    store = open_store(f"sqlite:///{tmp_path / 'store.db'}")
    fleet = store.create_fleet("a")
    recording, _ = register(store, fleet, Path(shutil.copy(RECORDING, data / "recordings")))
    store.enqueue(recording, ANALYSIS_VERSION)
    before = _semaphores()
    worker = Worker(store, data, 1, lease=timedelta(seconds=30))
    try:
        worker.start()
        assert _semaphores() > before  # the pool's queues
        deadline = time.monotonic() + 60
        while (job := store.job(recording, ANALYSIS_VERSION)) is None or job.state != "running":
            assert time.monotonic() < deadline, "the job was not taken"
            time.sleep(0.01)
        while moment == "mid-analysis" and not (data / "plots" / "began").exists():
            assert time.monotonic() < deadline, "the analysis process did not begin"
            time.sleep(0.05)
        start = time.monotonic()
        worker.stop()
        took = time.monotonic() - start
        assert took < STOP_S, took
        assert [t for t in list(_threads_wakeups) if t.is_alive()] == []
        assert _semaphores() == before
        job = store.job(recording, ANALYSIS_VERSION)
        assert job is not None and job.state == "running"
    finally:
        worker.stop()
        store.close()
