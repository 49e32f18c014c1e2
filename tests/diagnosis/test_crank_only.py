"""Recordings of the crank speed alone (a tooth wheel and a cam) calibrate and compare.

The files are written with h5py by the test (:mod:`tests.diagnosis.crank_only_files`), not by the
product's writer. The baseline keeps no sensor but the wheel's pitch errors, the crank-speed model's
calibration, the operating point and the strengths; the diagnosis judges the cylinders as usual and
says that the main bearings were not judged, without making a healthy engine inconclusive.
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from monitor.diagnosis import Baseline, Diagnosis, calibrate, diagnose
from monitor.errors import DiagnosisError
from monitor.io import open_recording
from monitor.model.engine import Engine, bundled_engines, load_engine
from monitor.report.diagnosis import diagnosis_document, diagnosis_table
from monitor.report.web import engine_page, recording_page
from tests.diagnosis.crank_only_files import (
    ENGINE,
    FIRST_TOOTH_DEG,
    PITCH_ERRORS_DEG,
    TEETH,
    write_crank_only,
)

NOT_JUDGED = "no main-bearing vibration channel"


@pytest.fixture(scope="module")
def engine() -> Engine:
    return load_engine(bundled_engines()[ENGINE])


@pytest.fixture(scope="module")
def files(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """A healthy recording to calibrate on, a healthy one 5 rpm slower, one with cylinder 3 misfiring."""
    folder = tmp_path_factory.mktemp("crank-only")
    rng = np.random.default_rng(28)
    return {
        "baseline": write_crank_only(folder / "baseline.h5", rng),
        "healthy": write_crank_only(folder / "healthy.h5", rng, speed_rpm=745.0),
        "misfire": write_crank_only(folder / "misfire-cyl3.h5", rng, misfiring=[3]),
    }


@pytest.fixture(scope="module")
def baseline(files: dict[str, Path], engine: Engine) -> Baseline:
    with open_recording(files["baseline"]) as recording:
        return calibrate(recording, engine, source="baseline.h5")


def _diagnose(path: Path, engine: Engine, baseline: Baseline | None) -> Diagnosis:
    with open_recording(path) as recording:
        return diagnose(recording, engine, baseline=baseline)


def test_the_baseline_keeps_no_sensor_but_the_crank_speed_model_and_the_wheels_errors(
    baseline: Baseline,
) -> None:
    """No sensor; the operating point; a strength per cylinder; the crank-speed model calibrated at the
    firing harmonic (order 3 of the six-cylinder four-stroke); and the pitch errors of the 58 teeth.

    The errors are checked against those the test put on the wheel, by another route: away from the
    firing harmonics (orders 0, 3, 6 ... 27, where the engine's own fluctuation is, left out of both
    by a least-squares fit at the teeth's angles) they must agree to 0.002 deg, a tenth of what is
    left of the errors there (0.022 deg rms); the edge timer's 0.5 us jitter averages to 2e-4 deg over
    the recording's 124 revolutions."""
    assert baseline.sensors == {} and baseline.samples_per_cycle == 0
    assert baseline.speed_rpm == pytest.approx(750.0, abs=0.5) and baseline.load == 1.0
    assert len(baseline.strengths) == 6 and baseline.crank is not None
    assert 3.0 in baseline.crank.orders.tolist()
    assert baseline.pitch is not None and baseline.pitch_channel == "crank-teeth"
    assert baseline.pitch.errors.size == TEETH - 2
    theta = math.radians(FIRST_TOOTH_DEG) + np.arange(TEETH - 2) * (2 * math.pi / TEETH)
    firing = np.array(
        [np.ones(theta.size)] + [f(k * theta) for k in range(3, TEETH // 2, 3) for f in (np.cos, np.sin)]
    ).T

    def away_from_firing(errors: np.ndarray) -> np.ndarray:
        return np.asarray(errors - firing @ np.linalg.lstsq(firing, errors, rcond=None)[0])

    put = away_from_firing(np.radians(PITCH_ERRORS_DEG))
    learned = away_from_firing(baseline.pitch.errors)
    assert math.degrees(float(np.sqrt(np.mean(put**2)))) > 0.015  # the check below has something to see
    np.testing.assert_allclose(np.degrees(learned), np.degrees(put), atol=0.002)


def test_a_baseline_without_sensors_round_trips(baseline: Baseline, tmp_path: Path) -> None:
    """Through its JSON document and through its file: the same document back, nothing lost (the pitch
    errors, stored in degrees and kept in radians, to the conversion's last bits)."""
    document = baseline.to_document()
    assert document["sensors"] == {} and document["crank_speed_model"] is not None

    def same(other: Baseline) -> None:
        back = other.to_document()
        errors = back["tooth_pitch"]["errors_deg"]
        assert errors == pytest.approx(document["tooth_pitch"]["errors_deg"], rel=1e-12, abs=1e-15)
        assert back == dict(document, tooth_pitch=dict(document["tooth_pitch"], errors_deg=errors))

    again = Baseline.from_document(json.loads(json.dumps(document)))
    same(again)
    assert again.sensors == {} and again.pitch is not None and again.crank is not None
    np.testing.assert_allclose(again.pitch.errors, baseline.pitch.errors, rtol=1e-12)  # type: ignore[union-attr]
    np.testing.assert_array_equal(again.crank.factor, baseline.crank.factor)  # type: ignore[union-attr]
    assert again.strengths == baseline.strengths
    same(Baseline.read(baseline.write(tmp_path / "baseline.json")))


@pytest.mark.parametrize("with_baseline", [False, True], ids=["no baseline", "baseline"])
def test_a_healthy_engine_is_healthy_and_its_bearings_not_judged(
    files: dict[str, Path], engine: Engine, baseline: Baseline, with_baseline: bool
) -> None:
    """Healthy (not inconclusive: a missing bearing sensor is a stated limitation), no finding, the
    cylinders balanced; the note, the document's field, the table's line and the page say that the main
    bearings were not judged, and nothing speaks of bearing orders or impacts."""
    diagnosis = _diagnose(files["healthy"], engine, baseline if with_baseline else None)
    assert diagnosis.status == "healthy" and diagnosis.findings == [] and diagnosis.bearings == []
    assert diagnosis.balance is not None and diagnosis.balance.separable
    assert NOT_JUDGED in diagnosis.bearings_not_judged
    assert any(n.startswith("main bearings not judged") for n in diagnosis.notes)
    assert not any("impacts" in n or "bearing orders" in n for n in diagnosis.notes)
    document = diagnosis_document(diagnosis, recording="healthy.h5")
    assert document["main_bearings"]["judged"] is False
    assert NOT_JUDGED in document["main_bearings"]["not_judged_because"]
    assert document["impacts"] == {} and document["status"] == "healthy"
    assert f"main bearings: NOT JUDGED: {diagnosis.bearings_not_judged}" in diagnosis_table(diagnosis)
    page = recording_page(document)
    assert 'id="bearings-not-judged"' in page and "Main bearings not judged" in page
    assert 'id="findings">No findings.' in page
    links = SimpleNamespace(fleet="/fleet", recording=lambda i: f"/recordings/{i}")
    engine_view = engine_page(ENGINE, None, document, latest_id=1, links=links, assets="/static")
    assert 'id="bearings-not-judged"' in engine_view  # the engine's latest verdict says it too


@pytest.mark.parametrize("with_baseline", [False, True], ids=["no baseline", "baseline"])
def test_a_misfiring_cylinder_is_named(
    files: dict[str, Path], engine: Engine, baseline: Baseline, with_baseline: bool
) -> None:
    """Cylinder 3, and it alone, an alarm called misfiring; the bearings still said not judged."""
    diagnosis = _diagnose(files["misfire"], engine, baseline if with_baseline else None)
    assert diagnosis.status == "alarm"
    assert [(f.kind, f.subject, f.severity) for f in diagnosis.findings] == [
        ("cylinder", "cylinder 3", "alarm")
    ]
    assert "(misfiring;" in diagnosis.findings[0].summary
    assert NOT_JUDGED in diagnosis.bearings_not_judged


def test_a_recording_with_bearing_sensors_says_its_bearings_were_judged(engine: Engine) -> None:
    """The field is no constant: a bundled 6L32 recording, with its two bearing accelerometers, is
    judged there; with both left out it is not, and the reason says they were left out."""
    sample = Path(__file__).resolve().parents[2] / "recordings" / "samples" / "6l32-misfire-cyl3.h5"
    with open_recording(sample) as recording:
        judged = diagnose(recording, engine)
        left_out = diagnose(recording, engine, exclude=["mb3-vertical", "mb6-vertical"])
    assert judged.bearings_not_judged == ""
    assert diagnosis_document(judged)["main_bearings"] == {"judged": True, "not_judged_because": None}
    assert "NOT JUDGED" not in diagnosis_table(judged)
    assert 'id="bearings-not-judged"' not in recording_page(diagnosis_document(judged))
    assert "left out" in left_out.bearings_not_judged


def test_a_keyphasor_and_a_cam_alone_are_refused(tmp_path: Path, engine: Engine) -> None:
    """Neither a bearing sensor nor crank-speed orders (a keyphasor gives none): nothing to calibrate."""
    path = write_crank_only(tmp_path / "keyphasor.h5", np.random.default_rng(1), keyphasor=True)
    with open_recording(path) as recording, pytest.raises(DiagnosisError, match="nothing to calibrate"):
        calibrate(recording, engine)
