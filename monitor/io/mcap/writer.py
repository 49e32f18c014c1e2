"""Writing a recording to the product's MCAP format, whole or not at all."""

from __future__ import annotations

import calendar
import contextlib
import os
import tempfile
from datetime import datetime
from pathlib import Path
from typing import Literal

import numpy as np
from mcap.writer import CompressionType, Writer

from monitor import __version__
from monitor.errors import FormatError
from monitor.io.files import in_existing_folder, publish
from monitor.io.mcap.metadata import METADATA_CRC, channel_metadata, metadata_crc32
from monitor.io.mcap.wire import (
    EVENT_SCHEMA,
    FORMAT_NAME,
    FORMAT_VERSION,
    SAMPLE_SCHEMA,
    encode_event_block,
    encode_sample_block,
    schema_descriptor_set,
)
from monitor.io.recording import Channel, Recording

__all__ = ["write_mcap"]


def write_mcap(
    recording: Recording,
    path: str | Path,
    *,
    block_seconds: float = 0.1,
    compression: Literal["zstd", "lz4", "none"] = "zstd",
    chunk_size: int = 4 * 1024 * 1024,
) -> Path:
    """Write a recording to MCAP, whole or not at all (temporary file, fsync, atomic rename).

    Parameters
    ----------
    recording : Recording
    path : str or Path
        Output file (.mcap).
    block_seconds : float, optional
        Length of one sample block (one message) [s].
    compression : {"zstd", "lz4", "none"}
        Chunk compression.
    chunk_size : int, optional
        Target uncompressed chunk size [bytes]. Each chunk holds one channel: a
        window of about this size of it, the windows of all channels in turn.

    Returns
    -------
    Path

    Raises
    ------
    FormatError
        For a waveform that is neither float32 nor float64.
    OutputFolderError
        If the file's folder does not exist (none is created).
    """
    for c in recording.channels:
        if not c.is_events and c.data.dtype not in (np.float32, np.float64):
            raise FormatError(
                f"channel {c.name!r}: MCAP stores float32 or float64 samples, not {c.data.dtype}"
            )
    start_ns = _start_ns(recording.start_time)
    target = in_existing_folder(path)
    handle, temporary = tempfile.mkstemp(prefix=f".{target.name}.", suffix=".tmp", dir=target.parent)
    os.close(handle)
    kinds = {"zstd": CompressionType.ZSTD, "lz4": CompressionType.LZ4, "none": CompressionType.NONE}
    try:
        with open(temporary, "wb") as fh:
            writer = Writer(fh, chunk_size=chunk_size, compression=kinds[compression])
            writer.start(profile="", library=f"engine-monitor {__version__}")
            descriptor = schema_descriptor_set()
            schemas = {
                name: writer.register_schema(name=name, encoding="protobuf", data=descriptor)
                for name in (SAMPLE_SCHEMA, EVENT_SCHEMA)
            }
            metadata = {
                "recording": {
                    "format": FORMAT_NAME,
                    "format_version": str(FORMAT_VERSION),
                    "engine_id": recording.engine_id,
                    "start_time": recording.start_time,
                    "notes": recording.notes,
                    "channels": ",".join(c.name for c in recording.channels),
                    **(
                        {"cycle_phase_deg": repr(float(recording.cycle_phase_deg))}
                        if recording.cycle_phase_deg is not None
                        else {}
                    ),
                },
                **({"truth": {"json": recording.truth}} if recording.truth else {}),
            }
            for name, entries in metadata.items():
                writer.add_metadata(name, entries)
            checksum = {METADATA_CRC: str(metadata_crc32(metadata))}
            blocks = []
            for order, c in enumerate(recording.channels):
                channel_id = writer.register_channel(
                    topic=f"/{c.name}",
                    message_encoding="protobuf",
                    schema_id=schemas[EVENT_SCHEMA if c.is_events else SAMPLE_SCHEMA],
                    metadata={**channel_metadata(c), **checksum},
                )
                blocks.extend(_blocks(c, channel_id, order, block_seconds, start_ns))
            # one channel per chunk, a window of about chunk_size bytes of it: a reader of one topic
            # decompresses that topic's chunks only
            rates = [
                c.data.dtype.itemsize * float(c.sample_rate or 0)
                for c in recording.channels
                if not c.is_events
            ]
            window_ns = max(block_seconds, chunk_size / max(rates, default=1.0)) * 1e9
            blocks.sort(key=lambda b: (int((b[0] - start_ns) // window_ns), b[1], b[0]))
            group = None
            for sequence, (time_ns, order, channel_id, payload) in enumerate(blocks):
                if (int((time_ns - start_ns) // window_ns), order) != group:
                    writer.flush()  # finishes the chunk in progress, if any
                    group = (int((time_ns - start_ns) // window_ns), order)
                writer.add_message(
                    channel_id=channel_id,
                    log_time=time_ns,
                    publish_time=time_ns,
                    data=payload(),
                    sequence=sequence,
                )
            writer.finish()
            fh.flush()
            os.fsync(fh.fileno())
        publish(temporary, target)
    except BaseException:
        with contextlib.suppress(FileNotFoundError):
            os.unlink(temporary)
        raise
    return target


def _start_ns(start_time: str) -> int:
    """UTC start time in integer nanoseconds since the Unix epoch (exact to the microsecond)."""
    moment = datetime.fromisoformat(start_time.replace("Z", "+00:00"))
    return calendar.timegm(moment.utctimetuple()) * 1_000_000_000 + moment.microsecond * 1000


def _blocks(c: Channel, channel_id: int, order: int, block_seconds: float, start_ns: int):  # type: ignore[no-untyped-def]
    if c.is_events:
        per_block = 4096
        for i in range(0, max(c.data.size, 1), per_block):
            part = np.asarray(c.data[i : i + per_block], dtype=np.float64)
            t = part[0] if part.size else c.start_offset
            yield (
                start_ns + round(float(t) * 1e9),
                order,
                channel_id,
                lambda part=part, t=t: encode_event_block(start_ns + round(float(t) * 1e9), part),
            )
        return
    rate = float(c.sample_rate)  # type: ignore[arg-type]
    per_block = max(1, round(block_seconds * rate))
    for i in range(0, max(c.data.size, 1), per_block):
        offset = c.start_offset + i / rate
        time_ns = start_ns + round(offset * 1e9)
        yield (
            time_ns,
            order,
            channel_id,
            lambda i=i, offset=offset, time_ns=time_ns: encode_sample_block(
                time_ns, offset, rate, np.asarray(c.data[i : i + per_block])
            ),
        )
