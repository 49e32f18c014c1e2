"""The MCAP recording format: round trips, the official decoder, truncation, checksums, real files."""

from __future__ import annotations

import io
from pathlib import Path

import numpy as np
import pytest
from google.protobuf import descriptor_pb2
from grpc_tools import protoc
from mcap.reader import make_reader
from mcap.writer import IndexType
from mcap_protobuf.decoder import DecoderFactory

import monitor.io.mcap.writer as mcap_writer
from monitor.errors import FormatError
from monitor.io.hdf5 import read_hdf5, write_hdf5
from monitor.io.mcap.listing import list_mcap
from monitor.io.mcap.reader import open_mcap, read_mcap
from monitor.io.mcap.samples import McapSamples
from monitor.io.mcap.wire import decode_block, encode_sample_block, schema_descriptor_set
from monitor.io.mcap.writer import write_mcap
from monitor.io.proto.engine_monitor import recording_pb2
from tests.conftest import shared_path
from tests.io.test_hdf5 import _recording


def _same(a, b) -> None:  # type: ignore[no-untyped-def]
    assert (a.engine_id, a.start_time, a.notes) == (b.engine_id, b.start_time, b.notes)
    assert [c.name for c in a.channels] == [c.name for c in b.channels]
    for x, y in zip(a.channels, b.channels, strict=True):
        assert (x.kind, x.unit, x.sample_rate, x.start_offset, x.location, x.direction, x.fields) == (
            y.kind,
            y.unit,
            y.sample_rate,
            y.start_offset,
            y.location,
            y.direction,
            y.fields,
        )
        assert x.data.dtype == y.data.dtype
        assert x.data.tobytes() == y.data.tobytes()  # bit-exact, NaNs included


def test_round_trip_hdf5_mcap_hdf5_is_bit_exact(tmp_path: Path, rng: np.random.Generator) -> None:
    """Issue acceptance: HDF5 -> MCAP -> HDF5 keeps every sample bit-exact and every attribute."""
    original = _recording(rng)
    first = read_hdf5(write_hdf5(original, tmp_path / "a.h5"))
    via = read_mcap(write_mcap(first, tmp_path / "b.mcap"))
    back = read_hdf5(write_hdf5(via, tmp_path / "c.h5"))
    _same(original, first)
    _same(first, via)
    _same(via, back)
    assert not via.truncated


@pytest.mark.parametrize("compression", ["zstd", "lz4", "none"])
def test_compressions(tmp_path: Path, rng: np.random.Generator, compression: str) -> None:
    original = _recording(rng)
    _same(original, read_mcap(write_mcap(original, tmp_path / "r.mcap", compression=compression)))  # type: ignore[arg-type]


def test_the_official_protobuf_decoder_reads_our_blocks(tmp_path: Path, rng: np.random.Generator) -> None:
    """The schema is a real FileDescriptorSet: mcap-protobuf-support decodes every message the way
    our own wire-level decoder does (what a general viewer such as Foxglove relies on)."""
    path = write_mcap(_recording(rng), tmp_path / "r.mcap")
    with open(path, "rb") as fh:
        reader = make_reader(fh, decoder_factories=[DecoderFactory()], validate_crcs=True)
        checked = 0
        for schema, _channel, message, decoded in reader.iter_decoded_messages():
            start, rate, values = decode_block(message.data)
            if schema.name == "engine_monitor.SampleBlock":
                theirs = np.array(decoded.samples_f32 or decoded.samples_f64)
                assert decoded.start_offset_s == start and decoded.sample_rate_hz == rate
                assert decoded.maximum == pytest.approx(float(np.max(values)))
            else:
                theirs = np.array(decoded.times_s)
            np.testing.assert_array_equal(theirs.astype(values.dtype), values)
            assert decoded.timestamp.seconds > 1_700_000_000
            checked += 1
    assert checked > 50


def test_block_encoding_handles_both_precisions() -> None:
    for dtype in (np.float32, np.float64):
        samples = np.array([1.5, -2.25, np.nan, 3.0], dtype=dtype)
        start, rate, values = decode_block(encode_sample_block(123, 0.5, 100.0, samples))
        assert (start, rate, values.dtype) == (0.5, 100.0, np.dtype(dtype))
        assert values.tobytes() == samples.tobytes()


def test_a_truncated_file_is_read_to_its_last_whole_chunk(tmp_path: Path, rng: np.random.Generator) -> None:
    original = _recording(rng)
    path = write_mcap(original, tmp_path / "r.mcap", chunk_size=16 * 1024)
    data = path.read_bytes()
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(data[: len(data) // 2])
    partial = read_mcap(cut)
    assert partial.truncated
    for a, b in zip(original.channels, partial.channels, strict=True):
        assert 0 < b.data.size < a.data.size or a.is_events
        assert np.array_equal(a.data[: b.data.size], b.data)  # what is there is exact


def test_a_flipped_byte_in_a_chunk_is_detected(tmp_path: Path, rng: np.random.Generator) -> None:
    path = write_mcap(_recording(rng), tmp_path / "r.mcap", compression="none")
    data = bytearray(path.read_bytes())
    data[len(data) // 3] ^= 0x01  # inside the first chunk's records
    damaged = tmp_path / "bad.mcap"
    damaged.write_bytes(bytes(data))
    with pytest.raises(FormatError, match="checksum failure"):
        read_mcap(damaged)


def test_files_that_are_not_recordings_are_refused(tmp_path: Path) -> None:
    text = tmp_path / "x.mcap"
    text.write_text("not an mcap file at all")
    with pytest.raises(FormatError, match="not an MCAP file"):
        read_mcap(text)
    with pytest.raises(FormatError, match="not an engine-monitor recording"):
        read_mcap(shared_path("external", "mcap-real", "owa-example.mcap"))


def test_unindexed_files_are_read_by_streaming(tmp_path: Path, rng: np.random.Generator) -> None:
    """A writer that keeps no index and no summary (a recorder that died before finishing, or a
    streaming one): the reader streams it and gets everything."""
    original = _recording(rng)
    plain = mcap_writer.Writer

    class Unindexed(plain):  # type: ignore[misc, valid-type]
        def __init__(self, output, **kwargs):  # type: ignore[no-untyped-def]
            super().__init__(
                output,
                **{
                    **kwargs,
                    "index_types": IndexType.NONE,
                    "use_summary_offsets": False,
                    "use_statistics": False,
                    "repeat_channels": False,
                    "repeat_schemas": False,
                },
            )

    mcap_writer.Writer = Unindexed
    try:
        path = write_mcap(original, tmp_path / "r.mcap")
    finally:
        mcap_writer.Writer = plain
    _same(original, read_mcap(path))


# -------------------------------------------------------------------------------- real files
def test_real_cart_pole_file_and_its_truncation(tmp_path: Path) -> None:
    """../shared/external/mcap-real/cartpole-kill_me_pls.mcap: 43 950 messages on 7 topics in 4 zstd
    chunks whose time ranges overlap; cut at byte 845 525 a recovering reader gets exactly 22 680."""
    path = shared_path("external", "mcap-real", "cartpole-kill_me_pls.mcap")
    listing = list_mcap(path)
    assert listing.total == 43950 and len(listing.messages) == 7 and not listing.truncated
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(path.read_bytes()[:845525])
    partial = list_mcap(cut)
    assert partial.truncated and partial.total == 22680


@pytest.mark.parametrize(
    "name", ["owa-0.3.2.mcap", "owa-0.5.1.mcap", "owa-example.mcap", "keelson-empty.mcap"]
)
def test_real_files_agree_with_their_own_statistics(name: str) -> None:
    """Streaming counts equal the file's own Statistics record (read with the indexed reader)."""
    path = shared_path("external", "mcap-real", name)
    listing = list_mcap(path)
    with open(path, "rb") as fh:
        summary = make_reader(fh).get_summary()
    assert summary is not None and summary.statistics is not None
    assert listing.total == summary.statistics.message_count
    if name == "keelson-empty.mcap":
        assert listing.total == 0
    _ = io


def test_each_chunk_holds_one_channel_and_opened_files_read_by_topic(
    tmp_path: Path, rng: np.random.Generator
) -> None:
    """Chunks are per channel (a reader of one topic decompresses only its own), and open_mcap serves
    every sample of every channel by slices, equal to reading the file whole."""
    original = _recording(rng)
    path = write_mcap(original, tmp_path / "r.mcap", chunk_size=8 * 1024)
    with open(path, "rb") as fh:
        summary = make_reader(fh).get_summary()
    assert summary is not None and len(summary.chunk_indexes) > len(original.channels)
    assert all(len(c.message_index_offsets) == 1 for c in summary.chunk_indexes)
    with open_mcap(path) as opened:
        for channel in original.channels:
            data = opened.channel(channel.name).data
            if channel.is_events:
                np.testing.assert_array_equal(data, channel.data)
                continue
            assert isinstance(data, McapSamples)
            n = channel.data.size
            pieces = [data[a : a + 700] for a in range(0, n, 500)]  # overlapping, forward
            np.testing.assert_array_equal(np.concatenate([p[:500] for p in pieces]), channel.data)
            np.testing.assert_array_equal(data[10:20], channel.data[10:20])  # backwards: starts again


def test_damage_met_while_reading_by_slices_names_the_channel(
    tmp_path: Path, rng: np.random.Generator
) -> None:
    path = write_mcap(_recording(rng), tmp_path / "r.mcap", compression="none")
    with open(path, "rb") as fh:
        summary = make_reader(fh).get_summary()
    assert summary is not None
    topic = {c.id: c.topic for c in summary.channels.values()}
    chunk = next(
        c for c in summary.chunk_indexes if topic[next(iter(c.message_index_offsets))] == "/mb3-vertical"
    )
    data = bytearray(path.read_bytes())
    data[chunk.chunk_start_offset + chunk.chunk_length // 2] ^= 0x01
    damaged = tmp_path / "bad.mcap"
    damaged.write_bytes(bytes(data))
    with open_mcap(damaged) as opened, pytest.raises(FormatError, match="'mb3-vertical': checksum failure"):
        opened.channel("mb3-vertical").data[:]


def test_an_opened_file_without_its_index_is_read_whole(tmp_path: Path, rng: np.random.Generator) -> None:
    original = _recording(rng)
    path = write_mcap(original, tmp_path / "r.mcap", chunk_size=16 * 1024)
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(path.read_bytes()[: path.stat().st_size // 2])
    with open_mcap(cut) as opened:
        assert opened.truncated
        assert isinstance(opened.channels[0].data, np.ndarray)


def test_the_shipped_proto_compiles_to_the_messages_the_product_uses(tmp_path: Path) -> None:
    """recording_pb2 is generated from the shipped .proto (make proto): compiled again here by protoc,
    the .proto gives the very descriptor the product encodes with and embeds as each file's schema."""
    proto = Path(recording_pb2.__file__).with_suffix("").with_name("recording.proto")
    include = proto.parents[1]
    out = tmp_path / "set.pb"
    well_known = Path(protoc.__file__).parent / "_proto"  # google/protobuf/timestamp.proto, from protoc
    argv = ["protoc", f"-I{include}", f"-I{well_known}", f"--descriptor_set_out={out}"]
    assert protoc.main([*argv, str(proto.relative_to(include))]) == 0
    compiled = descriptor_pb2.FileDescriptorSet.FromString(out.read_bytes()).file[0]
    for message in compiled.message_type:  # protoc adds the JSON names a generated module leaves out
        for field in message.field:
            field.ClearField("json_name")
    shipped = descriptor_pb2.FileDescriptorProto()
    recording_pb2.DESCRIPTOR.CopyToProto(shipped)
    assert compiled == shipped
    embedded = descriptor_pb2.FileDescriptorSet.FromString(schema_descriptor_set())
    assert [f.name for f in embedded.file] == [
        "google/protobuf/timestamp.proto",
        "engine_monitor/recording.proto",
    ]
    assert embedded.file[1] == shipped


def test_a_block_that_is_not_protobuf_is_refused() -> None:
    for data in (b"\x0a\xff\xff\xff\xff\x0f", b"\x22\x05abc", b"\x07"):
        with pytest.raises(FormatError, match="not a valid SampleBlock or EventBlock"):
            decode_block(data)
    block = encode_sample_block(0, 0.0, 100.0, np.arange(3, dtype=np.float32))
    with pytest.raises(FormatError, match="not whole 4-byte floats"):  # 12 sample bytes, one cut off
        decode_block(block.replace(b"\x22\x0c", b"\x22\x0b").replace(b"\x00\x00\x00@", b"\x00\x00@", 1))
