"""The browser's way in: the login form, the logout, and the API's documentation page (Swagger UI).

- ``GET /login``: a form that asks for the API key; ``POST /login`` checks it
  and sets the session (:mod:`api.auth`), then sends the browser back to the
  page it came from (a path of this service only); a wrong key gets the form
  again with the reason, 401. ``POST /logout`` clears the session.
- ``GET /docs``: Swagger UI over ``/openapi.json``, behind the key like every
  route but ``/health`` (a browser without a session is sent to the login).
  Its scripts and styles are served here, under ``/docs/assets/``, from the
  installed package ``swagger-ui-bundle-v2``: the page loads nothing from
  elsewhere (its Content-Security-Policy allows this service alone), so it
  works on a ship without network. Its requests carry the session's CSRF
  token, so "Try it out" works for the routes that change state too.
"""

from __future__ import annotations

import html
import secrets
from pathlib import Path
from typing import Annotated
from urllib.parse import parse_qs

from fastapi import APIRouter, Query, Request
from fastapi import Path as FastPath
from fastapi.responses import FileResponse, HTMLResponse, RedirectResponse, Response
from starlette.concurrency import run_in_threadpool

from api.auth import CSRF_COOKIE, CSRF_HEADER, SESSION_COOKIE, Fleet, PageFleet, Sessions, same_site
from api.errors import ApiError
from monitor.store import Store, key_digest

__all__ = ["ASSETS", "router", "safe_next"]

router = APIRouter(include_in_schema=False)

#: The Swagger UI files the page loads, served from the installed package (nothing else of it is served).
ASSETS = {
    "swagger-ui-bundle.js": "text/javascript; charset=utf-8",
    "swagger-ui.css": "text/css; charset=utf-8",
    "favicon-32x32.png": "image/png",
}
#: The longest login form body read [bytes] (a key is 43 characters).
FORM_BYTES = 4096
_NO_STORE = {"Cache-Control": "no-store"}


def _swagger_folder() -> Path:
    from swagger_ui_bundle import swagger_ui_path

    return Path(str(swagger_ui_path))


def safe_next(target: str | None) -> str:
    """Where the login sends the browser: a path of this service (``/...``), never another site
    (``//host``, ``/\\host`` or a full URL would be an open redirect); else the fleet's page, ``/ui``."""
    if (
        not target
        or not target.startswith("/")
        or target.startswith(("//", "/\\"))
        or any(c < " " or c == "\\" for c in target)
    ):
        return "/ui"
    return target


def _csp(nonce: str = "") -> str:
    script = f"script-src 'self' 'nonce-{nonce}'" if nonce else "script-src 'none'"
    return (
        f"default-src 'self'; {script}; style-src 'self' 'unsafe-inline'; img-src 'self' data:; "
        "frame-ancestors 'none'; form-action 'self'; base-uri 'none'"
    )


def _page(body: str, *, status: int = 200, nonce: str = "", title: str = "engine-monitor") -> HTMLResponse:
    document = (
        '<!doctype html><html lang="en"><head><meta charset="utf-8">'
        f'<meta name="viewport" content="width=device-width, initial-scale=1"><title>{html.escape(title)}'
        f"</title></head><body>{body}</body></html>"
    )
    headers = {**_NO_STORE, "Content-Security-Policy": _csp(nonce), "X-Frame-Options": "DENY"}
    return HTMLResponse(document, status_code=status, headers=headers)


def _login_form(target: str, message: str = "", *, status: int = 200) -> HTMLResponse:
    said = f'<p role="alert" style="color:#b00020">{html.escape(message)}</p>' if message else ""
    return _page(
        '<main style="font-family:sans-serif;max-width:28rem;margin:4rem auto">'
        "<h1>engine-monitor</h1><p>Log in with your fleet's API key.</p>"
        f'{said}<form method="post" action="/login">'
        f'<input type="hidden" name="next" value="{html.escape(target)}">'
        '<label for="key">API key</label><br>'
        '<input id="key" name="key" type="password" autocomplete="current-password" required '
        'style="width:100%;margin:0.5rem 0">'
        '<button type="submit">Log in</button></form></main>',
        status=status,
        title="engine-monitor: log in",
    )


def _cross_site() -> ApiError:
    return ApiError(
        403,
        "cross_site",
        "the browser says this request came from another site: log in on this service's own page",
    )


@router.get("/login", response_class=HTMLResponse)
def login_form(next_path: Annotated[str | None, Query(alias="next", max_length=2000)] = None) -> HTMLResponse:
    """The login form."""
    return _login_form(safe_next(next_path))


@router.post("/login")
async def login(request: Request) -> Response:
    """Check the form's key; set the session and send the browser on, or show the form again (401)."""
    if not same_site(request):
        raise _cross_site()
    body = b""
    async for chunk in request.stream():
        body += chunk
        if len(body) > FORM_BYTES:
            raise ApiError(413, "too_large", f"the login form is over {FORM_BYTES} bytes: send the key alone")
    fields = parse_qs(body.decode("utf-8", "replace"), max_num_fields=10)
    key = (fields.get("key") or [""])[0].strip()
    target = safe_next((fields.get("next") or [""])[0])
    if not key:
        return _login_form(target, "Enter the API key.", status=401)
    digest = key_digest(key)
    store: Store = request.app.state.store
    if await run_in_threadpool(store.fleet_of_digest, digest) is None:
        return _login_form(target, "That API key is not known (or was revoked).", status=401)
    sessions: Sessions = request.app.state.sessions
    token = sessions.token(digest)
    answer = RedirectResponse(target, status_code=303, headers=_NO_STORE)
    secure = request.url.scheme == "https"
    lifetime = int(sessions.lifetime_s)
    answer.set_cookie(
        SESSION_COOKIE, token, max_age=lifetime, path="/", secure=secure, httponly=True, samesite="strict"
    )
    answer.set_cookie(
        CSRF_COOKIE, sessions.csrf(token), max_age=lifetime, path="/", secure=secure, samesite="strict"
    )
    return answer


@router.post("/logout")
def logout(request: Request) -> Response:
    """End the browser's session (its cookies are cleared) and show the login."""
    if not same_site(request):
        raise _cross_site()
    answer = RedirectResponse("/login", status_code=303, headers=_NO_STORE)
    for name, httponly in ((SESSION_COOKIE, True), (CSRF_COOKIE, False)):
        answer.delete_cookie(name, path="/", httponly=httponly, samesite="strict")
    return answer


_SWAGGER_INIT = """
const csrf = () => {
  const found = document.cookie.split("; ").find((c) => c.startsWith("%(cookie)s="));
  return found ? decodeURIComponent(found.slice(%(length)d)) : "";
};
window.ui = SwaggerUIBundle({
  url: "/openapi.json",
  dom_id: "#swagger-ui",
  deepLinking: true,
  presets: [SwaggerUIBundle.presets.apis],
  layout: "BaseLayout",
  requestInterceptor: (request) => {
    const token = csrf();
    if (token) request.headers["%(header)s"] = token;
    return request;
  },
});
"""


@router.get("/docs", response_class=HTMLResponse)
def docs(_: PageFleet) -> HTMLResponse:
    """The API's documentation (Swagger UI), for a browser with a session (else it is sent to log in)."""
    nonce = secrets.token_urlsafe(16)
    script = _SWAGGER_INIT % {"cookie": CSRF_COOKIE, "length": len(CSRF_COOKIE) + 1, "header": CSRF_HEADER}
    return _page(
        '<link rel="stylesheet" href="/docs/assets/swagger-ui.css">'
        '<link rel="icon" type="image/png" href="/docs/assets/favicon-32x32.png">'
        '<form method="post" action="/logout" style="position:absolute;top:0.5rem;right:1rem;z-index:10">'
        '<button type="submit">Log out</button></form>'
        '<div id="swagger-ui"></div>'
        '<script src="/docs/assets/swagger-ui-bundle.js"></script>'
        f'<script nonce="{nonce}">{script}</script>',
        nonce=nonce,
        title="engine-monitor: API",
    )


@router.get("/docs/assets/{name}")
def docs_asset(_: Fleet, name: Annotated[str, FastPath(max_length=100)]) -> FileResponse:
    """One of Swagger UI's files, from the installed package."""
    media_type = ASSETS.get(name)
    if media_type is None:
        raise ApiError(404, "not_found", f"no asset {name!r}: the docs page loads {', '.join(ASSETS)}")
    return FileResponse(
        _swagger_folder() / name,
        media_type=media_type,
        headers={"Cache-Control": "private, max-age=86400", "Vary": "Cookie, X-API-Key"},
    )
