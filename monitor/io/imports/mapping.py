"""The channel-mapping file (see :mod:`monitor.io.imports`), and what it says applied to a source's
channels."""

from __future__ import annotations

import importlib
import tomllib
from datetime import UTC, datetime
from pathlib import Path
from typing import Annotated, Any, Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, NonNegativeInt, ValidationError, field_validator

from monitor.errors import FormatError
from monitor.io.recording import KINDS, Channel

__all__ = [
    "LEVEL_CHANGES",
    "TIME_UNITS",
    "ChannelMapping",
    "ImportMapping",
    "load_mapping",
    "mapped_channel",
    "mapped_start_time",
    "optional_module",
    "refuse_text_options",
]

_Rate = Annotated[float, Field(gt=0, allow_inf_nan=False)]
#: Seconds per unit of a text file's time column (``time_unit``).
TIME_UNITS: dict[str, float] = {"s": 1.0, "ms": 1e-3, "us": 1e-6, "ns": 1e-9}
#: The ``layout`` of a logic analyser's level-change capture (:mod:`~monitor.io.imports.levels`).
LEVEL_CHANGES = "level changes"


class ChannelMapping(BaseModel):
    """One source channel and the recording channel it becomes."""

    model_config = ConfigDict(extra="forbid", frozen=True)

    source: str | NonNegativeInt
    name: str
    kind: str
    unit: str | None = None
    location: str = ""
    direction: str = ""
    scale: float = 1.0
    fields: dict[str, float | int | str] = Field(default_factory=dict)
    edge: Literal["rising", "falling"] | None = None  # level-change captures: the edge that is the event


class ImportMapping(BaseModel):
    """A channel-mapping file."""

    model_config = ConfigDict(extra="forbid", frozen=True, populate_by_name=True)

    engine_id: str
    start_time: str | None = None
    notes: str = ""
    cycle_phase_deg: float | None = None  # four-stroke without a cam: 0 or 360 (FORMAT.md)
    sample_rate_hz: _Rate | None = None
    time_tolerance_s: _Rate | None = None
    time_column: str | NonNegativeInt | None = None
    time_unit: Literal["s", "ms", "us", "ns"] = "s"
    layout: Literal["samples", "level changes"] = "samples"
    delimiter: str | None = None
    header_rows: NonNegativeInt | None = None
    channels: list[ChannelMapping] = Field(alias="channel", min_length=1)

    @field_validator("delimiter")
    @classmethod
    def _one_character(cls, value: str | None) -> str | None:
        if (
            value is None
            or value in ("tab", "whitespace")
            or (len(value) == 1 and value not in '0123456789.+-eE"\r\n')
        ):
            return value
        raise ValueError("expected 'tab', 'whitespace' or one character that cannot be part of a number")


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


def optional_module(module: str) -> Any:
    """The optional reader ``module`` (asammdf, npTDMS), imported when a file of its format is met.

    Parameters
    ----------
    module : str
        The reader's import name, e.g. ``"asammdf"`` or ``"nptdms"``.

    Returns
    -------
    module
        The imported module.

    Raises
    ------
    FormatError
        If it is not installed, saying how to install the ``import`` extra.
    """
    try:
        return importlib.import_module(module)
    except ImportError:
        raise FormatError(f"importing needs {module}: pip install 'engine-monitor[import]'") from None


def mapped_channel(
    mapping: ChannelMapping, data: np.ndarray, rate: float, offset: float, unit: str
) -> Channel:
    """The recording channel a mapped source channel becomes: renamed, scaled, its data quality found.

    Parameters
    ----------
    mapping : ChannelMapping
        The mapping's entry for this channel: its name, kind, unit, location,
        direction, fields and the ``scale`` the samples are multiplied by.
    data : ndarray
        The source channel's samples, shape (n,) [the source's unit].
    rate : float
        Sample rate [Hz]: given, or derived from the source's times.
    offset : float
        Time of the first sample after the recording's start [s].
    unit : str
        The unit the source states ("" if none); the mapping's ``unit``, if
        given, replaces it.

    Returns
    -------
    Channel
        With its data-quality spans found (:meth:`Channel.checked`).

    Raises
    ------
    FormatError
        If the channel is not a valid recording channel (kind, unit, rate, start offset).
    """
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


def mapped_start_time(mapping: ImportMapping, fallback: datetime | None) -> str:
    """The recording's start time: the mapping's ``start_time``, else the one the source states.

    Parameters
    ----------
    mapping : ImportMapping
        Its ``start_time``, if given, is used as written.
    fallback : datetime or None
        The start time the source file states (taken as UTC if naive); None if
        it states none (text files).

    Returns
    -------
    str
        ISO 8601 UTC time with microseconds, e.g. ``2026-01-01T00:00:00.000000Z``
        (or the mapping's ``start_time`` as written).

    Raises
    ------
    FormatError
        If neither the mapping nor the source gives a start time.
    """
    if mapping.start_time:
        return mapping.start_time
    if fallback is None:
        raise FormatError("the source has no start time: give start_time in the channel mapping")
    moment = fallback if fallback.tzinfo else fallback.replace(tzinfo=UTC)
    return moment.astimezone(UTC).strftime("%Y-%m-%dT%H:%M:%S.%fZ")


def refuse_text_options(mapping: ImportMapping, source: Path, kind: str) -> None:
    """Refuse what a mapping says that this kind of file cannot use.

    Parameters
    ----------
    mapping : ImportMapping
        Its text-file options (``time_column``, ``delimiter``, ``header_rows``,
        ``time_unit``, ``layout``; ``time_tolerance_s`` for TDMS) must be unset, and its
        channels' sources must be channel names, not column numbers, with no ``edge``.
    source : Path
        The file being imported, named in the refusal.
    kind : str
        The file's format as the refusal names it: ``"MDF"`` or ``"TDMS"``.

    Raises
    ------
    FormatError
        Naming the options, or the channel, that do not apply.
    """
    keys = [k for k in ("time_column", "delimiter", "header_rows") if getattr(mapping, k) is not None]
    if mapping.time_unit != "s":
        keys.append("time_unit")
    if mapping.layout != "samples":
        keys.append("layout")
    if kind == "TDMS" and mapping.time_tolerance_s is not None:
        keys.append("time_tolerance_s")
    if keys:
        raise FormatError(
            f"{source}: {', '.join(keys)} do not apply to a {kind} file (they are for text files)"
        )
    for m in mapping.channels:
        if m.edge is not None:
            raise FormatError(
                f"{source}: channel {m.name!r}: edge applies to a text file that is a level-change capture "
                f'(layout = "{LEVEL_CHANGES}"), not to a {kind} file'
            )
        if not isinstance(m.source, str):
            raise FormatError(
                f"{source}: channel {m.name!r}: source {m.source!r} is a column number, which is for text "
                f"files; expected the name of the {kind} channel"
            )
