"""The loads the validation bench tells per segment of a load step: the load run on each segment's side."""

from __future__ import annotations

import math

import pytest

from benchmarks.diagnosed import loads_told
from monitor.signal.steady import Segment


def _segment(start_s: float, stop_s: float) -> Segment:
    return Segment(0, 10, start_s, stop_s, 50.0, None)


def _truth(segment_loads: list[float]) -> dict[str, object]:
    return {
        "step_time_s": 6.0,
        "segment_loads": segment_loads,
        "test_loads": [0.5, 0.7],  # as set; the loads run differ a little
        "load_given_ratio": 1.1,
    }


def test_each_segment_is_told_the_load_run_on_its_side_of_the_step_off_by_the_told_error() -> None:
    told = loads_told([_segment(0.5, 5.0), _segment(7.0, 9.5)], _truth([0.52, 0.69]))
    assert told == pytest.approx([1.1 * 0.52, 1.1 * 0.69], rel=1e-12)


def test_a_segment_split_off_on_one_side_is_told_that_side_s_load() -> None:
    """A governor's dip can cut one side in two: both pieces are told the load of their side."""
    told = loads_told([_segment(0.5, 2.5), _segment(3.0, 5.5), _segment(7.0, 9.5)], _truth([0.52, 0.69]))
    assert told == pytest.approx([1.1 * 0.52, 1.1 * 0.52, 1.1 * 0.69], rel=1e-12)


def test_with_no_whole_cycle_run_after_the_step_a_later_segment_is_told_the_load_set() -> None:
    """The truth holds the loads of whole cycles only (case 200112: a step 6.6 s into 10 s of a slow
    engine); a segment found after the step is told the load set there, not refused."""
    told = loads_told([_segment(0.5, 5.0), _segment(7.0, 9.5)], _truth([0.52]))
    assert told == pytest.approx([1.1 * 0.52, 1.1 * 0.7], rel=1e-12)
    assert all(math.isfinite(v) for v in told)
