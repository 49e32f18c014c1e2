"""Reading and writing recordings: the product's HDF5 and MCAP formats (recordings/FORMAT.md)."""

from __future__ import annotations

from pathlib import Path

from monitor.recording import FormatError

__all__ = ["HDF5_SIGNATURE", "MCAP_MAGIC", "file_signature"]

HDF5_SIGNATURE = b"\x89HDF\r\n\x1a\n"
MCAP_MAGIC = b"\x89MCAP0\r\n"


def file_signature(path: str | Path) -> bytes:
    """The first eight bytes of a file, which tell HDF5 from MCAP.

    Parameters
    ----------
    path : str or Path

    Returns
    -------
    bytes

    Raises
    ------
    FormatError
        If the file cannot be read.
    """
    try:
        with open(path, "rb") as fh:
            return fh.read(8)
    except OSError as error:
        raise FormatError(f"{path}: cannot read: {error}") from None
