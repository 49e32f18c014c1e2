"""Plausible values of a recording's fields: the ranges outside which a value is a mistake.

A recording comes from outside, and a field can hold any number its type
allows. These are the ranges a real acquisition on an engine falls in, so
that a value outside them is refused at the boundary, by the readers, with
a message that names the field, the value and the range, rather than
stored and failing later in the analysis, or shown on a page:

- the recording's start time, from :data:`EARLIEST_START` (1980-01-01, before
  any digital acquisition this product reads) to :data:`AHEAD` (one day)
  past the clock of the machine that reads it: a recording dated in year
  9999 would stay an engine's latest for ever;
- a channel's start offset from the recording's start, and an event
  channel's times, within :data:`MAX_TIME` (one day) either side of it;
- a sample rate, from :data:`MIN_RATE` (a sample every 1000 s) to
  :data:`MAX_RATE` (10 MHz, past an acoustic-emission sensor's);
- names: see :mod:`monitor.names` (:data:`~monitor.names.MAX_NAME` characters).
"""

from __future__ import annotations

import math
from datetime import UTC, datetime, timedelta

__all__ = [
    "AHEAD",
    "EARLIEST_START",
    "MAX_RATE",
    "MAX_TIME",
    "MIN_RATE",
    "rate_problem",
    "start_problem",
    "time_problem",
]

#: The earliest start time of a recording.
EARLIEST_START = datetime(1980, 1, 1, tzinfo=UTC)
#: How far past the reading machine's clock a start time may be (clocks of ships and of servers differ).
AHEAD = timedelta(days=1)
#: The lowest and the highest sample rate [Hz].
MIN_RATE = 1e-3
MAX_RATE = 1e7
#: The most a channel's start offset or an event time may be from the recording's start, either side [s].
MAX_TIME = 86400.0


def start_problem(start: datetime, *, now: datetime | None = None) -> str | None:
    """What is implausible about a recording's start time, in words, or None.

    Parameters
    ----------
    start : datetime
        With its time zone.
    now : datetime, optional
        The clock's time (default: now).

    Returns
    -------
    str or None
    """
    latest = (now or datetime.now(UTC)) + AHEAD
    if start < EARLIEST_START or start > latest:
        return (
            f"expected a time from {EARLIEST_START:%Y-%m-%d} to a day past this machine's clock "
            f"({latest:%Y-%m-%dT%H:%M}Z)"
        )
    return None


def rate_problem(rate: float) -> str | None:
    """What is implausible about a sample rate, in words, or None.

    Parameters
    ----------
    rate : float
        [Hz].

    Returns
    -------
    str or None
    """
    if not (math.isfinite(rate) and MIN_RATE <= rate <= MAX_RATE):
        return f"expected a positive rate from {MIN_RATE:g} Hz to {MAX_RATE / 1e6:g} MHz"
    return None


def time_problem(time: float) -> str | None:
    """What is implausible about a time from the recording's start, in words, or None.

    Parameters
    ----------
    time : float
        A channel's start offset or an event's time [s].

    Returns
    -------
    str or None
    """
    if not (math.isfinite(time) and abs(time) <= MAX_TIME):
        return f"expected a time within {MAX_TIME:g} s (a day) of the recording's start"
    return None
