"""compare says when the cylinder balance leans on whole crank-speed orders the wheel's unlearned pitch
errors can move (:func:`monitor.diagnosis.analysis._unlearned_orders`).

Without a baseline nothing taught the wheel: the whole orders the balance uses carry a bound beyond their
standard error (the spectra's ``systematic``), and the note names them. A baseline learns every tooth but
at its firing harmonics, which its crank-speed calibration then calibrates: no order is left to note.
And the balance weighs those orders with what the wheel's errors can put in them.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

import monitor.diagnosis.balance as balance_module
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


def test_the_unlearned_pitch_errors_weigh_in_the_balance(monkeypatch: pytest.MonkeyPatch) -> None:
    """A healthy 7K98MC (a two-stroke: every order the balance uses is whole) read by a wheel whose teeth
    are off by 0.1 deg rms, no baseline to teach it: with the errors' rms share of each order in the
    weights (the spectra's bound over its coverage) the balance fits (reduced chi-square 0.91), every
    cylinder reads within 3 of its errors of the others (1.5 at most), and the engine is healthy.
    Without it the wheel's errors read as the cylinders' (chi-square 35, cylinders at 43 % to 143 %:
    inconclusive)."""
    engine = load_engine(bundled_engines()["man-b-w-7k98mc"])
    scene = load_scene(ROOT / "recordings" / "scenes" / "7k98mc-baseline.toml")
    effects = dict(scene.effects) | {"tooth_spacing_errors": {"sensor": "tooth", "rms_deg": 0.1}}
    recording = simulate(scene.model_copy(update={"duration_s": 12.0, "effects": effects})).recording
    diagnosis = diagnose(recording, engine)
    balance = diagnosis.balance
    assert balance is not None and balance.wheel_error.max() > balance.standard_error.max()
    assert balance.chi2_reduced < 2.0
    assert np.all(np.abs(balance.relative - 1.0) < 3 * balance.relative_error)
    assert diagnosis.status == "healthy"
    monkeypatch.setattr(balance_module, "COVERAGE", math.inf)  # the bound weighs nothing
    assert diagnose(recording, engine).balance.chi2_reduced > 10.0  # type: ignore[union-attr]
