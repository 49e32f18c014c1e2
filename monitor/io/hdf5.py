"""The product's HDF5 recording format (recordings/FORMAT.md): reader and writer.

One file per recording: root attributes describe the recording, the group
``/channels`` holds one dataset per channel with the channel's attributes.
Datasets are chunked (about one second each, so a slice reads alone) and
carry Fletcher-32 checksums, so a damaged chunk is detected when read.

The reader is strict, because files come from outside: a file that is not
HDF5 or not this format, a missing or malformed attribute, an unknown unit,
a sample count that contradicts the stated duration, a checksum failure,
a file cut short or otherwise damaged, and the HDF5 features that can read
other files of the server (external links, external raw storage, virtual
datasets) are all refused with a one-line message naming the channel (or
the file) and the problem.  It also accepts the waveform
attribute names that NI's TDMS-to-HDF5 exports use (``wf_increment``,
``wf_start_offset``, ``unit_string``).
"""

from __future__ import annotations

import contextlib
import os
import re
import tempfile
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import h5py
import numpy as np

from monitor.errors import FormatError
from monitor.io.files import in_existing_folder, publish
from monitor.io.plausible import rate_problem
from monitor.io.recording import KIND_FIELDS, Channel, Recording, SampleReader, field_value
from monitor.io.signatures import recording_format

__all__ = ["FORMAT_NAME", "FORMAT_VERSION", "Hdf5Samples", "open_hdf5", "read_hdf5", "write_hdf5"]

FORMAT_NAME = "engine-monitor recording"
FORMAT_VERSION = 1


#: The root attributes of the format (recordings/FORMAT.md).
ROOT_ATTRIBUTES = frozenset(
    {"format", "format_version", "engine_id", "start_time", "notes", "cycle_phase_deg", "truth"}
)
#: The attributes every channel may have, whatever its kind (NI's export names included).
CHANNEL_ATTRIBUTES = frozenset(
    {
        "kind", "unit", "representation", "sample_rate_hz", "start_offset_s", "duration_s",
        "location", "direction", "range_min", "range_max", "unit_string", "wf_increment", "wf_start_offset",
    }
)  # fmt: skip
#: Attribute names left to others: the user's own (``x_``) and the rest of NI's exports (``wf_``, ``NI_``).
FREE_PREFIXES = ("x_", "wf_", "NI_")


def _unknown_attributes(where: str, names: Any, allowed: frozenset[str] | set[str]) -> None:
    """Refuse an attribute the format does not have: a misspelt (or damaged) name would otherwise
    be ignored and its value silently lost, e.g. a channel's location."""
    for name in names:
        if name not in allowed and not name.startswith(FREE_PREFIXES):
            raise FormatError(
                f"{where}: unknown attribute {name!r}; expected one of {', '.join(sorted(allowed))} "
                f"(or a name starting with {', '.join(FREE_PREFIXES)})"
            )


def _text(value: Any) -> str:
    return value.decode() if isinstance(value, bytes) else str(value)


def write_hdf5(recording: Recording, path: str | Path, *, chunk_seconds: float = 1.0) -> Path:
    """Write a recording, whole or not at all (temporary file, fsync, atomic rename).

    Parameters
    ----------
    recording : Recording
    path : str or Path
        Output file (.h5).
    chunk_seconds : float, optional
        Length of a chunk of a waveform [s].

    Returns
    -------
    Path

    Raises
    ------
    OutputFolderError
        If the file's folder does not exist (none is created).
    """
    target = in_existing_folder(path)
    handle, temporary = tempfile.mkstemp(prefix=f".{target.name}.", suffix=".tmp", dir=target.parent)
    os.close(handle)
    try:
        # HDF5 1.10 object headers carry checksums: a damaged attribute is refused, not misread
        with h5py.File(temporary, "w", libver=("v110", "latest")) as f:
            _put_text(f, "format", FORMAT_NAME)
            f.attrs["format_version"] = FORMAT_VERSION
            _put_text(f, "engine_id", recording.engine_id)
            _put_text(f, "start_time", recording.start_time)
            _put_text(f, "notes", recording.notes)
            if recording.truth:
                _put_text(f, "truth", recording.truth)
            if recording.cycle_phase_deg is not None:
                f.attrs["cycle_phase_deg"] = float(recording.cycle_phase_deg)
            group = f.create_group("channels", track_order=True)
            for c in recording.channels:
                if c.is_events:
                    chunk = max(1, min(c.data.size, 65536))
                else:
                    chunk = max(1, min(c.data.size, round(chunk_seconds * float(c.sample_rate))))  # type: ignore[arg-type]
                ds = group.create_dataset(
                    c.name,
                    data=c.data,
                    chunks=(chunk,) if c.data.size else None,
                    fletcher32=bool(c.data.size),
                )
                _put_text(ds, "kind", c.kind)
                _put_text(ds, "unit", c.unit)
                _put_text(ds, "representation", "events" if c.is_events else "waveform")
                if not c.is_events:
                    ds.attrs["sample_rate_hz"] = float(c.sample_rate)  # type: ignore[arg-type]
                    ds.attrs["duration_s"] = c.duration
                ds.attrs["start_offset_s"] = c.start_offset
                _put_text(ds, "location", c.location)
                _put_text(ds, "direction", c.direction)
                for key, value in c.fields.items():
                    if isinstance(value, str):
                        _put_text(ds, key, value)
                    else:
                        ds.attrs[key] = value
                if c.range is not None:
                    ds.attrs["range_min"], ds.attrs["range_max"] = c.range
        with open(temporary, "rb") as fh:
            os.fsync(fh.fileno())
        publish(temporary, target)
    except BaseException:
        with contextlib.suppress(FileNotFoundError):
            os.unlink(temporary)
        raise
    return target


def _put_text(owner: h5py.HLObject, name: str, value: str) -> None:
    """A text attribute as a fixed-length UTF-8 string, kept in the object's checksummed header
    (h5py's default, a variable-length string, lives in the global heap, which has no checksum)."""
    encoded = value.encode("utf-8")
    owner.attrs.create(name, np.bytes_(encoded), dtype=h5py.string_dtype("utf-8", max(1, len(encoded))))


def read_hdf5(path: str | Path) -> Recording:
    """Read and validate a recording (see the module docstring for what is refused).

    Parameters
    ----------
    path : str or Path

    Returns
    -------
    Recording
        Waveform channels come with their data-quality spans found and masked.

    Raises
    ------
    FormatError
        Naming the channel (or the file) and the problem.
    """
    with _open(Path(path)) as f, _damage_named(Path(path)):
        return _recording(f, Path(path), lazy=False)


@contextlib.contextmanager
def open_hdf5(path: str | Path) -> Iterator[Recording]:
    """Open a recording whose waveform channels stay in the file and are read by slices.

    Everything but the waveform samples is read and validated at once; each
    waveform channel's ``data`` is a :class:`Hdf5Samples`, which checks every
    slice it reads (checksums, NaN, Inf, clipping against the stated range)
    and refuses a bad one, naming the channel and the time. An hour-long
    recording is analysed in bounded memory this way.

    Parameters
    ----------
    path : str or Path

    Yields
    ------
    Recording
        Valid while the context is open.

    Raises
    ------
    FormatError
        As :func:`read_hdf5`.
    """
    with _open(Path(path)) as f:
        with _damage_named(Path(path)):
            recording = _recording(f, Path(path), lazy=True)
        yield recording


def _open(source: Path) -> h5py.File:
    if recording_format(source) != "HDF5":
        raise FormatError(f"{source}: not an HDF5 file (no HDF5 signature at 0, 512, 1024, ... bytes)")
    try:
        return h5py.File(source, "r")
    except OSError as error:
        cut = re.search(r"truncated file: eof = (\d+).*stored_eof = (\d+)", str(error))
        if cut:  # the HDF5 library refuses a file shorter than its superblock says
            raise FormatError(
                f"{source}: the file was cut short: {cut[1]} bytes of the {cut[2]} its HDF5 superblock "
                "states; an HDF5 file cut short is refused (its metadata may be anywhere in it)"
            ) from None
        raise FormatError(f"{source}: damaged HDF5 file: {_one_line(error)}") from None


def _one_line(error: BaseException) -> str:
    return " ".join(str(error).split())


@contextlib.contextmanager
def _damage_named(source: Path) -> Iterator[None]:
    """An error of the HDF5 library on a damaged file's structure, as a FormatError naming the file."""
    try:
        yield
    except FormatError:
        raise
    except (OSError, KeyError, RuntimeError, ValueError, TypeError) as error:
        raise FormatError(f"{source}: damaged HDF5 file: {_one_line(error)}") from None


def _recording(f: h5py.File, source: Path, *, lazy: bool) -> Recording:
    fmt = _text(f.attrs.get("format", ""))
    if fmt != FORMAT_NAME:
        raise FormatError(f"{source}: not an {FORMAT_NAME} (root attribute 'format' is {fmt!r})")
    version = int(f.attrs.get("format_version", 0))
    if version != FORMAT_VERSION:
        raise FormatError(f"{source}: format_version {version} is not supported (expected {FORMAT_VERSION})")
    for name in ("engine_id", "start_time"):
        if name not in f.attrs:
            raise FormatError(f"{source}: missing root attribute {name!r}")
    _unknown_attributes(f"{source}: root", f.attrs.keys(), ROOT_ATTRIBUTES)
    _refuse_links(f, source)
    if "channels" not in f or not isinstance(f["channels"], h5py.Group):
        raise FormatError(f"{source}: missing the group 'channels'")
    channels = [_read_channel(f["channels"], name, source, lazy=lazy) for name in f["channels"]]
    return Recording(
        engine_id=_text(f.attrs["engine_id"]),
        start_time=_text(f.attrs["start_time"]),
        channels=tuple(channels),
        notes=_text(f.attrs.get("notes", "")),
        truth=_text(f.attrs.get("truth", "")),
        cycle_phase_deg=_phase(f.attrs.get("cycle_phase_deg"), source),
    )


def _phase(value: Any, source: Path) -> float | None:
    """The recording attribute ``cycle_phase_deg``, if stated [deg]."""
    if value is None:
        return None
    try:
        return float(value)
    except (TypeError, ValueError):
        raise FormatError(f"{source}: cycle_phase_deg = {value!r}: expected 0 or 360 (degrees)") from None


class Hdf5Samples(SampleReader):
    """A waveform channel's samples in an open HDF5 file, read by slices and checked as they are read.

    Parameters
    ----------
    dataset : h5py.Dataset
    where : str
        The file and channel, for messages.
    sample_rate : float
        [Hz].
    start_offset : float
        [s].
    limits : (float, float) or None
        Measuring range for the clipping check [the channel's unit]; None: not judged.
    """

    def __init__(
        self,
        dataset: h5py.Dataset,
        where: str,
        sample_rate: float,
        start_offset: float,
        limits: tuple[float, float] | None,
    ) -> None:
        super().__init__(where, dataset.shape[0], dataset.dtype, sample_rate, start_offset, limits)
        self._dataset = dataset

    def _read(self, start: int, stop: int) -> np.ndarray:
        try:
            return np.asarray(self._dataset[start:stop])
        except OSError as error:
            raise FormatError(
                f"{self._where}: checksum failure or damaged data ({error}); the file is corrupt"
            ) from None

    def _read_into(self, start: int, out: np.ndarray) -> None:
        if out.dtype != self._dtype or not out.flags.c_contiguous:
            super()._read_into(start, out)
            return
        try:  # straight into the caller's buffer: no array made per slice
            self._dataset.read_direct(out, np.s_[start : start + out.size], np.s_[0 : out.size])
        except OSError as error:
            raise FormatError(
                f"{self._where}: checksum failure or damaged data ({error}); the file is corrupt"
            ) from None


#: The deepest nesting of groups read: the format's is 2 (``/channels/NAME``); a file may hold groups of
#: its own beside it, but one nested thousands deep is a hostile file's, refused before it is walked.
MAX_DEPTH = 8


def _refuse_links(f: h5py.File, source: Path) -> None:
    """Refuse the links and datasets that can read other files, and groups nested past :data:`MAX_DEPTH`.

    Walked with a stack of its own, not by recursion, so the depth of a file's nesting is the file's
    fault to report, never the interpreter's recursion limit."""
    pending: list[tuple[h5py.Group, str, int]] = [(f, "", 0)]
    while pending:
        group, prefix, depth = pending.pop()
        if depth > MAX_DEPTH:
            raise FormatError(
                f"{source}: groups nested more than {MAX_DEPTH} deep ({prefix[:80]}...); the format "
                f"nests 2 (/channels/NAME): refused"
            )
        for name in group:
            link = group.get(name, getlink=True)
            where = f"{prefix}/{name}"
            if isinstance(link, h5py.ExternalLink):
                raise FormatError(
                    f"{source}: {where} is an external link (to {link.filename!r}); "
                    "external links are refused: they can read other files"
                )
            if isinstance(link, h5py.SoftLink):
                raise FormatError(f"{source}: {where} is a soft link; the format has none")
            item = group[name]
            if isinstance(item, h5py.Group):
                pending.append((item, where, depth + 1))
            elif isinstance(item, h5py.Dataset):
                if item.is_virtual:
                    raise FormatError(
                        f"{source}: {where} is a virtual dataset; refused: it can read other files"
                    )
                if item.external:
                    raise FormatError(f"{source}: {where} keeps its data in external files; refused")


def _read_channel(group: h5py.Group, name: str, source: Path, *, lazy: bool) -> Channel:
    ds = group[name]
    where = f"{source}: channel {name!r}"
    if not isinstance(ds, h5py.Dataset):
        raise FormatError(f"{where}: expected a dataset")
    a = ds.attrs
    kind = _text(a.get("kind", ""))
    if not kind:
        raise FormatError(f"{where}: missing attribute 'kind'")
    _unknown_attributes(where, a.keys(), CHANNEL_ATTRIBUTES | set(KIND_FIELDS.get(kind, {})))
    unit = _text(a["unit"]) if "unit" in a else _text(a.get("unit_string", ""))
    if not unit:
        raise FormatError(f"{where}: missing attribute 'unit' (or NI 'unit_string')")
    representation = _text(a.get("representation", "waveform"))
    if representation not in ("waveform", "events"):
        raise FormatError(f"{where}: representation {representation!r}: expected 'waveform' or 'events'")
    rate: float | None = None
    if representation == "waveform":
        if "sample_rate_hz" in a:
            rate = float(a["sample_rate_hz"])
        elif "wf_increment" in a:
            increment = float(a["wf_increment"])
            if not increment > 0:
                raise FormatError(f"{where}: wf_increment {increment!r}: expected a positive sample interval")
            rate = 1.0 / increment
        else:
            raise FormatError(f"{where}: missing attribute 'sample_rate_hz' (or NI 'wf_increment')")
        problem = rate_problem(rate)
        if problem is not None:
            raise FormatError(f"{where}: sample_rate_hz = {rate!r}: {problem}")
    offset = float(a.get("start_offset_s", a.get("wf_start_offset", 0.0)))
    fields: dict[str, float | int | str] = {}
    for key in KIND_FIELDS.get(kind, {}):
        if key in a:
            fields[key] = field_value(name, key, a[key])
    if ds.ndim != 1:
        raise FormatError(f"{where}: data has shape {ds.shape}, expected one dimension")
    if rate is not None and "duration_s" in a:
        stated = float(a["duration_s"])
        if abs(ds.size / rate - stated) > 1.0 / rate:
            raise FormatError(
                f"{where}: {ds.size} samples at {rate:g} Hz last {ds.size / rate:.6g} s, "
                f"but duration_s says {stated:.6g} s"
            )
    limits = (float(a["range_min"]), float(a["range_max"])) if "range_min" in a and "range_max" in a else None
    data: Any
    if lazy and rate is not None:
        pulses = kind in ("keyphasor", "tooth", "cam")  # pulse channels sit at their rails by design
        data = Hdf5Samples(ds, where, rate, offset, None if pulses else limits)
    else:
        try:
            data = ds[()]
        except OSError as error:
            raise FormatError(
                f"{where}: checksum failure or damaged data ({error}); the file is corrupt"
            ) from None
    try:
        channel = Channel(
            name=name,
            kind=kind,
            unit=unit,
            data=data,
            sample_rate=rate,
            start_offset=offset,
            location=_text(a.get("location", "")),
            direction=_text(a.get("direction", "")),
            fields=fields,
            range=limits,
        )
    except FormatError as error:
        raise FormatError(f"{source}: {error}") from None
    return channel.checked()
