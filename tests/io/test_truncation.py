"""Files cut short never give a traceback: every cut is read up to its last whole chunk, flagged
``truncated``, or refused in one line with the product's error (a :class:`MonitorError`).

The sweeps cut a file at byte offsets and read each cut the ways the product does: whole
(:func:`monitor.io.read_recording`) and for analysis (:func:`monitor.io.open_recording`, every
sample read). Before the MCAP reader was made to parse whole records only, a cut inside a
record's header or fixed-size field raised ``struct.error``: 1254 of the 5927 cuts of the small
product file swept here, 27 521 of the 78 038 cuts of the four small third-party files; and 610
cuts of the product file left a channel with no samples, refused much later by the analysis with
a message about TDCs or a signal of shape (0,).
"""

from __future__ import annotations

import contextlib
import io
import json
from collections.abc import Callable, Iterable
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from mcap.reader import make_reader

from monitor.cli import main
from monitor.diagnosis import diagnose
from monitor.errors import FormatError, MonitorError
from monitor.io import open_recording, read_recording
from monitor.io.hdf5 import read_hdf5, write_hdf5
from monitor.io.mcap.listing import McapListing, list_mcap
from monitor.io.mcap.reader import MIN_SAMPLES_LEFT
from monitor.io.mcap.writer import write_mcap
from monitor.io.recording import Channel, Recording
from monitor.jobs.batch import run_batch
from monitor.model.engine import load_engine
from monitor.scene import load_scene, simulate
from monitor.store import open_store
from tests.conftest import ROOT, shared_path

SAMPLES = ROOT / "recordings" / "samples"
SCENES = ROOT / "recordings" / "scenes"
FOOTER_OPCODE = 0x02


def _small_recording() -> Recording:
    """A waveform and an event channel, short enough that sweeping every byte of its file is fast."""
    fs = 1000.0
    rng = np.random.default_rng(12)
    return Recording(
        engine_id="man-b-w-7k98mc",
        start_time="2026-11-22T10:15:00Z",
        notes="cut me",
        truth=json.dumps({"scene": "none"}),
        channels=(
            Channel(
                "mb3-vertical",
                "acceleration",
                "m/s^2",
                rng.standard_normal(240).astype(np.float32),
                fs,
                location="main bearing 3",
            ),
            Channel(
                "tooth",
                "tooth",
                "s",
                np.cumsum(np.full(40, 0.006)),
                None,
                fields={"teeth": 60, "missing_teeth": 2, "first_tooth_angle_deg": 117.0},
            ),
        ),
    )


def _record_starts(data: bytes) -> list[int]:
    """Byte offsets of the top-level records of a whole MCAP file (from its opcodes and lengths)."""
    starts, position = [], 8
    while position + 9 <= len(data):
        starts.append(position)
        if data[position] == FOOTER_OPCODE:
            break
        position += 9 + int.from_bytes(data[position + 1 : position + 9], "little")
    return starts


def _read_both(path: Path) -> Recording:
    """The recording read whole and opened for analysis (every sample read); the two must agree."""
    try:
        whole = read_recording(path)
    except MonitorError as error:
        with pytest.raises(type(error)), open_recording(path):
            pass
        raise
    with open_recording(path) as opened:
        assert opened.truncated == whole.truncated
        assert [c.name for c in opened.channels] == [c.name for c in whole.channels]
        for a, b in zip(whole.channels, opened.channels, strict=True):
            assert np.array_equal(np.asarray(b.data[:]), a.data)
    return whole


def _sweep(data: bytes, offsets: Iterable[int], cut: Path, read: Callable[[Path], Any]) -> dict[int, Any]:
    """Each cut's outcome: what ``read`` returned, or the MonitorError it raised. Any other
    exception is what these tests are about: they are gathered and fail the test together."""
    outcomes: dict[int, Any] = {}
    escaped = []
    for n in offsets:
        cut.write_bytes(data[:n])
        try:
            outcomes[n] = read(cut)
        except MonitorError as error:
            assert "\n" not in str(error), f"cut at {n}: a message of several lines: {error}"
            outcomes[n] = error
        except Exception as error:
            escaped.append(f"cut at {n}: {type(error).__name__}: {error}")
    assert not escaped, f"{len(escaped)} cuts raised other than a MonitorError, e.g. {escaped[:3]}"
    return outcomes


# ------------------------------------------------------------------------- the product's MCAP
def test_every_cut_of_a_small_product_mcap_file_reads_truncated_or_is_refused(tmp_path: Path) -> None:
    """Every byte offset of a 5.9 kB file of 5 chunks (about 1 ms a cut read both ways, so the whole
    file is swept): a recording flagged ``truncated`` whose samples are exactly the original's first
    ones, or a FormatError saying the file was cut short; the whole file reads whole."""
    original = _small_recording()
    path = write_mcap(original, tmp_path / "r.mcap", block_seconds=0.04, chunk_size=320)
    data = path.read_bytes()
    outcomes = _sweep(data, range(len(data) + 1), tmp_path / "cut.mcap", _read_both)

    whole = outcomes.pop(len(data))
    assert isinstance(whole, Recording) and not whole.truncated
    assert whole.truth == original.truth
    readable = {n: r for n, r in outcomes.items() if isinstance(r, Recording)}
    refused = {n: str(e) for n, e in outcomes.items() if not isinstance(e, Recording)}
    for n, recording in readable.items():
        assert recording.truncated, f"cut at {n} read as whole"
        assert [c.name for c in recording.channels] == [c.name for c in original.channels]
        for a, b in zip(original.channels, recording.channels, strict=True):
            assert MIN_SAMPLES_LEFT <= b.data.size <= a.data.size
            assert np.array_equal(a.data[: b.data.size], b.data), f"cut at {n}: {a.name} differs"
    for n, message in refused.items():
        assert isinstance(outcomes[n], FormatError)
        assert "cut short" in message or (n == 0 and "empty" in message), f"cut at {n}: {message}"
    # each kind of outcome occurs: before the metadata, before a channel's first chunk, partial reads
    assert any("before any 'recording' metadata record" in m for m in refused.values())
    assert any("channel 'mb3-vertical'" in m for m in refused.values())
    assert any("channel 'tooth'" in m for m in refused.values())
    partial = [r for r in readable.values() if r.channels[0].data.size < original.channels[0].data.size]
    assert partial, "no cut kept part of a channel"


def test_a_cut_after_one_channels_chunk_names_the_channel_left_without_samples(tmp_path: Path) -> None:
    """The windows of the channels follow each other, so a cut after the first chunk leaves the
    second channel without a sample: refused naming it, instead of failing later in the analysis."""
    path = write_mcap(_small_recording(), tmp_path / "r.mcap", block_seconds=0.04, chunk_size=320)
    with open(path, "rb") as fh:
        summary = make_reader(fh).get_summary()
    assert summary is not None
    first = min(summary.chunk_indexes, key=lambda c: c.chunk_start_offset)
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(path.read_bytes()[: first.chunk_start_offset + first.chunk_length + 5])
    with pytest.raises(FormatError, match=r"channel 'tooth': the file was cut short \(\d+ bytes\): none"):
        read_recording(cut)


# ------------------------------------------------------------------------- third-party MCAP
def _offsets(data: bytes, stride: int) -> list[int]:
    """Every offset of the first 512 bytes, of the first 32 of each record (its opcode, length and
    fixed-size fields: where struct.error came from) and of the last 64; a stride elsewhere."""
    chosen = set(range(0, min(512, len(data)))) | set(range(max(0, len(data) - 64), len(data) + 1))
    for start in _record_starts(data):
        chosen |= set(range(start, min(start + 32, len(data))))
    chosen |= set(range(0, len(data), stride))
    return sorted(chosen)


@pytest.mark.parametrize(
    ("name", "stride"),
    [
        ("keelson-empty.mcap", 1),
        ("owa-0.3.2.mcap", 61),
        ("owa-0.5.1.mcap", 61),
        ("owa-example.mcap", 61),
        ("cartpole-kill_me_pls.mcap", 16411),
    ],
)
def test_cuts_of_real_third_party_files_are_refused_in_one_line(
    name: str, stride: int, tmp_path: Path
) -> None:
    """../shared/external/mcap-real: files other programs wrote (other schemas). Read as a recording
    every cut is refused in one line: not this format, or cut short before any of its metadata.
    Listed (:func:`list_mcap`, any schema) every cut is read to its last whole chunk, flagged.

    Every offset of the 303-byte file; of the others, every offset in the record headers and
    fixed-size fields (where the old reader's ``struct.error`` came from) and a stride elsewhere:
    a cut inside chunk or schema bytes all take one path, and the cart-pole file has 1.6 MB."""
    data = shared_path("external", "mcap-real", name).read_bytes()
    offsets = _offsets(data, stride)
    cut = tmp_path / "cut.mcap"
    for n, outcome in _sweep(data, offsets, cut, read_recording).items():
        assert isinstance(outcome, FormatError), f"cut at {n} read as a recording"
        message = str(outcome)
        assert any(
            words in message
            for words in ("not an engine-monitor recording", "not readable as an engine-monitor", "signature")
        ) or (n == 0 and "empty" in message), f"cut at {n}: {message}"
    # listing parses every message and index entry: every 4th cut, of the 1.6 MB file in its first quarter
    listed_offsets = offsets[::4] if len(data) < 100_000 else [n for n in offsets if n < len(data) // 4][::64]
    full = list_mcap(shared_path("external", "mcap-real", name))
    for n, listing in _sweep(data, listed_offsets, cut, list_mcap).items():
        if isinstance(listing, McapListing):
            assert listing.truncated == (n < len(data)) and listing.total <= full.total, f"cut at {n}"
        else:
            assert n < 8 and "not an MCAP file" in str(listing), f"cut at {n}: {listing}"


# ------------------------------------------------------------------------- HDF5
def test_cuts_of_product_hdf5_files_are_refused_saying_cut_short(tmp_path: Path) -> None:
    """HDF5 keeps its metadata anywhere in the file, so a file cut short is refused, not read in
    part: every 7th byte of a small product file, and about 120 cuts of a bundled sample, each
    read whole and opened for analysis. Past the superblock (the first 48 bytes or so) the
    message says the file was cut short."""
    small = write_hdf5(_small_recording(), tmp_path / "small.h5", chunk_seconds=0.05).read_bytes()
    sample = (SAMPLES / "6l32-misfire-cyl3.h5").read_bytes()
    for data, stride in ((small, 7), (sample, 7919)):
        outcomes = _sweep(data, range(0, len(data), stride), tmp_path / "cut.h5", _read_both)
        for n, outcome in outcomes.items():
            assert isinstance(outcome, FormatError), f"cut at {n} was read"
            assert n < 64 or "the file was cut short" in str(outcome), f"cut at {n}: {outcome}"


# ------------------------------------------------------------------------- the command line
def _run(argv: list[str]) -> tuple[int, str, str]:
    """``engine-monitor ARGV`` in this process: exit status, standard output, standard error."""
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        try:
            status = main(argv)
        except SystemExit as exit_:
            status = exit_.code if isinstance(exit_.code, int) else 2
    return status, out.getvalue(), err.getvalue()


def test_the_commands_that_read_a_recording_answer_every_kind_of_cut_in_one_line(tmp_path: Path) -> None:
    """A simulated recording in MCAP (1.5 s of a 6L32, 5 channels, 64 kB chunks), cut inside its
    magic, its header, its metadata, a chunk's header, a later chunk, its data end, its summary and
    its closing magic, through ``spectrum``, ``compare``, ``calibrate`` and ``simulate --truth``:
    only the documented exit statuses (errors 2, ``compare`` 0-3), an error on one line of
    standard error, and a read cut says ``(truncated)``."""
    scene = load_scene(SCENES / "6l32-baseline.toml").model_copy(update={"duration_s": 1.5})
    path = write_mcap(simulate(scene, seed=5).recording, tmp_path / "r.mcap", chunk_size=64 * 1024)
    data = path.read_bytes()
    starts = _record_starts(data)
    chunks = [s for s in starts if data[s] == 0x06]
    data_end = next(s for s in starts if data[s] == 0x0F)
    cuts = [5, 12, starts[1] + 11, chunks[0] + 20, chunks[-1] - 100, data_end + 4]
    cuts += [(data_end + len(data)) // 2, len(data) - 3]
    cut = tmp_path / "cut.mcap"
    read_as_truncated = 0
    for n in cuts:
        cut.write_bytes(data[:n])
        readable = True
        try:
            read_recording(cut)
        except FormatError:
            readable = False
        commands = [
            ["spectrum", str(cut)],
            ["compare", str(cut)],
            ["calibrate", str(cut), "-o", str(tmp_path / "baseline.json")],
            ["simulate", "--truth", str(cut)],
        ]
        for argv in commands if not readable or n == cuts[4] else commands[::3]:
            status, out, err = _run(argv)
            failed = status == 3 if argv[0] == "compare" else status != 0
            assert status in ((0, 1, 2, 3) if argv[0] == "compare" else (0, 2)), (n, argv, status, err)
            if failed:
                assert err.startswith("engine-monitor: error: ") and err.count("\n") == 1, (n, argv, err)
                assert readable or "cut short" in err, (n, argv, err)
            if argv[0] == "spectrum" and status == 0:
                assert "(truncated)" in out.splitlines()[0]
                read_as_truncated += 1
            assert readable or failed, (n, argv, "a refused file was read")
    assert read_as_truncated >= 3


# ------------------------------------------------------------------------- the batch
def test_a_batch_lists_cut_files_as_unreadable_and_diagnoses_the_others(tmp_path: Path) -> None:
    """A folder with a readable recording cut in its summary, an MCAP file cut inside its header
    (which used to abort the whole batch with struct.error), an MCAP file cut before its first
    whole chunk and an HDF5 file cut in half: the cut ones are listed with their one-line reason,
    the readable one is diagnosed and said to be cut short."""
    folder = tmp_path / "recordings"
    folder.mkdir()
    mcap = write_mcap(read_hdf5(SAMPLES / "6l32-misfire-cyl3.h5"), tmp_path / "whole.mcap").read_bytes()
    starts = _record_starts(mcap)
    (folder / "summary-cut.mcap").write_bytes(mcap[:-40])
    (folder / "header-cut.mcap").write_bytes(mcap[:12])
    (folder / "chunk-cut.mcap").write_bytes(mcap[: starts[3] + 1000])
    sample = (SAMPLES / "7k98mc-baseline.h5").read_bytes()
    (folder / "half.h5").write_bytes(sample[: len(sample) // 2])
    store = open_store(f"sqlite:///{tmp_path / 's.db'}")
    try:
        fleet = store.create_fleet("ships")
        summary = run_batch(store, fleet, path=folder, workers=1)
    finally:
        store.close()
    assert (summary.registered, summary.diagnosed, summary.failed) == (1, 1, [])
    assert summary.truncated == ["summary-cut.mcap"]
    reasons = dict(summary.unreadable)
    assert sorted(reasons) == ["chunk-cut.mcap", "half.h5", "header-cut.mcap"]
    for name, reason in reasons.items():
        assert "cut short" in reason and "\n" not in reason, (name, reason)
    text = summary.text()
    assert "1 diagnosed, 0 failed, 3 unreadable" in text
    assert "cut short, read to its last whole chunk: summary-cut.mcap" in text


def test_a_diagnosis_of_a_file_cut_short_says_so() -> None:
    """compare's notes say a recording was cut short (it was only spectrum's output that said it)."""
    recording = read_recording(ROOT / "recordings" / "samples" / "7k98mc-misfire-cyl4.h5")
    cut = diagnose(replace(recording, truncated=True), load_engine("man-b-w-7k98mc"))
    assert any("cut short" in note for note in cut.notes)
