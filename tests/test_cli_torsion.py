"""``engine-monitor torsion ...`` end to end: JSON agrees with the library, plots, errors exit 2."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from monitor.cli import main
from monitor.engine import load_engine
from monitor.torsion.shaft_line import shaft_line_of


def _json(argv: list[str], capsys: pytest.CaptureFixture[str]) -> dict:  # type: ignore[type-arg]
    assert main(argv) == 0
    return json.loads(capsys.readouterr().out)


def test_modes(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    doc = _json(["torsion", "modes", "man-b-w-7k98mc", "--json", "--plot", str(tmp_path / "m.png")], capsys)
    expected = shaft_line_of(load_engine("man-b-w-7k98mc")).modes().frequencies_hz
    np.testing.assert_allclose(doc["frequencies_hz"], expected, rtol=1e-12)
    assert doc["nodes"][0] == "front end" and doc["rigid_body_modes"] == 1
    assert (tmp_path / "m.png").read_bytes()[:4] == b"\x89PNG"


def test_campbell(capsys: pytest.CaptureFixture[str]) -> None:
    doc = _json(["torsion", "campbell", "medium-speed-6l32", "--json", "--max-order", "6"], capsys)
    assert doc["orders"][0] == 0.5 and doc["orders"][-1] == 6.0
    for c in doc["critical_speeds"]:
        assert c["order"] * c["speed_rpm"] / 60 == pytest.approx(doc["frequencies_hz"][c["mode"] - 1])


def test_response(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    doc = _json(
        [
            "torsion",
            "response",
            "man-b-w-7k98mc",
            "--steps",
            "12",
            "--max-order",
            "8",
            "--json",
            "--plot",
            str(tmp_path / "r.png"),
        ],
        capsys,
    )
    assert doc["node"] == "turning wheel" and len(doc["speed_rpm"]) == 12
    assert np.array(doc["angle_mrad"]["amplitude"]).shape == (12, 8)
    assert (tmp_path / "r.png").exists()


def test_axial(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    doc = _json(
        [
            "torsion",
            "axial",
            "man-b-w-7k98mc",
            "--steps",
            "6",
            "--max-order",
            "8",
            "--json",
            "--plot",
            str(tmp_path / "a.png"),
        ],
        capsys,
    )
    assert len(doc["couplings_m_per_nm"]) == 7 and np.array(doc["free_end_axial_um"]).shape == (6, 8)
    assert doc["frequencies_hz"][0] > 1.0 and (tmp_path / "a.png").exists()


def test_stability_lists_the_table_1_ranges(capsys: pytest.CaptureFixture[str]) -> None:
    doc = _json(["torsion", "stability", "--points", "20", "--epsilon", "0.34", "--json"], capsys)
    (low, _), (_, high) = doc["instability_ranges"]["0.34"]
    assert abs(low - 0.512) < 0.006 and abs(high - 1.168) < 0.006
    assert np.array(doc["unstable"]).shape == (20, 20)


def test_simulate(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    doc = _json(
        [
            "torsion",
            "simulate",
            "--epsilon",
            "0.34",
            "--r",
            "0.1",
            "--revolutions",
            "1",
            "--samples",
            "100",
            "--json",
            "--plot",
            str(tmp_path / "s.png"),
        ],
        capsys,
    )
    assert len(doc["gamma_rad"]) == 101 and doc["gamma_rad"][0] == 1.0 and doc["integrator"] == "periodic"


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["torsion", "simulate", "--epsilon", "1.0", "--r", "0.5"], "expected 0 <= epsilon < 1"),
        (
            ["torsion", "simulate", "--epsilon", "0.3", "--r", "0"],
            "argument --r: '0': expected a positive number",
        ),
        (["torsion", "modes", "kluczyk-1cyl-4stroke"], "has no [shaft_line]"),
        (["torsion", "axial", "medium-speed-6l32"], "no [shaft_line.axial] data"),
        (["torsion", "response", "man-b-w-7k98mc", "--node", "nowhere"], "no node named 'nowhere'"),
        (["torsion", "response", "man-b-w-7k98mc", "--load", "heavy"], "--load 'heavy'"),
        (
            [
                "torsion",
                "simulate",
                "--epsilon",
                "0.3",
                "--r",
                "0.5",
                "--form",
                "full",
                "--integrator",
                "periodic",
            ],
            "propagates the linear equation only",
        ),
    ],
)
def test_errors_exit_2(argv: list[str], message: str, capsys: pytest.CaptureFixture[str]) -> None:
    try:
        status = main(argv)
    except SystemExit as stop:  # a usage error, from argparse
        status = stop.code  # type: ignore[assignment]
    assert status == 2
    assert message in capsys.readouterr().err
