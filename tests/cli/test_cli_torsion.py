"""``engine-monitor torsion ...`` end to end: JSON agrees with the library, plots, errors exit 2."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from monitor.cli import main
from monitor.model.engine import load_engine
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
    """Paper 002 Table 1 (Gregory's analysis, 0.512..0.516 and 0.966..1.168 at epsilon 0.34): the ranges
    near r = 1/2 and 1 within 0.006, beside the narrow one near r = 1/3 in the default window."""
    doc = _json(["torsion", "stability", "--points", "20", "--epsilon", "0.34", "--json"], capsys)
    found = doc["instability_ranges"]["0.34"]
    near_half = [x for x in found if 0.45 < x[0] < 0.55]
    near_one = [x for x in found if 0.9 < x[0] < 1.1]
    assert len(near_half) == len(near_one) == 1
    assert abs(near_half[0][0] - 0.512) < 0.006 and abs(near_one[0][1] - 1.168) < 0.006
    assert np.array(doc["unstable"]).shape == (20, 20)
    assert doc["steps"] >= 8 and 0 < doc["boundary_error"] <= 0.5e-6


def test_stability_tolerance_sets_the_step_count(capsys: pytest.CaptureFixture[str]) -> None:
    """A boundary tolerance 16 times looser takes about half the Magnus steps (fourth-order method);
    --steps overrides it; the boundaries of a range move by less than the looser tolerance."""
    argv = ["torsion", "stability", "--points", "8", "--epsilon", "0.5", "--json"]
    fine = _json([*argv, "--tolerance", "1e-7"], capsys)
    loose = _json([*argv, "--tolerance", "1.6e-6"], capsys)
    fixed = _json([*argv, "--steps", "300"], capsys)
    assert 1.8 < fine["steps"] / loose["steps"] < 2.2 and fixed["steps"] == 300
    for a, b in zip(fine["instability_ranges"]["0.5"], loose["instability_ranges"]["0.5"], strict=True):
        assert abs(a[0] - b[0]) < 1.6e-6 and abs(a[1] - b[1]) < 1.6e-6


def test_stability_shows_a_progress_bar_for_a_long_chart(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """On a terminal a chart of much work draws a bar (rows done, time left); a small one draws none."""
    import monitor.runtime.progress

    monkeypatch.setattr(monitor.runtime.progress, "_is_terminal", lambda stream: True)
    assert main(["torsion", "stability", "--points", "12", "--json"]) == 0
    assert "stability chart" not in capsys.readouterr().err
    monkeypatch.setattr("monitor.cli.torsion._PROGRESS_WORK", 100.0)
    assert main(["torsion", "stability", "--points", "12", "--json"]) == 0
    err = capsys.readouterr().err
    assert "stability chart" in err and "row" in err


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
        (
            ["torsion", "stability", "--tolerance", "0"],
            "argument --tolerance: '0': expected a positive number",
        ),
        (
            ["torsion", "stability", "--tolerance", "nan"],
            "argument --tolerance: 'nan': expected a finite number",
        ),
        (["torsion", "stability", "--steps", "0"], "argument --steps: '0': expected a positive whole number"),
        (["torsion", "stability", "--zeta", "-0.1"], "--zeta -0.1: expected a non-negative damping ratio"),
        (["torsion", "stability", "--eps-max", "0.99"], "measured up to epsilon 0.95 only"),
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
