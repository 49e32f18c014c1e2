"""The service as a hostile client sees it: other fleets' ids on every route, hostile HDF5, damaged
uploads. (The kill -9 series of server and worker runs in ``make bench-kill``, benchmarks/service_kill.py.)

The counts each test drives are printed (``-s`` shows them) and stated in docs/service.md.
"""

from __future__ import annotations

import os
import time
import tomllib
from collections.abc import Iterator
from pathlib import Path

import h5py
import httpx
import numpy as np

from monitor.io.hdf5 import read_hdf5, write_hdf5
from monitor.io.mcap.reader import read_mcap
from monitor.io.mcap.writer import write_mcap
from tests.api.test_api import SAMPLES, Server, _upload

from . import test_api

server = test_api.server  # the same fixture: a server with fleets a and b, one analysis process

ENGINES = Path(__file__).resolve().parents[2] / "monitor" / "model" / "engines"
#: Damaged copies uploaded per format: bit flips anywhere, then cuts.
FLIPS, CUTS = 12, 4


def _routes(server: Server) -> list[tuple[str, str]]:
    """Every (method, path) of the OpenAPI document that takes a recording or an engine id."""
    document = httpx.get(f"{server.url}/openapi.json", headers={"X-API-Key": server.keys["a"]}).json()
    return [
        (method.upper(), path)
        for path, operations in document["paths"].items()
        for method in operations
        if "{recording_id}" in path or "{engine_id}" in path
    ]


def test_another_fleet_s_ids_answer_404_on_every_route_as_unknown_ones_do(server: Server) -> None:
    """Fleet a's recording and engine, asked for by fleet b on every route that takes an id (every
    method the document lists), answer exactly as ids nobody has: 404 not_found, same body shape.

    Fleet a's engine has an id of its own: a bundled engine's id is every fleet's to read. A body, where
    a route takes one, is valid for it (an engine description, a recording id), so the answer is the
    route's own and not the body's validation."""
    with server.client("a") as a, server.client("b") as b:
        recording = _upload(a, SAMPLES / "6l32-misfire-cyl3.h5").json()["id"]
        engine = "ship-a-main-engine"
        description = tomllib.loads((ENGINES / "medium-speed-6l32.toml").read_text())
        created = a.post("/engines", json={"description": {**description, "id": engine}})
        assert created.status_code == 201, created.text
        probes = 0
        for method, path in _routes(server):
            for ids in ((recording, engine), (987654, "nobody-has-this-engine")):
                url = path.replace("{recording_id}", str(ids[0])).replace("{engine_id}", str(ids[1]))
                body = {"description": {**description, "id": ids[1]}, "recording_id": ids[0]}
                answer = b.request(method, url, json=body if method in ("PUT", "POST") else None)
                probes += 1
                assert answer.status_code == 404, (method, url, answer.text)
                assert answer.json()["error"]["code"] == "not_found"
        assert a.get(f"/engines/{engine}").status_code == 200  # fleet a's engine is as it was
        assert a.get(f"/engines/{engine}").json() == created.json()
    print(f"cross-fleet probes: {probes} on {len(_routes(server))} routes")
    assert probes >= 10


def _hostile_files(folder: Path) -> dict[str, Path]:
    """HDF5 files that try to read what is not theirs, or to cost what they do not hold."""
    canary = folder / "outside" / "canary.bin"
    canary.parent.mkdir()
    canary.write_bytes(np.arange(1000, dtype=np.float32).tobytes())
    os.utime(canary, (0, time.time()))  # atime before mtime: any read moves it (relatime)
    good = read_hdf5(SAMPLES / "6l32-misfire-cyl3.h5")
    files = {}

    def copy(name: str) -> Path:
        path = folder / name
        write_hdf5(good, path)
        return path

    path = copy("external-storage.h5")
    with h5py.File(path, "r+") as f:
        f["channels"].create_dataset(
            "stolen", shape=(1000,), dtype=np.float32, external=[(str(canary), 0, 4000)]
        )
    files["external raw storage"] = path
    path = copy("virtual.h5")
    with h5py.File(path, "r+") as f:
        layout = h5py.VirtualLayout(shape=(1000,), dtype=np.float32)
        layout[:] = h5py.VirtualSource(str(canary), "data", shape=(1000,))
        f["channels"].create_virtual_dataset("stolen", layout)
    files["virtual dataset"] = path
    path = copy("external-link.h5")
    with h5py.File(path, "r+") as f:
        f["channels"]["stolen"] = h5py.ExternalLink(str(canary), "/data")
    files["external link"] = path
    path = copy("soft-link.h5")
    with h5py.File(path, "r+") as f:
        f["channels"]["loop"] = h5py.SoftLink("/channels/loop")
    files["soft-link loop"] = path
    path = folder / "bomb.h5"  # 200 MB of zeros, gzip level 9: about 200 kB on disk
    write_hdf5(good, path)
    with h5py.File(path, "r+") as f:
        ds = f["channels"].create_dataset(
            "zeros",
            data=np.zeros(50_000_000, np.float32),
            chunks=(1 << 20,),
            compression="gzip",
            compression_opts=9,
        )
        ds.attrs.update({"kind": "acceleration", "unit": "m/s^2", "sample_rate_hz": 25600.0})
    files["compression bomb"] = path
    path = copy("huge-shape.h5")
    with h5py.File(path, "r+") as f:
        ds = f["channels"].create_dataset("huge", shape=(10**12,), dtype=np.float32, chunks=(4096,))
        ds.attrs.update({"kind": "acceleration", "unit": "m/s^2", "sample_rate_hz": 25600.0})
    files["declared 10^12 samples"] = path
    return files


def _atime_counts(path: Path) -> bool:
    """Whether a read of this file would show in its access time (not on a noatime mount)."""
    probe = path.with_name("probe.bin")
    probe.write_bytes(b"x")
    os.utime(probe, (0, time.time()))
    probe.read_bytes()
    counted = probe.stat().st_atime > 0
    probe.unlink()
    return counted


def test_hostile_hdf5_uploads_are_refused_reading_nothing_outside(server: Server, tmp_path: Path) -> None:
    files = _hostile_files(tmp_path)
    canary = tmp_path / "outside" / "canary.bin"
    with server.client() as client:
        for what, path in files.items():
            answer = _upload(client, path)
            assert answer.status_code == 422, (what, answer.text)
            assert answer.json()["error"]["code"] == "not_a_recording", what
        assert client.get("/recordings").json()["items"] == []
    assert list((server.data / "recordings").iterdir()) == []
    assert list((server.data / "incoming").iterdir()) == []
    if _atime_counts(canary):
        assert canary.stat().st_atime == 0, "a file outside the data folder was read"
    print(f"hostile HDF5 refused: {len(files)} ({', '.join(files)})")


def _damaged(data: bytes, rng: np.random.Generator) -> Iterator[tuple[str, bytes]]:
    for _ in range(FLIPS):
        position = int(rng.integers(len(data)))
        flipped = bytearray(data)
        flipped[position] ^= 1 << int(rng.integers(8))
        yield f"bit flip at byte {position}", bytes(flipped)
    for cut in rng.integers(16, len(data) - 1, CUTS):
        yield f"cut at {cut} of {len(data)} bytes", data[: int(cut)]


def test_damaged_uploads_are_refused_or_stored_intact_never_a_5xx(server: Server, tmp_path: Path) -> None:
    """Bit flips anywhere in an uploaded MCAP or HDF5 file, and cuts: each is refused (422, or 415 for a
    flip in the signature) or, where the bit is one no result depends on, stored and read back as the
    original. Nothing half-stored."""
    rng = np.random.default_rng(14)
    original = read_hdf5(SAMPLES / "6l32-misfire-cyl3.h5")
    sources = {
        "HDF5": (SAMPLES / "6l32-misfire-cyl3.h5").read_bytes(),
        "MCAP": write_mcap(original, tmp_path / "r.mcap").read_bytes(),
    }
    outcomes: dict[str, int] = {"refused": 0, "stored intact": 0}
    with server.client() as client:
        for kind, data in sources.items():
            suffix = ".h5" if kind == "HDF5" else ".mcap"
            for what, damaged in _damaged(data, rng):
                answer = client.post("/recordings", params={"filename": f"d{suffix}"}, content=damaged)
                assert answer.status_code in (200, 201, 415, 422), (kind, what, answer.text)
                if answer.status_code in (415, 422):  # 415: a flip in the signature, refused unread
                    outcomes["refused"] += 1
                    continue
                stored = next((server.data / "recordings").glob(f"{answer.json()['content_hash']}*"))
                read = read_hdf5(stored) if kind == "HDF5" else read_mcap(stored)
                for a, b in zip(read.channels, original.channels, strict=True):
                    assert np.array_equal(np.asarray(a.data), np.asarray(b.data)), (kind, what)
                outcomes["stored intact"] += 1
    assert list((server.data / "incoming").iterdir()) == []
    assert outcomes["refused"] >= FLIPS  # most flips land in samples, whose checksums refuse them
    print(f"damaged uploads: {2 * (FLIPS + CUTS)}: {outcomes}")
