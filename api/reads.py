"""Reads that cost a key lookup and a stored document: entity tags, conditional answers, remembered keys.

- A result (a diagnosis, a spectrum) is answered with the JSON text the store
  holds, byte for byte: never parsed, never re-serialised. Its entity tag is
  the SHA-256 of that text, stored with it when it was written. A recording's
  metadata is small and changes with its analysis: its tag is the digest of
  the answer itself.
- ``If-None-Match`` with the current tag (or ``*``) answers 304 without a
  body. The key and the fleet are checked first all the same: another fleet's
  recording stays 404, and a revoked key 401, whatever tag is sent.
- ``Cache-Control: private, no-cache``: an answer depends on the key, so no
  shared cache may keep it, and a client's own copy is checked again (a cheap
  304) before each use, so a revoked key or a finished analysis is seen at
  once. ``Vary: X-API-Key, Cookie`` says the same to caches that read it (a
  browser's session is a cookie).
- :func:`read`: a read's one indexed query, on the event loop for SQLite, in
  one of the reads' threads for PostgreSQL.
- :class:`KeyCache`: the fleet of a key found in the store, remembered for
  :data:`KEY_TTL_S`, so a client's reads do not each look their key up. A
  key revoked meanwhile (by ``engine-monitor keys revoke``, in another
  process, which no cache here can hear) is refused at most that long after.
  Unknown keys are never remembered: a key just created works at once.
"""

from __future__ import annotations

import asyncio
import hashlib
import json
import time
from collections.abc import Callable, Iterable
from datetime import datetime
from typing import Any, TypeVar

from anyio import to_thread
from starlette.requests import Request
from starlette.responses import Response

__all__ = [
    "CACHE_CONTROL",
    "KEY_TTL_S",
    "KeyCache",
    "conditional",
    "json_body",
    "json_time",
    "matches",
    "read",
]

#: Seconds a key found in the store is taken as valid without asking the store again.
KEY_TTL_S = 1.0
CACHE_CONTROL = "private, no-cache"
_HEADERS = {"Cache-Control": CACHE_CONTROL, "Vary": "X-API-Key, Cookie"}
T = TypeVar("T")


async def read(request: Request, function: Callable[..., T], *args: Any) -> T:
    """``function(*args)``, a read's one indexed query. On SQLite it runs here, on the event loop: an
    in-process lookup of tens of microseconds that never waits for the writer (WAL), cheaper than
    the hand-over to a thread and back, which would cost more than the query. It first gives the loop
    one turn: a request answered whole in the step that began it let the loop serve the connections
    unevenly under load (50 readers: p99 280 to 480 ms at a p50 of 30 ms; with the turn, 90 to 160
    ms). On PostgreSQL, a round trip to a server, it runs in one of the reads' threads, so the loop
    serves others meanwhile."""
    state = request.app.state
    if state.store.dialect == "sqlite":
        await asyncio.sleep(0)
        return function(*args)
    return await to_thread.run_sync(function, *args, limiter=state.readers)


class KeyCache:
    """Fleets of recently seen API keys (by the keys' digests), each for ``ttl_s`` seconds.

    Parameters
    ----------
    ttl_s : float
        How long a key found in the store is trusted without asking it again [s]; 0: never.
    size : int, optional
        Keys remembered at most; past that the cache starts afresh (a bound, not a policy: a fleet
        has a handful of keys).
    """

    def __init__(self, ttl_s: float, size: int = 10_000) -> None:
        self.ttl_s = ttl_s
        self.size = size
        self._fleets: dict[str, tuple[int, float]] = {}

    def fleet(self, digest: str) -> int | None:
        """The remembered fleet of a key, or None (never seen, or seen too long ago)."""
        found = self._fleets.get(digest)
        if found is None:
            return None
        if time.monotonic() >= found[1]:
            self._fleets.pop(digest, None)
            return None
        return found[0]

    def remember(self, digest: str, fleet_id: int) -> None:
        """Remember a key the store has just confirmed."""
        if self.ttl_s <= 0:
            return
        if len(self._fleets) >= self.size:
            self._fleets.clear()
        self._fleets[digest] = (fleet_id, time.monotonic() + self.ttl_s)


def json_time(moment: datetime) -> str:
    """A time as the service's JSON writes it: ISO 8601, UTC as ``Z`` (as pydantic writes it)."""
    text = moment.isoformat()
    return text[:-6] + "Z" if text.endswith("+00:00") else text


def json_body(document: dict[str, Any]) -> bytes:
    """A small answer's JSON bytes (UTF-8, compact)."""
    return json.dumps(document, ensure_ascii=False, separators=(",", ":")).encode("utf-8")


def matches(if_none_match: str | None, tag: str) -> bool:
    """Whether an ``If-None-Match`` header names this entity tag (weak comparison, RFC 9110 13.1.2)."""
    if if_none_match is None:
        return False
    if if_none_match.strip() == "*":
        return True
    return tag in _tags(if_none_match.split(","))


def _tags(items: Iterable[str]) -> set[str]:
    return {item.strip().removeprefix("W/") for item in items}


def conditional(if_none_match: str | None, body: bytes, digest: str | None = None) -> Response:
    """The answer to a read: ``body`` (JSON) tagged with ``digest`` (default: the body's SHA-256), or
    304 when the client's ``If-None-Match`` names that tag."""
    tag = f'"{digest or hashlib.sha256(body).hexdigest()}"'
    headers = {"ETag": tag, **_HEADERS}
    if matches(if_none_match, tag):
        return Response(status_code=304, headers=headers)
    return Response(body, media_type="application/json", headers=headers)
