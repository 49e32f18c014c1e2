"""What text exports share: a line split into its fields, a number read, a column found by its number."""

from __future__ import annotations

import csv
from pathlib import Path

from monitor.errors import FormatError

__all__ = ["is_number", "numbered_column", "split_fields"]


def split_fields(line: str, delimiter: str | None) -> list[str]:
    """A line's fields, unquoted.

    Parameters
    ----------
    line : str
    delimiter : str or None
        None splits at runs of whitespace.

    Returns
    -------
    list of str
        A delimiter ending the line (as some exporters write one after the last column) makes no field.
    """
    if delimiter is None:
        return [f.strip('"') for f in line.split()]
    fields = [f.strip().strip('"') for f in next(csv.reader([line], delimiter=delimiter), [])]
    if len(fields) > 1 and fields[-1] == "":  # a delimiter ending the line
        fields.pop()
    return fields


def is_number(text: str, decimal_comma: bool = False) -> bool:
    """Whether a field reads as a number.

    Parameters
    ----------
    text : str
    decimal_comma : bool, optional
        A comma is the decimal point.

    Returns
    -------
    bool
    """
    try:
        float(text.replace(",", ".") if decimal_comma else text)
    except ValueError:
        return False
    return True


def numbered_column(spec: int, columns: int, source: Path, what: str) -> int:
    """A 0-based column number the rows hold.

    Parameters
    ----------
    spec : int
        The number a mapping gives.
    columns : int
        The columns of the rows [-].
    source : Path
        The file, for the message.
    what : str
        What names the column (a mapping key), for the message.

    Returns
    -------
    int
        ``spec``.

    Raises
    ------
    FormatError
        When the rows have no such column, naming the columns there are.
    """
    if spec >= columns:
        raise FormatError(
            f"{source}: {what}: there is no column {spec}; the rows have {columns} columns "
            f"(0 to {columns - 1})"
        )
    return spec
