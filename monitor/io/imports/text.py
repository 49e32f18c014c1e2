"""Import from text exports: a time column and one column per channel (see :mod:`monitor.io.imports`)."""

from __future__ import annotations

import itertools
import os
import re
import warnings
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from monitor.errors import FormatError
from monitor.io.imports.columns import is_number, numbered_column, split_fields
from monitor.io.imports.mapping import (
    LEVEL_CHANGES,
    TIME_UNITS,
    ImportMapping,
    mapped_channel,
    mapped_start_time,
)
from monitor.io.imports.rates import BLOCK_ROWS, Rounding, fixed_rate, printed_rounding, significant_digits
from monitor.io.recording import UNITS, Recording

__all__ = ["TEXT_SUFFIXES", "import_text"]

#: File suffixes read as text exports (``.dat`` only when it is not an MDF file).
TEXT_SUFFIXES = (".csv", ".txt", ".tsv", ".dat")
_SNIFF_BYTES = 1 << 16  # bytes read at each end of a text file to learn its layout
_SNIFF_LINES = 200
_FLOAT32_DIGITS = 7  # float32 tells apart all numbers of 7 significant digits


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
            rows = [split_fields(line, candidate) for line in probe]
            columns = len(rows[0])
            comma = candidate != "," and any("," in f for r in rows for f in r)
            if (
                columns >= least
                and all(len(r) == columns for r in rows)
                and all(is_number(f, comma) for r in rows for f in r)
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
        fields = split_fields(line, delimiter)
        if len(fields) == columns and all(is_number(f, decimal_comma) for f in fields):
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
        header=tuple(tuple(split_fields(line, delimiter)) for line in head_lines[:header_rows]),
        columns=columns,
        sample=tuple(r for r in sample if r is not None),
    )


def _column(spec: str | int, layout: _TextLayout, source: Path, what: str) -> int:
    """The 0-based column that a mapping's source or time_column names."""
    if isinstance(spec, int):
        return numbered_column(spec, layout.columns, source, what)
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
            while block := list(itertools.islice(lines, BLOCK_ROWS)):
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
    if mapping.layout == LEVEL_CHANGES:
        raise FormatError(
            f"{source}: the mapping says layout = {LEVEL_CHANGES!r}: a level-change capture is read by "
            "monitor.io.imports.levels.import_levels (engine-monitor import dispatches it)"
        )
    start = mapped_start_time(mapping, None)
    for m in mapping.channels:
        if m.edge is not None:
            raise FormatError(
                f"{source}: channel {m.name!r}: edge applies to a level-change capture "
                f'(layout = "{LEVEL_CHANGES}"); expected no edge for a column of samples'
            )
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
    digits = max((significant_digits(r[c]) for r in layout.sample for c in wanted), default=0)
    dtype: type[np.floating[Any]] = np.float32 if digits <= _FLOAT32_DIGITS else np.float64
    dtypes = {c: dtype for c in wanted}
    if time is not None:
        dtypes[time] = np.float64
    columns, row = _read_columns(source, layout, dtypes)
    offset, rate = 0.0, given or 0.0  # a rate is given, or derived from the time column below
    if time is not None:
        scale = TIME_UNITS[mapping.time_unit]
        t = columns[time]
        if scale != 1.0:  # in place, unless the time column is also a channel
            t = t * scale if time in wanted else np.multiply(t, scale, out=t)
        offset = float(t[0])
        if given is None:
            if mapping.time_tolerance_s is not None:
                rounding = Rounding(stated=mapping.time_tolerance_s)
            else:
                printed = printed_rounding(r[time] for r in layout.sample)
                rounding = Rounding(step=printed.step * scale, significant=printed.significant)
            rate = fixed_rate(t, rounding, f"{source}: time column {mapping.time_column!r}", row)
    channels = tuple(
        mapped_channel(m, columns[c], rate, offset, "") for m, c in zip(mapping.channels, wanted, strict=True)
    )
    return Recording(
        mapping.engine_id, start, channels, notes=mapping.notes, cycle_phase_deg=mapping.cycle_phase_deg
    )
