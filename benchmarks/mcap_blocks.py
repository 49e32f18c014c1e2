"""The cost of encoding and decoding one MCAP block, by the protobuf runtime, against what it replaced.

``python -m benchmarks.mcap_blocks`` times, in one run, the product's block codec
(``monitor.io.mcap.wire.encode_sample_block`` / ``decode_block``: the protobuf runtime, as
``BlockWire``) against the hand-written wire-format codec it replaced (kept below, as it was, as
the reference) and against the floor (numpy viewing the same bytes). A block is 0.1 s of a 25.6 kHz
float32 channel (2560 samples), as the writer makes them. It writes its section of
docs/performance.md; its target: the runtime no slower than the hand-written codec.
"""

from __future__ import annotations

import argparse
import platform
import struct
import timeit
from datetime import UTC, datetime
from pathlib import Path

import numpy as np

from benchmarks.sections import replace_section
from monitor.io.mcap.wire import decode_block, encode_sample_block

ROOT = Path(__file__).resolve().parents[1]
DOC = ROOT / "docs" / "performance.md"
START, END = "<!-- mcap-blocks: start -->", "<!-- mcap-blocks: end -->"


# ------------------------------------------------ the hand-written codec the protobuf runtime replaced
def _varint(value: int) -> bytes:
    out = bytearray()
    while True:
        byte = value & 0x7F
        value >>= 7
        if value:
            out.append(byte | 0x80)
        else:
            out.append(byte)
            return bytes(out)


def _read_varint(buf: memoryview, pos: int) -> tuple[int, int]:
    result = shift = 0
    while True:
        byte = buf[pos]
        pos += 1
        result |= (byte & 0x7F) << shift
        if not byte & 0x80:
            return result, pos
        shift += 7


def hand_encode(time_ns: int, start_offset: float, rate: float, samples: np.ndarray) -> bytes:
    """The replaced encoder: the same message, assembled field by field."""
    finite = samples[np.isfinite(samples)].astype(np.float64)
    stats = (
        (finite.mean(), np.sqrt(np.mean(finite**2)), finite.min(), finite.max())
        if finite.size
        else (0.0,) * 4
    )
    seconds, nanos = divmod(time_ns, 1_000_000_000)
    inner = (b"\x08" + _varint(seconds) if seconds else b"") + (b"\x10" + _varint(nanos) if nanos else b"")
    raw = samples.astype(samples.dtype.newbyteorder("<"), copy=False).tobytes()
    field = 4 if samples.dtype == np.float32 else 5
    return (
        b"\x0a"
        + _varint(len(inner))
        + inner
        + _varint(2 << 3 | 1)
        + struct.pack("<d", start_offset)
        + _varint(3 << 3 | 1)
        + struct.pack("<d", rate)
        + _varint(field << 3 | 2)
        + _varint(len(raw))
        + raw
        + b"".join(_varint((6 + i) << 3 | 1) + struct.pack("<d", float(v)) for i, v in enumerate(stats))
    )


def hand_decode(data: bytes) -> tuple[float, float, np.ndarray]:
    """The replaced decoder: the wire format walked field by field (its checks left out)."""
    buf = memoryview(data)
    pos, start, rate = 0, 0.0, 0.0
    values: np.ndarray = np.empty(0)
    while pos < len(buf):
        key, pos = _read_varint(buf, pos)
        number, wire = key >> 3, key & 7
        if wire == 1:
            value = struct.unpack_from("<d", buf, pos)[0]
            pos += 8
            if number == 2:
                start = value
            elif number == 3:
                rate = value
        elif wire == 2:
            length, pos = _read_varint(buf, pos)
            if number in (4, 5):
                dtype = "<f4" if number == 4 and rate else "<f8"
                values = np.frombuffer(buf[pos : pos + length], dtype=dtype).copy()
            pos += length
        elif wire == 0:
            _, pos = _read_varint(buf, pos)
        elif wire == 5:
            pos += 4
    return start, rate, values


# ------------------------------------------------------------------------------------------- timing
def _per_call(call, repeat: int, number: int) -> float:  # type: ignore[no-untyped-def]
    """The fastest of ``repeat`` runs of ``number`` calls, per call [s] (the least disturbed by others)."""
    return min(timeit.repeat(call, repeat=repeat, number=number)) / number


def measure(repeat: int = 7, number: int = 2000) -> dict[str, float]:
    rng = np.random.default_rng(1)
    samples = rng.standard_normal(2560).astype(np.float32)
    time_ns, start, rate = 1_767_225_600_123_456_789, 12.3, 25_600.0
    ours = encode_sample_block(time_ns, start, rate, samples)
    theirs = hand_encode(time_ns, start, rate, samples)
    assert ours == theirs, "the two encoders write different bytes"
    assert np.array_equal(decode_block(ours)[2], hand_decode(ours)[2])
    raw = samples.tobytes()
    return {
        "encode_runtime": _per_call(
            lambda: encode_sample_block(time_ns, start, rate, samples), repeat, number
        ),
        "encode_hand": _per_call(lambda: hand_encode(time_ns, start, rate, samples), repeat, number),
        "decode_runtime": _per_call(lambda: decode_block(ours), repeat, number),
        "decode_hand": _per_call(lambda: hand_decode(ours), repeat, number),
        "floor": _per_call(lambda: np.frombuffer(raw, dtype="<f4").copy(), repeat, number),
        "bytes": float(len(ours)),
    }


def document(result: dict[str, float]) -> str:
    us = 1e6
    moment = datetime.now(UTC).strftime("%Y-%m-%d %H:%M UTC")
    met = (
        result["decode_runtime"] <= result["decode_hand"]
        and result["encode_runtime"] <= result["encode_hand"]
    )
    rows = [
        ("encode, protobuf runtime (the product)", result["encode_runtime"], result["encode_hand"]),
        ("encode, hand-written wire format (replaced)", result["encode_hand"], result["encode_hand"]),
        ("decode, protobuf runtime (the product)", result["decode_runtime"], result["decode_hand"]),
        ("decode, hand-written wire format (replaced)", result["decode_hand"], result["decode_hand"]),
        ("floor: numpy copies the samples' bytes", result["floor"], result["decode_hand"]),
    ]
    lines = [
        START,
        "## One MCAP block, encoded and decoded",
        "",
        f"Written by `python -m benchmarks.mcap_blocks` on {moment}, Python {platform.python_version()}, "
        f"{platform.machine()} (shared machine). A block of 2560 float32 samples (0.1 s at 25.6 kHz), "
        f"{result['bytes']:.0f} bytes; the two encoders write the same bytes. Each time is the fastest of "
        "7 runs of 2000 calls, per call.",
        "",
        "| codec | time per block | ratio to the hand-written codec |",
        "|---|---|---|",
        *[
            f"| {name} | {seconds * us:.1f} us | {seconds / reference:.2f} |"
            for name, seconds, reference in rows
        ],
        "",
        "Target (the hardening issue): the protobuf runtime no slower than the hand-written codec it "
        f"replaced: {'met' if met else 'not met'}.",
        END,
    ]
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.parse_args(argv)
    section = document(measure())
    replace_section(DOC, START, END, section)
    print(section)


if __name__ == "__main__":
    main()
