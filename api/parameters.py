"""The parameters a route reads from text: a file name, times, a page's cursor; each checked, or a
clear 4xx that names the parameter and what was expected."""

from __future__ import annotations

import base64
import json
import re
from datetime import UTC, datetime

from api.errors import ApiError
from monitor.store.trends import parse_since

__all__ = ["cursor", "filename", "moment", "next_cursor", "since"]

# a plain file name: no folder separators, no C0 or C1 controls, no line or paragraph separators and no
# bidirectional overrides (a name that displays as another), matched whole (``$`` would allow a final "\n")
_NAME = re.compile("[^/\\\\\x00-\x1f\x7f-\x9f\u2028\u2029\u202a-\u202e\u2066-\u2069]{1,255}")


def filename(name: str) -> str:
    """A plain file name, or a clear 400: no folders, no control characters, at most 255 bytes."""
    if not _NAME.fullmatch(name) or name in (".", "..") or len(name.encode("utf-8")) > 255:
        raise ApiError(
            400,
            "bad_filename",
            "filename: expected a plain file name of 1 to 255 bytes, without '/', '\\', NUL or control "
            "characters, and not '.' or '..'",
        )
    return name


def moment(name: str, text: str | None) -> datetime | None:
    """An ISO 8601 time (UTC if it has no zone), or a clear 422."""
    if text is None:
        return None
    try:
        when = datetime.fromisoformat(text)
        if when.tzinfo is not None:  # the store compares in UTC; at the calendar's ends that overflows
            when = when.astimezone(UTC)
        return when
    except (ValueError, OverflowError):
        raise ApiError(
            422, "invalid_request", f"{name}: expected an ISO 8601 date or time in years 1-9999, got {text!r}"
        ) from None


def since(text: str | None) -> datetime | None:
    """A trend's ``since`` (:func:`parse_since`), or a clear 422."""
    if text is None:
        return None
    try:
        return parse_since(text)
    except ValueError:
        raise ApiError(422, "bad_since", f"since={text!r}: expected a date or time in ISO 8601") from None


def next_cursor(uploaded_at: datetime, recording_id: int) -> str:
    """The cursor of the page after a recording: its upload time and id, opaque to clients."""
    text = json.dumps([uploaded_at.isoformat(), recording_id], separators=(",", ":"))
    return base64.urlsafe_b64encode(text.encode("utf-8")).decode("ascii").rstrip("=")


def cursor(text: str) -> tuple[datetime, int]:
    """The upload time and id a cursor stands for, or a clear 422."""
    try:
        stamp, recording_id = json.loads(base64.urlsafe_b64decode(text + "=" * (-len(text) % 4)))
        uploaded_at = datetime.fromisoformat(stamp)
        if uploaded_at.tzinfo is None or type(recording_id) is not int or not 0 < recording_id < 2**31:
            raise ValueError(text)
        return uploaded_at.astimezone(UTC), recording_id
    except (ValueError, TypeError, OverflowError):
        raise ApiError(
            422, "invalid_request", "cursor: expected the next_cursor of a previous page, unchanged"
        ) from None
