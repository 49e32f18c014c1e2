"""An MCAP file's records for the official readers, CRCs checked, its damage refused in one line.

A file cut short is read up to its last whole record, that is its last whole chunk (a record the file
ends inside is never parsed), and told apart from a damaged one; a CRC or decompression failure is a
checksum failure.
"""

from __future__ import annotations

import contextlib
import os
import struct
import zlib
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import IO, Any, cast

from mcap.exceptions import EndOfFile, McapError
from mcap.opcode import Opcode
from mcap.records import Channel as McapChannel
from mcap.records import Chunk, Message, Schema
from mcap.stream_reader import CRCValidationError, StreamReader, get_chunk_data_stream

from monitor.errors import FormatError
from monitor.io.signatures import MCAP_MAGIC, file_signature

__all__ = ["Chunked", "bounded", "checked_records", "damage_named", "summary_checked"]


_FOOTER = struct.Struct("<BQQQI")  # opcode, record length, summary start, summary offset start, summary CRC


def summary_checked(fh: IO[bytes], source: Path) -> bool:
    """Whether the file's summary is there and its CRC matches; a mismatch is refused.

    False for a file without a summary or whose writer left the summary CRC at
    zero: its metadata cannot be trusted from the summary, and it is read by streaming.

    Parameters
    ----------
    fh : binary file
        The MCAP file, open for reading; left at its start.
    source : Path
        The file, named in a refusal.

    Returns
    -------
    bool

    Raises
    ------
    FormatError
        If the footer puts the summary outside the file, or the summary's CRC does not match.
    """
    size = os.fstat(fh.fileno()).st_size
    end = size - len(MCAP_MAGIC)
    if end - _FOOTER.size < len(MCAP_MAGIC):
        return False
    fh.seek(end - _FOOTER.size)
    opcode, length, start, _, stated = _FOOTER.unpack(fh.read(_FOOTER.size))
    fh.seek(0)
    if opcode != Opcode.FOOTER or length != _FOOTER.size - 9 or start == 0 or stated == 0:
        return False
    if not len(MCAP_MAGIC) <= start < end - _FOOTER.size:
        raise FormatError(
            f"{source}: damaged MCAP file: the footer puts the summary at byte {start}, "
            f"outside the file's {size} bytes"
        )
    fh.seek(start)
    actual = zlib.crc32(fh.read(end - 4 - start))
    fh.seek(0)
    if actual != stated:
        raise FormatError(
            f"{source}: checksum failure: the summary's CRC is {actual:#010x}, the footer states "
            f"{stated:#010x}; the summary (channel metadata, index) is damaged"
        )
    return True


class _CutShort(EndOfFile):
    """The file ends inside a record: it was cut short (or a damaged length or index points past it)."""

    def __init__(self) -> None:
        super().__init__("a record runs past the end of the file")


class _WholeReads:
    """A file as the MCAP readers see it: every read returns all the bytes asked for, or raises
    :class:`_CutShort` when the file ends first; a seek outside the file is refused.

    The stream reader itself takes a short read at the end of a file for a whole
    one, then fails on a fixed-size field of too few bytes (``struct.error``) or
    hands a partial chunk to the decompressor. Here a record that the file ends
    inside is never parsed, and no more than the file holds is ever asked for,
    whatever a damaged length field or index says.

    Parameters
    ----------
    fh : binary file
        Open for reading, at its start.
    size : int
        The file's size [bytes].
    """

    def __init__(self, fh: IO[bytes], size: int) -> None:
        self._fh = fh
        self._size = size
        self._position = 0

    def read(self, size: int = -1) -> bytes:
        """``size`` bytes (all that is left for a negative size), or raise :class:`_CutShort`."""
        left = self._size - self._position
        size = left if size < 0 else size
        if size > left:
            raise _CutShort()
        data = self._fh.read(size)
        if len(data) < size:  # the file shrank while it was read
            raise _CutShort()
        self._position += size
        return data

    def seekable(self) -> bool:
        """True: the indexed reader may seek."""
        return True

    def seek(self, offset: int, whence: int = os.SEEK_SET) -> int:
        """Move to a byte of the file; refuse (McapError) a position outside it."""
        base = {os.SEEK_SET: 0, os.SEEK_CUR: self._position, os.SEEK_END: self._size}[whence]
        if not 0 <= base + offset <= self._size:
            raise McapError(
                f"an offset points to byte {base + offset}, outside the file ({self._size} bytes)"
            )
        self._position = self._fh.seek(base + offset)
        return self._position

    def tell(self) -> int:
        """The current byte."""
        return self._position


def bounded(fh: IO[bytes]) -> IO[bytes]:
    """An open MCAP file for the official readers, read through :class:`_WholeReads`.

    Parameters
    ----------
    fh : binary file
        The MCAP file, open for reading, at its start.

    Returns
    -------
    binary file
        Every read returns all the bytes asked for or raises :class:`_CutShort`; a seek outside
        the file is refused.
    """
    return cast(IO[bytes], _WholeReads(fh, os.fstat(fh.fileno()).st_size))


@dataclass(frozen=True)
class Chunked:
    """A channel record read from inside a chunk (so covered by the chunk's CRC)."""

    channel: McapChannel


def checked_records(path: Path, *, mark_chunked: bool = False) -> Iterator[Any]:
    """Records of an MCAP file, CRCs checked; a file cut short stops at its last whole record (that is,
    after its last whole chunk) and then yields None. With ``mark_chunked``, a channel record from
    inside a chunk comes as a :class:`Chunked`.

    Parameters
    ----------
    path : Path
        The MCAP file.
    mark_chunked : bool, optional
        Yield a channel record from inside a chunk (covered by its CRC) as a :class:`Chunked`, to
        tell it from the summary's copy (default False).

    Yields
    ------
    mcap record, Chunked or None
        The file's records in order, a chunk's schemas, channels and messages in place of the
        chunk; None once, last, if the file was cut short.

    Raises
    ------
    FormatError
        If it is not an MCAP file, cannot be read, or is damaged (a CRC, record or decompression
        failure, or a record running past the end of a file that ends with the MCAP magic).
    """
    if file_signature(path) != MCAP_MAGIC:
        raise FormatError(f"{path}: not an MCAP file (no MCAP magic at its start)")
    try:
        with open(path, "rb") as fh, damage_named(str(path)):
            reader = StreamReader(bounded(fh), validate_crcs=True, emit_chunks=True)
            try:
                for record in reader.records:
                    if isinstance(record, Chunk):
                        for inner in _chunk_records(record):
                            yield (
                                Chunked(inner) if mark_chunked and isinstance(inner, McapChannel) else inner
                            )
                    else:
                        yield record
            except _CutShort:
                size = os.fstat(fh.fileno()).st_size
                fh.seek(max(len(MCAP_MAGIC), size - len(MCAP_MAGIC)))
                if fh.read() == MCAP_MAGIC:  # the file ends as a whole one does: damage, not a cut
                    raise FormatError(
                        f"{path}: damaged MCAP file: a record runs past the end of the file, "
                        "which ends with the MCAP magic (not cut short)"
                    ) from None
                yield None
    except OSError as error:
        raise FormatError(f"{path}: cannot read: {error}") from None


def _chunk_records(chunk: Chunk) -> Iterator[Schema | McapChannel | Message]:
    """The schemas, channels and messages of a chunk one at a time, its CRC checked on decompression.

    One at a time (unlike the official ``breakup_chunk``, which parses a whole
    chunk first), so that a file another program wrote is refused at its first
    topic of another schema without parsing its messages.
    """
    stream, size = get_chunk_data_stream(chunk, validate_crc=True)
    while stream.count < size:
        opcode = stream.read1()
        length = stream.read8()
        if opcode == Opcode.MESSAGE:
            yield Message.read(stream, length)
        elif opcode == Opcode.CHANNEL:
            yield McapChannel.read(stream)
        elif opcode == Opcode.SCHEMA:
            yield Schema.read(stream)
        else:
            stream.read(length)  # a record a chunk may hold that is of no use here


@contextlib.contextmanager
def damage_named(where: str) -> Iterator[None]:
    """A CRC, record or decompression failure while reading, as a FormatError naming ``where``.

    Parameters
    ----------
    where : str
        The file (and channel), named in the FormatError.

    Yields
    ------
    None
        The body runs inside; a FormatError it raises passes unchanged.

    Raises
    ------
    FormatError
        "checksum failure" for a CRC or decompression failure, "damaged MCAP file" for a record
        that does not parse.
    """
    try:
        yield
    except FormatError:
        raise
    except CRCValidationError as error:
        raise FormatError(f"{where}: checksum failure: {error}") from None
    except McapError as error:
        raise FormatError(f"{where}: damaged MCAP file: {error}") from None
    except (struct.error, ValueError, IndexError, KeyError) as error:  # a record's fields contradict it
        raise FormatError(f"{where}: damaged MCAP file: a record does not parse ({error})") from None
    except Exception as error:  # decompression of a damaged chunk (zstd, lz4)
        if type(error).__module__.split(".")[0] in ("zstandard", "lz4"):
            raise FormatError(f"{where}: checksum failure: a chunk does not decompress ({error})") from None
        raise
