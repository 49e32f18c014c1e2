"""The service itself: ``GET /`` says where to go, ``GET /health`` whether it works (no key needed
for either), ``GET /openapi.json`` its OpenAPI document (with a key or a session, as every other
route; its descriptions in Markdown, :mod:`api.openapi`)."""

from __future__ import annotations

from fastapi import APIRouter, Request
from fastapi.responses import JSONResponse, RedirectResponse, Response

from api.auth import Fleet
from api.dependencies import ServiceStore
from api.errors import ApiError
from api.outage import DataFolder
from api.schemas import ErrorResponse, Health
from monitor.diagnosis import ANALYSIS_VERSION

__all__ = ["router"]

router = APIRouter()


@router.get("/openapi.json", include_in_schema=False)
def openapi(request: Request, _: Fleet) -> JSONResponse:
    """The OpenAPI document (with a key or a session, as every route but /health)."""
    return JSONResponse(request.app.openapi())


@router.get("/", include_in_schema=False, response_model=None)
def root(request: Request) -> Response:
    """Where to go (no key needed): a browser is sent to the web pages, any other client is answered
    the service's entry points."""
    if "text/html" in request.headers.get("accept", ""):
        return RedirectResponse("/ui", status_code=303)
    return JSONResponse(
        {
            "service": "engine-monitor",
            "ui": "/ui",
            "docs": "/docs",
            "openapi": "/openapi.json",
            "health": "/health",
            "message": "the web pages are at /ui and the API's documentation at /docs (in a browser, "
            "after the login); the OpenAPI document at /openapi.json (with an X-API-Key); /health "
            "needs no key",
        }
    )


@router.get("/health", response_model=Health, responses={503: {"model": ErrorResponse}}, tags=["service"])
def health(request: Request, store: ServiceStore) -> dict[str, str]:
    """Whether the service, its store and its data folder answer (no key needed); else 503, whose
    code says which does not: ``store_unavailable`` or ``data_folder_full``."""
    store.count("fleets")
    store.outage.back()
    data_folder: DataFolder = request.app.state.data_folder
    if not data_folder.has_room():
        raise ApiError(
            503,
            "data_folder_full",
            f"the service's data folder is full: uploads are refused until space is freed there "
            f"({data_folder.free()} bytes free)",
            headers={"Retry-After": "60"},
        )
    return {"status": "ok", "store": store.dialect, "analysis_version": ANALYSIS_VERSION}
