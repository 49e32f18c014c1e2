"""The format's names, the schema embedded in a file, and the sample and event blocks' wire format.

The messages are those of ``proto/engine_monitor/recording.proto``, shipped with the product; its
compiled descriptor is the schema embedded in each file (:func:`schema_descriptor_set`). The protobuf
runtime encodes and decodes them, as ``BlockWire``: the same fields and wire format, the packed samples
taken as the bytes they are on the wire (a packed ``repeated float`` is a little-endian float32 array),
so numpy views them without work per sample.
"""

from __future__ import annotations

import numpy as np
from google.protobuf import descriptor_pb2, timestamp_pb2
from google.protobuf.message import DecodeError

from monitor.errors import FormatError
from monitor.io.proto.engine_monitor import recording_pb2

__all__ = [
    "EVENT_SCHEMA",
    "FORMAT_NAME",
    "FORMAT_VERSION",
    "SAMPLE_SCHEMA",
    "decode_block",
    "decode_channel_block",
    "encode_event_block",
    "encode_sample_block",
    "schema_descriptor_set",
]

FORMAT_NAME = "engine-monitor recording"
FORMAT_VERSION = 1
SAMPLE_SCHEMA = "engine_monitor.SampleBlock"
EVENT_SCHEMA = "engine_monitor.EventBlock"


def schema_descriptor_set() -> bytes:
    """The ``FileDescriptorSet`` embedded as the MCAP schema: ``engine_monitor/recording.proto`` (shipped
    in monitor/io/proto, compiled to ``recording_pb2``) with ``google/protobuf/timestamp.proto``."""
    fds = descriptor_pb2.FileDescriptorSet()
    timestamp_pb2.DESCRIPTOR.CopyToProto(fds.file.add())
    recording_pb2.DESCRIPTOR.CopyToProto(fds.file.add())
    return fds.SerializeToString()


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


def decode_channel_block(where: str, data: bytes) -> tuple[float, float, np.ndarray]:
    """:func:`decode_block`, its refusal naming the file and channel (``where``).

    Parameters
    ----------
    where : str
        The file and channel, named in a refusal.
    data : bytes
        The message.

    Returns
    -------
    start_offset, sample_rate, values : float, float, ndarray
        As :func:`decode_block`: start offset [s], sample rate [Hz] (0 for an EventBlock), and the
        samples or event times [s].

    Raises
    ------
    FormatError
        As :func:`decode_block`, prefixed with ``where``.
    """
    try:
        return decode_block(data)
    except FormatError as error:
        raise FormatError(f"{where}: {error}") from None
