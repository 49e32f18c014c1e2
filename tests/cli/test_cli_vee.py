"""The bundled V engines through the command line: their orders named by bank, a misfire named by bank.

The 12-cylinder medium-speed V's bundled sample (recordings/samples/12v32-misfire-b3.h5, cylinder B3
misfiring) is diagnosed against a baseline calibrated on its healthy scene; the 16-cylinder high-speed
V, whose banks fire at 60 and 30 deg intervals, is simulated with a misfire on one bank and a
healthy twin, and the misfiring cylinder must be named, not its partner on the other bank.
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from monitor.cli import main
from monitor.io.hdf5 import write_hdf5
from monitor.scene import load_scene, simulate
from tests.conftest import ENGINES

SCENES = ENGINES.parent / "scenes"
SAMPLES = ENGINES.parent / "samples"


@pytest.mark.parametrize(("engine", "names"), [("medium-speed-12v32", 12), ("high-speed-16v170", 16)])
def test_orders_name_the_cylinders_by_bank(
    engine: str, names: int, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(["orders", engine, "--rpm", "700", "--max-order", "4", "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    half = names // 2
    expected = [f"A{k}" for k in range(1, half + 1)] + [f"B{k}" for k in range(1, half + 1)]
    assert doc["engine"]["cylinder_names"] == expected
    assert [c["name"] for c in doc["cylinders"]] == expected
    assert doc["engine"]["vee"]["rods"] == "side-by-side"
    assert len(doc["main_bearings"]) == half + 1
    assert main(["orders", engine, "--rpm", "700", "--max-order", "4"]) == 0
    table = capsys.readouterr().out
    assert " ".join(f"{name:>6}" for name in expected) in table


def _simulated(scene: Path, out: Path, *, seconds: float, seed: int, **changes: object) -> Path:
    loaded = load_scene(scene).model_copy(update={"duration_s": seconds, **changes})
    return write_hdf5(simulate(loaded, seed=seed).recording, out)


def test_the_bundled_v12_sample_names_cylinder_b3(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    healthy = _simulated(SCENES / "12v32-baseline.toml", tmp_path / "healthy.h5", seconds=6.0, seed=5)
    baseline = tmp_path / "baseline.json"
    assert main(["calibrate", str(healthy), "-o", str(baseline)]) == 0
    capsys.readouterr()
    code = main(["compare", str(SAMPLES / "12v32-misfire-b3.h5"), "--baseline", str(baseline), "--json"])
    doc = json.loads(capsys.readouterr().out)
    assert code == 2
    subjects = [f["subject"] for f in doc["findings"]]
    assert subjects == ["cylinder B3"], subjects
    assert doc["cylinder_balance"]["names"][8] == "B3"


def test_a_v16_misfire_is_named_on_its_bank(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """B5 (the maker's cylinder 9) misfiring on the 60 deg V16 at 1800 rpm: its throw partner A5 fires
    60 deg after it, so a mistake of bank or of firing angle would name A5 or another cylinder."""
    scene = load_scene(SCENES / "12v32-baseline.toml")
    common = {
        "engine": "high-speed-16v170",
        "operating_point": scene.operating_point.model_copy(update={"speed_rpm": 1800.0}),
    }
    healthy = _simulated(
        SCENES / "12v32-baseline.toml", tmp_path / "healthy.h5", seconds=4.0, seed=3, **common
    )
    effects = dict(scene.effects)
    effects["misfire"] = {"cylinders": ["B5"]}
    misfire = _simulated(
        SCENES / "12v32-baseline.toml", tmp_path / "b5.h5", seconds=4.0, seed=4, effects=effects, **common
    )
    baseline = tmp_path / "baseline.json"
    assert main(["calibrate", str(healthy), "-o", str(baseline)]) == 0
    capsys.readouterr()
    code = main(["compare", str(misfire), "--baseline", str(baseline), "--json"])
    doc = json.loads(capsys.readouterr().out)
    assert code == 2
    assert [f["subject"] for f in doc["findings"] if f["kind"] == "cylinder"] == ["cylinder B5"]
