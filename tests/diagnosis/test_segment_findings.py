"""A segmented recording's findings are each subject's worst over its segments, written once
(:attr:`monitor.diagnosis.segments.SegmentedDiagnosis.findings`) for the report and the benchmarks.

Hand-built segment diagnoses: the merge reads only their findings, statuses and notes.
"""

from __future__ import annotations

import pytest

from monitor.diagnosis.findings import Finding
from monitor.diagnosis.segments import SegmentDiagnosis, SegmentedDiagnosis, _note
from monitor.report.diagnosis import segmented_document
from monitor.signal.steady import Segment, Transition
from tests.diagnosis.hand_built import hand_built


def _finding(kind: str, subject: str, severity: str, confidence: float, said: str) -> Finding:
    return Finding(kind, subject, severity, f"{subject}: {said}", confidence, [{"segment": said}])


def _segmented() -> SegmentedDiagnosis:
    """Cylinder 3 a warning in segment 1 and an alarm in segment 2; main bearing 2 a warning in both
    (the first more confident); a vibration zone an alarm in segment 2 only."""
    first = hand_built(
        "warning",
        [
            _finding("cylinder", "cylinder 3", "warning", 0.99, "segment 1"),
            _finding("main bearing", "main bearing 2", "warning", 0.95, "segment 1"),
        ],
        ["segment 1 of 2", "first"],
    )
    second = hand_built(
        "alarm",
        [
            _finding("main bearing", "main bearing 2", "warning", 0.8, "segment 2"),
            _finding("cylinder", "cylinder 3", "alarm", 0.6, "segment 2"),
            _finding("vibration zone", "v1", "alarm", 0.9, "segment 2"),
        ],
        ["segment 2 of 2"],
    )
    spans = [Segment(0, 60, 0.0, 9.6, 78.5, 0.02), Segment(62, 122, 9.9, 19.5, 78.5, 0.01)]
    return SegmentedDiagnosis(
        hand_built("alarm", [], ["whole"]),
        (SegmentDiagnosis(1, spans[0], first), SegmentDiagnosis(2, spans[1], second)),
        (Transition(9.6, 9.9, spans[0], spans[1]),),
    )


def test_a_subject_is_kept_at_its_worst_with_every_segment_it_was_found_in() -> None:
    merged = {(m.finding.kind, m.finding.subject): m for m in _segmented().findings}
    cylinder = merged["cylinder", "cylinder 3"]
    assert cylinder.finding.severity == "alarm" and cylinder.finding.summary.endswith("segment 2")
    assert cylinder.segments == (1, 2)
    # equally severe: the first found stands, not the later (less confident) one
    bearing = merged["main bearing", "main bearing 2"]
    assert bearing.finding.summary.endswith("segment 1") and bearing.segments == (1, 2)
    assert merged["vibration zone", "v1"].segments == (2,)


def test_the_subjects_are_in_the_order_they_were_first_found() -> None:
    assert [m.finding.subject for m in _segmented().findings] == ["cylinder 3", "main bearing 2", "v1"]


def test_a_recording_not_segmented_has_no_merged_findings_and_is_its_wholehand_built() -> None:
    whole = hand_built("warning", [_finding("cylinder", "cylinder 1", "warning", 0.9, "whole")], [])
    alone = SegmentedDiagnosis(whole)
    assert alone.findings == () and alone.as_one() is whole


def test_as_one_holds_the_worst_status_the_merged_findings_alarms_first_and_every_note() -> None:
    segmented = _segmented()
    one = segmented.as_one()
    assert one.status == "alarm"
    assert [(f.subject, f.severity) for f in one.findings] == [
        ("v1", "alarm"),  # the more confident alarm first
        ("cylinder 3", "alarm"),
        ("main bearing 2", "warning"),
    ]
    assert one.findings[1] is segmented.segments[1].diagnosis.findings[1]
    assert one.notes == ["segment 1 of 2", "first", "segment 2 of 2"]


def test_the_report_gives_the_merged_findings_with_their_segments() -> None:
    document = segmented_document(_segmented(), recording="step")
    assert document["status"] == "alarm"
    assert [(f["subject"], f["severity"], f["segments"]) for f in document["findings"]] == [
        ("cylinder 3", "alarm", [1, 2]),
        ("main bearing 2", "warning", [1, 2]),
        ("v1", "alarm", [2]),
    ]
    assert document["findings"][0]["evidence"] == [{"segment": "segment 2"}]
    assert list(document["findings"][0]) == [
        "kind",
        "subject",
        "severity",
        "summary",
        "confidence",
        "evidence",
        "segments",
    ]


@pytest.mark.parametrize(
    ("source", "said"),
    [
        ("segment", "the model at the load given for this segment (0.40)"),
        ("stated", "the model at the load given for the recording (0.40): give each segment's load"),
        ("raised", "the model at the load estimated from this segment (0.40), above the load given;"),
        ("estimated", "the reference at the load estimated from this segment (0.40)"),
        ("speed", "the reference at the load this segment's speed reads on the calibrated points (0.40)"),
        (
            "baseline",
            "the reference at its own load (0.40): this segment's crank-speed orders tell none; give",
        ),
        ("rated", "the model at rated load (0.40), without a baseline or a load given: give each segment's"),
    ],
)
def test_a_segments_note_says_where_the_load_it_was_judged_at_came_from(source: str, said: str) -> None:
    """Each source of a segment's load (``load_used_from``, or a load given per segment) in its own words:
    a segment judged at its own estimate does not read as judged at the recording's stated load."""
    note = _note(Segment(0, 60, 0.0, 9.6, 78.5, 0.02), 1, 2, 0.4, source, 0.02)
    assert note.startswith("segment 1 of 2: 0.00 to 9.60 s, 60 cycles at 749.6 rpm; " + said), note
    assert note.endswith(
        "this segment's load indicator (the firing harmonic's speed fluctuation) is 1.00 times the "
        "recording's"
    )
