"""`engine-monitor calibrate` and `compare --baseline` on recordings of the crank speed alone.

The recordings are written with h5py by the test (:mod:`tests.diagnosis.crank_only_files`): a 60-2
tooth wheel's edge times and a cam pulse, no bearing sensor.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from monitor.cli import main
from tests.diagnosis.crank_only_files import write_crank_only

NOT_JUDGED = "main bearings: NOT JUDGED: the recording has no main-bearing vibration channel"


@pytest.fixture(scope="module")
def files(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    folder = tmp_path_factory.mktemp("crank-only-cli")
    rng = np.random.default_rng(2028)
    return {
        "baseline": write_crank_only(folder / "baseline.h5", rng),
        "healthy": write_crank_only(folder / "healthy.h5", rng, speed_rpm=755.0),
        "misfire": write_crank_only(folder / "misfire-cyl5.h5", rng, misfiring=[5]),
        "keyphasor": write_crank_only(folder / "keyphasor.h5", rng, keyphasor=True),
    }


def test_calibrate_then_compare(
    files: dict[str, Path], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """calibrate exits 0 and says that no bearing sensor was calibrated and the bearings will not be
    judged; compare --baseline exits 0 on the healthy recording and 2 on the misfire, naming cylinder 5,
    each printing that the main bearings were not judged (and --json saying so in its field)."""
    baseline = tmp_path / "baseline.json"
    assert main(["calibrate", str(files["baseline"]), "-o", str(baseline)]) == 0
    said = capsys.readouterr().err
    assert "no bearing sensor calibrated" in said and "main bearings will not be judged" in said
    assert "crank-speed model (rigid) calibrated at orders 3" in said
    assert "tooth-pitch errors of 'crank-teeth' learned on the baseline" in said
    assert json.loads(baseline.read_text())["sensors"] == {}

    assert main(["compare", str(files["healthy"]), "--baseline", str(baseline)]) == 0
    out = capsys.readouterr().out
    assert "status: HEALTHY" in out and "findings: none" in out and NOT_JUDGED in out

    assert main(["compare", str(files["misfire"]), "--baseline", str(baseline)]) == 2
    out = capsys.readouterr().out
    assert "status: ALARM" in out and NOT_JUDGED in out
    findings = [line for line in out.splitlines() if line.startswith("  [")]
    assert len(findings) == 1 and findings[0].startswith("  [alarm] cylinder 5 at ")

    assert main(["compare", str(files["misfire"]), "--baseline", str(baseline), "--json"]) == 2
    document = json.loads(capsys.readouterr().out)
    assert document["main_bearings"]["judged"] is False
    assert [f["subject"] for f in document["findings"]] == ["cylinder 5"]


def test_compare_without_a_baseline(files: dict[str, Path], capsys: pytest.CaptureFixture[str]) -> None:
    """Healthy, exit 0, the bearings not judged: not an inconclusive 3."""
    assert main(["compare", str(files["healthy"])]) == 0
    out = capsys.readouterr().out
    assert "status: HEALTHY" in out and NOT_JUDGED in out
    assert "impacts judged" not in out


def test_refusals(files: dict[str, Path], tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """No sensor transfer to write as TOML (exit 2, nothing written); a keyphasor alone gives nothing to
    calibrate (exit 2)."""
    transfers = tmp_path / "transfers.toml"
    assert main(["calibrate", str(files["baseline"]), "-o", str(transfers)]) == 2
    assert "no main-bearing vibration channel" in capsys.readouterr().err and not transfers.exists()
    assert main(["calibrate", str(files["keyphasor"]), "-o", str(tmp_path / "b.json")]) == 2
    assert "nothing to calibrate" in capsys.readouterr().err
