"""An upload, from the request's body to a stored recording whose analysis is queued.

The body is streamed to a temporary file in ``incoming/`` (never whole in memory) up to
:attr:`api.settings.Settings.max_upload_bytes`, each piece within ``upload_idle_s`` and at
``upload_min_rate`` on average; its bytes must be HDF5 or MCAP (:func:`api.validate.format_refusal`);
the product's readers validate it in a child process with memory and time limits, in the fleet's
turn (:class:`Uploads`); then it is stored whole or not at all: fsync, atomic rename to its content
hash, fsync of the folder, its row and queued analysis in one transaction. The same content uploaded
twice is stored once.
"""

from __future__ import annotations

import asyncio
import hashlib
import logging
import os
import tempfile
import time
from collections import Counter, defaultdict
from pathlib import Path
from typing import Any

from starlette.concurrency import run_in_threadpool
from starlette.requests import ClientDisconnect, Request

from api.errors import ApiError
from api.outage import DataFolder, Placing, disk_full, remove_unregistered
from api.settings import Settings
from api.validate import Validation, format_refusal, validate
from monitor.diagnosis import ANALYSIS_VERSION
from monitor.model.engine import bundled_engines
from monitor.store import RecordingRow, Store

__all__ = ["Uploads"]

log = logging.getLogger("engine_monitor.api")


def _sync(out: Any) -> None:
    out.flush()
    os.fsync(out.fileno())


async def _receive(request: Request, out: Any, settings: Settings) -> tuple[int, str]:
    """Stream an upload's body to ``out``: its size and SHA-256, or a 413 / 408 ApiError.

    Each piece must come within ``upload_idle_s``, and after that long the body must have come at
    ``upload_min_rate`` on average: a client that trickles bytes to hold a connection and an open
    file is cut off.
    """
    digest = hashlib.sha256()
    size = 0
    started = time.monotonic()
    pieces = request.stream().__aiter__()
    while True:
        try:
            chunk = await asyncio.wait_for(pieces.__anext__(), settings.upload_idle_s)
        except StopAsyncIteration:
            break
        except TimeoutError:
            raise ApiError(
                408, "upload_timeout", f"no bytes of the upload came for {settings.upload_idle_s:g} s"
            ) from None
        size += len(chunk)
        if size > settings.max_upload_bytes:
            raise ApiError(
                413, "too_large", f"the file is over the limit of {settings.max_upload_bytes} bytes"
            )
        elapsed = time.monotonic() - started
        if elapsed > settings.upload_idle_s and size < settings.upload_min_rate * elapsed:
            raise ApiError(
                408,
                "upload_too_slow",
                f"the upload came at {size / elapsed:.0f} bytes/s over {elapsed:.0f} s, slower than the "
                f"{settings.upload_min_rate:g} bytes/s the service needs",
            )
        digest.update(chunk)
        await run_in_threadpool(out.write, chunk)  # the disk never blocks the event loop
    await run_in_threadpool(_sync, out)
    return size, digest.hexdigest()


class Uploads:
    """The service's uploads in progress: each fleet's count, the validations' turns, the contents
    being placed.

    Parameters
    ----------
    settings : Settings
    data_folder : DataFolder
        Told when an upload finds the data folder full, and asked again after each stored upload.
    """

    def __init__(self, settings: Settings, data_folder: DataFolder) -> None:
        self.settings = settings
        self.data_folder = data_folder
        self.slots = asyncio.Semaphore(settings.validations)  # each child may take validation_memory_bytes
        self.fleet_slots: defaultdict[int, asyncio.Semaphore] = defaultdict(
            lambda: asyncio.Semaphore(settings.validations_per_fleet)
        )
        self.uploading: Counter[int] = Counter()  # uploads in progress per fleet
        self.placing = Placing()  # contents whose files uploads are moving in and registering now

    async def take(
        self, request: Request, store: Store, fleet_id: int, name: str
    ) -> tuple[RecordingRow, bool]:
        """Store the request's body as the fleet's recording ``name`` and queue its analysis: its row,
        and whether it is new (false: the same content was stored before); else an ApiError that says
        why nothing was kept."""
        settings = self.settings
        kind = request.headers.get("content-type", "").split(";")[0].strip().lower()
        if kind.startswith("multipart/"):
            raise ApiError(
                400,
                "form_upload",
                f"the file came as a form ({kind}): send it as the request body itself, e.g. "
                "curl --data-binary @FILE -H 'Content-Type: application/octet-stream', not curl -F",
            )
        declared = request.headers.get("content-length")
        if declared is not None and declared.isdigit() and int(declared) > settings.max_upload_bytes:
            raise ApiError(
                413, "too_large", f"the file is over the limit of {settings.max_upload_bytes} bytes"
            )
        if self.uploading[fleet_id] >= settings.uploads_per_fleet:
            raise ApiError(
                429,
                "too_many_uploads",
                f"this fleet has {self.uploading[fleet_id]} uploads in progress, the most it may have at "
                "once: send the next when one has finished",
                headers={"Retry-After": "5"},
            )
        self.uploading[fleet_id] += 1
        incoming = settings.data_dir / "incoming"
        handle, temporary = tempfile.mkstemp(dir=incoming, suffix=".part")
        try:
            with os.fdopen(handle, "wb") as out:
                try:
                    size, content = await _receive(request, out, settings)
                except ClientDisconnect:  # the client went away: nothing to answer, nothing kept
                    log.info(
                        "upload fleet=%d filename=%r: the client went away; nothing kept", fleet_id, name
                    )
                    raise ApiError(
                        400, "disconnected", "the client disconnected before the end of the body"
                    ) from None
            if size == 0:
                raise ApiError(400, "empty", "the request body is empty: send the recording's bytes")
            refusal = await run_in_threadpool(format_refusal, Path(temporary))
            if refusal is not None:
                raise ApiError(415, "unsupported_format", f"{name}: {refusal}")
            verdict = await self._checked(fleet_id, name, Path(temporary))
            return await run_in_threadpool(
                self._keep, store, fleet_id, name, Path(temporary), content, size, verdict
            )
        except OSError as error:  # the data folder full: it is so until it has room for this upload
            if disk_full(error):
                self.data_folder.filled(int(declared) if declared and declared.isdigit() else 0)
            raise
        finally:
            self.uploading[fleet_id] -= 1
            if os.path.exists(temporary):
                os.unlink(temporary)

    async def _checked(self, fleet_id: int, name: str, temporary: Path) -> Validation:
        """The validator's verdict on an uploaded file, awaited in the fleet's turn (no thread held)."""
        settings = self.settings
        async with self.fleet_slots[fleet_id], self.slots:
            verdict = await validate(
                temporary,
                memory_bytes=settings.validation_memory_bytes,
                timeout_s=settings.validation_timeout_s,
                max_expansion=settings.max_expansion,
            )
        if not verdict.ok:
            message = verdict.message.replace(str(temporary), name)  # the reader names the file it read
            raise ApiError(422, "not_a_recording", message if name in message else f"{name}: {message}")
        return verdict

    def _keep(
        self,
        store: Store,
        fleet_id: int,
        name: str,
        temporary: Path,
        content: str,
        size: int,
        checked: Validation,
    ) -> tuple[RecordingRow, bool]:
        """Move a validated upload to its content's name, register it and queue its analysis."""
        if checked.engine_id not in bundled_engines() and store.engine(fleet_id, checked.engine_id) is None:
            raise ApiError(
                422,
                "unknown_engine",
                f"{name}: engine {checked.engine_id!r} is neither bundled nor among the fleet's engines: "
                "add its description (POST /engines), then upload the recording again",
            )
        with open(temporary, "rb") as fh:
            suffix = ".mcap" if fh.read(8).startswith(b"\x89MCAP") else ".h5"
        final = self.settings.data_dir / "recordings" / f"{content}{suffix}"
        with self.placing.hold(content):
            moved = not final.exists()
            try:
                if moved:
                    os.replace(temporary, final)
                    directory = os.open(final.parent, os.O_RDONLY)
                    try:
                        os.fsync(directory)
                    finally:
                        os.close(directory)
                row, created = store.add_recording(  # the row and its queued job, in one transaction
                    fleet_id,
                    content_hash=content,
                    engine_id=checked.engine_id,
                    filename=name,
                    path=str(final),
                    size_bytes=size,
                    recorded_at=checked.start_time,
                    queue=ANALYSIS_VERSION,
                )
            except BaseException:  # no file without its row: the one this upload moved in goes
                if moved:
                    remove_unregistered(final, content, store, self.placing)
                raise
        self.data_folder.has_room()  # a folder full before: logs once it has room again
        return row, created
