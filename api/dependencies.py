"""What the routes are given: the store, the service's settings, its uploads' and calibrations'
limits and its analysis worker, each a FastAPI dependency that reads the application's state (set by
:func:`api.app.create_app` and its lifespan), never a closure over it."""

from __future__ import annotations

from typing import Annotated

from fastapi import Depends, Request

from api.baselines import Calibrations
from api.settings import Settings
from api.uploads import Uploads
from monitor.jobs.worker import Worker
from monitor.store import Store

__all__ = ["ServiceCalibrations", "ServiceSettings", "ServiceStore", "ServiceUploads", "wake_worker"]


async def _store(request: Request) -> Store:
    """The service's store (opened by the lifespan)."""
    store: Store = request.app.state.store
    return store


async def _settings(request: Request) -> Settings:
    settings: Settings = request.app.state.settings
    return settings


async def _uploads(request: Request) -> Uploads:
    uploads: Uploads = request.app.state.uploads
    return uploads


async def _calibrations(request: Request) -> Calibrations:
    calibrations: Calibrations = request.app.state.calibrations
    return calibrations


def wake_worker(request: Request) -> None:
    """Tell the service's own analysis worker, if it runs one, that an analysis is queued."""
    worker: Worker | None = request.app.state.worker
    if worker is not None:
        worker.wake()


ServiceStore = Annotated[Store, Depends(_store)]
ServiceSettings = Annotated[Settings, Depends(_settings)]
ServiceUploads = Annotated[Uploads, Depends(_uploads)]
ServiceCalibrations = Annotated[Calibrations, Depends(_calibrations)]
