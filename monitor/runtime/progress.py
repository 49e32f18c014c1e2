"""Progress bars with an estimate of the time left, on a terminal only.

Work that can take more than a couple of seconds (the spectra of a long
recording, a simulation, a batch, a torsion chart) reports how far it has
come through a plain callable, ``report(done)``, so that the computing code
knows nothing of terminals.  :func:`progress_bar` turns such reports into a
bar drawn by tqdm on standard error when, and only when, that is a terminal:
a log file, a pipe or a service's output gets nothing.
"""

from __future__ import annotations

import sys
from collections.abc import Callable, Iterator
from contextlib import ExitStack, contextmanager
from typing import TextIO

__all__ = ["Report", "progress_bar", "progress_counter"]

Report = Callable[[float], None]
"""Told the amount of work done so far (in the unit the bar was opened with), from 0 to its total."""


@contextmanager
def progress_bar(
    total: float,
    description: str,
    *,
    unit: str = "it",
    stream: TextIO | None = None,
    redraw_s: float = 0.1,
    delay_s: float = 1.0,
) -> Iterator[Report]:
    """A bar from 0 to ``total`` with the time left, drawn while the block runs.

    Parameters
    ----------
    total : float
        The work to do [``unit``] (e.g. seconds of signal, recordings, chart rows).
    description : str
        What is being done, shown before the bar.
    unit : str
        The unit of ``total``, shown with the rate.
    stream : text stream, optional
        Where to draw (default standard error); nothing is drawn unless it is a terminal.
    redraw_s : float
        Least time between two redraws [s]: reports in between only move the count.
    delay_s : float
        The bar appears only once the work has run this long [s]: quick work shows none.

    Yields
    ------
    callable
        ``report(done)``: the amount done so far.  Reports that go backwards are ignored.
    """
    out = stream if stream is not None else sys.stderr
    if not _is_terminal(out):
        yield _ignore
        return
    from tqdm import tqdm  # only where a bar is drawn: tqdm costs an import otherwise unneeded

    with tqdm(
        total=total,
        desc=description,
        unit=unit,
        file=out,
        leave=False,
        dynamic_ncols=True,
        mininterval=redraw_s,
        miniters=1,
        delay=delay_s,
    ) as bar:

        def report(done: float) -> None:
            step = min(done, total) - bar.n
            if step > 0:
                bar.update(step)

        yield report


@contextmanager
def progress_counter(
    description: str,
    *,
    unit: str = "it",
    stream: TextIO | None = None,
    redraw_s: float = 0.1,
    delay_s: float = 1.0,
) -> Iterator[Callable[[float, float], None]]:
    """:func:`progress_bar` for work that learns its total only once it has started (a batch's jobs).

    Parameters
    ----------
    description : str
        What is being done, shown before the bar.
    unit : str
        The unit of the totals, shown with the rate.
    stream : text stream, optional
        Where to draw (default standard error); nothing is drawn unless it is a terminal.
    redraw_s : float
        Least time between two redraws [s].
    delay_s : float
        The bar appears only once the work has run this long [s].

    Yields
    ------
    callable
        ``report(done, total)``; the bar is opened at the first report, with that total.
    """
    with ExitStack() as stack:
        opened: list[Report] = []

        def report(done: float, total: float) -> None:
            if not opened:
                bar = progress_bar(
                    total, description, unit=unit, stream=stream, redraw_s=redraw_s, delay_s=delay_s
                )
                opened.append(stack.enter_context(bar))
            opened[0](done)

        yield report


def _is_terminal(stream: TextIO) -> bool:
    isatty = getattr(stream, "isatty", None)
    return bool(isatty and isatty())


def _ignore(done: float) -> None:
    """The report of work whose progress is not shown."""
