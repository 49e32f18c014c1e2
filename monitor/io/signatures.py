"""File signatures: what a file's bytes say it is, whatever its name or a request's content type says.

A recording is HDF5 or MCAP, each known by its signature ("magic bytes"):

- HDF5: ``\\x89HDF\\r\\n\\x1a\\n`` at the start of its superblock, which is at
  byte 0, or after a user block of 512 bytes or a larger power of two (the
  HDF5 library looks at 0, 512, 1024, 2048, ... and so does
  :func:`hdf5_offset`);
- MCAP: ``\\x89MCAP0\\r\\n`` at byte 0.

Anything else is refused by what its bytes look like (:func:`looks_like`: a
PNG image, a PDF document, text...), so that a client who sent the wrong file
is told which file it sent.
"""

from __future__ import annotations

from pathlib import Path
from typing import BinaryIO, Literal

from monitor.errors import FormatError

__all__ = [
    "HDF5_SIGNATURE",
    "MCAP_MAGIC",
    "file_signature",
    "hdf5_offset",
    "looks_like",
    "recording_format",
]

HDF5_SIGNATURE = b"\x89HDF\r\n\x1a\n"
MCAP_MAGIC = b"\x89MCAP0\r\n"
#: The first place an HDF5 superblock may be after byte 0 (a user block's smallest size) [bytes].
_USER_BLOCK = 512

#: Other formats' signatures at byte 0, and what they are, for the message of a refusal.
_OTHERS: tuple[tuple[bytes, str], ...] = (
    (b"\x89PNG\r\n\x1a\n", "a PNG image"),
    (b"\xff\xd8\xff", "a JPEG image"),
    (b"GIF87a", "a GIF image"),
    (b"GIF89a", "a GIF image"),
    (b"%PDF-", "a PDF document"),
    (b"PK\x03\x04", "a ZIP archive (or an Office document)"),
    (b"\x1f\x8b", "gzip-compressed data"),
    (b"BZh", "bzip2-compressed data"),
    (b"\xfd7zXZ\x00", "xz-compressed data"),
    (b"\x28\xb5\x2f\xfd", "zstd-compressed data"),
    (b"7z\xbc\xaf\x27\x1c", "a 7-Zip archive"),
    (b"TDSm", "a TDMS file (convert it first: engine-monitor import)"),
    (b"\x7fELF", "an executable (ELF)"),
)


def file_signature(path: str | Path) -> bytes:
    """The first eight bytes of a file, which tell MCAP (and HDF5 without a user block).

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


def hdf5_offset(fh: BinaryIO, size: int) -> int | None:
    """Where an open file's HDF5 superblock starts (0, 512, 1024, ...), or None if it has none.

    Parameters
    ----------
    fh : binary file
        Open for reading, seekable.
    size : int
        Its size [bytes].

    Returns
    -------
    int or None
    """
    offset = 0
    while offset + len(HDF5_SIGNATURE) <= size:
        fh.seek(offset)
        if fh.read(len(HDF5_SIGNATURE)) == HDF5_SIGNATURE:
            return offset
        offset = _USER_BLOCK if offset == 0 else 2 * offset
    return None


def recording_format(path: str | Path) -> Literal["HDF5", "MCAP"] | None:
    """Which of the recording formats a file's signature says it is, or None for neither.

    Parameters
    ----------
    path : str or Path

    Returns
    -------
    {"HDF5", "MCAP"} or None

    Raises
    ------
    FormatError
        If the file cannot be read.
    """
    try:
        with open(path, "rb") as fh:
            if fh.read(len(MCAP_MAGIC)) == MCAP_MAGIC:
                return "MCAP"
            size = fh.seek(0, 2)
            return "HDF5" if hdf5_offset(fh, size) is not None else None
    except OSError as error:
        raise FormatError(f"{path}: cannot read: {error}") from None


def looks_like(head: bytes) -> str:
    """What a file's first bytes look like, in words, for a refusal's message.

    Parameters
    ----------
    head : bytes
        Its first bytes (64 or more say the most; fewer are enough for most formats).

    Returns
    -------
    str
        E.g. "a PNG image", "text ('hello world')", "empty".
    """
    if not head:
        return "empty"
    for signature, what in _OTHERS:
        if head.startswith(signature):
            return what
    try:
        text = head.decode("utf-8")
    except UnicodeDecodeError as error:  # text cut inside a character at the end of the head is text
        text = head[: error.start].decode("utf-8") if error.start >= len(head) - 3 else ""
    if text and all(c.isprintable() or c in "\t\r\n" for c in text):
        stripped = text.lstrip()
        kind = (
            "JSON"
            if stripped[:1] in ("{", "[")
            else "HTML or XML"
            if stripped[:1] == "<"
            else "form data"
            if "=" in stripped.split("&", 1)[0] and " " not in stripped.split("&", 1)[0]
            else "text"
        )
        return f"{kind} ({text[:24]!r})"
    return f"binary data of no format the product knows (first bytes {head[:8].hex(' ')})"
