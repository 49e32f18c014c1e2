"""The recording files of a batch's scope: found under a folder, registered in the store by their content.

A file seen before, under any name, is not registered twice: copies of one
content are one recording, which keeps each name it was given.
"""

from __future__ import annotations

import hashlib
from pathlib import Path

from monitor.errors import MonitorError
from monitor.io import open_recording
from monitor.store import Store

__all__ = ["RECORDING_SUFFIXES", "content_hash", "recording_files", "register", "register_file"]

RECORDING_SUFFIXES = (".h5", ".hdf5", ".mcap")


def content_hash(path: str | Path) -> str:
    """SHA-256 of a file's bytes (hex), read in 1 MiB blocks.

    Parameters
    ----------
    path : str or Path

    Returns
    -------
    str
    """
    digest = hashlib.sha256()
    with open(path, "rb") as fh:
        for block in iter(lambda: fh.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


def register(store: Store, fleet_id: int, path: Path) -> tuple[int, bool]:
    """Register a recording file in the store: ``(recording id, created)``.

    Parameters
    ----------
    store : Store
    fleet_id : int
    path : Path
        A recording (HDF5 or MCAP); its engine and start time are read from it.

    Raises
    ------
    MonitorError
        If the file is not a recording the product can read.
    """
    recording_id, created, _ = register_file(store, fleet_id, path)
    return recording_id, created


def register_file(store: Store, fleet_id: int, path: Path) -> tuple[int, bool, bool]:
    """:func:`register`, and whether the file was cut short (an MCAP file read to its last whole chunk).

    Parameters
    ----------
    store : Store
    fleet_id : int
    path : Path
        A recording (HDF5 or MCAP).

    Returns
    -------
    tuple of (int, bool, bool)
        The recording's id, whether it was created, whether the file was cut short.
    """
    with open_recording(path) as recording:
        engine_id, recorded_at, truncated = recording.engine_id, recording.start_time, recording.truncated
    row, created = store.add_recording(
        fleet_id,
        content_hash=content_hash(path),
        engine_id=engine_id,
        filename=path.name,
        path=str(path.resolve()),
        size_bytes=path.stat().st_size,
        recorded_at=recorded_at,
    )
    return row.id, created, truncated


def recording_files(root: Path) -> list[Path]:
    """The recording files of a scope: the file given, or those under a folder (by their suffix), sorted.

    Parameters
    ----------
    root : Path
        A recording file or a folder searched recursively.

    Returns
    -------
    list of Path

    Raises
    ------
    MonitorError
        If there is no such file or folder.
    """
    if root.is_file():
        return [root]
    if not root.is_dir():
        raise MonitorError(f"{root}: no such file or folder")
    return sorted(p for p in root.rglob("*") if p.is_file() and p.suffix.lower() in RECORDING_SUFFIXES)
