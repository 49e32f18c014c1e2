"""Where the diagnosis plots are kept: the data folder's ``plots/``, each named after its recording's file.

With a data folder, each diagnosis plot is kept in its ``plots/`` folder,
named after its recording's file (:func:`plot_names`), for people browsing the
folder; the store records that file with the diagnosis, and a plot is found by
the recording's id through the store (:meth:`monitor.store.Store.plot`), never
by a name. The batch and the service's worker name them alike.
"""

from __future__ import annotations

import re
from collections.abc import Iterable
from pathlib import PurePath

from monitor.diagnosis import ANALYSIS_VERSION
from monitor.errors import MonitorError
from monitor.store import Store

__all__ = ["PLOTS", "plot_files", "plot_names", "recording_plot"]

PLOTS = "plots"  # the data folder's folder of diagnosis plots
PLOT_STEM_CHARACTERS = 120  # a plot's name keeps this much of its recording's stem


def _safe_stem(filename: str) -> str:
    """A file name's stem as a plot's name may hold it: ASCII letters, digits, ``.``, ``_`` and ``-``
    (any other character becomes ``_``), not hidden, at most :data:`PLOT_STEM_CHARACTERS` long."""
    stem = re.sub(r"[^A-Za-z0-9._-]", "_", PurePath(filename).stem)[:PLOT_STEM_CHARACTERS]
    return "_" + stem[1:] if stem.startswith(".") else stem or "recording"


def plot_names(recordings: Iterable[tuple[int, str]]) -> dict[int, str]:
    """The diagnosis plots' file names of recordings, named after their files' stems.

    A recording's plot is named ``STEM-vVERSION.png`` (the analysis version) when no recording of
    a lower id has the same stem, else ``STEM+ID-vVERSION.png``. Stems are compared as a
    case-insensitive file system would, after the characters a plot's name leaves out are replaced.
    ``+`` is one of those, so an id added to a stem can never make another recording's name: the names
    never collide. A recording's name depends only on the recordings registered before it, so it is
    the same on every run.

    Parameters
    ----------
    recordings : iterable of (int, str)
        Every recording whose plot shares the folder: its id in the store and its file name (as
        registered).

    Returns
    -------
    dict of int to str
        The plot's file name, by recording id.
    """
    listed = sorted(recordings)
    first: dict[str, int] = {}
    for recording_id, filename in listed:
        first.setdefault(_safe_stem(filename).casefold(), recording_id)
    names = {}
    for recording_id, filename in listed:
        stem = _safe_stem(filename)
        if first[stem.casefold()] != recording_id:
            stem = f"{stem}+{recording_id}"
        names[recording_id] = f"{stem}-v{ANALYSIS_VERSION}.png"
    return names


def plot_files(store: Store) -> dict[int, str]:
    """The plot file of every recording in the store (of every fleet: they share the data folder),
    relative to the data folder, by recording id (:func:`plot_names`).

    Parameters
    ----------
    store : Store

    Returns
    -------
    dict of int to str
    """
    return {i: f"{PLOTS}/{name}" for i, name in plot_names(store.registered_filenames()).items()}


def recording_plot(store: Store, recording_id: int) -> str:
    """Where a recording's diagnosis plot is to be kept, relative to the data folder: ``plots/NAME``,
    named after the recording's file (:func:`plot_names`).

    The batch and the service's worker write the plot there and record it with the diagnosis
    (:meth:`monitor.store.Store.complete`); a reader finds it through the store
    (:meth:`monitor.store.Store.plot`), never by this name.

    Parameters
    ----------
    store : Store
        The store the recording is registered in.
    recording_id : int
        The recording's id in the store.

    Raises
    ------
    MonitorError
        If no recording has that id.
    """
    files = plot_files(store)
    if recording_id not in files:
        raise MonitorError(f"recording {recording_id}: no such recording in the store")
    return files[recording_id]
