"""The command line, end to end: tables, JSON, plots, help and errors."""

from __future__ import annotations

import json
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from monitor.cli import main
from monitor.model.crankshaft import EngineModel
from monitor.model.engine import load_engine
from monitor.model.predicted import predict_orders
from monitor.report.plots import diagnosis_title
from tests.conftest import ENGINES


def test_orders_json_matches_the_library(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["orders", str(ENGINES / "man-b-w-7k98mc.toml"), "--rpm", "104", "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["format"] == "engine-monitor/model-orders"
    e = load_engine("man-b-w-7k98mc")
    lib = predict_orders(EngineModel(e), crank_speed=104 * math.pi / 30, load=1.0)
    assert doc["orders"] == [float(k) for k in lib.orders]
    np.testing.assert_allclose(
        doc["engine_torque_knm"]["amplitude"], np.abs(lib.engine_torque) / 1e3, atol=1e-8
    )
    assert len(doc["cylinders"]) == 7 and len(doc["main_bearings"]) == 8
    c4 = doc["cylinders"][3]["inertia_force_kn"]["vertical"]
    np.testing.assert_allclose(
        c4["phase_deg"][2], np.degrees(np.angle(lib.cylinder_inertia_force[3, 1, 2])), atol=1e-5
    )
    assert doc["operating_point"]["speed_rpm"] == pytest.approx(104)


def test_orders_table_and_plot(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    plot = tmp_path / "orders.png"
    assert (
        main(
            [
                "orders",
                "medium-speed-6l32",
                "--rpm",
                "750",
                "--load",
                "0.5",
                "--max-order",
                "6",
                "--plot",
                str(plot),
            ]
        )
        == 0
    )
    out = capsys.readouterr()
    assert "Engine torque [kN m]" in out.out and "Main-bearing force, vertical" in out.out
    assert plot.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_approximate_kinematics_selects_the_two_mass_rod(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["orders", "man-b-w-7k98mc", "--rpm", "104", "--kinematics", "approx", "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["model"]["rod_model"] == "two-mass" and doc["model"]["kinematics"] == "approx"
    amp = doc["cylinders"][0]["inertia_force_kn"]["vertical"]["amplitude"]
    assert max(amp[3:]) < 1e-9 * amp[1]  # the approximation has orders 1 and 2 only


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["orders", "no-such-engine", "--rpm", "100"], "no such engine file"),
        (["orders", "man-b-w-7k98mc", "--rpm", "104", "--load", "3"], "expected 0 <= load <= 1.1"),
        (
            ["orders", "man-b-w-7k98mc", "--rpm", "104", "--kinematics", "approx", "--rod-model", "rigid"],
            "two-mass",
        ),
    ],
)
def test_errors_exit_2_with_a_message(
    argv: list[str], message: str, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(argv) == 2
    assert message in capsys.readouterr().err


def test_bad_arguments_and_help() -> None:
    with pytest.raises(SystemExit) as info:
        main(["orders", "man-b-w-7k98mc", "--rpm", "-5"])
    assert info.value.code == 2
    with pytest.raises(SystemExit) as info:
        main(["--help"])
    assert info.value.code == 0


def test_module_entry_point_and_engine_list() -> None:
    run = subprocess.run(
        [sys.executable, "-m", "monitor", "engines"], capture_output=True, text=True, check=True
    )
    assert "man-b-w-7k98mc" in run.stdout and "four-stroke" in run.stdout
    version = subprocess.run(
        [sys.executable, "-m", "monitor", "--version"], capture_output=True, text=True, check=True
    )
    assert version.stdout.startswith("engine-monitor ")


SAMPLE = Path(__file__).resolve().parents[2] / "recordings" / "samples" / "7k98mc-baseline.h5"
BAD_FIGURES = [
    # arguments, exit status, what the one-line message must name
    (["orders", "man-b-w-7k98mc", "--rpm", "100", "--plot", "x.jpgx"], 2, "'jpgx'"),
    (["orders", "man-b-w-7k98mc", "--rpm", "100", "--plot", "{missing}/x.png"], 2, "does not exist"),
    (["torsion", "modes", "man-b-w-7k98mc", "--plot", "{missing}/x.png"], 2, "does not exist"),
    (["spectrum", str(SAMPLE), "--speed-map", "4", "--map-plot", "{missing}/m.png"], 2, "does not exist"),
    (["compare", str(SAMPLE), "--plot", "x.pdf"], 3, ".html, .png"),
]


@pytest.mark.parametrize(
    ("argv", "status", "named"), BAD_FIGURES, ids=[" ".join(c[0][:2]) for c in BAD_FIGURES]
)
def test_a_figure_that_cannot_be_written_is_refused_in_one_line_before_any_work(
    argv: list[str], status: int, named: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """An unknown figure format or a folder that does not exist: one error line naming it, the
    documented status (2; 3 for compare), nothing on stdout (refused before any work), and the
    folder not created."""
    missing = tmp_path / "no" / "such"
    assert main([a.format(missing=missing) for a in argv]) == status
    said = capsys.readouterr()
    lines = said.err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("engine-monitor: error: --") and named in lines[0]
    assert said.out == ""
    assert not (tmp_path / "no").exists()


def test_serve_refuses_a_port_out_of_range_and_one_in_use(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """--port 99999 is a usage error (argparse, status 2); a port another socket holds on loopback is
    refused in one line with status 2, as the README says, before the service starts."""
    import socket

    with pytest.raises(SystemExit) as stop:
        main(["serve", "--port", "99999", "--data", str(tmp_path)])
    assert stop.value.code == 2
    assert "expected a TCP port, 1 to 65535" in capsys.readouterr().err
    with socket.socket() as held:
        held.bind(("127.0.0.1", 0))
        held.listen()
        port = held.getsockname()[1]
        assert main(["serve", "--host", "127.0.0.1", "--port", str(port), "--data", str(tmp_path)]) == 2
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 1 and f"cannot listen on 127.0.0.1:{port}" in lines[0]


def _hostile_copies(folder: Path) -> dict[str, Path]:
    """Copies of a sample, each damaged as a hostile or broken file is."""
    import shutil

    import h5py

    out = {}
    zero = folder / "zero-rate.h5"
    shutil.copy(SAMPLE, zero)
    with h5py.File(zero, "r+") as f:
        # text attributes are fixed-length strings (kept in the checksummed header): bytes to h5py
        name = next(n for n, ds in f["channels"].items() if ds.attrs["representation"] == b"waveform")
        f["channels"][name].attrs["sample_rate_hz"] = 0.0
    out["a waveform at 0 Hz"] = zero
    loop = folder / "link-loop.h5"
    with h5py.File(loop, "w") as f:
        f.attrs["format"] = "engine-monitor recording"
        group = f.create_group("channels")
        group["a"] = h5py.SoftLink("/channels/b")
        group["b"] = h5py.SoftLink("/channels/a")
    out["a soft-link loop"] = loop
    missing = folder / "no-channels.h5"
    shutil.copy(SAMPLE, missing)
    with h5py.File(missing, "r+") as f:
        del f["channels"]
    out["no channels group"] = missing
    empty = folder / "empty.h5"
    empty.write_bytes(b"")
    out["an empty file"] = empty
    text = folder / "notes.mcap"
    text.write_text("not a recording\n")
    out["text named .mcap"] = text
    cut = folder / "cut.h5"
    cut.write_bytes(SAMPLE.read_bytes()[: SAMPLE.stat().st_size // 2])
    out["an HDF5 file cut in half"] = cut
    from monitor.io.hdf5 import read_hdf5
    from monitor.io.mcap.writer import write_mcap

    damaged = write_mcap(read_hdf5(SAMPLE), folder / "damaged.mcap", compression="none")
    data = damaged.read_bytes()  # the engine id is in the 'recording' metadata record only
    damaged.write_bytes(data.replace(b"man-b-w-7k98mc", b"man-b-w-7k98md"))
    out["an MCAP file with its engine id changed"] = damaged
    return out


COMMANDS_READING_A_RECORDING = [
    ["spectrum", "{path}"],
    ["compare", "{path}"],
    ["calibrate", "{path}", "-o", "{tmp}/baseline.json"],
    ["tdc", "{path}"],
    ["simulate", "--truth", "{path}"],
]


@pytest.mark.parametrize(
    "argv", COMMANDS_READING_A_RECORDING, ids=[c[0] for c in COMMANDS_READING_A_RECORDING]
)
def test_a_damaged_or_hostile_file_is_one_error_line_not_a_traceback(
    argv: list[str], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Every command that reads a recording, given a sample with a waveform at 0 Hz (it divided by
    zero), a soft-link loop, a file without its channels, an empty file, text, an HDF5 file cut in half,
    an MCAP file whose metadata was changed: one line on stderr naming the file, status 2 (3 for
    compare). (Damage inside one channel's samples is that channel's fault, reported as such.)"""
    for what, path in _hostile_copies(tmp_path).items():
        status = main([a.format(path=path, tmp=tmp_path) for a in argv])
        assert status == (3 if argv[0] == "compare" else 2), what
        assert not (tmp_path / "baseline.json").exists()
        said = capsys.readouterr().err
        assert "Traceback" not in said and len(said.strip().splitlines()) == 1, (what, said)
        assert said.startswith("engine-monitor: error: ") and path.name in said, (what, said)


def test_keys_are_created_listed_and_revoked_in_the_store_serve_uses(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    """`keys create|list|revoke --data DIR` use the store `serve --data DIR` uses: a created key is
    listed by id, fleet and label (never the key), and once revoked the store knows it no more, so the
    service refuses it from the next request on; revoking an unknown id is one error line, status 2."""
    from monitor.store import default_url, open_store

    monkeypatch.delenv("ENGINE_MONITOR_DB", raising=False)
    data = tmp_path / "data"
    assert main(["keys", "create", "--fleet", "north", "--label", "bridge pc", "--data", str(data)]) == 0
    key = capsys.readouterr().out.strip()
    store = open_store(default_url(data))
    try:
        assert store.fleet_of_key(key) is not None
        assert main(["keys", "list", "--data", str(data)]) == 0
        listed = capsys.readouterr().out
        assert "north" in listed and "bridge pc" in listed and key not in listed
        key_id = store.list_keys("north")[0].id
        assert main(["keys", "revoke", str(key_id), "--data", str(data)]) == 0
        assert store.fleet_of_key(key) is None
        assert main(["keys", "revoke", str(key_id), "--data", str(data)]) == 2
        assert f"no API key with id {key_id}" in capsys.readouterr().err
    finally:
        store.close()
    assert main(["keys", "list", "--data", str(tmp_path / "nowhere")]) == 2
    assert not (tmp_path / "nowhere").exists()


BAD_INPUTS = [
    # a command with a bad input, the status, what the one line must say
    (["orders", "no-such-engine", "--rpm", "100"], 2, "no such engine file"),
    (["spectrum", "{tmp}/missing.h5"], 2, "missing.h5"),
    (["simulate", "{tmp}/missing.toml", "-o", "{tmp}/x.h5"], 2, "missing.toml"),
    (["compare", "{tmp}/missing.h5"], 3, "missing.h5"),
    (["calibrate", "{tmp}/missing.h5", "-o", "{tmp}/b.json"], 2, "missing.h5"),
    (["batch", "{tmp}/no-such-folder", "--data", "{tmp}/data"], 3, "no such file or folder"),
    (["tdc", "{tmp}/missing.h5"], 2, "missing.h5"),
    (["torsion", "modes", "no-such-engine"], 2, "no such engine file"),
    (["keys", "revoke", "5", "--data", "{tmp}/no-data"], 2, "no such folder"),
    (["worker", "--store", "sqlite:///{tmp}/no/such/dir/x.db", "--data", "{tmp}"], 2, "cannot be reached"),
]


SAMPLE_ARG = "{sample}"
BAD_OPTIONS = [
    # every subcommand with an option out of its range: the status and what the error line must name
    (["orders", "man-b-w-7k98mc", "--rpm", "-5"], "--rpm"),
    (["orders", "man-b-w-7k98mc", "--rpm", "80", "--load", "7"], "load = 7.0"),
    (["spectrum", SAMPLE_ARG, "--max-order", "-3"], "--max-order"),
    (["spectrum", SAMPLE_ARG, "--orders", "x,-1"], "--orders"),
    (["spectrum", SAMPLE_ARG, "--speed-map", "0"], "speed bin"),
    (["import", "{tmp}/nothing.mf4", "-o", "{tmp}/x.h5"], "--map"),
    (["simulate", "{scene}", "-o", "{tmp}/x.txt"], ".h5 or .mcap"),
    (["simulate", "{scene}", "-o", "{tmp}/x.h5", "--seed", "-1"], "--seed"),
    (["compare", SAMPLE_ARG, "--cycle-phase", "90"], "--cycle-phase"),
    (["compare", SAMPLE_ARG, "--baseline", "{tmp}/none.json"], "none.json"),
    (["calibrate", SAMPLE_ARG, "-o", "{tmp}/no/such/b.json"], "b.json"),
    (["batch", "{tmp}", "--workers", "0"], "--workers"),
    (["batch", "--since", "notadate"], "--since"),
    (["serve", "--port", "99999"], "--port"),
    (["serve", "--uploads-per-fleet", "0"], "--uploads-per-fleet"),
    (["serve", "--upload-idle", "0"], "--upload-idle"),
    (["worker", "--processes", "0"], "--processes"),
    (["worker", "--lease", "nan"], "--lease"),
    (["keys", "create"], "--fleet"),
    (["keys", "revoke", "x"], "id"),
    (["tdc", SAMPLE_ARG, "--cylinder", "0"], "--cylinder 0"),
    (["engines", "--bogus"], "--bogus"),
    (["torsion", "modes", "man-b-w-7k98mc", "--reciprocating", "half"], "--reciprocating"),
    (["torsion", "campbell", "man-b-w-7k98mc", "--max-order", "0"], "--max-order"),
    (["torsion", "response", "man-b-w-7k98mc", "--rpm-min", "100", "--rpm-max", "50"], "rpm-min"),
    (["torsion", "axial", "man-b-w-7k98mc", "--max-order", "inf"], "--max-order"),
    (["torsion", "stability", "--points", "0"], "points >= 2"),
    (["torsion", "stability", "--r-min", "nan"], "--r-min"),
    (["torsion", "simulate", "--epsilon", "0.1", "--r", "-1"], "--r"),
]


@pytest.mark.parametrize(("argv", "said"), BAD_OPTIONS, ids=[" ".join(c[0][:3]) for c in BAD_OPTIONS])
def test_every_subcommand_answers_a_bad_option_with_its_usage_error(
    argv: list[str],
    said: str,
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """An option out of its range, of the wrong type, or missing: status 2 (3 for compare and batch, whose
    2 is an alarm) and an error line naming it
    (argparse's usage lines above it for a usage error), never a traceback, never an 'unexpected'."""
    monkeypatch.delenv("ENGINE_MONITOR_DB", raising=False)
    monkeypatch.chdir(tmp_path)
    values = {
        "tmp": tmp_path,
        "sample": SAMPLE,
        "scene": SAMPLE.parents[1] / "scenes" / "6l32-baseline.toml",
    }
    try:
        status = main([a.format(**values) for a in argv])
    except SystemExit as stop:  # argparse's usage error
        status = stop.code  # type: ignore[assignment]
    err = capsys.readouterr().err
    assert status == (3 if argv[0] in ("compare", "batch") else 2), err  # their 3: not diagnosed (README)
    last = err.strip().splitlines()[-1]
    assert "error: " in last and said in last, err
    assert "Traceback" not in err and "unexpected" not in err
    assert not (tmp_path / "data").exists()


@pytest.mark.parametrize(("argv", "status", "said"), BAD_INPUTS, ids=[" ".join(c[0][:2]) for c in BAD_INPUTS])
def test_every_subcommand_answers_a_bad_input_in_one_line(
    argv: list[str],
    status: int,
    said: str,
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """Each subcommand given a file, engine, folder or store that is not there: one line on stderr
    naming it, the README's status (2; 3 for compare and batch), no traceback, and nothing made for it (no
    data folder, no store)."""
    monkeypatch.delenv("ENGINE_MONITOR_DB", raising=False)
    monkeypatch.chdir(tmp_path)
    assert main([a.format(tmp=tmp_path) for a in argv]) == status
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("engine-monitor: error: ") and said in err[0], err
    assert not (tmp_path / "data").exists() and not (tmp_path / "no-data").exists()


@given(
    status=st.sampled_from(["healthy", "warning", "alarm", "inconclusive"]),
    summaries=st.lists(st.text(alphabet="abcdef %-()0123456789", min_size=1, max_size=150), max_size=8),
    width=st.integers(min_value=40, max_value=200),
)
def test_a_diagnosis_title_says_the_status_first_then_every_finding_shown_or_counted(
    status: str, summaries: list[str], width: int
) -> None:
    """Issue 16: the PNG's title carries the status and the findings. The first line starts with the
    status word, fits its width, and each finding is there whole, cut (the first alone, with an
    ellipsis), or counted in "+N more": none is lost, none is counted twice."""
    line, heading = diagnosis_title(status, summaries, heading="x.h5", width=width).split("\n")
    assert heading == "x.h5"
    assert line.startswith(status.upper()) and len(line) <= width
    parts = line[len(status) + 2 :].split("; ") if summaries else []
    more = int(parts.pop()[1:].split()[0]) if parts and parts[-1].startswith("+") else 0
    if not summaries:
        assert line == status.upper()
    if more == len(summaries) and parts == [] and summaries:  # nothing shown: only counted
        assert line == f"{status.upper()}: +{more} more"
    assert len(parts) + more == len(summaries)
    for shown, summary in zip(parts, summaries, strict=False):
        assert shown == summary or (shown.endswith("\u2026") and summary.startswith(shown[:-1]))
    assert all(shown == summary for shown, summary in zip(parts[1:], summaries[1:], strict=False))
