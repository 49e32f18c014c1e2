"""The recording's metadata records and each channel's metadata: written, read back and checked.

The recording's attributes are an MCAP metadata record ``recording`` (and the simulation's truth a
record ``truth``); each channel's are its MCAP channel metadata, strings. Every channel also states the
CRC of the metadata records (:func:`metadata_crc32`), which no CRC of MCAP's own reliably covers.
"""

from __future__ import annotations

import json
import zlib
from pathlib import Path
from typing import Any, TypeVar

import numpy as np
from mcap.records import Channel as McapChannel

from monitor.errors import FormatError
from monitor.io.mcap.wire import FORMAT_NAME, FORMAT_VERSION
from monitor.io.recording import INTEGER_FIELDS, KIND_FIELDS, Channel, field_value

__all__ = [
    "CHECKED_METADATA",
    "METADATA_CRC",
    "channel_from_metadata",
    "channel_metadata",
    "check_metadata_crc",
    "check_recording_metadata",
    "checked_channel_metadata",
    "cycle_phase",
    "metadata_crc32",
    "metadata_dtype",
    "metadata_number",
]

_N = TypeVar("_N", int, float)


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


def check_metadata_crc(
    source: Path, channels: list[McapChannel], metadata: dict[str, dict[str, str]]
) -> None:
    """Refuse a file whose metadata records do not match the CRC its (checksummed) channels state.

    Parameters
    ----------
    source : Path
        The file, named in a refusal.
    channels : list of mcap.records.Channel
        The file's channel records, each stating :data:`METADATA_CRC` in its metadata.
    metadata : dict of str to dict of str to str
        The file's metadata records by name, as read (see :func:`metadata_crc32`).

    Raises
    ------
    FormatError
        If a channel states no CRC, or one that does not match the metadata records.
    """
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


def check_recording_metadata(source: Path, recording_meta: dict[str, str] | None) -> None:
    """Refuse a file whose ``recording`` metadata record is missing, of another format or version,
    or without its engine or start time.

    Parameters
    ----------
    source : Path
        The file, named in a refusal.
    recording_meta : dict of str to str or None
        The entries of the file's ``recording`` metadata record; None if it has none.

    Raises
    ------
    FormatError
        If the record is missing or does not name :data:`FORMAT_NAME`, its ``format_version`` is not
        :data:`FORMAT_VERSION`, or ``engine_id`` or ``start_time`` is missing or empty.
    """
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


def cycle_phase(source: Path, recording_meta: dict[str, str]) -> float | None:
    """The recording metadata's ``cycle_phase_deg``, if stated [deg].

    Parameters
    ----------
    source : Path
        The file, named in a refusal.
    recording_meta : dict of str to str
        The entries of the file's ``recording`` metadata record.

    Returns
    -------
    float or None
        The four-stroke cycle phase [deg] (0 or 360); None if not stated.

    Raises
    ------
    FormatError
        If the entry is not a number.
    """
    text = recording_meta.get("cycle_phase_deg")
    if text is None:
        return None
    try:
        return float(text)
    except ValueError:
        raise FormatError(f"{source}: cycle_phase_deg = {text!r}: expected 0 or 360 (degrees)") from None


def channel_metadata(c: Channel) -> dict[str, str]:
    """A channel's attributes as the MCAP channel metadata it is written with (strings).

    Parameters
    ----------
    c : Channel
        The recording channel to write.

    Returns
    -------
    dict of str to str
        ``kind``, ``unit``, ``representation`` ("waveform" or "events"), ``start_offset_s`` [s],
        ``location``, ``direction``, ``dtype``, ``samples``; ``sample_rate_hz`` [Hz] for a waveform;
        the channel's fields; ``range_min`` and ``range_max`` [the channel's unit] if it has a range.
        Floats are written with ``repr``, so they read back exactly.
    """
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


def checked_channel_metadata(source: Path, channel: McapChannel) -> dict[str, str]:
    """An MCAP channel record's metadata, refused if it lacks an entry every channel has.

    Parameters
    ----------
    source : Path
        The file, named in a refusal.
    channel : mcap.records.Channel
        The channel record as read; its topic is ``/`` and the channel's name.

    Returns
    -------
    dict of str to str
        A copy of its metadata, with ``kind``, ``unit``, ``representation`` and ``dtype``.

    Raises
    ------
    FormatError
        If one of those is missing, or ``representation`` is neither "waveform" nor "events".
    """
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


def metadata_number(
    where: str, meta: dict[str, str], key: str, kind: type[_N], default: _N | None = None
) -> _N:
    """A number of a channel's metadata (stored as a string), or the default where it is absent.

    Parameters
    ----------
    where : str
        The file and channel, named in a refusal.
    meta : dict of str to str
        The channel's metadata.
    key : str
        The entry, e.g. ``"sample_rate_hz"`` [Hz], ``"start_offset_s"`` [s] or ``"samples"``.
    kind : type
        ``int`` or ``float``: the type the entry is read as.
    default : int or float, optional
        Returned where the entry is absent; without it, an absent entry is refused.

    Returns
    -------
    int or float
        Of ``kind``, in the entry's unit.

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


def metadata_dtype(where: str, meta: dict[str, str]) -> np.dtype[Any]:
    """The sample type a channel's metadata states: float32 or float64, anything else refused.

    Parameters
    ----------
    where : str
        The file and channel, named in a refusal.
    meta : dict of str to str
        The channel's metadata, with its ``dtype`` entry (see :func:`checked_channel_metadata`).

    Returns
    -------
    numpy.dtype
        float32 or float64: the only sample types the format admits.

    Raises
    ------
    FormatError
        If ``dtype`` names no numpy type, or one that is not a float.
    """
    try:
        dtype = np.dtype(meta["dtype"])
    except TypeError:
        dtype = None
    if dtype is None or dtype.kind != "f":
        raise FormatError(
            f"{where}: channel metadata 'dtype' is {meta['dtype']!r}, expected float32 or float64"
        )
    return dtype


def channel_from_metadata(source: Path, channel: McapChannel, meta: dict[str, str], data: Any) -> Channel:
    """The recording channel an MCAP channel record and its samples make.

    Parameters
    ----------
    source : Path
        The file, named in a refusal.
    channel : mcap.records.Channel
        The channel record; its topic less the leading ``/`` is the channel's name.
    meta : dict of str to str
        Its metadata, checked by :func:`checked_channel_metadata`.
    data : ndarray or McapSamples
        The samples [the channel's unit] or event times [s], shape (n,): in memory, or read by
        slices from the file (:class:`~monitor.io.mcap.samples.McapSamples`).

    Returns
    -------
    Channel
        Not yet checked for data quality (:meth:`Channel.checked`).

    Raises
    ------
    FormatError
        If an entry (rate, start offset, range, a field of its kind) is not valid, naming the file.
    """
    name = channel.topic.lstrip("/")
    where = f"{source}: channel {name!r}"
    rate = (
        None if meta["representation"] == "events" else metadata_number(where, meta, "sample_rate_hz", float)
    )
    offset = metadata_number(where, meta, "start_offset_s", float, 0.0)
    limits = (
        (metadata_number(where, meta, "range_min", float), metadata_number(where, meta, "range_max", float))
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
