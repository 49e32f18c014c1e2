"""The service when its surroundings fail: the store unreachable, the data folder full.

What a client is answered (:func:`api.errors.dependency_error`), with the service's one error body:

- the store unreachable (:func:`monitor.store.outage.store_fault`: stopped,
  restarting, its connections cut): 503 ``store_unavailable`` with
  ``Retry-After`` (:data:`RETRY_AFTER_S`), on every route and on ``/health``.
  One log line when the outage begins and one when the store is back
  (:class:`monitor.store.outage.Outage`), never a traceback per request;
- the data folder full (``ENOSPC``, ``EDQUOT``; or SQLite's "database or
  disk is full" for a store file in it): 507 ``data_folder_full``; the disk
  of a store elsewhere full: 507 ``store_full``. ``/health`` answers 503
  ``data_folder_full`` from an upload refused for lack of room until the
  folder has room for it again, :class:`DataFolder`.

An upload never leaves a file without its row: one whose registration fails
after its file was moved into ``recordings/`` removes that file, unless
another upload in progress holds the same content (:class:`Placing`) or the
store says a recording already has it.
"""

from __future__ import annotations

import errno
import logging
import os
import threading
from collections import Counter
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

from monitor.store import Store

__all__ = ["MIN_ROOM", "RETRY_AFTER_S", "DataFolder", "Placing", "disk_full", "remove_unregistered"]

log = logging.getLogger("engine_monitor.api")

#: The wait a client is asked for before it sends again a request the store could not serve [s].
RETRY_AFTER_S = 5
#: The errors of a write that found no room: the disk full, the user's quota reached.
DISK_FULL = frozenset({errno.ENOSPC, errno.EDQUOT})
#: Room the data folder must have again before ``/health`` calls it no longer full, at least [bytes].
MIN_ROOM = 1 << 20


def disk_full(error: BaseException) -> bool:
    """Whether an error is a write that found no room (``ENOSPC``, ``EDQUOT``)."""
    return isinstance(error, OSError) and error.errno in DISK_FULL


class DataFolder:
    """Whether the service's data folder has room, as the last write that found none left it.

    A write that finds the folder full (:meth:`filled`) logs it once; the folder counts as full until
    it has room for that write again (:meth:`has_room`, at least :data:`MIN_ROOM`), which logs the
    end, once.

    Parameters
    ----------
    path : Path
    """

    def __init__(self, path: Path) -> None:
        self.path = path
        self._lock = threading.Lock()
        self.needed: int | None = None  # room a refused write wanted [bytes], None while not full

    def free(self) -> int:
        """Room left in the folder for this user [bytes]."""
        stat = os.statvfs(self.path)
        return stat.f_bavail * stat.f_frsize

    def filled(self, needed: int) -> None:
        """A write of ``needed`` bytes [bytes] found no room: logged once per time the folder fills."""
        with self._lock:
            first = self.needed is None
            self.needed = max(needed, MIN_ROOM, self.needed or 0)
        if first:
            log.warning(
                "data folder %s full: uploads answer 507 until space is freed (%d bytes free)",
                self.path,
                self.free(),
            )

    def _emptied(self) -> None:
        """The folder has room again (logs the end of its being full, once)."""
        with self._lock:
            was, self.needed = self.needed, None
        if was is not None:
            log.warning("data folder %s has room again (%d bytes free)", self.path, self.free())

    def has_room(self) -> bool:
        """False while the last refused write would still find no room."""
        needed = self.needed
        if needed is None:
            return True
        if self.free() < needed:
            return False
        self._emptied()
        return True


class Placing:
    """Contents whose files uploads are placing in ``recordings/`` now (moved in, rows not committed),
    counted by content hash: an upload whose registration fails leaves a file that another upload in
    progress is placing."""

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._held: Counter[str] = Counter()

    @contextmanager
    def hold(self, content: str) -> Iterator[None]:
        """While an upload places the file of ``content``."""
        with self._lock:
            self._held[content] += 1
        try:
            yield
        finally:
            with self._lock:
                self._held[content] -= 1
                if not self._held[content]:
                    del self._held[content]

    def others(self, content: str) -> bool:
        """Whether another upload than the caller's (which holds it) places this content now."""
        return self._held[content] > 1


def remove_unregistered(final: Path, content: str, store: Store, placing: Placing) -> None:
    """Remove a file an upload moved into ``recordings/`` and could not register, unless another upload
    in progress places the same content or the store says a recording has it (a store that cannot say
    is down: the file was moved in by this upload, there was none before it, so it is this upload's)."""
    if placing.others(content):
        return
    try:
        if store.content_stored(content):
            return
    except Exception:  # the store cannot say: the file is this upload's (above)
        pass
    final.unlink(missing_ok=True)
    log.info("upload %s: not registered (the store failed); its file was removed", content[:12])
