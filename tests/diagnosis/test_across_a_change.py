"""A recording whose operating point changes too soon to cut it in steady segments
(:func:`monitor.diagnosis.segments.diagnose_segments`): its diagnosis is the whole recording's, the
cylinders' strengths read over both points, with a note that says where the point changed.

Hand-built diagnoses and segmentations: the rule reads only the findings, the status, the notes and
where the steady spans lie (:mod:`monitor.signal.steady` is tested on its own series).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import cast

import numpy as np
import pytest

import monitor.diagnosis.segments as segments
from monitor.diagnosis.diagnose import Diagnosis
from monitor.diagnosis.findings import RELATIVE_STRENGTH, Finding
from monitor.io.recording import Recording
from monitor.model.engine import Engine
from monitor.signal.steady import CycleSeries, Segment, Segmentation, steady_segments
from tests.diagnosis.hand_built import hand_built

WEAK = Finding(
    "cylinder",
    "cylinder 10",
    "alarm",
    "cylinder 10 at 151 %",
    0.9,
    [{"quantity": RELATIVE_STRENGTH, "measured": 1.51}],
)
KNOCK = Finding("main bearing", "main bearing 2", "warning", "knocks", 0.9, [{"quantity": "impact power"}])


def _whole(status: str, findings: list[Finding]) -> Diagnosis:
    return hand_built(status, findings, ["whole"])


def _segmented_as(monkeypatch: pytest.MonkeyPatch, short: Segmentation) -> None:
    """No segment of the minimum's cycles; ``short`` at three cycles a side."""

    def segmentation_of(
        diagnosis: Diagnosis, engine: Engine, *, min_cycles: int, drift_over: int = 0
    ) -> Segmentation:
        return short if min_cycles == segments.SHORT_SIDE else Segmentation((), (), 14)

    monkeypatch.setattr(segments, "segmentation_of", segmentation_of)


def _diagnosed(whole: Diagnosis) -> Diagnosis:
    found = segments.diagnose_segments(cast(Recording, None), cast(Engine, None), whole)
    assert found.segments == ()
    return found.whole


STEP_AT_THE_END = Segmentation((Segment(0, 10, 0.6, 7.6, 9.95, 0.024),), (), 14)


def test_a_cylinder_strength_read_across_a_change_stands_with_a_note(monkeypatch: pytest.MonkeyPatch) -> None:
    """Each cycle's speed less its drift, every cylinder's share moves alike with the load: a cylinder
    read weak or strong across the change is reported, with a note where the point changed."""
    _segmented_as(monkeypatch, STEP_AT_THE_END)
    whole = _whole("alarm", [WEAK, KNOCK])
    said = _diagnosed(whole)
    assert said.findings == [WEAK, KNOCK] and said.status == "alarm"
    assert said.notes[0].startswith("the operating point changes inside the recording (steady 0.6-7.6 s)")
    assert "strengths are read over both points" in said.notes[0] and said.notes[1:] == whole.notes


def test_cylinders_that_read_alike_across_a_change_stay_healthy(monkeypatch: pytest.MonkeyPatch) -> None:
    _segmented_as(monkeypatch, STEP_AT_THE_END)
    said = _diagnosed(_whole("healthy", []))
    assert said.findings == [] and said.status == "healthy"
    assert said.notes[0].startswith("the operating point changes inside the recording")


@pytest.mark.parametrize(
    "short",
    [
        Segmentation((Segment(0, 14, 0.6, 10.0, 9.95, 0.024),), (), 14),  # steady throughout
        Segmentation((), (), 14),  # no steady span at all: a run-up, judged as before
    ],
)
def test_a_steady_recording_or_a_run_up_is_diagnosed_as_it_was(
    monkeypatch: pytest.MonkeyPatch, short: Segmentation
) -> None:
    _segmented_as(monkeypatch, short)
    whole = _whole("alarm", [WEAK])
    assert _diagnosed(whole) is whole


def _stepped(before: int, after: int) -> CycleSeries:
    """A noise-free series: ``before`` cycles at 100 rad/s and load indicator 1, then ``after`` at 110
    and 1.5 (a step of 10 % in speed and 50 % in load, far beyond the same point's limits)."""
    n = before + after
    start = 0.1 * np.arange(n, dtype=np.float64)
    speed = np.where(np.arange(n) < before, 100.0, 110.0)
    load = np.where(np.arange(n) < before, 1.0, 1.5)
    return CycleSeries(start, start + 0.1, speed, load)


@pytest.mark.parametrize(
    ("before", "after", "across"),
    [
        (2, 4, True),  # three steady cycles after the change (the one next to it is the transition's)
        (2, 3, False),  # two: no steady span at all, as in a run-up
    ],
)
def test_three_steady_cycles_on_a_side_tell_a_change(
    monkeypatch: pytest.MonkeyPatch, before: int, after: int, across: bool
) -> None:
    """:data:`~monitor.diagnosis.segments.SHORT_SIDE` through the real segmentation of a tiny
    recording: with three steady cycles on a side the change is told and noted (were four needed, the
    whole recording would stand unnoted); with two it is not told, and the whole recording's diagnosis
    stands as a run-up's (were two enough, it would be noted)."""
    monkeypatch.setattr(segments, "segmentation_of", _real_segmentation(_stepped(before, after)))
    whole = _whole("alarm", [WEAK])
    said = _diagnosed(whole)
    assert said.findings == [WEAK]
    assert said.notes[0].startswith("the operating point changes inside the recording") is across
    assert (said is whole) is not across


def _real_segmentation(series: CycleSeries) -> Callable[..., Segmentation]:
    """``segmentation_of`` on a given series: :func:`monitor.signal.steady.steady_segments` itself."""

    def segmentation_of(
        diagnosis: Diagnosis, engine: Engine, *, min_cycles: int, drift_over: int = 0
    ) -> Segmentation:
        return steady_segments(series, min_cycles=min_cycles, drift_over=drift_over)

    return segmentation_of
