"""compare says when the cylinder balance leans on whole crank-speed orders the wheel's unlearned pitch
errors can move (:func:`monitor.diagnosis.analysis._unlearned_orders`).

Without a baseline nothing taught the wheel: the whole orders the balance uses carry a bound beyond their
standard error (the spectra's ``systematic``), and the note names them. A baseline learns every tooth but
at its firing harmonics, which its crank-speed calibration then calibrates: no order is left to note.
"""

from __future__ import annotations

from pathlib import Path

from monitor.diagnosis import calibrate, diagnose
from monitor.io import open_recording
from monitor.model.engine import bundled_engines, load_engine
from monitor.scene import load_scene, simulate

ROOT = Path(__file__).resolve().parents[2]
ENGINE = "medium-speed-6l32"


def _notes(said: list[str]) -> list[str]:
    return [n for n in said if "unlearned tooth-pitch errors" in n]


def test_without_a_baseline_the_whole_orders_the_balance_uses_are_named() -> None:
    engine = load_engine(bundled_engines()[ENGINE])
    with open_recording(ROOT / "recordings" / "samples" / "6l32-misfire-cyl3.h5") as recording:
        diagnosis = diagnose(recording, engine)
    (note,) = _notes(diagnosis.notes)
    assert note.startswith("the cylinder balance uses crank-speed orders 1, 2, 3, which ")
    assert "calibrate --pitch-from" in note
    speed = diagnosis.spectra.spectra["crank speed"]
    assert speed.systematic is not None and speed.systematic[speed.orders == 1.5][0] == 0.0


def test_against_a_baseline_that_learned_the_wheel_nothing_is_noted() -> None:
    engine = load_engine(bundled_engines()[ENGINE])
    scene = load_scene(ROOT / "recordings" / "scenes" / "6l32-baseline.toml")
    baseline = calibrate(simulate(scene.model_copy(update={"duration_s": 3.0})).recording, engine)
    with open_recording(ROOT / "recordings" / "samples" / "6l32-misfire-cyl3.h5") as recording:
        diagnosis = diagnose(recording, engine, baseline=baseline)
    assert _notes(diagnosis.notes) == []
