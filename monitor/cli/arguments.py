"""What the commands share: argument types, options given alike, the JSON output and the store's address.

Nothing here imports more than the standard library at start-up: the quick
commands (``--help``, ``engines``, ``orders``) build every command's parser.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path
from typing import Any

__all__ = [
    "ENGINE_MISSING",
    "add_cycle_phase",
    "add_exclude_channel",
    "add_store_option",
    "count",
    "exit_3_on_usage_error",
    "port",
    "positive_float",
    "positive_int",
    "print_json",
    "seed",
    "store_url",
]

ENGINE_MISSING = "is not bundled: give its description with --engine FILE.toml"
"""What a command that reads a recording says of an engine it does not know (after ``engine 'ID'``)."""


def _whole(text: str) -> int:
    try:
        return int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a whole number") from None


def positive_float(text: str) -> float:
    """A positive, finite number (argparse type).

    Parameters
    ----------
    text : str
        As given on the command line.

    Returns
    -------
    float

    Raises
    ------
    argparse.ArgumentTypeError
        With argparse's message when the text is not one.
    """
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None
    if not value > 0 or value != value or value == float("inf"):
        raise argparse.ArgumentTypeError(f"{text!r}: expected a positive, finite number")
    return value


def positive_int(text: str) -> int:
    """A whole number, 1 or more (argparse type).

    Parameters
    ----------
    text : str
        As given on the command line.

    Returns
    -------
    int

    Raises
    ------
    argparse.ArgumentTypeError
        With argparse's message when the text is not one.
    """
    value = _whole(text)
    if value < 1:
        raise argparse.ArgumentTypeError(f"{text!r}: expected 1 or more")
    return value


def count(text: str) -> int:
    """A whole number, 0 or more (argparse type).

    Parameters
    ----------
    text : str
        As given on the command line.

    Returns
    -------
    int

    Raises
    ------
    argparse.ArgumentTypeError
        With argparse's message when the text is not one.
    """
    value = _whole(text)
    if value < 0:
        raise argparse.ArgumentTypeError(f"{text!r}: expected 0 or more")
    return value


def seed(text: str) -> int:
    """A noise seed, 0 to 2**63 - 1 (argparse type).

    Parameters
    ----------
    text : str
        As given on the command line.

    Returns
    -------
    int

    Raises
    ------
    argparse.ArgumentTypeError
        With argparse's message when the text is not one.
    """
    value = _whole(text)
    if not 0 <= value < 2**63:
        raise argparse.ArgumentTypeError(f"{text!r}: expected a seed from 0 to 2**63 - 1")
    return value


def port(text: str) -> int:
    """A TCP port, 1 to 65535 (argparse type).

    Parameters
    ----------
    text : str
        As given on the command line.

    Returns
    -------
    int

    Raises
    ------
    argparse.ArgumentTypeError
        With argparse's message when the text is not one.
    """
    value = _whole(text)
    if not 1 <= value <= 65535:
        raise argparse.ArgumentTypeError(f"{value}: expected a TCP port, 1 to 65535")
    return value


def exit_3_on_usage_error(parser: argparse.ArgumentParser) -> Any:
    """``compare``'s and ``batch``'s usage errors exit with 3 (could not diagnose), not argparse's 2 (an
    alarm).

    Parameters
    ----------
    parser : argparse.ArgumentParser
        The command's parser, whose ``error`` this replaces.

    Returns
    -------
    callable
        The parser's new ``error(message)``.
    """

    def error(message: str) -> Any:
        parser.print_usage(sys.stderr)
        parser.exit(3, f"{parser.prog}: error: {message}\n")

    return error


def add_exclude_channel(parser: argparse.ArgumentParser) -> None:
    """The --exclude-channel option of the commands that diagnose or calibrate.

    Parameters
    ----------
    parser : argparse.ArgumentParser
        The command's parser.
    """
    parser.add_argument(
        "--exclude-channel",
        metavar="NAME",
        action="append",
        default=[],
        help="leave this channel out (a sensor known to be faulty); repeat for more",
    )


def add_cycle_phase(parser: argparse.ArgumentParser, *, unknown: bool = False) -> None:
    """The --cycle-phase option of the commands that read a four-stroke recording.

    Parameters
    ----------
    parser : argparse.ArgumentParser
        The command's parser.
    unknown : bool, optional
        Whether 'unknown' is taken too (``compare``: cylinders named in pairs).
    """
    parser.add_argument(
        "--cycle-phase",
        type=_cycle_phase_deg_or_unknown if unknown else _cycle_phase_deg,
        metavar="0|360|unknown" if unknown else "0|360",
        help="four-stroke without a cam or cylinder-1 pressure channel: which revolution holds cylinder 1's "
        "firing TDC, as degrees added to the angle reference's crank angle (0 or 360)"
        + ("; 'unknown' names each cylinder together with the one firing 360 deg from it" if unknown else ""),
    )


def _cycle_phase_deg(text: str) -> float:
    """--cycle-phase 0|360 as the shift of the angle reference [rad]."""
    try:
        value = float(text)
    except ValueError:
        value = math.nan
    if value not in (0.0, 360.0):
        raise argparse.ArgumentTypeError(f"{text!r}: expected 0 or 360 (degrees)")
    return math.radians(value)


def _cycle_phase_deg_or_unknown(text: str) -> float | str:
    """--cycle-phase 0|360|unknown."""
    return "unknown" if text == "unknown" else _cycle_phase_deg(text)


def add_store_option(parser: argparse.ArgumentParser) -> None:
    """The --store option of the commands that use the results store (with --data, :func:`store_url`).

    Parameters
    ----------
    parser : argparse.ArgumentParser
        The command's parser.
    """
    parser.add_argument(
        "--store", metavar="URL", help="the store (default: $ENGINE_MONITOR_DB, else DATA/engine-monitor.db)"
    )


def store_url(given: str | None, data: str) -> str:
    """The store a command uses: --store, else $ENGINE_MONITOR_DB, else the SQLite file in --data.

    Parameters
    ----------
    given : str or None
        --store.
    data : str
        --data, the service's data folder.

    Returns
    -------
    str
        The store's URL.
    """
    from monitor.store import default_url  # SQLAlchemy: only for the commands that use the store

    return given or default_url(Path(data))


def print_json(document: Any, *, indent: int = 1) -> None:
    """A command's JSON document on standard output, ended by a new line.

    Parameters
    ----------
    document : Any
        JSON-ready.
    indent : int, optional
        Spaces per level.
    """
    json.dump(document, sys.stdout, indent=indent)
    sys.stdout.write("\n")
