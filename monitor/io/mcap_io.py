"""The product's MCAP recording format (recordings/FORMAT.md): writer, strict reader, third-party listing.

A recording in MCAP is one topic per channel (``/<channel name>``) carrying
blocks of samples.  Messages are protobuf, and the schema embedded in the
file is a real protobuf ``FileDescriptorSet`` (``engine_monitor.SampleBlock``,
``engine_monitor.EventBlock``, with ``google.protobuf.Timestamp``), so a
general MCAP viewer such as Foxglove decodes and plots them.  The recording's
attributes are an MCAP metadata record ``recording``; each channel's are its
MCAP channel metadata.  Chunks are compressed (zstd or lz4) and carry CRCs.

Schema.  The messages are those of ``proto/engine_monitor/recording.proto``,
shipped with the product; its compiled descriptor is the schema embedded in
each file.  The protobuf runtime encodes and decodes them, as ``BlockWire``:
the same fields and wire format, the packed samples taken as the bytes they
are on the wire (a packed ``repeated float`` is a little-endian float32
array), so numpy views them without work per sample; the tests check the
official decoder reads the blocks as ``SampleBlock`` and ``EventBlock``.

Layout.  Each chunk holds one channel: a window of about ``chunk_size``
bytes of it, the windows of all channels in turn, so that a reader of one
topic decompresses that topic's chunks only.

Reading.  :func:`read_mcap` streams the file record by record with CRC
validation, which serves indexed and unindexed files alike; a file cut
short is read up to its last whole record, that is its last whole chunk
(a record the file ends inside is never parsed), and the result says so
(``truncated``), unless the cut leaves a channel without samples, which is
refused naming it; a CRC or decompression failure is a checksum failure.
A damaged file is refused with a :class:`FormatError`, in one line, naming what is wrong.
:func:`open_mcap` reads an indexed file topic by topic, forward in time, in
bounded memory (the analysis of an hour-long recording).
"""

from __future__ import annotations

import calendar
import contextlib
import json
import os
import struct
import tempfile
import threading
import zlib
from collections import defaultdict
from collections.abc import Iterator
from dataclasses import dataclass
from datetime import datetime
from pathlib import Path
from typing import IO, Any, Literal, TypeVar, cast

import numpy as np
from google.protobuf.message import DecodeError
from mcap.exceptions import EndOfFile, McapError
from mcap.opcode import Opcode
from mcap.reader import make_reader
from mcap.records import Channel as McapChannel
from mcap.records import Chunk, Message, Metadata, Schema
from mcap.stream_reader import CRCValidationError, StreamReader, get_chunk_data_stream
from mcap.writer import CompressionType, Writer

from monitor import __version__
from monitor.errors import FormatError
from monitor.io import MCAP_MAGIC, file_signature
from monitor.io.files import in_existing_folder, publish
from monitor.io.plausible import rate_problem
from monitor.io.proto.engine_monitor import recording_pb2
from monitor.io.recording import INTEGER_FIELDS, KIND_FIELDS, Channel, Recording, SampleReader, field_value

__all__ = [
    "McapListing",
    "McapSamples",
    "decode_block",
    "encode_event_block",
    "encode_sample_block",
    "list_mcap",
    "metadata_crc32",
    "open_mcap",
    "read_mcap",
    "schema_descriptor_set",
    "write_mcap",
]

FORMAT_NAME = "engine-monitor recording"
FORMAT_VERSION = 1
SAMPLE_SCHEMA = "engine_monitor.SampleBlock"
EVENT_SCHEMA = "engine_monitor.EventBlock"
_N = TypeVar("_N", int, float)


# --------------------------------------------------------------------------------------- schema
def schema_descriptor_set() -> bytes:
    """The ``FileDescriptorSet`` embedded as the MCAP schema: ``engine_monitor/recording.proto`` (shipped
    beside this module, compiled to ``recording_pb2``) with ``google/protobuf/timestamp.proto``."""
    from google.protobuf import descriptor_pb2, timestamp_pb2

    fds = descriptor_pb2.FileDescriptorSet()
    timestamp_pb2.DESCRIPTOR.CopyToProto(fds.file.add())
    recording_pb2.DESCRIPTOR.CopyToProto(fds.file.add())
    return fds.SerializeToString()


# ------------------------------------------------------------------------------------ wire format
def encode_sample_block(time_ns: int, start_offset: float, rate: float, samples: np.ndarray) -> bytes:
    """One ``engine_monitor.SampleBlock`` (float32 or float64 samples), serialised by the protobuf runtime.

    Parameters
    ----------
    time_ns : int
        Time of the first sample, nanoseconds since the Unix epoch [ns].
    start_offset : float
        Time of the first sample after the recording's start [s].
    rate : float
        Sample rate [Hz].
    samples : ndarray
        float32 or float64 samples [the channel's unit].

    Returns
    -------
    bytes
    """
    finite = samples[np.isfinite(samples)].astype(np.float64)
    mean, rms, low, high = (0.0,) * 4
    if finite.size:
        mean, rms, low, high = finite.mean(), np.sqrt(np.mean(finite**2)), finite.min(), finite.max()
    block = recording_pb2.BlockWire(
        start_offset_s=start_offset,
        sample_rate_hz=rate,
        mean=float(mean),
        rms=float(rms),
        minimum=float(low),
        maximum=float(high),
    )
    block.timestamp.FromNanoseconds(time_ns)
    raw = samples.astype(samples.dtype.newbyteorder("<"), copy=False).tobytes()
    if samples.dtype == np.float32:
        block.values_4 = raw
    else:
        block.values_5 = raw
    return block.SerializeToString()


def encode_event_block(time_ns: int, times: np.ndarray) -> bytes:
    """One ``engine_monitor.EventBlock``, serialised by the protobuf runtime.

    Parameters
    ----------
    time_ns : int
        Time of the first event, nanoseconds since the Unix epoch [ns].
    times : ndarray
        Event times after the recording's start [s].

    Returns
    -------
    bytes
    """
    block = recording_pb2.BlockWire(values_4=times.astype("<f8").tobytes())
    block.timestamp.FromNanoseconds(time_ns)
    return block.SerializeToString()


def decode_block(data: bytes) -> tuple[float, float, np.ndarray]:
    """Decode a SampleBlock or an EventBlock with the protobuf runtime (as ``BlockWire``).

    Parameters
    ----------
    data : bytes
        The message.

    Returns
    -------
    start_offset, sample_rate, values : float, float, ndarray
        Start offset [s], sample rate [Hz] (0 for an EventBlock), and the samples
        or event times [s].

    Raises
    ------
    FormatError
        If the message is not valid protobuf, or its samples are not whole floats.
    """
    block = recording_pb2.BlockWire()
    try:
        block.ParseFromString(data)
    except DecodeError as error:
        raise FormatError(f"message is not a valid SampleBlock or EventBlock ({error})") from None
    rate = block.sample_rate_hz
    if block.values_5 or not rate:  # float64 samples, or an EventBlock's times
        raw, dtype, number = (block.values_5, "<f8", 5) if rate else (block.values_4, "<f8", 4)
    else:
        raw, dtype, number = block.values_4, "<f4", 4
    size = np.dtype(dtype).itemsize
    if len(raw) % size:
        raise FormatError(f"message field {number} has {len(raw)} bytes, not whole {size}-byte floats")
    return block.start_offset_s, rate, np.frombuffer(raw, dtype=dtype).copy()


# ------------------------------------------------------------------------------------------ write
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
                    metadata={**_channel_metadata(c), **checksum},
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


#: The channel metadata entry holding :func:`metadata_crc32` of the file's metadata records.
METADATA_CRC = "metadata_crc32"
#: The metadata records :data:`METADATA_CRC` covers.
CHECKED_METADATA = ("recording", "truth")


def metadata_crc32(metadata: dict[str, dict[str, str]]) -> int:
    """CRC-32 of the file's ``recording`` and ``truth`` metadata records, as each channel states it.

    MCAP's metadata records lie outside the chunks, covered only by the data
    section's CRC, which a file cut short loses and most writers leave at
    zero; the channel records lie inside the checksummed chunks and in the
    checksummed summary. So every channel carries this CRC of the metadata
    (their entries as JSON, keys sorted, compact, UTF-8), and a reader refuses
    a file whose metadata does not match it.

    Parameters
    ----------
    metadata : dict of str to dict of str to str
        Metadata records by name; those other than :data:`CHECKED_METADATA` are left out.

    Returns
    -------
    int
    """
    covered = {name: dict(entries) for name, entries in metadata.items() if name in CHECKED_METADATA}
    text = json.dumps(covered, sort_keys=True, separators=(",", ":"), ensure_ascii=False)
    return zlib.crc32(text.encode("utf-8"))


def _check_metadata_crc(
    source: Path, channels: list[McapChannel], metadata: dict[str, dict[str, str]]
) -> None:
    """Refuse a file whose metadata records do not match the CRC its (checksummed) channels state."""
    actual = metadata_crc32(metadata)
    for channel in channels:
        where = f"{source}: channel {channel.topic.lstrip('/')!r}"
        stated = channel.metadata.get(METADATA_CRC)
        if stated is None:
            raise FormatError(
                f"{where}: no {METADATA_CRC!r} in its channel metadata, so the recording's metadata "
                "cannot be checked (a file written before the format required it: write it again)"
            )
        if stated != str(actual):
            raise FormatError(
                f"{source}: checksum failure: the metadata records' CRC is {actual}, but the channels "
                f"state {stated}; the 'recording' or 'truth' metadata is damaged"
            )


_FOOTER = struct.Struct("<BQQQI")  # opcode, record length, summary start, summary offset start, summary CRC


def _summary_checked(fh: IO[bytes], source: Path) -> bool:
    """Whether the file's summary is there and its CRC matches; a mismatch is refused.

    False for a file without a summary or whose writer left the summary CRC at
    zero: its metadata cannot be trusted from the summary, and it is read by streaming.
    """
    size = os.fstat(fh.fileno()).st_size
    end = size - len(MCAP_MAGIC)
    if end - _FOOTER.size < len(MCAP_MAGIC):
        return False
    fh.seek(end - _FOOTER.size)
    opcode, length, start, _, stated = _FOOTER.unpack(fh.read(_FOOTER.size))
    fh.seek(0)
    if opcode != Opcode.FOOTER or length != _FOOTER.size - 9 or start == 0 or stated == 0:
        return False
    if not len(MCAP_MAGIC) <= start < end - _FOOTER.size:
        raise FormatError(
            f"{source}: damaged MCAP file: the footer puts the summary at byte {start}, "
            f"outside the file's {size} bytes"
        )
    fh.seek(start)
    actual = zlib.crc32(fh.read(end - 4 - start))
    fh.seek(0)
    if actual != stated:
        raise FormatError(
            f"{source}: checksum failure: the summary's CRC is {actual:#010x}, the footer states "
            f"{stated:#010x}; the summary (channel metadata, index) is damaged"
        )
    return True


def _start_ns(start_time: str) -> int:
    """UTC start time in integer nanoseconds since the Unix epoch (exact to the microsecond)."""
    moment = datetime.fromisoformat(start_time.replace("Z", "+00:00"))
    return calendar.timegm(moment.utctimetuple()) * 1_000_000_000 + moment.microsecond * 1000


def _channel_metadata(c: Channel) -> dict[str, str]:
    meta = {
        "kind": c.kind,
        "unit": c.unit,
        "representation": "events" if c.is_events else "waveform",
        "start_offset_s": repr(float(c.start_offset)),
        "location": c.location,
        "direction": c.direction,
        "dtype": str(c.data.dtype),
        "samples": str(c.data.size),
    }
    if not c.is_events:
        meta["sample_rate_hz"] = repr(float(c.sample_rate))  # type: ignore[arg-type]
    for key, value in c.fields.items():
        if isinstance(value, str):
            meta[key] = value
        else:
            meta[key] = str(int(value)) if key in INTEGER_FIELDS else repr(float(value))
    if c.range is not None:
        meta["range_min"], meta["range_max"] = repr(float(c.range[0])), repr(float(c.range[1]))
    return meta


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


# ------------------------------------------------------------------------------------------- read
class _CutShort(EndOfFile):
    """The file ends inside a record: it was cut short (or a damaged length or index points past it)."""

    def __init__(self) -> None:
        super().__init__("a record runs past the end of the file")


class _WholeReads:
    """A file as the MCAP readers see it: every read returns all the bytes asked for, or raises
    :class:`_CutShort` when the file ends first; a seek outside the file is refused.

    The stream reader itself takes a short read at the end of a file for a whole
    one, then fails on a fixed-size field of too few bytes (``struct.error``) or
    hands a partial chunk to the decompressor. Here a record that the file ends
    inside is never parsed, and no more than the file holds is ever asked for,
    whatever a damaged length field or index says.

    Parameters
    ----------
    fh : binary file
        Open for reading, at its start.
    size : int
        The file's size [bytes].
    """

    def __init__(self, fh: IO[bytes], size: int) -> None:
        self._fh = fh
        self._size = size
        self._position = 0

    def read(self, size: int = -1) -> bytes:
        """``size`` bytes (all that is left for a negative size), or raise :class:`_CutShort`."""
        left = self._size - self._position
        size = left if size < 0 else size
        if size > left:
            raise _CutShort()
        data = self._fh.read(size)
        if len(data) < size:  # the file shrank while it was read
            raise _CutShort()
        self._position += size
        return data

    def seekable(self) -> bool:
        """True: the indexed reader may seek."""
        return True

    def seek(self, offset: int, whence: int = os.SEEK_SET) -> int:
        """Move to a byte of the file; refuse (McapError) a position outside it."""
        base = {os.SEEK_SET: 0, os.SEEK_CUR: self._position, os.SEEK_END: self._size}[whence]
        if not 0 <= base + offset <= self._size:
            raise McapError(
                f"an offset points to byte {base + offset}, outside the file ({self._size} bytes)"
            )
        self._position = self._fh.seek(base + offset)
        return self._position

    def tell(self) -> int:
        """The current byte."""
        return self._position


def _bounded(fh: IO[bytes]) -> IO[bytes]:
    """An open MCAP file for the official readers, read through :class:`_WholeReads`."""
    return cast(IO[bytes], _WholeReads(fh, os.fstat(fh.fileno()).st_size))


@dataclass(frozen=True)
class _Chunked:
    """A channel record read from inside a chunk (so covered by the chunk's CRC)."""

    channel: McapChannel


def _records(path: Path, *, mark_chunked: bool = False) -> Iterator[Any]:
    """Records of an MCAP file, CRCs checked; a file cut short stops at its last whole record (that is,
    after its last whole chunk) and then yields None. With ``mark_chunked``, a channel record from
    inside a chunk comes as a :class:`_Chunked`."""
    if file_signature(path) != MCAP_MAGIC:
        raise FormatError(f"{path}: not an MCAP file (no MCAP magic at its start)")
    try:
        with open(path, "rb") as fh, _damage_named(str(path)):
            reader = StreamReader(_bounded(fh), validate_crcs=True, emit_chunks=True)
            try:
                for record in reader.records:
                    if isinstance(record, Chunk):
                        for inner in _chunk_records(record):
                            yield (
                                _Chunked(inner) if mark_chunked and isinstance(inner, McapChannel) else inner
                            )
                    else:
                        yield record
            except _CutShort:
                size = os.fstat(fh.fileno()).st_size
                fh.seek(max(len(MCAP_MAGIC), size - len(MCAP_MAGIC)))
                if fh.read() == MCAP_MAGIC:  # the file ends as a whole one does: damage, not a cut
                    raise FormatError(
                        f"{path}: damaged MCAP file: a record runs past the end of the file, "
                        "which ends with the MCAP magic (not cut short)"
                    ) from None
                yield None
    except OSError as error:
        raise FormatError(f"{path}: cannot read: {error}") from None


def _chunk_records(chunk: Chunk) -> Iterator[Schema | McapChannel | Message]:
    """The schemas, channels and messages of a chunk one at a time, its CRC checked on decompression.

    One at a time (unlike the official ``breakup_chunk``, which parses a whole
    chunk first), so that a file another program wrote is refused at its first
    topic of another schema without parsing its messages.
    """
    stream, size = get_chunk_data_stream(chunk, validate_crc=True)
    while stream.count < size:
        opcode = stream.read1()
        length = stream.read8()
        if opcode == Opcode.MESSAGE:
            yield Message.read(stream, length)
        elif opcode == Opcode.CHANNEL:
            yield McapChannel.read(stream)
        elif opcode == Opcode.SCHEMA:
            yield Schema.read(stream)
        else:
            stream.read(length)  # a record a chunk may hold that is of no use here


def _cut_short(source: Path) -> str:
    """What to say of a file that ends inside a record."""
    try:
        return f"the file was cut short ({source.stat().st_size} bytes)"
    except OSError:
        return "the file was cut short"


@contextlib.contextmanager
def _damage_named(where: str) -> Iterator[None]:
    """A CRC, record or decompression failure while reading, as a FormatError naming ``where``."""
    try:
        yield
    except FormatError:
        raise
    except CRCValidationError as error:
        raise FormatError(f"{where}: checksum failure: {error}") from None
    except McapError as error:
        raise FormatError(f"{where}: damaged MCAP file: {error}") from None
    except (struct.error, ValueError, IndexError, KeyError) as error:  # a record's fields contradict it
        raise FormatError(f"{where}: damaged MCAP file: a record does not parse ({error})") from None
    except Exception as error:  # decompression of a damaged chunk (zstd, lz4)
        if type(error).__module__.split(".")[0] in ("zstandard", "lz4"):
            raise FormatError(f"{where}: checksum failure: a chunk does not decompress ({error})") from None
        raise


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
    for record in _records(source, mark_chunked=True):
        if record is None:
            truncated = True
        elif isinstance(record, Schema):
            schemas[record.id] = record.name
        elif isinstance(record, _Chunked) or isinstance(record, McapChannel):
            channel = record.channel if isinstance(record, _Chunked) else record
            if schemas.get(channel.schema_id) not in (SAMPLE_SCHEMA, EVENT_SCHEMA):  # refused at once
                raise FormatError(
                    f"{source}: {'' if recording_meta else f'not an {FORMAT_NAME}: '}topic {channel.topic!r} "
                    f"has schema {schemas.get(channel.schema_id)!r}, not one of this format's"
                )
            # the copy inside a chunk is checksummed; one outside (the summary's) is not used
            (channels if isinstance(record, _Chunked) else unchunked)[channel.id] = channel
        elif isinstance(record, Metadata):
            metadata[record.name] = dict(record.metadata)
            if record.name == "recording":
                recording_meta = metadata["recording"]
            elif record.name == "truth":
                truth = metadata["truth"].get("json", "")
        elif isinstance(record, Message):
            owner = channels.get(record.channel_id)
            if owner is not None:
                start, _, values = _decoded(f"{source}: channel {owner.topic.lstrip('/')!r}", record.data)
                blocks[record.channel_id].append((start, values))
    if recording_meta is None and truncated:
        raise FormatError(
            f"{source}: {_cut_short(source)} before any 'recording' metadata record: "
            f"not readable as an {FORMAT_NAME}"
        )
    _check_recording_metadata(source, recording_meta)
    assert recording_meta is not None
    for channel_id, channel in unchunked.items():
        if channel_id not in channels:
            raise FormatError(
                f"{source}: channel {channel.topic.lstrip('/')!r} has its record outside any chunk, where "
                "no CRC covers its metadata; this format keeps channel records in the chunks"
            )
    _check_metadata_crc(source, list(channels.values()), metadata)
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
        cycle_phase_deg=_phase(source, recording_meta),
    )


def _decoded(where: str, data: bytes) -> tuple[float, float, np.ndarray]:
    """:func:`decode_block`, its refusal naming the file and channel (``where``)."""
    try:
        return decode_block(data)
    except FormatError as error:
        raise FormatError(f"{where}: {error}") from None


#: The fewest samples (events) a channel must keep when its file was cut short; fewer is refused.
MIN_SAMPLES_LEFT = 2


def _check_recording_metadata(source: Path, recording_meta: dict[str, str] | None) -> None:
    if recording_meta is None or recording_meta.get("format") != FORMAT_NAME:
        raise FormatError(
            f"{source}: not an {FORMAT_NAME} (no 'recording' metadata record naming the format)"
        )
    if recording_meta.get("format_version") != str(FORMAT_VERSION):
        raise FormatError(
            f"{source}: format_version {recording_meta.get('format_version')!r} is not supported"
        )
    for name in ("engine_id", "start_time"):
        if not recording_meta.get(name):
            raise FormatError(f"{source}: the 'recording' metadata has no {name!r}")


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
    meta = _metadata(source, channel)
    events = meta["representation"] == "events"
    rate = None if events else _number(where, meta, "sample_rate_hz", float)
    parts.sort(key=lambda p: p[0])
    dtype = _dtype(where, meta)
    data = np.concatenate([p[1] for p in parts]).astype(dtype, copy=False) if parts else np.empty(0, dtype)
    if rate is not None and parts:
        problem = rate_problem(rate)
        if problem is not None:
            raise FormatError(f"{where}: sample_rate_hz = {rate!r}: {problem}")
        expected = _number(where, meta, "start_offset_s", float, 0.0)
        for start, values in parts:  # blocks must follow each other without gaps or overlaps
            if abs(start - expected) > 0.5 / rate:
                raise FormatError(
                    f"{where}: a block starts at {start:.9g} s, expected {expected:.9g} s "
                    "(missing or repeated block)"
                )
            expected = start + values.size / rate
    stated = _number(where, meta, "samples", int, data.size)
    if truncated and data.size < min(MIN_SAMPLES_LEFT, stated):
        what = "events" if events else "samples"
        left = "none" if data.size == 0 else f"only {data.size}"
        raise FormatError(
            f"{where}: {_cut_short(source)}: {left} of its {stated} {what} before the cut, "
            f"fewer than the {MIN_SAMPLES_LEFT} a channel needs"
        )
    if data.size != stated and not (truncated and data.size < stated):
        raise FormatError(f"{where}: {data.size} samples in its blocks, but its metadata says {stated}")
    return _channel(source, channel, meta, data).checked()


def _metadata(source: Path, channel: McapChannel) -> dict[str, str]:
    meta = dict(channel.metadata)
    for key in ("kind", "unit", "representation", "dtype"):
        if key not in meta:
            raise FormatError(
                f"{source}: channel {channel.topic.lstrip('/')!r}: missing channel metadata {key!r}"
            )
    if meta["representation"] not in ("waveform", "events"):
        raise FormatError(
            f"{source}: channel {channel.topic.lstrip('/')!r}: representation {meta['representation']!r}: "
            "expected 'waveform' or 'events'"
        )
    return meta


def _number(where: str, meta: dict[str, str], key: str, kind: type[_N], default: _N | None = None) -> _N:
    """A number of a channel's metadata (stored as a string), or the default where it is absent.

    Raises
    ------
    FormatError
        If the entry is absent without a default, or is not a number of the kind.
    """
    if key not in meta:
        if default is None:
            raise FormatError(f"{where}: missing channel metadata {key!r}")
        return default
    try:
        return kind(meta[key])
    except ValueError:
        expected = "an integer" if kind is int else "a number"
        raise FormatError(
            f"{where}: channel metadata {key!r} is {meta[key]!r}, expected {expected}"
        ) from None


def _dtype(where: str, meta: dict[str, str]) -> np.dtype[Any]:
    """The sample type a channel's metadata states (a numpy float or integer type)."""
    try:
        dtype = np.dtype(meta["dtype"])
    except TypeError:
        dtype = None
    if dtype is None or dtype.kind != "f":
        raise FormatError(
            f"{where}: channel metadata 'dtype' is {meta['dtype']!r}, expected float32 or float64"
        )
    return dtype


def _channel(source: Path, channel: McapChannel, meta: dict[str, str], data: Any) -> Channel:
    name = channel.topic.lstrip("/")
    where = f"{source}: channel {name!r}"
    rate = None if meta["representation"] == "events" else _number(where, meta, "sample_rate_hz", float)
    offset = _number(where, meta, "start_offset_s", float, 0.0)
    limits = (
        (_number(where, meta, "range_min", float), _number(where, meta, "range_max", float))
        if "range_min" in meta
        else None
    )
    try:
        fields = {
            key: field_value(name, key, meta[key]) for key in KIND_FIELDS.get(meta["kind"], {}) if key in meta
        }
        return Channel(
            name=name,
            kind=meta["kind"],
            unit=meta["unit"],
            data=data,
            sample_rate=rate,
            start_offset=offset,
            location=meta.get("location", ""),
            direction=meta.get("direction", ""),
            fields=fields,
            range=limits,
        )
    except FormatError as error:
        raise FormatError(f"{source}: {error}") from None


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
    with open(source, "rb") as fh, _damage_named(str(source)):
        if _summary_checked(fh, source):
            try:
                reader = make_reader(_bounded(fh), validate_crcs=True)
                summary = reader.get_summary()
                metadata = {m.name: dict(m.metadata) for m in reader.iter_metadata()}
                recording_meta = metadata.get("recording")
            except Exception:  # no usable summary (unindexed, cut short): stream the whole file instead
                summary = None
    if summary is None or not summary.chunk_indexes:
        yield read_mcap(source)
        return
    _check_recording_metadata(source, recording_meta)
    assert recording_meta is not None
    _check_metadata_crc(source, list(summary.channels.values()), metadata)
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
            meta = _metadata(source, channel)
            if meta["representation"] == "events":
                where = f"{source}: channel {channel.topic.lstrip('/')!r}"
                parts = [_decoded(where, m.data)[::2] for m in McapSamples.messages(source, channel.topic)]
                channels.append(_assemble(source, channel, [(p[0], p[1]) for p in parts], False))
                continue
            samples = McapSamples(source, channel.topic, meta)
            opened.append(samples)
            channels.append(_channel(source, channel, meta, samples))
        order = _listed_channels(source, recording_meta, [c.topic for c in summary.channels.values()], False)
        channels.sort(key=lambda c: order.index(c.name) if c.name in order else len(order))
        yield Recording(
            engine_id=recording_meta["engine_id"],
            start_time=recording_meta["start_time"],
            notes=recording_meta.get("notes", ""),
            channels=tuple(channels),
            truth=metadata.get("truth", {}).get("json", ""),
            cycle_phase_deg=_phase(source, recording_meta),
        )
    finally:
        for samples in opened:
            samples.close()


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
        rate = _number(where, meta, "sample_rate_hz", float)
        problem = rate_problem(rate)
        if problem is not None:
            raise FormatError(f"{where}: sample_rate_hz = {rate!r}: {problem}")
        super().__init__(
            where,
            _number(where, meta, "samples", int),
            _dtype(where, meta),
            rate,
            _number(where, meta, "start_offset_s", float, 0.0),
            (_number(where, meta, "range_min", float), _number(where, meta, "range_max", float))
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
        with open(source, "rb") as fh, _damage_named(f"{source}: channel {topic.lstrip('/')!r}"):
            for _, _, message in make_reader(_bounded(fh), validate_crcs=True).iter_messages(topics=[topic]):
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
        start, _, values = _decoded(self._where, message.data)
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


# -------------------------------------------------------------------------------- third-party files
@dataclass(frozen=True)
class McapListing:
    """What an MCAP file holds, by topic (any schema, for files other programs wrote).

    Attributes
    ----------
    messages : dict of str to int
        Messages per topic.
    schemas : dict of str to str
        Schema name per topic.
    truncated : bool
        The file was cut short; counts cover its whole chunks.
    """

    messages: dict[str, int]
    schemas: dict[str, str]
    truncated: bool

    @property
    def total(self) -> int:
        """All messages."""
        return sum(self.messages.values())


def list_mcap(path: str | Path) -> McapListing:
    """Count the messages per topic of any MCAP file, streaming, CRCs checked.

    Parameters
    ----------
    path : str or Path

    Returns
    -------
    McapListing
    """
    source = Path(path)
    schemas: dict[int, str] = {}
    topics: dict[int, str] = {}
    counts: dict[str, int] = defaultdict(int)
    truncated = False
    names: dict[str, str] = {}
    for record in _records(source):
        if record is None:
            truncated = True
        elif isinstance(record, Schema):
            schemas[record.id] = record.name
        elif isinstance(record, McapChannel):
            topics[record.id] = record.topic
            names[record.topic] = schemas.get(record.schema_id, "")
            counts.setdefault(record.topic, 0)
        elif isinstance(record, Message):
            counts[topics.get(record.channel_id, f"channel {record.channel_id}")] += 1
    return McapListing(dict(counts), names, truncated)


def _phase(source: Path, recording_meta: dict[str, str]) -> float | None:
    """The recording metadata's ``cycle_phase_deg``, if stated [deg]."""
    text = recording_meta.get("cycle_phase_deg")
    if text is None:
        return None
    try:
        return float(text)
    except ValueError:
        raise FormatError(f"{source}: cycle_phase_deg = {text!r}: expected 0 or 360 (degrees)") from None
