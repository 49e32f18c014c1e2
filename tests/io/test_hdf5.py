"""The HDF5 recording format: round trip, and every bad input refused with its message."""

from __future__ import annotations

import os
import stat
from pathlib import Path

import h5py
import numpy as np
import pytest

from monitor.errors import FormatError, OutputFolderError
from monitor.io.hdf5 import FORMAT_NAME, open_hdf5, read_hdf5, write_hdf5
from monitor.io.mcap.reader import open_mcap
from monitor.io.mcap.writer import write_mcap
from monitor.io.recording import Channel, Recording, quality_spans


def _recording(rng: np.random.Generator) -> Recording:
    fs = 2560.0
    t = np.arange(int(2.0 * fs)) / fs
    return Recording(
        engine_id="man-b-w-7k98mc",
        start_time="2026-11-22T10:15:00Z",
        notes="test bench run",
        channels=(
            Channel(
                "mb3-vertical",
                "acceleration",
                "m/s^2",
                (rng.standard_normal(t.size)).astype(np.float32),
                fs,
                location="main bearing 3",
                direction="vertical",
            ),
            Channel(
                "pressure-1",
                "pressure",
                "bar",
                (50 + 10 * np.sin(t)).astype(np.float32),
                fs,
                start_offset=0.01,
                fields={"cylinder": 1},
            ),
            Channel(
                "tooth",
                "tooth",
                "s",
                np.cumsum(np.full(400, 0.004)),
                None,
                fields={"teeth": 60, "missing_teeth": 2, "first_tooth_angle_deg": 117.0},
            ),
            Channel(
                "keyphasor",
                "keyphasor",
                "V",
                np.where(np.mod(t, 0.5) < 0.01, 5.0, 0.0),
                fs,
                fields={"pulse_angle_deg": 12.5},
            ),
        ),
    )


def test_round_trip_keeps_every_sample_and_attribute(tmp_path: Path, rng: np.random.Generator) -> None:
    original = _recording(rng)
    path = write_hdf5(original, tmp_path / "r.h5")
    back = read_hdf5(path)
    assert (back.engine_id, back.start_time, back.notes) == (
        original.engine_id,
        original.start_time,
        original.notes,
    )
    for a, b in zip(original.channels, back.channels, strict=True):
        assert (a.name, a.kind, a.unit, a.sample_rate, a.start_offset, a.location, a.direction, a.fields) == (
            b.name,
            b.kind,
            b.unit,
            b.sample_rate,
            b.start_offset,
            b.location,
            b.direction,
            b.fields,
        )
        assert a.data.dtype == b.data.dtype and np.array_equal(a.data, b.data)
    with h5py.File(path) as f:  # checksums and a chunked layout that lets a slice be read alone
        ds = f["channels/mb3-vertical"]
        assert ds.fletcher32 and ds.chunks == (2560,)


def _write_raw(path: Path, edit) -> Path:  # type: ignore[no-untyped-def]
    with h5py.File(path, "w") as f:
        f.attrs["format"] = "engine-monitor recording"
        f.attrs["format_version"] = 1
        f.attrs["engine_id"] = "e"
        f.attrs["start_time"] = "2026-11-22T10:15:00Z"
        ds = f.create_group("channels").create_dataset("acc", data=np.zeros(100, dtype=np.float32))
        ds.attrs.update({"kind": "acceleration", "unit": "m/s^2", "sample_rate_hz": 100.0, "duration_s": 1.0})
        edit(f)
    return path


@pytest.mark.parametrize(
    ("edit", "message"),
    [
        (lambda f: f.attrs.__setitem__("format", "something else"), "not an engine-monitor recording"),
        (lambda f: f.attrs.__delitem__("start_time"), "missing root attribute 'start_time'"),
        (lambda f: f["channels/acc"].attrs.__delitem__("kind"), "channel 'acc': missing attribute 'kind'"),
        (
            lambda f: f["channels/acc"].attrs.__delitem__("sample_rate_hz"),
            "channel 'acc': missing attribute 'sample_rate_hz'",
        ),
        (
            lambda f: f["channels/acc"].attrs.__setitem__("unit", "furlong"),
            "unit 'furlong' is unknown for a acceleration",
        ),
        (
            lambda f: f["channels/acc"].attrs.__setitem__("duration_s", 2.0),
            "100 samples at 100 Hz last 1 s, but duration_s says 2 s",
        ),
        (lambda f: f["channels/acc"].attrs.__setitem__("kind", "sound"), "kind 'sound' is unknown"),
        (lambda f: f.attrs.__setitem__("start_time", "yesterday"), "is not ISO 8601"),
        (lambda f: f.attrs.__setitem__("start_time", "2026-11-22T10:15:00+02:00"), "must be in UTC"),
    ],
)
def test_bad_files_are_refused_with_their_reason(tmp_path: Path, edit, message: str) -> None:  # type: ignore[no-untyped-def]
    path = _write_raw(tmp_path / "bad.h5", edit)
    with pytest.raises(FormatError, match=message.replace("(", r"\(").replace(")", r"\)")):
        read_hdf5(path)


def test_a_file_that_is_not_hdf5_is_refused(tmp_path: Path) -> None:
    path = tmp_path / "x.h5"
    path.write_text("time,value\n0,1\n")
    with pytest.raises(FormatError, match="not an HDF5 file"):
        read_hdf5(path)


def test_links_to_other_files_are_refused(tmp_path: Path) -> None:
    """External links, external raw storage and virtual datasets can read other files of the server."""
    other = tmp_path / "secret.h5"
    with h5py.File(other, "w") as f:
        f.create_dataset("data", data=np.arange(100.0))
    path = _write_raw(
        tmp_path / "link.h5", lambda f: f.__setitem__("channels/leak", h5py.ExternalLink(str(other), "data"))
    )
    with pytest.raises(FormatError, match="external link"):
        read_hdf5(path)
    raw = tmp_path / "raw.bin"
    np.arange(100, dtype=np.float32).tofile(raw)

    def external(f: h5py.File) -> None:
        f["channels"].create_dataset("ext", shape=(100,), dtype=np.float32, external=[(str(raw), 0, 400)])

    with pytest.raises(FormatError, match="external files"):
        read_hdf5(_write_raw(tmp_path / "external.h5", external))

    def virtual(f: h5py.File) -> None:
        layout = h5py.VirtualLayout(shape=(100,), dtype=np.float64)
        layout[:] = h5py.VirtualSource(str(other), "data", shape=(100,))
        f["channels"].create_virtual_dataset("virt", layout)

    with pytest.raises(FormatError, match="virtual dataset"):
        read_hdf5(_write_raw(tmp_path / "virtual.h5", virtual))


def test_a_flipped_byte_is_detected(tmp_path: Path, rng: np.random.Generator) -> None:
    path = write_hdf5(_recording(rng), tmp_path / "r.h5")
    with h5py.File(path) as f:
        offset = f["channels/mb3-vertical"].id.get_chunk_info(1).byte_offset
    with open(path, "r+b") as fh:
        fh.seek(offset + 100)
        byte = fh.read(1)
        fh.seek(offset + 100)
        fh.write(bytes([byte[0] ^ 0x10]))
    with pytest.raises(FormatError, match="channel 'mb3-vertical': checksum failure"):
        read_hdf5(path)
    with open_hdf5(path) as opened:  # read by slices: the damaged chunk is met when it is read
        samples = opened.channel("mb3-vertical").data
        samples[: samples.shape[0] // 100]  # the first chunk is whole
        with pytest.raises(FormatError, match="channel 'mb3-vertical': checksum failure"):
            samples[:]


def test_ni_waveform_attribute_names_are_accepted(tmp_path: Path) -> None:
    def ni(f: h5py.File) -> None:
        ds = f["channels"].create_dataset("ni", data=np.ones(50))
        ds.attrs.update(
            {"kind": "velocity", "unit_string": "mm/s", "wf_increment": 0.001, "wf_start_offset": 0.25}
        )

    channel = read_hdf5(_write_raw(tmp_path / "ni.h5", ni)).channel("ni")
    assert (
        channel.sample_rate == pytest.approx(1000.0)
        and channel.start_offset == 0.25
        and channel.unit == "mm/s"
    )


def test_nan_inf_and_clipping_are_reported_and_masked(tmp_path: Path) -> None:
    """NaN and Inf always; clipping only against the stated measuring range."""
    x = np.sin(np.linspace(0, 20, 1000)).astype(np.float32)
    x[100:110] = np.nan
    x[500] = np.inf
    x[700:720] = 2.0  # a sensor stuck at the top of its +-2 range
    spans, mask = quality_spans(x, 100.0, limits=(-2.0, 2.0))
    assert [(s.reason, s.samples) for s in spans] == [("nan", 10), ("inf", 1), ("clipped", 20)]
    assert spans[0].start == pytest.approx(1.0) and spans[2].stop == pytest.approx(7.19)
    assert mask.sum() == 31
    unranged, _ = quality_spans(x, 100.0)
    assert [s.reason for s in unranged] == ["nan", "inf"]  # no range: clipping is not judged

    def stored(f: h5py.File) -> None:
        ds = f["channels"].create_dataset("bad", data=x)
        ds.attrs.update(
            {
                "kind": "acceleration",
                "unit": "g",
                "sample_rate_hz": 100.0,
                "range_min": -2.0,
                "range_max": 2.0,
            }
        )

    channel = read_hdf5(_write_raw(tmp_path / "q.h5", stored)).channel("bad")
    assert channel.mask is not None and channel.mask.sum() == 31 and len(channel.quality) == 3
    assert channel.range == (-2.0, 2.0)


def test_clean_quantised_and_pulse_channels_are_not_masked(tmp_path: Path) -> None:
    """A 16-bit accelerometer well inside its range, and a 0/5 V keyphasor sitting on its rails:
    flat peaks and pulse tops are not clipping (review finding: they used to be masked)."""
    t = np.arange(200000) / 25600.0
    quantised = np.round(8.0 * np.sin(2 * np.pi * 1.733 * t) / (20 / 65536)) * (20 / 65536)
    ttl = np.where(np.mod(t, 0.58) < 0.01, 5.0, 0.0)

    def stored(f: h5py.File) -> None:
        a = f["channels"].create_dataset("acc16", data=quantised.astype(np.float32))
        a.attrs.update(
            {
                "kind": "acceleration",
                "unit": "m/s^2",
                "sample_rate_hz": 25600.0,
                "range_min": -10.0,
                "range_max": 10.0,
            }
        )
        k = f["channels"].create_dataset("kp", data=ttl.astype(np.float32))
        k.attrs.update(
            {
                "kind": "keyphasor",
                "unit": "V",
                "sample_rate_hz": 25600.0,
                "pulse_angle_deg": 0.0,
                "range_min": 0.0,
                "range_max": 5.0,
            }
        )

    recording = read_hdf5(_write_raw(tmp_path / "clean.h5", stored))
    assert recording.channel("acc16").mask is None and recording.channel("kp").mask is None


def test_write_is_all_or_nothing(
    tmp_path: Path, rng: np.random.Generator, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A write that fails leaves the earlier file untouched and no temporary file behind."""
    path = write_hdf5(_recording(rng), tmp_path / "r.h5")
    before = path.read_bytes()
    broken = Recording("e", "2026-11-22T10:15:00Z", (Channel("a", "acceleration", "g", np.zeros(10), 10.0),))

    def fail(*args, **kwargs):  # type: ignore[no-untyped-def]
        raise OSError("disk full")

    monkeypatch.setattr("monitor.io.hdf5.os.fsync", fail)
    with pytest.raises(OSError, match="disk full"):
        write_hdf5(broken, path)
    assert path.read_bytes() == before
    assert [p.name for p in tmp_path.iterdir()] == ["r.h5"]


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"kind": "tooth", "unit": "V", "fields": {"teeth": 60}}, "needs the attribute 'missing_teeth'"),
        (
            {
                "kind": "tooth",
                "unit": "V",
                "fields": {"teeth": 60, "missing_teeth": 60, "first_tooth_angle_deg": 0.0},
            },
            "1 <= missing_teeth < teeth - 1",
        ),
        (
            {"kind": "keyphasor", "unit": "s", "sample_rate": 10.0, "fields": {"pulse_angle_deg": 0.0}},
            "unit 's' is for event",
        ),
        ({"kind": "acceleration", "unit": "g", "sample_rate": -1.0}, "expected a positive rate"),
    ],
)
def test_bad_channels_are_refused(kwargs: dict, message: str) -> None:  # type: ignore[type-arg]
    base = {"name": "c", "data": np.zeros(10), "sample_rate": 100.0}
    with pytest.raises(FormatError, match=message):
        Channel(**{**base, **kwargs})


@pytest.mark.parametrize("umask", [0o022, 0o077, 0o002])
def test_written_files_take_the_users_umask(tmp_path: Path, rng: np.random.Generator, umask: int) -> None:
    """A recording is written through a temporary file (made 0600) and renamed: the file that appears
    has the mode a newly created file gets, 0666 less the umask, in HDF5 and in MCAP alike."""
    recording = _recording(rng)
    before = os.umask(umask)
    try:
        written = [write_hdf5(recording, tmp_path / "r.h5"), write_mcap(recording, tmp_path / "r.mcap")]
    finally:
        os.umask(before)
    for path in written:
        assert stat.S_IMODE(path.stat().st_mode) == 0o666 & ~umask, path


def test_writers_make_no_folder_they_were_not_asked_for(tmp_path: Path, rng: np.random.Generator) -> None:
    """A recording written into a folder that does not exist is refused naming it; none is created."""
    for write, name in ((write_hdf5, "r.h5"), (write_mcap, "r.mcap")):
        with pytest.raises(OutputFolderError, match=r"missing/deeper.*does not exist"):
            write(_recording(rng), tmp_path / "missing" / "deeper" / name)
    assert not (tmp_path / "missing").exists()


@pytest.mark.parametrize("dtype", [np.complex64, np.bool_, np.int16])
def test_samples_that_are_not_floats_are_refused(tmp_path: Path, dtype: type) -> None:
    """Issue 14: complex, bool and integer samples were taken (and failed later, or meant nothing)."""
    path = tmp_path / "r.h5"
    with h5py.File(path, "w") as f:
        f.attrs.update(
            {
                "format": FORMAT_NAME,
                "format_version": 1,
                "engine_id": "e",
                "start_time": "2026-01-01T00:00:00Z",
            }
        )
        ds = f.create_group("channels").create_dataset("mb1", data=np.ones(100, dtype))
        ds.attrs.update({"kind": "acceleration", "unit": "g", "sample_rate_hz": 1000.0})
    with pytest.raises(FormatError, match=f"samples of type {np.dtype(dtype)}; expected float32 or float64"):
        read_hdf5(path)


@pytest.mark.parametrize(
    ("kind", "fields", "said"),
    [
        ("tooth", {"teeth": 10**9, "missing_teeth": 2, "first_tooth_angle_deg": 0.0}, "3 <= teeth <= 3600"),
        ("encoder", {"pulses_per_revolution": 2**30, "first_pulse_angle_deg": 0.0}, "from 2 to 1048576"),
    ],
)
def test_absurd_pulse_counts_are_refused(kind: str, fields: dict, said: str) -> None:  # type: ignore[type-arg]
    with pytest.raises(FormatError, match=said):
        Channel("wheel", kind, "s", np.cumsum(np.full(10, 0.01)), None, fields=fields)


def test_read_into_a_reused_buffer_gives_the_slices_samples_and_their_checks(
    tmp_path: Path, rng: np.random.Generator
) -> None:
    """The resampler's reads: straight into a buffer it keeps (HDF5: read_direct; MCAP: the slice
    copied in), the same samples as slicing, unusable samples refused as a slice refuses them."""
    recording = _recording(rng)
    expected = np.asarray(recording.channel("mb3-vertical").data)
    for path, opener in (
        (write_hdf5(recording, tmp_path / "r.h5"), open_hdf5),
        (write_mcap(recording, tmp_path / "r.mcap"), open_mcap),
    ):
        with opener(path) as opened:
            data = opened.channel("mb3-vertical").data
            buffer = np.full(1000, np.nan, dtype=np.float32)
            for start in (0, 1234, expected.size - 1000):
                data.read_into(start, buffer)
                np.testing.assert_array_equal(buffer, expected[start : start + 1000])  # copies, exact
            with pytest.raises(FormatError, match="samples 5000 to 6000 asked"):
                data.read_into(expected.size - 120, buffer)

    def stored(f: h5py.File) -> None:
        x = np.sin(np.linspace(0, 20, 1000)).astype(np.float32)
        x[600] = np.nan
        ds = f["channels"].create_dataset("bad", data=x)
        ds.attrs.update({"kind": "acceleration", "unit": "g", "sample_rate_hz": 100.0})

    with open_hdf5(_write_raw(tmp_path / "q.h5", stored)) as opened:
        bad = opened.channel("bad").data
        bad.read_into(0, np.empty(500, dtype=np.float32))  # the clean part reads
        with pytest.raises(FormatError, match=r"unusable samples \(nan 6\.000"):
            bad.read_into(500, np.empty(500, dtype=np.float32))
