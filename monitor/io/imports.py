"""Import from what test benches write: ASAM MDF4 (asammdf) and NI TDMS (npTDMS).

A channel-mapping file (TOML) says which source channels become which
recording channels, with the attributes the product needs and the source
does not carry::

    engine_id = "medium-speed-6l32"
    start_time = "2026-11-22T10:15:00Z"   # optional: else the file's own start time
    [[channel]]
    source = "Vibration/MB3 vertical"      # TDMS: "group/channel"; MDF: the channel name
    name = "mb3-vertical"
    kind = "acceleration"
    unit = "g"                              # optional: else the source's unit
    location = "main bearing 3"
    direction = "vertical"
    scale = 1.0                             # optional factor applied to the samples
    [[channel]]
    source = "Speed/Teeth"
    name = "tooth"
    kind = "tooth"
    fields = { teeth = 60, missing_teeth = 2, first_tooth_angle_deg = 117.0 }

Both readers are an optional extra (``pip install 'engine-monitor[import]'``).
"""

from __future__ import annotations

import math
import tomllib
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, ValidationError

from monitor.recording import KINDS, Channel, FormatError, Recording

__all__ = ["ChannelMapping", "ImportMapping", "import_mdf", "import_tdms", "load_mapping"]


class ChannelMapping(BaseModel):
    """One source channel and the recording channel it becomes."""

    model_config = ConfigDict(extra="forbid", frozen=True)

    source: str
    name: str
    kind: str
    unit: str | None = None
    location: str = ""
    direction: str = ""
    scale: float = 1.0
    fields: dict[str, float | int] = Field(default_factory=dict)


class ImportMapping(BaseModel):
    """A channel-mapping file."""

    model_config = ConfigDict(extra="forbid", frozen=True, populate_by_name=True)

    engine_id: str
    start_time: str | None = None
    notes: str = ""
    channels: list[ChannelMapping] = Field(alias="channel", min_length=1)


def load_mapping(path: str | Path) -> ImportMapping:
    """Read and validate a channel-mapping file.

    Parameters
    ----------
    path : str or Path
        TOML file.

    Returns
    -------
    ImportMapping

    Raises
    ------
    FormatError
        Naming the field and the problem.
    """
    source = Path(path)
    try:
        data = tomllib.loads(source.read_text(encoding="utf-8"))
    except (OSError, tomllib.TOMLDecodeError) as error:
        raise FormatError(f"{source}: cannot read the channel mapping: {error}") from None
    try:
        mapping = ImportMapping.model_validate(data)
    except ValidationError as error:
        problems = "; ".join(
            f"{'.'.join(str(p) for p in e['loc'])}: {e['msg']}" for e in error.errors(include_url=False)
        )
        raise FormatError(f"{source}: invalid channel mapping: {problems}") from None
    for c in mapping.channels:
        if c.kind not in KINDS:
            known = ", ".join(KINDS)
            raise FormatError(
                f"{source}: channel {c.name!r}: kind {c.kind!r} is unknown; expected one of {known}"
            )
    return mapping


def _need(module: str) -> Any:
    import importlib

    try:
        return importlib.import_module(module)
    except ImportError:
        raise FormatError(f"importing needs {module}: pip install 'engine-monitor[import]'") from None


def _channel(mapping: ChannelMapping, data: np.ndarray, rate: float, offset: float, unit: str) -> Channel:
    values = data if mapping.scale == 1.0 else data * mapping.scale
    fields: dict[str, float | int | str] = dict(mapping.fields)
    return Channel(
        mapping.name,
        mapping.kind,
        mapping.unit or unit,
        np.asarray(values),
        rate,
        start_offset=offset,
        location=mapping.location,
        direction=mapping.direction,
        fields=fields,
    ).checked()


def _start(mapping: ImportMapping, fallback: datetime | None) -> str:
    if mapping.start_time:
        return mapping.start_time
    if fallback is None:
        raise FormatError("the source has no start time: give start_time in the channel mapping")
    moment = fallback if fallback.tzinfo else fallback.replace(tzinfo=UTC)
    return moment.astimezone(UTC).strftime("%Y-%m-%dT%H:%M:%S.%fZ")


def import_tdms(path: str | Path, mapping: ImportMapping) -> Recording:
    """A recording from an NI TDMS file.

    Parameters
    ----------
    path : str or Path
    mapping : ImportMapping
        Sources are ``group/channel``.

    Returns
    -------
    Recording
    """
    nptdms = _need("nptdms")
    source = Path(path)
    try:
        tdms = nptdms.TdmsFile.read(source)
    except Exception as error:  # npTDMS raises plain exceptions for files that are not TDMS
        raise FormatError(f"{source}: not a readable TDMS file: {error}") from None
    available = [f"{g.name}/{c.name}" for g in tdms.groups() for c in g.channels()]
    channels = []
    start: datetime | None = None
    for m in mapping.channels:
        if m.source not in available:
            raise FormatError(f"{source}: no channel {m.source!r}; the file has {', '.join(available)}")
        group, name = m.source.split("/", 1)
        ch = tdms[group][name]
        props = ch.properties
        increment = float(props.get("wf_increment", 0.0))
        if not increment > 0:
            raise FormatError(f"{source}: channel {m.source!r} has no wf_increment (sample interval)")
        if start is None and "wf_start_time" in props:
            start = props["wf_start_time"].astype("datetime64[us]").astype(datetime)
        channels.append(
            _channel(
                m,
                ch[:],
                1.0 / increment,
                float(props.get("wf_start_offset", 0.0)),
                str(props.get("unit_string", "")),
            )
        )
    return Recording(mapping.engine_id, _start(mapping, start), tuple(channels), notes=mapping.notes)


def import_mdf(path: str | Path, mapping: ImportMapping) -> Recording:
    """A recording from an ASAM MDF (3 or 4) file.

    Parameters
    ----------
    path : str or Path
    mapping : ImportMapping
        Sources are channel names.

    Returns
    -------
    Recording

    Raises
    ------
    FormatError
        For a missing channel or one not sampled at a fixed rate.
    """
    asammdf = _need("asammdf")
    source = Path(path)
    try:
        mdf = asammdf.MDF(source)
    except Exception as error:  # asammdf raises plain exceptions for files that are not MDF
        raise FormatError(f"{source}: not a readable MDF file: {error}") from None
    with mdf:
        available = sorted(mdf.channels_db)
        channels = []
        for m in mapping.channels:
            if m.source not in mdf.channels_db:
                raise FormatError(f"{source}: no channel {m.source!r}; the file has {', '.join(available)}")
            signal = mdf.get(m.source)
            stamps = np.asarray(signal.timestamps, dtype=np.float64)
            if stamps.size < 2:
                raise FormatError(f"{source}: channel {m.source!r} has fewer than two samples")
            steps = np.diff(stamps)
            step = float(np.median(steps))
            if not step > 0 or np.max(np.abs(steps - step)) > 1e-6 * step + 1e-12:
                raise FormatError(
                    f"{source}: channel {m.source!r} is not sampled at a fixed rate "
                    f"(steps {steps.min():.6g} to {steps.max():.6g} s)"
                )
            rate = 1.0 / step
            if math.isclose(rate, round(rate), rel_tol=1e-9):
                rate = float(round(rate))
            channels.append(
                _channel(m, np.asarray(signal.samples), rate, float(stamps[0]), str(signal.unit or ""))
            )
        start = mdf.header.start_time
    return Recording(mapping.engine_id, _start(mapping, start), tuple(channels), notes=mapping.notes)
