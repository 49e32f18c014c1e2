"""A recording cut to a span of time: the same channels, holding only what was recorded in it.

Times keep their origin, the recording's start: a waveform cut from sample ``i`` on starts at
``start_offset + i / rate``, an event channel keeps the event times inside the span. A channel
opened in a file (a :class:`~monitor.io.recording.SampleReader`) stays in the file: the cut reads
its slice of samples only when asked, and checks them as the whole channel's reader does.
"""

from __future__ import annotations

import dataclasses
import math
from typing import Any

import numpy as np

from monitor.errors import FormatError
from monitor.io.recording import Channel, QualitySpan, Recording, SampleReader

__all__ = ["between"]


class _Window(SampleReader):
    """Samples ``first`` to ``first + size`` of a channel held by another reader."""

    def __init__(self, whole: SampleReader, first: int, size: int, where: str, rate: float, offset: float):
        super().__init__(where, size, whole.dtype, rate, offset, whole.limits)
        self._whole = whole
        self._first = first

    def _read(self, start: int, stop: int) -> np.ndarray:
        return self._whole._read(self._first + start, self._first + stop)

    def _read_into(self, start: int, out: np.ndarray) -> None:
        self._whole._read_into(self._first + start, out)


def _cut(channel: Channel, start: float, stop: float) -> Channel:
    """One channel cut to ``[start, stop]`` [s]."""
    if channel.is_events:
        times = np.asarray(channel.data)
        inside = times[(times >= start) & (times <= stop)]
        return dataclasses.replace(channel, data=inside)
    rate = float(channel.sample_rate)  # type: ignore[arg-type]
    first = max(0, math.ceil((start - channel.start_offset) * rate - 1e-9))
    last = min(channel.data.size, math.floor((stop - channel.start_offset) * rate + 1e-9) + 1)
    last = max(last, first)
    offset = channel.start_offset + first / rate
    data: Any
    if isinstance(channel.data, SampleReader):
        data = _Window(channel.data, first, last - first, f"{channel.name} from {offset:.6g} s", rate, offset)
    else:
        data = channel.data[first:last]
    mask = channel.mask[first:last] if channel.mask is not None else None
    quality = []
    for q in channel.quality:
        if q.stop >= offset and q.start <= stop:
            a, b = max(q.start, offset), min(q.stop, stop)
            quality.append(QualitySpan(a, b, min(q.samples, round((b - a) * rate) + 1), q.reason))
    return dataclasses.replace(
        channel,
        data=data,
        start_offset=offset,
        mask=mask if mask is not None and mask.any() else None,
        quality=tuple(quality),
    )


def between(recording: Recording, start: float, stop: float) -> Recording:
    """The recording cut to the span ``[start, stop]`` of its time.

    Parameters
    ----------
    recording : Recording
    start, stop : float
        The span, from the recording's start [s].

    Returns
    -------
    Recording
        Its channels cut to the span (times from the recording's start, as before); its notes say
        the span.

    Raises
    ------
    FormatError
        For a span that is empty or not finite.
    """
    if not (math.isfinite(start) and math.isfinite(stop) and start < stop):
        raise FormatError(f"span {start!r} to {stop!r} s: expected finite times, start before stop")
    span = f"cut to {start:.3f}-{stop:.3f} s"
    return dataclasses.replace(
        recording,
        channels=tuple(_cut(c, start, stop) for c in recording.channels),
        notes=f"{recording.notes}; {span}" if recording.notes else span,
    )
