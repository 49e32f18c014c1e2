"""A waveform channel of an indexed MCAP recording, read forward by slices (what :func:`open_mcap`
gives)."""

from __future__ import annotations

import threading
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
from mcap.reader import make_reader

from monitor.errors import FormatError
from monitor.io.mcap.metadata import metadata_dtype, metadata_number
from monitor.io.mcap.records import bounded, damage_named
from monitor.io.mcap.wire import decode_channel_block
from monitor.io.plausible import rate_problem
from monitor.io.recording import SampleReader

__all__ = ["McapSamples"]


class McapSamples(SampleReader):
    """A waveform channel of an indexed MCAP recording, read forward by slices and checked as read.

    Slices are served from a buffer that moves forward with them; a slice
    that starts before the buffer restarts the topic from its first block.
    Every block must start where the one before ended.

    Parameters
    ----------
    source : Path
        The MCAP file.
    topic : str
        The channel's topic.
    meta : dict of str to str
        The channel's MCAP metadata (sample rate, start offset, sample count, dtype, range).
    """

    def __init__(self, source: Path, topic: str, meta: dict[str, str]) -> None:
        where = f"{source}: channel {topic.lstrip('/')!r}"
        pulses = meta["kind"] in ("keyphasor", "tooth", "cam")  # pulse channels sit at their rails by design
        rate = metadata_number(where, meta, "sample_rate_hz", float)
        problem = rate_problem(rate)
        if problem is not None:
            raise FormatError(f"{where}: sample_rate_hz = {rate!r}: {problem}")
        super().__init__(
            where,
            metadata_number(where, meta, "samples", int),
            metadata_dtype(where, meta),
            rate,
            metadata_number(where, meta, "start_offset_s", float, 0.0),
            (
                metadata_number(where, meta, "range_min", float),
                metadata_number(where, meta, "range_max", float),
            )
            if "range_min" in meta and not pulses
            else None,
        )
        self._source = source
        self._topic = topic
        self._messages: Iterator[Any] | None = None
        self._buffer = np.empty(0, self._dtype)
        self._start = 0  # sample index of the buffer's first sample
        self._expected = 0  # sample index of the next block's first sample
        self._lock = threading.Lock()

    @staticmethod
    def messages(source: Path, topic: str) -> Iterator[Any]:
        """The messages of one topic in log-time order, CRCs checked, errors named."""
        with open(source, "rb") as fh, damage_named(f"{source}: channel {topic.lstrip('/')!r}"):
            for _, _, message in make_reader(bounded(fh), validate_crcs=True).iter_messages(topics=[topic]):
                yield message

    def close(self) -> None:
        """Stop reading (closes the file)."""
        if self._messages is not None:
            self._messages.close()  # type: ignore[attr-defined]
            self._messages = None

    def _next_block(self) -> np.ndarray:
        assert self._messages is not None
        message = next(self._messages, None)
        if message is None:
            raise FormatError(
                f"{self._where}: its blocks end after {self._expected} samples, but its metadata says "
                f"{self._size}"
            )
        start, _, values = decode_channel_block(self._where, message.data)
        if abs(start - (self._offset + self._expected / self._rate)) > 0.5 / self._rate:
            raise FormatError(
                f"{self._where}: a block starts at {start:.9g} s, expected "
                f"{self._offset + self._expected / self._rate:.9g} s (missing or repeated block)"
            )
        self._expected += values.size
        return values.astype(self._dtype, copy=False)

    def _read(self, start: int, stop: int) -> np.ndarray:
        with self._lock:  # one reader of the topic, whichever thread asks
            return self._slice(start, stop)

    def _slice(self, a: int, b: int) -> np.ndarray:
        b = max(a, b)
        if self._messages is None or a < self._start:
            self.close()
            self._messages = self.messages(self._source, self._topic)
            self._buffer, self._start, self._expected = np.empty(0, self._dtype), 0, 0
        pieces = [self._buffer[max(0, a - self._start) :]]
        held = self._start + self._buffer.size
        while held < b:
            block = self._next_block()
            if held + block.size > a:
                pieces.append(block[max(0, a - held) :])
            held += block.size
        self._buffer = np.concatenate(pieces) if len(pieces) > 1 else pieces[0]  # from sample a on
        self._start = a
        return self._buffer[: b - a]
