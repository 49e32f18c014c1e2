"""Where the time of a long computation goes: seconds per stage, for the benchmarks and the curious.

A :class:`StageClock` is handed down through a computation; each stage adds the
wall time it took.  Stages that run in several threads at once add each
thread's time, so the sum over stages can exceed the wall time of the whole.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Iterator
from contextlib import contextmanager

__all__ = ["StageClock", "stage"]


class StageClock:
    """Seconds spent per stage, summed over the threads that ran it."""

    def __init__(self) -> None:
        self.seconds: dict[str, float] = {}
        self._lock = threading.Lock()

    def add(self, name: str, seconds: float) -> None:
        """Add ``seconds`` to the stage ``name``."""
        with self._lock:
            self.seconds[name] = self.seconds.get(name, 0.0) + seconds

    @contextmanager
    def stage(self, name: str) -> Iterator[None]:
        """Time the block as (part of) the stage ``name``."""
        start = time.perf_counter()
        try:
            yield
        finally:
            self.add(name, time.perf_counter() - start)


@contextmanager
def stage(clock: StageClock | None, name: str) -> Iterator[None]:
    """``clock.stage(name)``, or nothing when there is no clock.

    Parameters
    ----------
    clock : StageClock or None
    name : str
        The stage.
    """
    if clock is None:
        yield
        return
    with clock.stage(name):
        yield
