"""Import from what test benches write: ASAM MDF (asammdf), NI TDMS (npTDMS) and text exports.

A channel-mapping file (TOML) says which source channels become which
recording channels, with the attributes the product needs and the source
does not carry::

    engine_id = "medium-speed-6l32"
    start_time = "2026-11-22T10:15:00Z"   # optional: else the file's own start time
    sample_rate_hz = 25600.0               # optional: else from the file (--rate overrides both)
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

Text exports (``.csv``, ``.txt``, ``.tsv``, and ``.dat`` that is not MDF): one
row per sample, a time column and one column per channel.  The mapping says
more, since a text file carries no start time and no units::

    engine_id = "kluczyk-1cyl-4stroke"
    start_time = "2026-11-22T10:15:00Z"   # required
    time_column = "time"                   # a header name, or a 0-based column number: time_column = 0
    time_unit = "s"                        # "s" (default), "ms" or "us"
    delimiter = "tab"                      # optional: "tab", ",", ";", "whitespace" or another character
    header_rows = 1                        # optional: lines before the first row of numbers
    time_tolerance_s = 5e-7                # optional: largest deviation of a time from the fixed-rate line
    [[channel]]
    source = 1                             # a 0-based column number, or a header name: source = "tooth"
    name = "tooth"
    kind = "tooth"
    unit = "V"                             # required
    fields = { teeth = 60, missing_teeth = 2, first_tooth_angle_deg = 117.5 }

Without ``delimiter``, it is the first of tab, semicolon, comma and
whitespace that splits the file's last lines into equal numbers of numbers.
With a delimiter other than the comma, a comma in a number is a decimal comma
(``0,25``); a number with both a point and a comma (a thousands separator) is
refused.  Without ``header_rows``, the header is the lines before the first
row of numbers; a column named by ``source`` is looked up in it.  The file is
read in blocks of rows: memory holds the samples (float32 when the first and
last rows print at most 7 significant digits, which float32 tells apart;
float64 otherwise) and the float64 time column.

The sample rate.  ``--rate`` or the mapping's ``sample_rate_hz`` is used as
given, for every channel; the times then give only the start offset.  Else the
rate is derived from the times (a text file's time column, the time stamps of
an MDF channel) by a least-squares line of time against sample index, whose
deviations must stay within the rounding of the written times: half the last
printed digit of a text file's times (fixed decimals or significant digits,
read from its first and last rows), half the decimal grid (1 us, 10 us ...)
that an MDF channel's stamps lie on, or the mapping's ``time_tolerance_s``.
Times with a gap or jitter beyond that are refused with the row named.  When
the nearest whole number of hertz fits the times as well, that is the rate.
TDMS waveforms carry their sample interval (``wf_increment``).

The MDF and TDMS readers are an optional extra (``pip install 'engine-monitor[import]'``);
text files need nothing more.
"""

from __future__ import annotations

import csv
import itertools
import math
import os
import re
import tomllib
import warnings
from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass
from datetime import UTC, datetime
from pathlib import Path
from typing import Annotated, Any, Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, NonNegativeInt, ValidationError, field_validator

from monitor.errors import FormatError
from monitor.io.recording import KINDS, UNITS, Channel, Recording

__all__ = [
    "TEXT_SUFFIXES",
    "ChannelMapping",
    "ImportMapping",
    "import_file",
    "import_mdf",
    "import_tdms",
    "import_text",
    "load_mapping",
]

#: File suffixes read as text exports (``.dat`` only when it is not an MDF file).
TEXT_SUFFIXES = (".csv", ".txt", ".tsv", ".dat")
_TIME_UNITS = {"s": 1.0, "ms": 1e-3, "us": 1e-6}
_BLOCK = 1 << 16  # rows per block, when reading text and when checking times
_SNIFF_BYTES = 1 << 16  # bytes read at each end of a text file to learn its layout
_SNIFF_LINES = 200
_FLOAT32_DIGITS = 7  # float32 tells apart all numbers of 7 significant digits
_Rate = Annotated[float, Field(gt=0, allow_inf_nan=False)]


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
    fields: dict[str, float | int] = Field(default_factory=dict)


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
    time_unit: Literal["s", "ms", "us"] = "s"
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


def _not_for(mapping: ImportMapping, source: Path, kind: str) -> None:
    """Refuse what a mapping says that this kind of file cannot use."""
    keys = [k for k in ("time_column", "delimiter", "header_rows") if getattr(mapping, k) is not None]
    if mapping.time_unit != "s":
        keys.append("time_unit")
    if kind == "TDMS" and mapping.time_tolerance_s is not None:
        keys.append("time_tolerance_s")
    if keys:
        raise FormatError(
            f"{source}: {', '.join(keys)} do not apply to a {kind} file (they are for text files)"
        )
    for m in mapping.channels:
        if not isinstance(m.source, str):
            raise FormatError(
                f"{source}: channel {m.name!r}: source {m.source!r} is a column number, which is for text "
                f"files; expected the name of the {kind} channel"
            )


# ------------------------------------------------------------------------------------------ rates
_HINT = "give the rate (sample_rate_hz in the mapping, or --rate) if it is known"


@dataclass(frozen=True)
class _Rounding:
    """How coarsely times were written, which bounds their deviation from the fixed-rate line.

    ``step`` [s] is the finest step of the written numbers (fixed decimals, a
    decimal grid); ``significant`` the significant digits of numbers written in
    exponent or ``%g`` style (0: none); ``stated`` [s] the mapping's bound,
    which replaces both.
    """

    step: float = 0.0
    significant: int = 0
    stated: float | None = None

    def half(self, t: np.ndarray) -> np.ndarray:
        """Half the step of the written numbers at times t [s]: how far rounding moved them [s]."""
        half = np.full(t.shape, 0.5 * self.step)
        if self.significant:
            magnitude = np.floor(np.log10(np.maximum(np.abs(t), np.finfo(np.float64).tiny)))
            half = np.maximum(half, 0.5 * 10.0 ** (magnitude - self.significant + 1))
        return half

    def slack(self, t: np.ndarray) -> float:
        """How far [s] the least-squares line through times t can be off the true one, by their rounding.

        Its standard deviation is at most about 1.2 h / sqrt(n), at the ends of a
        record of n times rounded by at most h; the slack is about four of those.
        """
        if self.stated is not None:
            return 0.0  # a stated bound is on the deviation from the fitted line
        largest = float(self.half(np.array([_largest(t)]))[0])
        return 5.0 * largest / math.sqrt(t.size)

    def limit(self, t: np.ndarray, slack: float) -> np.ndarray:
        """Largest deviation [s] from the fitted line that the rounding explains at times t; slack [s]."""
        floor = 8 * np.finfo(np.float64).eps * np.abs(t)  # parsing and arithmetic
        if self.stated is not None:
            return floor + self.stated
        return floor + self.half(t) + slack


def _largest(t: np.ndarray) -> float:
    """The largest magnitude of times t [s], without a temporary array."""
    return max(abs(float(t.min())), abs(float(t.max())))


_NUMBER = re.compile(r"[+-]?(\d*)(?:\.(\d*))?(?:[eE]([+-]?\d+))?")


def _significant(text: str) -> int:
    """Significant digits of a written number (0 if it is not one)."""
    match = _NUMBER.fullmatch(text.strip())
    return len((match.group(1) + (match.group(2) or "")).lstrip("0")) if match else 0


def _printed_rounding(texts: Iterable[str]) -> _Rounding:
    """The rounding of times written as text: the most decimals and the most significant digits seen."""
    decimals: int | None = None
    significant = 0
    for text in texts:
        match = _NUMBER.fullmatch(text.strip())
        if not match or not (match.group(1) or match.group(2)):
            continue
        fraction = match.group(2) or ""
        significant = max(significant, _significant(text))
        places = len(fraction) - int(match.group(3) or 0)
        decimals = places if decimals is None else max(decimals, places)
    return _Rounding(step=10.0**-decimals if decimals is not None else 0.0, significant=significant)


def _grid_rounding(t: np.ndarray) -> _Rounding:
    """Binary time stamps: the coarsest decimal grid, at most a tenth of the sample interval, they lie on."""
    interval = float(t[-1] - t[0]) / (t.size - 1) if t.size > 1 else 0.0
    if not (math.isfinite(interval) and interval > 0):
        return _Rounding()
    largest = _largest(t)
    for exponent in range(math.floor(math.log10(interval / 10)), -13, -1):
        grid = 10.0**exponent
        if largest / grid > 1e12:  # float64 cannot tell a grid this fine
            break
        if all(_on_grid(t[s : s + _BLOCK], grid) for s in range(0, t.size, _BLOCK)):
            return _Rounding(step=max(grid, 2e-6 * interval))
    return _Rounding(step=2e-6 * interval)


def _on_grid(t: np.ndarray, grid: float) -> bool:
    steps = t / grid
    return bool(np.all(np.abs(steps - np.rint(steps)) <= 1e-3))


def _off_line(
    t: np.ndarray, period: float, centre: float, rounding: _Rounding, row: Callable[[int], str]
) -> str | None:
    """Where times t [s] leave the line of the given period [s] through their centre, beyond the rounding."""
    n = t.size
    slack = rounding.slack(t)
    for s in range(0, n - 1, _BLOCK):
        seg = t[s : s + _BLOCK + 1]
        limit = rounding.limit(seg, slack)
        steps = np.diff(seg)
        allowed = limit[:-1] + limit[1:]
        bad = np.flatnonzero(np.abs(steps - period) > allowed)
        if bad.size:
            k = int(bad[0])
            return (
                f"at {row(s + k + 1)} the time steps by {steps[k]:.6g} s where {period:.6g} s is expected "
                f"(the rounding of the times allows {allowed[k]:.2g} s either way)"
            )
    middle = (n - 1) / 2
    for s in range(0, n, _BLOCK):
        seg = t[s : s + _BLOCK]
        limit = rounding.limit(seg, slack)
        residual = (seg - centre) - period * (np.arange(s, s + seg.size) - middle)
        bad = np.flatnonzero(np.abs(residual) > limit)
        if bad.size:
            k = int(bad[0])
            return (
                f"at {row(s + k)} the time {seg[k]:.9g} s is {residual[k]:.3g} s off the line of a fixed "
                f"rate ({1 / period:.9g} Hz), more than the rounding of the times allows ({limit[k]:.2g} s)"
            )
    return None


def _fixed_rate(t: np.ndarray, rounding: _Rounding, where: str, row: Callable[[int], str]) -> float:
    """The sample rate [Hz] of times t [s] written with a rounding; refuses gaps and jitter beyond it."""
    n = t.size
    if n < 2:
        raise FormatError(f"{where}: fewer than two samples, so no rate can be derived; {_HINT}")
    finite = np.isfinite(t)
    if not finite.all():
        k = int(np.argmin(finite))
        raise FormatError(f"{where}: the time at {row(k)} is {t[k]}; expected a finite time")
    middle = (n - 1) / 2
    centre = float(np.mean(t))
    covariance = 0.0
    for s in range(0, n, _BLOCK):
        seg = t[s : s + _BLOCK]
        covariance += float(np.dot(np.arange(s, s + seg.size) - middle, seg - centre))
    period = covariance / (n * (n * n - 1.0) / 12.0)
    if not (math.isfinite(period) and period > 0):
        raise FormatError(f"{where} is not sampled at a fixed rate: the time does not increase; {_HINT}")
    off = _off_line(t, period, centre, rounding, row)
    if off is not None:
        raise FormatError(
            f"{where} is not sampled at a fixed rate: {off}; {_HINT}, "
            "or time_tolerance_s if the times were written more coarsely"
        )
    whole = round(1.0 / period)
    if whole >= 1 and _off_line(t, 1.0 / whole, centre, rounding, row) is None:
        return float(whole)
    return 1.0 / period


# ------------------------------------------------------------------------------------------ MDF, TDMS
def import_tdms(
    path: str | Path, mapping: ImportMapping, *, sample_rate_hz: float | None = None
) -> Recording:
    """A recording from an NI TDMS file.

    Parameters
    ----------
    path : str or Path
    mapping : ImportMapping
        Sources are ``group/channel``.
    sample_rate_hz : float, optional
        [Hz]; overrides the mapping's ``sample_rate_hz``, which overrides the file's ``wf_increment``.

    Returns
    -------
    Recording
    """
    nptdms = _need("nptdms")
    source = Path(path)
    _not_for(mapping, source, "TDMS")
    given = sample_rate_hz or mapping.sample_rate_hz
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
        group, name = str(m.source).split("/", 1)
        ch = tdms[group][name]
        props = ch.properties
        increment = float(props.get("wf_increment", 0.0))
        if given is None and not increment > 0:
            raise FormatError(
                f"{source}: channel {m.source!r} has no wf_increment (sample interval); {_HINT}"
            )
        if start is None and "wf_start_time" in props:
            start = props["wf_start_time"].astype("datetime64[us]").astype(datetime)
        channels.append(
            _channel(
                m,
                ch[:],
                given or 1.0 / increment,
                float(props.get("wf_start_offset", 0.0)),
                str(props.get("unit_string", "")),
            )
        )
    return Recording(
        mapping.engine_id,
        _start(mapping, start),
        tuple(channels),
        notes=mapping.notes,
        cycle_phase_deg=mapping.cycle_phase_deg,
    )


def import_mdf(path: str | Path, mapping: ImportMapping, *, sample_rate_hz: float | None = None) -> Recording:
    """A recording from an ASAM MDF (3 or 4) file.

    Parameters
    ----------
    path : str or Path
    mapping : ImportMapping
        Sources are channel names.
    sample_rate_hz : float, optional
        [Hz]; overrides the mapping's ``sample_rate_hz``. Without either, each
        channel's rate is derived from its time stamps, within their rounding.

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
    _not_for(mapping, source, "MDF")
    given = sample_rate_hz or mapping.sample_rate_hz
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
            if stamps.size == 0:
                raise FormatError(f"{source}: channel {m.source!r} has no samples")
            if given is not None:
                rate = given
            else:
                rounding = (
                    _Rounding(stated=mapping.time_tolerance_s)
                    if mapping.time_tolerance_s is not None
                    else _grid_rounding(stamps)
                )
                rate = _fixed_rate(
                    stamps, rounding, f"{source}: channel {m.source!r}", lambda k: f"sample {k}"
                )
            channels.append(
                _channel(m, np.asarray(signal.samples), rate, float(stamps[0]), str(signal.unit or ""))
            )
        start = mdf.header.start_time
    return Recording(
        mapping.engine_id,
        _start(mapping, start),
        tuple(channels),
        notes=mapping.notes,
        cycle_phase_deg=mapping.cycle_phase_deg,
    )


# ------------------------------------------------------------------------------------------ text
@dataclass(frozen=True)
class _TextLayout:
    """What a text export's first and last lines tell: how to split it and where its numbers start."""

    encoding: str
    delimiter: str | None  # None: runs of whitespace
    decimal_comma: bool
    header_rows: int
    header: tuple[tuple[str, ...], ...]  # the header lines, split
    columns: int
    sample: tuple[tuple[str, ...], ...]  # rows of numbers from the head and the tail, split


def _fields(line: str, delimiter: str | None) -> list[str]:
    if delimiter is None:
        return [f.strip('"') for f in line.split()]
    fields = [f.strip().strip('"') for f in next(csv.reader([line], delimiter=delimiter), [])]
    if len(fields) > 1 and fields[-1] == "":  # a delimiter ending the line
        fields.pop()
    return fields


def _is_number(text: str, decimal_comma: bool) -> bool:
    try:
        float(text.replace(",", ".") if decimal_comma else text)
    except ValueError:
        return False
    return True


def _delimiter_name(delimiter: str | None) -> str:
    return {None: "whitespace", "\t": "tab"}.get(delimiter, repr(delimiter))


def _sniff(source: Path, mapping: ImportMapping) -> _TextLayout:
    """The layout of a text export, from its first and last lines and the mapping."""
    try:
        with open(source, "rb") as fh:
            head = fh.read(_SNIFF_BYTES)
            size = fh.seek(0, os.SEEK_END)
            fh.seek(max(len(head), size - _SNIFF_BYTES))
            tail = fh.read()
    except OSError as error:
        raise FormatError(f"{source}: cannot read: {error.strerror or error}") from None
    try:
        head.decode("utf-8")
        encoding = "utf-8-sig"
    except UnicodeDecodeError as error:  # a multi-byte character cut at the end is still UTF-8
        encoding = "utf-8-sig" if error.start >= len(head) - 3 and size > len(head) else "latin-1"
    head_lines = head.decode(encoding, errors="replace").splitlines()
    if size > len(head):
        head_lines.pop()  # cut short
    tail_lines = [line for line in tail.decode(encoding, errors="replace").splitlines()[1:] if line.strip()]
    if not tail_lines:  # the file is all in the head (the first line of the tail is cut short)
        tail_lines = [line for line in head_lines if line.strip()]
    tail_lines = tail_lines[-_SNIFF_LINES:]
    head_lines = head_lines[:_SNIFF_LINES]
    probe = tail_lines[-20:]
    if not probe:
        raise FormatError(f"{source}: the file holds no rows of numbers")
    if mapping.delimiter is not None:
        candidates: list[str | None] = [
            {"tab": "\t", "whitespace": None, " ": None}.get(mapping.delimiter, mapping.delimiter)
        ]
    else:
        candidates = ["\t", ";", ",", None]
    found: tuple[str | None, bool, int] | None = None
    for least in (2, 1):  # rather several columns than one column of numbers with a decimal comma
        for candidate in candidates:
            rows = [_fields(line, candidate) for line in probe]
            columns = len(rows[0])
            comma = candidate != "," and any("," in f for r in rows for f in r)
            if (
                columns >= least
                and all(len(r) == columns for r in rows)
                and all(_is_number(f, comma) for r in rows for f in r)
            ):
                found = candidate, comma, columns
                break
        if found:
            break
    if found is None:
        if re.search(r"\d\.\d{3},\d|\d,\d{3}\.\d", probe[-1]):
            raise FormatError(
                f"{source}: the numbers have thousands separators ({probe[-1]!r}), which cannot be read "
                "safely; expected an export without them"
            )
        given = (
            f"by {_delimiter_name(candidates[0])}" if mapping.delimiter else "by tab, ';', ',' or whitespace"
        )
        raise FormatError(
            f"{source}: the last line {probe[-1]!r} does not split into numbers {given}; "
            "expected rows of numbers (give delimiter in the mapping if it is another character)"
        )
    delimiter, decimal_comma, columns = found

    def numbers(line: str) -> tuple[str, ...] | None:
        fields = _fields(line, delimiter)
        if len(fields) == columns and all(_is_number(f, decimal_comma) for f in fields):
            return tuple(f.replace(",", ".") for f in fields) if decimal_comma else tuple(fields)
        return None

    if mapping.header_rows is not None:
        header_rows = mapping.header_rows
    else:
        header_rows = next((i for i, line in enumerate(head_lines) if numbers(line) is not None), -1)
        if header_rows < 0:
            raise FormatError(
                f"{source}: no row of numbers in the first {len(head_lines)} lines; "
                "give header_rows in the mapping"
            )
    sample = [numbers(line) for line in [*head_lines[header_rows:], *tail_lines]]
    return _TextLayout(
        encoding=encoding,
        delimiter=delimiter,
        decimal_comma=decimal_comma,
        header_rows=header_rows,
        header=tuple(tuple(_fields(line, delimiter)) for line in head_lines[:header_rows]),
        columns=columns,
        sample=tuple(r for r in sample if r is not None),
    )


def _column(spec: str | int, layout: _TextLayout, source: Path, what: str) -> int:
    """The 0-based column that a mapping's source or time_column names."""
    if isinstance(spec, int):
        if spec >= layout.columns:
            raise FormatError(
                f"{source}: {what}: there is no column {spec}; the rows have {layout.columns} columns "
                f"(0 to {layout.columns - 1})"
            )
        return spec
    for names in layout.header:
        if spec in names:
            index = names.index(spec)
            if names.count(spec) > 1 or index >= layout.columns:
                raise FormatError(
                    f"{source}: {what}: column {spec!r} is not one column of the rows; "
                    "expected its 0-based number instead"
                )
            return index
    if not layout.header:
        number = f" (source = {spec} without quotes is column {spec})" if spec.isdigit() else ""
        raise FormatError(
            f"{source}: {what}: no column {spec!r}: the file has no header row; "
            f"expected a 0-based column number{number}"
        )
    names = next((h for h in layout.header if len(h) == layout.columns), layout.header[-1])
    raise FormatError(
        f"{source}: {what}: no column {spec!r}; the header has {', '.join(repr(n) for n in names)} "
        "(or give a 0-based column number)"
    )


def _count_lines(source: Path) -> int:
    """Lines in a file (an upper bound of its rows), counted without decoding it."""
    newlines = returns = 0
    last = b""
    with open(source, "rb") as fh:
        while chunk := fh.read(1 << 24):
            newlines += chunk.count(b"\n")
            returns += chunk.count(b"\r")
            last = chunk[-1:]
    return max(newlines, returns) + (1 if last not in (b"", b"\n", b"\r") else 0)


def _loadtxt_message(source: Path, error: ValueError, lines_before: int) -> str:
    text = str(error)
    found = re.search(r"could not convert string (.*) to float64 at row (\d+), column (\d+)", text)
    if found:
        line, column = lines_before + int(found.group(2)) + 1, int(found.group(3)) - 1
        return f"{source}: line {line}, column {column} (0-based): {found.group(1)} is not a number"
    found = re.search(r"invalid column index (\d+) at row (\d+) with (\d+) columns", text)
    if found:
        line = lines_before + int(found.group(2)) + 1
        return (
            f"{source}: line {line} has {found.group(3)} columns; expected at least {int(found.group(1)) + 1}"
        )
    found = re.search(r" at row (\d+)", text)
    if found:
        line = lines_before + int(found.group(1)) + 1
        return f"{source}: line {line}: {text.replace(found.group(0), '')}"
    return f"{source}: cannot read the numbers: {text}"


def _read_columns(
    source: Path, layout: _TextLayout, dtypes: dict[int, type[np.floating[Any]]]
) -> tuple[dict[int, np.ndarray], Callable[[int], str]]:
    """The columns of a text export, read by blocks of rows, and the names of its rows for messages."""
    usecols = sorted(dtypes)
    capacity = max(_count_lines(source) - layout.header_rows, 0)
    out = {c: np.empty(capacity, dtype=dtypes[c]) for c in usecols}
    rows = lines_read = trailing = 0
    first_skip: int | None = None  # rows before the first block with blank or comment lines
    try:
        with open(source, encoding=layout.encoding, errors="replace") as fh:
            for _ in range(layout.header_rows):
                fh.readline()
            lines: Iterator[str] = (
                (line.replace(",", ".") for line in fh) if layout.decimal_comma else iter(fh)
            )
            while block := list(itertools.islice(lines, _BLOCK)):
                try:
                    with warnings.catch_warnings():
                        warnings.simplefilter("ignore", UserWarning)  # a block of blank lines has no data
                        values = np.loadtxt(
                            block, delimiter=layout.delimiter, usecols=usecols, ndmin=2, quotechar='"'
                        )
                except ValueError as error:
                    raise FormatError(
                        _loadtxt_message(source, error, layout.header_rows + lines_read)
                    ) from None
                k = values.shape[0]
                if rows + k > capacity:  # only if counting the lines was wrong
                    capacity = 2 * (rows + k)
                    out = {
                        c: np.concatenate([a[:rows], np.empty(capacity - rows, a.dtype)])
                        for c, a in out.items()
                    }
                for j, c in enumerate(usecols):
                    out[c][rows : rows + k] = values[:, j]
                trailing = 0
                if k < len(block):
                    first_skip = rows if first_skip is None else first_skip
                    while trailing < len(block) and not block[-1 - trailing].strip():
                        trailing += 1
                rows += k
                lines_read += len(block)
    except OSError as error:
        raise FormatError(f"{source}: cannot read: {error.strerror or error}") from None
    if rows == 0:
        raise FormatError(f"{source}: no rows of numbers after the {layout.header_rows} header line(s)")
    exact = rows if lines_read - trailing == rows else (first_skip or 0)

    def row(k: int) -> str:
        return f"line {layout.header_rows + k + 1}" if k < exact else f"data row {k + 1}"

    return {c: a[:rows] for c, a in out.items()}, row


def import_text(
    path: str | Path, mapping: ImportMapping, *, sample_rate_hz: float | None = None
) -> Recording:
    """A recording from a text export: a time column and one column per channel (CSV and the like).

    Parameters
    ----------
    path : str or Path
    mapping : ImportMapping
        Sources are header names or 0-based column numbers; ``start_time``,
        ``time_column`` or ``sample_rate_hz``, and each channel's ``unit`` are required.
    sample_rate_hz : float, optional
        [Hz]; overrides the mapping's ``sample_rate_hz``. Without either, the
        rate is derived from the time column, within the rounding of its printed times.

    Returns
    -------
    Recording

    Raises
    ------
    FormatError
        Naming the line, the column or the mapping key that is wrong.
    """
    source = Path(path)
    start = _start(mapping, None)
    for m in mapping.channels:
        if m.unit is None:
            raise FormatError(
                f"{source}: channel {m.name!r}: a text file carries no units; give unit in the channel "
                f"mapping (for a {m.kind} channel: {', '.join(UNITS.get(m.kind, ()))})"
            )
    given = sample_rate_hz or mapping.sample_rate_hz
    if given is None and mapping.time_column is None:
        raise FormatError(
            f"{source}: no time column and no rate: give time_column or sample_rate_hz in the channel mapping"
        )
    layout = _sniff(source, mapping)
    time = (
        None if mapping.time_column is None else _column(mapping.time_column, layout, source, "time_column")
    )
    wanted = [_column(m.source, layout, source, f"channel {m.name!r}") for m in mapping.channels]
    digits = max((_significant(r[c]) for r in layout.sample for c in wanted), default=0)
    dtype: type[np.floating[Any]] = np.float32 if digits <= _FLOAT32_DIGITS else np.float64
    dtypes = {c: dtype for c in wanted}
    if time is not None:
        dtypes[time] = np.float64
    columns, row = _read_columns(source, layout, dtypes)
    offset, rate = 0.0, given or 0.0  # a rate is given, or derived from the time column below
    if time is not None:
        scale = _TIME_UNITS[mapping.time_unit]
        t = columns[time]
        if scale != 1.0:  # in place, unless the time column is also a channel
            t = t * scale if time in wanted else np.multiply(t, scale, out=t)
        offset = float(t[0])
        if given is None:
            if mapping.time_tolerance_s is not None:
                rounding = _Rounding(stated=mapping.time_tolerance_s)
            else:
                printed = _printed_rounding(r[time] for r in layout.sample)
                rounding = _Rounding(step=printed.step * scale, significant=printed.significant)
            rate = _fixed_rate(t, rounding, f"{source}: time column {mapping.time_column!r}", row)
    channels = tuple(
        _channel(m, columns[c], rate, offset, "") for m, c in zip(mapping.channels, wanted, strict=True)
    )
    return Recording(
        mapping.engine_id, start, channels, notes=mapping.notes, cycle_phase_deg=mapping.cycle_phase_deg
    )


def _is_mdf(source: Path) -> bool:
    try:
        with open(source, "rb") as fh:
            return fh.read(8).startswith((b"MDF", b"UnFinMF"))
    except OSError:
        return False


def import_file(
    path: str | Path, mapping: ImportMapping, *, sample_rate_hz: float | None = None
) -> Recording:
    """A recording from a test-bench file, read by its suffix: MDF, TDMS or a text export.

    ``.mf4`` and ``.mdf`` are MDF, ``.tdms`` is TDMS, ``.csv``, ``.txt`` and
    ``.tsv`` are text; ``.dat`` is MDF when it starts like one (MDF 3 files
    often end in ``.dat``), else text.

    Parameters
    ----------
    path : str or Path
    mapping : ImportMapping
    sample_rate_hz : float, optional
        [Hz]; overrides the mapping's ``sample_rate_hz`` and the file's own rate.

    Returns
    -------
    Recording

    Raises
    ------
    FormatError
        For an unknown suffix, and whatever the reader refuses.
    """
    source = Path(path)
    suffix = source.suffix.lower()
    if suffix == ".tdms":
        return import_tdms(source, mapping, sample_rate_hz=sample_rate_hz)
    if suffix in (".mf4", ".mdf") or (suffix == ".dat" and _is_mdf(source)):
        return import_mdf(source, mapping, sample_rate_hz=sample_rate_hz)
    if suffix in TEXT_SUFFIXES:
        return import_text(source, mapping, sample_rate_hz=sample_rate_hz)
    raise FormatError(
        f"{source}: unknown source type {suffix!r}; expected .mf4, .mdf, .dat, .tdms, .csv, .txt or .tsv"
    )
