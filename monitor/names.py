"""Names people give and read: channels, engines, fleets and key labels, as printable text.

A name is shown in listings, page headings, file names and messages, and
compared byte for byte. So it must read as what it is: every character
printable (no C0 or C1 control, no line or paragraph separator, no Unicode
format character, among them the bidirectional controls that make a name
display as another and the zero-width ones that make two names look
alike), at most a stated number of characters, never '.' or '..' (a name
that is also a path step), and, for the names the product is given by its
operators (a fleet, a key's label), without leading or trailing white space:
such a name is refused, never stripped silently into another.
"""

from __future__ import annotations

import unicodedata

from monitor.errors import NamingError

__all__ = ["MAX_NAME", "check_name", "name_problem"]

#: The most characters of a name (the store's columns hold 200).
MAX_NAME = 200
#: Unicode categories of characters that do not print: controls, format characters (bidirectional
#: controls, zero-width characters, the byte order mark), surrogates, line and paragraph separators.
_UNPRINTABLE = frozenset({"Cc", "Cf", "Cs", "Zl", "Zp"})


def name_problem(
    name: str, *, max_length: int = MAX_NAME, padded: bool = True, path_step: bool = False
) -> str | None:
    """What is wrong with a name, in words, or None for a good one.

    Parameters
    ----------
    name : str
    max_length : int, optional
        The most characters.
    padded : bool, optional
        Whether leading or trailing white space is allowed.
    path_step : bool, optional
        Whether the name is also a path step (a channel's HDF5 dataset or MCAP topic): then '/' is
        refused too.

    Returns
    -------
    str or None
        E.g. "U+202E (RIGHT-TO-LEFT OVERRIDE) at character 3 does not print".
    """
    if not isinstance(name, str):
        return f"expected text, got {type(name).__name__}"
    if not name:
        return "it is empty"
    if len(name) > max_length:
        return f"{len(name)} characters, more than the {max_length} a name may have"
    if name in (".", ".."):
        return "'.' and '..' are path steps, not names"
    for position, character in enumerate(name, start=1):
        if unicodedata.category(character) in _UNPRINTABLE:
            described = unicodedata.name(character, "a control character")
            return f"U+{ord(character):04X} ({described}) at character {position} does not print"
        if path_step and character == "/":
            return f"'/' at character {position} separates path steps"
    if not padded and name != name.strip():
        return "it begins or ends with white space"
    return None


def check_name(what: str, name: str, *, max_length: int = MAX_NAME, padded: bool = False) -> str:
    """``name``, once it is a good name, else a :class:`NamingError` naming ``what`` and the problem.

    Parameters
    ----------
    what : str
        What the name is of, for the message ("fleet name", "key label").
    name : str
    max_length : int, optional
    padded : bool, optional
        Whether leading or trailing white space is allowed (not for operators' names).

    Returns
    -------
    str
        ``name`` unchanged.

    Raises
    ------
    NamingError
    """
    problem = name_problem(name, max_length=max_length, padded=padded)
    if problem is not None:
        raise NamingError(
            f"{what} {_shown(name)}: {problem}; expected 1 to {max_length} printable characters without "
            "control, bidirectional or zero-width characters"
            + ("" if padded else ", and no white space at either end")
        )
    return name


def _shown(name: str, limit: int = 40) -> str:
    """A name as a message shows it: quoted, its unprintable characters escaped (``repr``), cut short."""
    return repr(name[:limit]) + (
        f" (the first {limit} of {len(name)} characters)" if len(name) > limit else ""
    )
