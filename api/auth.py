"""Who asks: the fleet of an API key, sent by a program in a header or held by a browser in a session.

- Programs send the key in ``X-API-Key`` (the OpenAPI scheme ``ApiKey``), as
  they always have.
- A browser cannot send a header when it opens a page, so ``POST /login``
  takes the key once from a form and sets a session cookie (the scheme
  ``Session``): ``HttpOnly`` (no script reads it), ``SameSite=Strict`` (no
  other site's page sends it), ``Secure`` when the request came over HTTPS. It
  holds a token the server signed (HMAC-SHA256 with a secret kept in the data
  folder, :func:`session_secret`): the key's SHA-256 digest and the time the
  session ends, never the key. Each request finds the digest's fleet as a
  header's key is found (a revoked key ends its sessions within the key
  cache's second). ``POST /logout`` clears the cookie.
- :func:`fleet_of` gives the fleet from the header, else from the cookie: the
  one dependency of the JSON routes (:data:`Fleet`) and of the pages
  (:data:`PageFleet`, which sends a browser without a session to the login).
- Cross-site requests: a request that changes state (any method but GET, HEAD
  and OPTIONS) and comes with the cookie alone must carry ``X-CSRF-Token``
  equal to the session's CSRF token, which the login sets in a second cookie
  that the service's own pages read (not ``HttpOnly``); another site can
  neither read it nor send a custom header without a CORS preflight, which this
  service never allows. ``POST /login`` and ``POST /logout`` are refused when
  the browser says they came from another site (``Sec-Fetch-Site``,
  ``Origin``), so no page elsewhere logs a browser into its own fleet.
"""

from __future__ import annotations

import hashlib
import hmac
import os
import secrets
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Annotated
from urllib.parse import urlsplit

from fastapi import Depends, Request, Security
from fastapi.security import APIKeyCookie, APIKeyHeader

from api.errors import ApiError, LoginRequired
from api.reads import KeyCache, read
from monitor.errors import MonitorError
from monitor.store import Store, key_digest

__all__ = [
    "CSRF_COOKIE",
    "CSRF_HEADER",
    "SESSION_COOKIE",
    "SESSION_S",
    "Fleet",
    "PageFleet",
    "Sessions",
    "api_key_header",
    "fleet_of",
    "page_fleet",
    "same_site",
    "session_cookie",
    "session_secret",
]

SESSION_COOKIE = "engine_monitor_session"
CSRF_COOKIE = "engine_monitor_csrf"
CSRF_HEADER = "X-CSRF-Token"
#: How long a session lasts after its login [s].
SESSION_S = 12 * 3600.0
#: The methods that change nothing (a cookie alone may send them, without the CSRF token).
SAFE_METHODS = frozenset({"GET", "HEAD", "OPTIONS"})

api_key_header = APIKeyHeader(
    name="X-API-Key",
    scheme_name="ApiKey",
    description="the fleet's API key (engine-monitor keys create)",
    auto_error=False,
)
session_cookie = APIKeyCookie(
    name=SESSION_COOKIE,
    scheme_name="Session",
    description="a browser's session, set by POST /login; a request that changes state with it alone "
    f"also sends {CSRF_HEADER}, the value of the {CSRF_COOKIE} cookie",
    auto_error=False,
)


def session_secret(data_dir: Path) -> bytes:
    """The key sessions are signed with: ``session.key`` in the data folder, made on first use (32
    random bytes, readable by its owner alone), so sessions outlive a restart and every server on the
    same data folder accepts them. Delete the file to end every session.

    Parameters
    ----------
    data_dir : Path
    """
    path = data_dir / "session.key"
    try:
        handle = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o600)
    except FileExistsError:
        secret = path.read_bytes()
        if len(secret) < 32:
            raise MonitorError(
                f"{path}: the sessions' key holds {len(secret)} bytes, expected 32 or more (delete the "
                "file to make a new one; every session then ends)"
            ) from None
        return secret
    secret = secrets.token_bytes(32)
    with os.fdopen(handle, "wb") as out:
        out.write(secret)
        out.flush()
        os.fsync(out.fileno())
    return secret


@dataclass(frozen=True)
class Sessions:
    """Session tokens signed with a server's secret: ``DIGEST.EXPIRES.SIGNATURE``.

    Parameters
    ----------
    secret : bytes
    lifetime_s : float
        How long a session lasts after its login [s].
    """

    secret: bytes
    lifetime_s: float = SESSION_S

    def _sign(self, text: str) -> str:
        return hmac.new(self.secret, text.encode("ascii"), hashlib.sha256).hexdigest()

    def token(self, digest: str, now: float | None = None) -> str:
        """A new session's token for the key of this digest."""
        expires = int((time.time() if now is None else now) + self.lifetime_s)
        payload = f"{digest}.{expires}"
        return f"{payload}.{self._sign('session:' + payload)}"

    def digest(self, token: str, now: float | None = None) -> str | None:
        """The key digest a token holds, or None if the server did not sign it or it has expired."""
        parts = token.split(".")
        if len(parts) != 3 or not parts[1].isdigit() or len(parts[0]) != 64:
            return None
        payload = f"{parts[0]}.{parts[1]}"
        if not hmac.compare_digest(self._sign("session:" + payload), parts[2]):
            return None
        if int(parts[1]) <= (time.time() if now is None else now):
            return None
        return parts[0]

    def csrf(self, token: str) -> str:
        """The CSRF token of a session: what a request that changes state sends in ``X-CSRF-Token``."""
        return self._sign("csrf:" + token)


async def _fleet_of_digest(request: Request, digest: str) -> int | None:
    """The fleet of a key by its digest: remembered for the key cache's time, else one indexed query
    (:func:`api.reads.read`, as every read)."""
    keys: KeyCache = request.app.state.keys
    found = keys.fleet(digest)
    if found is not None:
        return found
    store: Store = request.app.state.store
    found = await read(request, store.fleet_of_digest, digest)
    if found is not None:
        keys.remember(digest, found)
    return found


async def fleet_of(
    request: Request,
    key: Annotated[str | None, Security(api_key_header)] = None,
    session: Annotated[str | None, Security(session_cookie)] = None,
) -> int:
    """The fleet of the request's API key (header), else of its session (cookie); 401 without either,
    403 for a request that changes state with the cookie alone and without its CSRF token.

    The dependency of every route that needs a key, JSON or page.
    """
    if key:
        digest = key_digest(key)
        unknown = "the API key is not known"
    elif session:
        sessions: Sessions = request.app.state.sessions
        found = sessions.digest(session)
        if found is None:
            raise ApiError(
                401, "session_expired", "the session has ended or was not made here: log in again at /login"
            )
        if request.method not in SAFE_METHODS and not hmac.compare_digest(
            request.headers.get(CSRF_HEADER, ""), sessions.csrf(session)
        ):
            raise ApiError(
                403,
                "csrf",
                f"a request that changes state with the session cookie alone must send {CSRF_HEADER}, the "
                f"value of the {CSRF_COOKIE} cookie (or send the key in X-API-Key instead)",
            )
        digest = found
        unknown = "the session's API key was revoked: log in again at /login with a valid key"
    else:
        raise ApiError(
            401,
            "missing_key",
            "an API key is needed: send it in the X-API-Key header (a browser: log in at /login)",
        )
    fleet = await _fleet_of_digest(request, digest)
    if fleet is None:
        raise ApiError(401, "unknown_key", unknown)
    return fleet


async def page_fleet(
    request: Request,
    key: Annotated[str | None, Security(api_key_header)] = None,
    session: Annotated[str | None, Security(session_cookie)] = None,
) -> int:
    """:func:`fleet_of` for a page a browser opens: without a valid key or session, the browser is sent
    to the login (:class:`LoginRequired`), which brings it back here."""
    try:
        return await fleet_of(request, key, session)
    except ApiError as error:
        if error.status == 401:
            raise LoginRequired(request.url.path) from None
        raise


Fleet = Annotated[int, Depends(fleet_of)]
PageFleet = Annotated[int, Depends(page_fleet)]


def same_site(request: Request) -> bool:
    """Whether the browser says the request came from this site (or says nothing, as a program does):
    ``Sec-Fetch-Site`` not ``cross-site`` or ``same-site``, and an ``Origin``, if sent, of this host."""
    if request.headers.get("sec-fetch-site", "same-origin") not in ("same-origin", "none"):
        return False
    origin = request.headers.get("origin")
    if origin is None:
        return True
    parts = urlsplit(origin)
    return parts.scheme in ("http", "https") and parts.netloc == request.headers.get("host", "")
