"""Output files: written into a folder that exists, with the mode a new file gets."""

from __future__ import annotations

import os
import threading
from pathlib import Path

from monitor.errors import OutputFolderError

__all__ = ["in_existing_folder", "publish"]


def in_existing_folder(path: str | Path) -> Path:
    """``path``, once its folder is known to exist.

    Parameters
    ----------
    path : str or Path
        An output file.

    Returns
    -------
    Path

    Raises
    ------
    OutputFolderError
        Naming the folder, when it does not exist (or is not a folder).
    """
    target = Path(path)
    if not target.parent.is_dir():
        raise OutputFolderError(f"{target}: the folder {target.parent} does not exist (create it first)")
    return target


_LOCK = threading.Lock()


def _umask() -> int:
    """The process's umask, read without changing it where Linux tells it (``/proc/self/status``)."""
    try:
        for line in Path("/proc/self/status").read_text().splitlines():
            if line.startswith("Umask:"):
                return int(line.split()[1], 8)
    except (OSError, ValueError):
        pass
    with _LOCK:  # elsewhere: set and restore it, one thread at a time
        mask = os.umask(0o022)
        os.umask(mask)
    return mask


def publish(temporary: str | Path, target: str | Path) -> None:
    """Give a finished temporary file the mode a newly created file gets (0666 less the umask; a
    temporary file is made 0600) and move it over ``target`` in one step.

    Parameters
    ----------
    temporary : str or Path
        The finished file, in ``target``'s folder.
    target : str or Path
        Its name.
    """
    os.chmod(temporary, 0o666 & ~_umask())
    os.replace(temporary, target)
