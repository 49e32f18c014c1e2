"""Reading and writing recordings: the product's HDF5 and MCAP formats (recordings/FORMAT.md)."""

from __future__ import annotations

import contextlib
from collections.abc import Iterator
from pathlib import Path

from monitor.errors import FormatError, MonitorError
from monitor.io.recording import Recording
from monitor.io.signatures import (
    HDF5_SIGNATURE,
    MCAP_MAGIC,
    file_signature,
    looks_like,
    recording_format,
)

# the readers are imported where a file of their format is met: h5py and mcap are slow to import, and
# the quick commands import this package without reading a recording (tests/cli/test_startup.py)
__all__ = [
    "HDF5_SIGNATURE",
    "MCAP_MAGIC",
    "file_signature",
    "looks_like",
    "open_recording",
    "read_recording",
    "recording_format",
]


def read_recording(path: str | Path) -> Recording:
    """Read a recording in the product's HDF5 or MCAP format (by the file's signature).

    Parameters
    ----------
    path : str or Path

    Returns
    -------
    Recording
        ``truncated`` is True for an MCAP file cut short and read to its last whole chunk.

    Raises
    ------
    FormatError
        If the file is neither, or is refused by its reader (the message names the file, the
        channel if one, and what is wrong; a file cut short says so).
    """
    source = Path(path)
    kind = recording_format(source)
    if kind == "HDF5":
        from monitor.io.hdf5 import read_hdf5

        with _reader_failures(source, "HDF5"):
            return read_hdf5(source)
    if kind == "MCAP":
        from monitor.io.mcap.reader import read_mcap

        with _reader_failures(source, "MCAP"):
            return read_mcap(source)
    head = file_signature(source)
    if not head:
        raise FormatError(f"{source}: the file is empty; expected a recording (HDF5 or MCAP)")
    signatures = {"HDF5": HDF5_SIGNATURE, "MCAP": MCAP_MAGIC}
    started = " or ".join(name for name, sign in signatures.items() if sign.startswith(head))
    if len(head) < len(MCAP_MAGIC) and started:
        raise FormatError(f"{source}: cut short ({len(head)} bytes) inside its {started} signature")
    with open(source, "rb") as fh:
        seen = looks_like(fh.read(64))
    raise FormatError(
        f"{source}: neither HDF5 nor MCAP: its bytes look like {seen}; expected a recording file "
        "(HDF5 or MCAP, known by their signatures)"
    )


@contextlib.contextmanager
def open_recording(path: str | Path) -> Iterator[Recording]:
    """Open a recording for analysis in bounded memory: waveform samples are read by slices.

    HDF5 channels stay in the file (:func:`monitor.io.hdf5.open_hdf5`), an
    indexed MCAP file's are read topic by topic (:func:`monitor.io.mcap.reader.open_mcap`;
    a file without its index, or cut short, is read whole).

    Parameters
    ----------
    path : str or Path

    Yields
    ------
    Recording
        Valid while the context is open.
    """
    source = Path(path)
    kind = recording_format(source)
    with contextlib.ExitStack() as stack:
        if kind == "HDF5":
            from monitor.io.hdf5 import open_hdf5

            with _reader_failures(source, "HDF5"):  # the opening only: the caller's errors are its own
                recording = stack.enter_context(open_hdf5(source))
        elif kind == "MCAP":
            from monitor.io.mcap.reader import open_mcap

            with _reader_failures(source, "MCAP"):
                recording = stack.enter_context(open_mcap(source))
        else:
            recording = read_recording(source)  # refuses it with the reason
        yield recording


@contextlib.contextmanager
def _reader_failures(source: Path, kind: str) -> Iterator[None]:
    """A reader's own failure on a damaged or hostile file (h5py's KeyError or RuntimeError, a link
    loop's RecursionError, a zero rate's ZeroDivisionError, struct.error...) as a FormatError that
    names the file, in one line."""
    try:
        yield
    except MonitorError:
        raise
    except MemoryError:
        raise FormatError(f"{source}: the {kind} file needs more memory than there is to read") from None
    except (FileNotFoundError, PermissionError, IsADirectoryError) as error:
        raise FormatError(f"{source}: {error.strerror or error}") from None
    except Exception as error:
        said = str(error).splitlines()[0][:200] if str(error) else ""
        raise FormatError(
            f"{source}: the {kind} reader failed ({type(error).__name__}{': ' + said if said else ''}); "
            "the file is damaged or not a recording the product writes"
        ) from None
