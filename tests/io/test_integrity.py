"""Integrity: every piece of a recording's metadata that a result depends on is covered by a checked
checksum, so a damaged file is refused instead of silently read with other values.

The sample data are covered by the formats' own chunk checksums (tested in test_io_hdf5 and
test_io_mcap); here the bytes outside the chunks are damaged, one bit at a time: the MCAP
summary, metadata record, indexes and footer; the HDF5 superblock, object headers, attributes and
indexes. Every damaged file must either be refused with a FormatError or read to exactly the
recording that was written (a bit no result depends on: padding, free space, a statistic).
"""

from __future__ import annotations

from pathlib import Path

import h5py
import numpy as np
import pytest
from mcap.reader import make_reader

import monitor.io.mcap.writer
from monitor.errors import FormatError
from monitor.io.hdf5 import read_hdf5, write_hdf5
from monitor.io.mcap.metadata import METADATA_CRC
from monitor.io.mcap.reader import open_mcap, read_mcap
from monitor.io.mcap.writer import write_mcap
from monitor.io.recording import Channel, Recording
from tests.io.test_hdf5 import _recording

#: Damaged copies read per format: enough to cover every region outside the chunks several
#: times over (a few thousand bytes), few enough to stay under a few seconds.
FLIPS = 400


def _small(rng: np.random.Generator) -> Recording:
    """The round-trip recording, shortened, with a stated cycle phase and a truth record."""
    full = _recording(rng)
    channels = tuple(
        Channel(c.name, c.kind, c.unit, c.data[:600], c.sample_rate, c.start_offset, c.location,
                c.direction, c.fields, c.range)
        for c in full.channels
    )  # fmt: skip
    return Recording(full.engine_id, full.start_time, channels, notes=full.notes, truth='{"seed": 1}',
                     cycle_phase_deg=360.0)  # fmt: skip


def _contents(recording: Recording) -> tuple[object, ...]:
    """Everything a result depends on, samples as bytes."""
    return (
        recording.engine_id,
        recording.start_time,
        recording.notes,
        recording.truth,
        recording.cycle_phase_deg,
        tuple(
            (c.name, c.kind, c.unit, c.sample_rate, c.start_offset, c.location, c.direction,
             tuple(sorted(c.fields.items())), c.range, np.asarray(c.data[:]).tobytes())
            for c in recording.channels
        ),
    )  # fmt: skip


def _flipped(data: bytes, position: int, target: Path) -> Path:
    damaged = bytearray(data)
    damaged[position] ^= 1 << (position % 8)
    target.write_bytes(bytes(damaged))
    return target


def _positions(outside: np.ndarray) -> np.ndarray:
    """FLIPS positions spread evenly over the bytes outside the chunks."""
    where = np.flatnonzero(outside)
    return where[np.linspace(0, where.size - 1, min(FLIPS, where.size)).astype(int)]


def _mcap_outside_chunks(path: Path) -> np.ndarray:
    with open(path, "rb") as fh:
        summary = make_reader(fh).get_summary()
    assert summary is not None
    outside = np.ones(path.stat().st_size, bool)
    for chunk in summary.chunk_indexes:
        outside[chunk.chunk_start_offset : chunk.chunk_start_offset + chunk.chunk_length] = False
    return outside


def test_no_bit_flip_outside_the_mcap_chunks_changes_what_is_read(
    tmp_path: Path, rng: np.random.Generator
) -> None:
    """Issue 14: 26 of 2000 such flips changed the diagnosis silently (e.g. first_tooth_angle_deg
    0.0 -> 4.0). Now each is refused, or changes nothing, by both readers."""
    original = _small(rng)
    path = write_mcap(original, tmp_path / "r.mcap", chunk_size=2048)
    data = path.read_bytes()
    expected = _contents(original)
    assert _read_whole(path) == _opened(path) == (False, expected)
    outcomes = {"refused": 0, "unchanged": 0, "cut short": 0}
    for position in _positions(_mcap_outside_chunks(path)):
        damaged = _flipped(data, int(position), tmp_path / "damaged.mcap")
        for read in (_read_whole, _opened):
            try:
                truncated, contents = read(damaged)
            except FormatError:
                outcomes["refused"] += 1
                continue
            if truncated:  # a damaged footer magic reads as a file cut short, and says so
                outcomes["cut short"] += 1
                continue
            assert contents == expected, f"bit {position % 8} of byte {position} read silently"
            outcomes["unchanged"] += 1
    assert outcomes["refused"] > FLIPS // 2, outcomes


def _read_whole(path: Path) -> tuple[bool, tuple[object, ...]]:
    recording = read_mcap(path)
    return recording.truncated, _contents(recording)


def _opened(path: Path) -> tuple[bool, tuple[object, ...]]:
    with open_mcap(path) as recording:
        return recording.truncated, _contents(recording)


def _replace_once(data: bytes, old: bytes, new: bytes) -> bytes:
    assert len(old) == len(new) and data.count(old) >= 1
    return data.replace(old, new)


def test_mcap_metadata_damaged_in_place_is_refused_or_not_used(
    tmp_path: Path, rng: np.random.Generator
) -> None:
    """The two silent corruptions the issue names, made on purpose: a channel's tooth angle in the
    summary and the recording's cycle phase in its metadata record."""
    original = _small(rng)
    path = write_mcap(original, tmp_path / "r.mcap")
    data = path.read_bytes()
    # first_tooth_angle_deg in the summary's channel record (the chunks' copies are compressed):
    # the streaming reader takes the chunks' checksummed copy, the indexed one refuses the summary
    damaged = tmp_path / "damaged.mcap"
    damaged.write_bytes(_replace_once(data, b"117.0", b"113.0"))
    assert _read_whole(damaged) == (False, _contents(original))
    with pytest.raises(FormatError, match="checksum failure: the summary's CRC"):
        _opened(damaged)
    # cycle_phase_deg in the 'recording' metadata record, which no MCAP CRC covers but ours
    damaged.write_bytes(_replace_once(data, b"360.0", b"320.0"))
    for read in (_read_whole, _opened):
        with pytest.raises(FormatError, match="checksum failure: the metadata records' CRC"):
            read(damaged)


def test_an_mcap_file_without_the_metadata_crc_is_refused_saying_so(
    tmp_path: Path, rng: np.random.Generator, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A file whose channels state no metadata CRC (as written before the format required one)
    cannot have its metadata checked: refused, with what to do."""
    with monkeypatch.context() as patch:
        patch.setattr(monitor.io.mcap.writer, "METADATA_CRC", "written_before")
        path = write_mcap(_small(rng), tmp_path / "old.mcap")
    for read in (_read_whole, _opened):
        with pytest.raises(FormatError, match=f"no '{METADATA_CRC}'.*write it again"):
            read(path)


def _hdf5_outside_chunks(path: Path) -> np.ndarray:
    outside = np.ones(path.stat().st_size, bool)
    with h5py.File(path, "r") as f:
        for name in f["channels"]:
            dataset = f["channels"][name]
            for i in range(dataset.id.get_num_chunks()):
                info = dataset.id.get_chunk_info(i)
                outside[info.byte_offset : info.byte_offset + info.size] = False
    return outside


def test_no_bit_flip_outside_the_hdf5_chunks_changes_what_is_read(
    tmp_path: Path, rng: np.random.Generator
) -> None:
    """Issue 14: a flipped attribute name silently dropped a channel's location. The writer now keeps
    every attribute in checksummed object headers (HDF5 1.10 format, fixed-length strings)."""
    original = _small(rng)
    path = write_hdf5(original, tmp_path / "r.h5", chunk_seconds=0.05)
    data = path.read_bytes()
    expected = _contents(original)
    assert _contents(read_hdf5(path)) == expected
    outcomes = {"refused": 0, "unchanged": 0}
    for position in _positions(_hdf5_outside_chunks(path)):
        damaged = _flipped(data, int(position), tmp_path / "damaged.h5")
        try:
            recording = read_hdf5(damaged)
        except FormatError:
            outcomes["refused"] += 1
            continue
        assert _contents(recording) == expected, f"bit {position % 8} of byte {position} read silently"
        outcomes["unchanged"] += 1
    assert outcomes["refused"] > FLIPS // 4, outcomes


@pytest.mark.parametrize(
    ("owner", "name", "message"),
    [
        ("root", "engine_ib", "root: unknown attribute 'engine_ib'"),
        ("channel", "locatiom", "channel 'mb3-vertical': unknown attribute 'locatiom'"),
        ("channel", "teeth", "unknown attribute 'teeth'"),  # a tooth wheel's, on an accelerometer
    ],
)
def test_an_hdf5_attribute_the_schema_lacks_is_refused(
    tmp_path: Path, rng: np.random.Generator, owner: str, name: str, message: str
) -> None:
    """Files from other writers have no header checksums: a misspelt attribute would be ignored and
    its value lost, so the reader checks every name against the format's schema."""
    path = write_hdf5(_small(rng), tmp_path / "r.h5")
    with h5py.File(path, "r+") as f:
        target = f if owner == "root" else f["channels"]["mb3-vertical"]
        target.attrs[name] = 60 if name == "teeth" else "x"
    with pytest.raises(FormatError, match=message):
        read_hdf5(path)


def test_the_user_s_own_and_ni_s_attributes_are_let_through(tmp_path: Path, rng: np.random.Generator) -> None:
    path = write_hdf5(_small(rng), tmp_path / "r.h5")
    with h5py.File(path, "r+") as f:
        f.attrs["x_vessel"] = "MV Example"
        f["channels"]["mb3-vertical"].attrs["wf_samples"] = 600
        f["channels"]["mb3-vertical"].attrs["NI_ChannelName"] = "MB3 vertical"
    assert read_hdf5(path).channel("mb3-vertical").location == "main bearing 3"
