"""Reading a recording in the product's MCAP format: whole and streamed, or opened topic by topic.

:func:`read_mcap` streams the file record by record with CRC validation, which serves indexed and
unindexed files alike; a file cut short is read up to its last whole chunk, and the result says so
(``truncated``), unless the cut leaves a channel without samples, which is refused naming it.
:func:`open_mcap` reads an indexed file topic by topic, forward in time, in bounded memory (the
analysis of an hour-long recording).
"""

from __future__ import annotations

import contextlib
from collections import defaultdict
from collections.abc import Iterator
from pathlib import Path

import numpy as np
from mcap.reader import make_reader
from mcap.records import Channel as McapChannel
from mcap.records import Message, Metadata, Schema

from monitor.errors import FormatError
from monitor.io.mcap.metadata import (
    channel_from_metadata,
    check_metadata_crc,
    check_recording_metadata,
    checked_channel_metadata,
    cycle_phase,
    metadata_dtype,
    metadata_number,
)
from monitor.io.mcap.records import Chunked, bounded, checked_records, damage_named, summary_checked
from monitor.io.mcap.samples import McapSamples
from monitor.io.mcap.wire import EVENT_SCHEMA, FORMAT_NAME, SAMPLE_SCHEMA, decode_channel_block
from monitor.io.plausible import rate_problem
from monitor.io.recording import Channel, Recording
from monitor.io.signatures import MCAP_MAGIC, file_signature

__all__ = ["MIN_SAMPLES_LEFT", "open_mcap", "read_mcap"]


def read_mcap(path: str | Path) -> Recording:
    """Read and validate a recording written in the product's MCAP format.

    Parameters
    ----------
    path : str or Path

    Returns
    -------
    Recording
        ``truncated`` is True if the file was cut short (read to its last whole
        chunk); waveform channels come with their data-quality spans.

    Raises
    ------
    FormatError
        Naming the file or channel and the problem; for a file cut short, also
        when the cut leaves a channel without samples (fewer than
        :data:`MIN_SAMPLES_LEFT`) or before the recording's metadata.
    """
    source = Path(path)
    schemas: dict[int, str] = {}
    channels: dict[int, McapChannel] = {}
    blocks: dict[int, list[tuple[float, np.ndarray]]] = defaultdict(list)
    recording_meta: dict[str, str] | None = None
    truth = ""
    truncated = False
    metadata: dict[str, dict[str, str]] = {}
    unchunked: dict[int, McapChannel] = {}
    for record in checked_records(source, mark_chunked=True):
        if record is None:
            truncated = True
        elif isinstance(record, Schema):
            schemas[record.id] = record.name
        elif isinstance(record, Chunked) or isinstance(record, McapChannel):
            channel = record.channel if isinstance(record, Chunked) else record
            if schemas.get(channel.schema_id) not in (SAMPLE_SCHEMA, EVENT_SCHEMA):  # refused at once
                raise FormatError(
                    f"{source}: {'' if recording_meta else f'not an {FORMAT_NAME}: '}topic {channel.topic!r} "
                    f"has schema {schemas.get(channel.schema_id)!r}, not one of this format's"
                )
            # the copy inside a chunk is checksummed; one outside (the summary's) is not used
            (channels if isinstance(record, Chunked) else unchunked)[channel.id] = channel
        elif isinstance(record, Metadata):
            metadata[record.name] = dict(record.metadata)
            if record.name == "recording":
                recording_meta = metadata["recording"]
            elif record.name == "truth":
                truth = metadata["truth"].get("json", "")
        elif isinstance(record, Message):
            owner = channels.get(record.channel_id)
            if owner is not None:
                start, _, values = decode_channel_block(
                    f"{source}: channel {owner.topic.lstrip('/')!r}", record.data
                )
                blocks[record.channel_id].append((start, values))
    if recording_meta is None and truncated:
        raise FormatError(
            f"{source}: {_cut_short(source)} before any 'recording' metadata record: "
            f"not readable as an {FORMAT_NAME}"
        )
    check_recording_metadata(source, recording_meta)
    assert recording_meta is not None
    for channel_id, channel in unchunked.items():
        if channel_id not in channels:
            raise FormatError(
                f"{source}: channel {channel.topic.lstrip('/')!r} has its record outside any chunk, where "
                "no CRC covers its metadata; this format keeps channel records in the chunks"
            )
    check_metadata_crc(source, list(channels.values()), metadata)
    result = []
    for channel_id, channel in channels.items():
        result.append((channel, _assemble(source, channel, blocks.get(channel_id, []), truncated)))
    order = _listed_channels(source, recording_meta, [c.topic for c in channels.values()], truncated)
    result.sort(key=lambda item: order.index(item[1].name) if item[1].name in order else len(order))
    return Recording(
        engine_id=recording_meta["engine_id"],
        start_time=recording_meta["start_time"],
        notes=recording_meta.get("notes", ""),
        channels=tuple(c for _, c in result),
        truncated=truncated,
        truth=truth,
        cycle_phase_deg=cycle_phase(source, recording_meta),
    )


@contextlib.contextmanager
def open_mcap(path: str | Path) -> Iterator[Recording]:
    """Open a recording whose waveform channels are read by slices, topic by topic, CRCs checked.

    An indexed file (with its summary) is read through the official reader's
    index: each waveform channel's ``data`` is a :class:`McapSamples`, which
    decompresses only its own topic's chunks as the analysis moves forward
    in time, so an hour-long recording needs little memory. A file without a
    summary (unindexed, or cut short) is read whole by :func:`read_mcap`.

    Parameters
    ----------
    path : str or Path

    Yields
    ------
    Recording
        Valid while the context is open.

    Raises
    ------
    FormatError
        As :func:`read_mcap`; damage met later, while reading, names the channel.
    """
    source = Path(path)
    if file_signature(source) != MCAP_MAGIC:
        raise FormatError(f"{source}: not an MCAP file (no MCAP magic at its start)")
    summary = None
    with open(source, "rb") as fh, damage_named(str(source)):
        if summary_checked(fh, source):
            try:
                reader = make_reader(bounded(fh), validate_crcs=True)
                summary = reader.get_summary()
                metadata = {m.name: dict(m.metadata) for m in reader.iter_metadata()}
                recording_meta = metadata.get("recording")
            except Exception:  # no usable summary (unindexed, cut short): stream the whole file instead
                summary = None
    if summary is None or not summary.chunk_indexes:
        yield read_mcap(source)
        return
    check_recording_metadata(source, recording_meta)
    assert recording_meta is not None
    check_metadata_crc(source, list(summary.channels.values()), metadata)
    opened: list[McapSamples] = []
    try:
        channels = []
        for channel in summary.channels.values():
            schema = summary.schemas.get(channel.schema_id)
            if schema is None or schema.name not in (SAMPLE_SCHEMA, EVENT_SCHEMA):
                raise FormatError(
                    f"{source}: topic {channel.topic!r} has schema "
                    f"{schema.name if schema else None!r}, not one of this format's"
                )
            meta = checked_channel_metadata(source, channel)
            if meta["representation"] == "events":
                where = f"{source}: channel {channel.topic.lstrip('/')!r}"
                parts = [
                    decode_channel_block(where, m.data)[::2]
                    for m in McapSamples.messages(source, channel.topic)
                ]
                channels.append(_assemble(source, channel, [(p[0], p[1]) for p in parts], False))
                continue
            samples = McapSamples(source, channel.topic, meta)
            opened.append(samples)
            channels.append(channel_from_metadata(source, channel, meta, samples))
        order = _listed_channels(source, recording_meta, [c.topic for c in summary.channels.values()], False)
        channels.sort(key=lambda c: order.index(c.name) if c.name in order else len(order))
        yield Recording(
            engine_id=recording_meta["engine_id"],
            start_time=recording_meta["start_time"],
            notes=recording_meta.get("notes", ""),
            channels=tuple(channels),
            truth=metadata.get("truth", {}).get("json", ""),
            cycle_phase_deg=cycle_phase(source, recording_meta),
        )
    finally:
        for samples in opened:
            samples.close()


#: The fewest samples (events) a channel must keep when its file was cut short; fewer is refused.
MIN_SAMPLES_LEFT = 2


def _listed_channels(
    source: Path, recording_meta: dict[str, str], topics: list[str], truncated: bool
) -> list[str]:
    """The channel order of the 'recording' metadata, every channel of it checked to have its topic."""
    order = [name for name in recording_meta.get("channels", "").split(",") if name]
    present = {topic.lstrip("/") for topic in topics}
    for name in order:
        if name not in present:
            if truncated:
                raise FormatError(
                    f"{source}: channel {name!r}: {_cut_short(source)} before the channel's first "
                    "whole chunk: none of its samples can be read"
                )
            raise FormatError(
                f"{source}: channel {name!r} is listed in the 'recording' metadata but has no topic "
                f"'/{name}' in the file"
            )
    return order


def _assemble(
    source: Path, channel: McapChannel, parts: list[tuple[float, np.ndarray]], truncated: bool
) -> Channel:
    where = f"{source}: channel {channel.topic.lstrip('/')!r}"
    meta = checked_channel_metadata(source, channel)
    events = meta["representation"] == "events"
    rate = None if events else metadata_number(where, meta, "sample_rate_hz", float)
    parts.sort(key=lambda p: p[0])
    dtype = metadata_dtype(where, meta)
    data = np.concatenate([p[1] for p in parts]).astype(dtype, copy=False) if parts else np.empty(0, dtype)
    if rate is not None and parts:
        problem = rate_problem(rate)
        if problem is not None:
            raise FormatError(f"{where}: sample_rate_hz = {rate!r}: {problem}")
        expected = metadata_number(where, meta, "start_offset_s", float, 0.0)
        for start, values in parts:  # blocks must follow each other without gaps or overlaps
            if abs(start - expected) > 0.5 / rate:
                raise FormatError(
                    f"{where}: a block starts at {start:.9g} s, expected {expected:.9g} s "
                    "(missing or repeated block)"
                )
            expected = start + values.size / rate
    stated = metadata_number(where, meta, "samples", int, data.size)
    if truncated and data.size < min(MIN_SAMPLES_LEFT, stated):
        what = "events" if events else "samples"
        left = "none" if data.size == 0 else f"only {data.size}"
        raise FormatError(
            f"{where}: {_cut_short(source)}: {left} of its {stated} {what} before the cut, "
            f"fewer than the {MIN_SAMPLES_LEFT} a channel needs"
        )
    if data.size != stated and not (truncated and data.size < stated):
        raise FormatError(f"{where}: {data.size} samples in its blocks, but its metadata says {stated}")
    return channel_from_metadata(source, channel, meta, data).checked()


def _cut_short(source: Path) -> str:
    """What to say of a file that ends inside a record."""
    try:
        return f"the file was cut short ({source.stat().st_size} bytes)"
    except OSError:
        return "the file was cut short"
