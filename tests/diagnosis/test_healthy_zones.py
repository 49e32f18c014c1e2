"""A healthy recording already in zone C or D is said so at calibration, and a zone finding says whose
limits it was judged against (the engine file's, or the product's defaults)."""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from monitor.diagnosis.zones import DEFAULT_BOUNDARIES_MM_S, healthy_zone_notes, limits_named
from monitor.io.hdf5 import write_hdf5
from monitor.jobs.calibration import calibrate_recordings
from monitor.model.engine import BUNDLED_DIR
from monitor.scene import load_scene, simulate
from tests.conftest import ENGINES

SCENE = ENGINES.parent / "scenes" / "6l32-baseline.toml"


@pytest.mark.parametrize(
    ("value", "zone"), [(11.0 - 1e-9, None), (11.0 + 1e-9, "C"), (18.0 + 1e-9, "D"), (math.nan, None)]
)
def test_a_channel_just_over_a_boundary_is_noted_with_its_zone(value: float, zone: str | None) -> None:
    notes = healthy_zone_notes({"mb2": value}, DEFAULT_BOUNDARIES_MM_S, stated=False, label="run.h5")
    if zone is None:
        assert notes == []
        return
    (note,) = notes
    assert note.startswith(f"run.h5: mb2 reads {value:.2f} mm/s rms on this healthy recording, zone {zone} ")
    assert "the product's default limits 7.1/11/18 mm/s" in note and "[vibration_limits]" in note


def test_whose_limits_they_are_is_named() -> None:
    assert limits_named((2.8, 4.5, 7.1), stated=True) == "the engine file's limits 2.8/4.5/7.1 mm/s"
    assert "default" in limits_named(DEFAULT_BOUNDARIES_MM_S, stated=False)


def test_calibrating_on_a_recording_in_zone_c_of_the_stated_limits_says_so(tmp_path: Path) -> None:
    """The 6L32 baseline scene against limits stated so low that its main bearings are in zone C:
    the calibration notes it per channel, with the engine file's limits; with the defaults, which
    its few mm/s lie well inside, it notes nothing."""
    scene = load_scene(SCENE).model_copy(update={"duration_s": 3.0})
    path = write_hdf5(simulate(scene, seed=2).recording, tmp_path / "healthy.h5")
    quiet = calibrate_recordings([path], engine=BUNDLED_DIR / "medium-speed-6l32.toml")
    assert not [n for n in quiet.notes if "zone" in n]
    text = (BUNDLED_DIR / "medium-speed-6l32.toml").read_text(encoding="utf-8")
    low = tmp_path / "low-limits.toml"
    low.write_text(
        text + "\n[vibration_limits]\nzone_boundaries_mm_s = [0.001, 0.002, 1000.0]\n", encoding="utf-8"
    )
    loud = calibrate_recordings([path], engine=low)
    zoned = [n for n in loud.notes if "zone C" in n]
    assert {n.split(":")[1].split()[0] for n in zoned} == {"mb3-vertical", "mb6-vertical"}
    assert all("the engine file's limits 0.001/0.002/1000 mm/s" in n for n in zoned)
