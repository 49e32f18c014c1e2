"""A recording with a load step inside it is diagnosed per steady segment (issue 28's acceptance).

The 6L32 on a generator (recordings/scenes/6l32-load-step.toml): 8 s at full load, then 8 s at half
load, the governor holding 750 rpm; healthy, and with cylinder 3 misfiring throughout. The step is
where the scene puts it (8.0 s); the segment finder sees only the recording.
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from monitor.cli import main
from monitor.io.hdf5 import write_hdf5
from monitor.jobs.analyse import AnalysisOptions, analyse
from monitor.report.diagnosis import diagnosis_document, diagnosis_table
from monitor.scene import load_scene, simulate

SCENES = Path(__file__).resolve().parents[2] / "recordings" / "scenes"
STEP_S = 8.0
CYCLE_S = 2 * 60 / 750  # a cycle of the four-stroke at 750 rpm [s]
LOADS = AnalysisOptions(segment_loads=(1.0, 0.5))


@pytest.fixture(scope="module")
def stepped(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    scene = load_scene(SCENES / "6l32-load-step.toml")
    assert [(s.time_s, s.load) for s in scene.operating_point.load_steps] == [(STEP_S, 0.5)]
    misfire = scene.model_copy(update={"effects": {**scene.effects, "misfire": {"cylinders": [3]}}})
    folder = tmp_path_factory.mktemp("steps")
    return {
        name: write_hdf5(simulate(s).recording, folder / f"{name}.h5")
        for name, s in (("healthy", scene), ("misfire", misfire))
    }


@pytest.mark.parametrize("name", ["healthy", "misfire"])
def test_the_step_splits_the_recording_into_two_segments_around_its_time(
    stepped: dict[str, Path], name: str
) -> None:
    """Two segments, the transition between them holding the step, its ends within two cycles of it
    (the guard cycle each side, and the cycle the step falls in)."""
    analysis = analyse(stepped[name], options=LOADS)
    assert len(analysis.segments) == 2
    (transition,) = analysis.transitions
    assert transition.start_s <= STEP_S <= transition.stop_s
    assert STEP_S - transition.start_s <= 2 * CYCLE_S and transition.stop_s - STEP_S <= 2 * CYCLE_S
    first, second = (s.segment for s in analysis.segments)
    assert first.speed == pytest.approx(second.speed, rel=1e-3)  # the governor held the speed
    assert first.load_indicator is not None and second.load_indicator is not None
    assert second.load_indicator < 0.5 * first.load_indicator  # the firing impulse fell with the load
    assert [s.diagnosis.load for s in analysis.segments] == [1.0, 0.5]


def test_a_healthy_engine_through_a_load_step_is_healthy_in_both_segments(stepped: dict[str, Path]) -> None:
    analysis = analyse(stepped["healthy"], options=LOADS)
    assert [s.diagnosis.status for s in analysis.segments] == ["healthy", "healthy"]
    assert analysis.exit_status == 0
    document = json.loads(json.dumps(analysis.diagnosis_document()))
    assert document["status"] == "healthy" and document["findings"] == []
    assert [s["index"] for s in document["segments"]] == [1, 2]
    assert [s["diagnosis"]["status"] for s in document["segments"]] == ["healthy", "healthy"]
    (transition,) = document["transitions"]
    assert transition["from"]["speed_rpm"] == pytest.approx(750.0, rel=1e-3)
    assert transition["to"]["load_indicator"] < transition["from"]["load_indicator"]


def test_a_misfire_through_a_load_step_is_named_at_its_cylinder_in_both_segments(
    stepped: dict[str, Path],
) -> None:
    analysis = analyse(stepped["misfire"], options=LOADS)
    for part in analysis.segments:
        cylinders = [f for f in part.diagnosis.findings if f.kind == "cylinder"]
        assert [f.subject for f in cylinders] == ["cylinder 3"], part.index
        assert cylinders[0].severity == "alarm" and "(misfiring;" in cylinders[0].summary
    assert analysis.status == "alarm" and analysis.exit_status == 2
    document = analysis.diagnosis_document()
    merged = [f for f in document["findings"] if f["kind"] == "cylinder"]
    assert [(f["subject"], f["segments"]) for f in merged] == [("cylinder 3", [1, 2])]


def test_without_the_loads_per_segment_a_misfire_is_never_called_healthy(stepped: dict[str, Path]) -> None:
    """Judged at the load given for the whole recording (1), the half-load segment's strengths all
    read low by one factor: its balance may be too uncertain to name the cylinder, but it is not healthy,
    and its note says how to judge it at its own load."""
    analysis = analyse(stepped["misfire"])
    assert len(analysis.segments) == 2
    assert "healthy" not in [s.diagnosis.status for s in analysis.segments]
    assert analysis.segments[0].diagnosis.status == "alarm"
    assert any("--segment-loads" in note for note in analysis.segments[1].diagnosis.notes)


def test_compare_prints_the_segments_and_exits_with_the_worst(
    stepped: dict[str, Path], capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(["compare", str(stepped["healthy"]), "--segment-loads", "1,0.5"]) == 0
    said = capsys.readouterr().out
    assert "diagnosed per steady segment (2 segments)" in said
    assert said.count("transition ") == 1 and said.count("--- segment ") == 2
    assert main(["compare", str(stepped["misfire"]), "--segment-loads", "1,0.5,0.3"]) == 3
    error = capsys.readouterr().err
    assert "3 load(s) given per segment; the recording has 2 steady segments" in error


def test_a_steady_recording_is_diagnosed_as_before(tmp_path: Path) -> None:
    """One steady segment: no segments, and the document and the tables are the whole diagnosis's,
    unchanged (no new entry, no new line)."""
    scene = load_scene(SCENES / "6l32-baseline.toml").model_copy(update={"duration_s": 6.0})
    path = write_hdf5(simulate(scene).recording, tmp_path / "steady.h5")
    analysis = analyse(path)
    assert analysis.segments == () and analysis.transitions == ()
    assert analysis.diagnosis_document() == diagnosis_document(analysis.diagnosis, recording="steady.h5")
    assert analysis.table() == diagnosis_table(analysis.diagnosis, recording="steady.h5")


def test_a_step_too_near_the_end_leaves_one_segment_which_is_the_diagnosis(tmp_path: Path) -> None:
    """The misfiring 6L32 stepped at 8 s and stopped 1.6 s later (10 cycles at half load, under the 20 a
    segment needs): the one steady segment before the step is diagnosed at its own load (1, given
    for it), the misfire named there; the rest is said not to be judged; the document and the table
    hold that one segment."""
    scene = load_scene(SCENES / "6l32-load-step.toml")
    scene = scene.model_copy(
        update={
            "duration_s": STEP_S + 10 * CYCLE_S,
            "effects": {**scene.effects, "misfire": {"cylinders": [3]}},
        }
    )
    path = write_hdf5(simulate(scene).recording, tmp_path / "late-step.h5")
    analysis = analyse(path, options=AnalysisOptions(segment_loads=(1.0,)))
    (only,) = analysis.segments
    assert only.segment.stop_s <= STEP_S and only.segment.cycles >= 20
    assert only.diagnosis.load == 1.0
    assert [f.subject for f in only.diagnosis.findings if f.kind == "cylinder"] == ["cylinder 3"]
    assert analysis.status == "alarm" and analysis.transitions == ()
    assert any("the rest of it (a change of operating point" in n for n in only.diagnosis.notes)
    document = analysis.diagnosis_document()
    assert [s["index"] for s in document["segments"]] == [1]
    assert document["notes"][0].startswith("diagnosed per steady segment: 1 segment, 0 transition(s)")
    assert "diagnosed per steady segment (1 segment)" in analysis.table()
