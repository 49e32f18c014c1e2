"""A simulated case diagnosed as ``engine-monitor compare`` diagnoses a recording.

``compare`` (:mod:`monitor.jobs.analyse`) diagnoses a recording against its baseline's calibrated points
at the recording's own load (:func:`monitor.diagnosis.at_point.diagnose_at_point`), then, when the
recording crosses operating points, each steady segment at its own
(:func:`monitor.diagnosis.segments.diagnose_segments`). The validation population holds its recordings in
memory, so it takes the same two steps here rather than through a file. An operator who knows the loads
gives one per segment found (``compare --segment-loads``): each segment is told the load the simulator ran
at its middle, off by the case's own error of the stated load.
"""

from __future__ import annotations

import tempfile
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from benchmarks.judging import vibrating
from monitor.diagnosis import Baseline, Diagnosis, calibrate
from monitor.diagnosis.at_point import diagnose_at_point
from monitor.diagnosis.operating_points import OperatingPoints
from monitor.diagnosis.segments import diagnose_segments, steady_parts
from monitor.io.recording import Recording
from monitor.model.engine import Engine, load_engine
from monitor.signal.steady import Segment
from validation.simulator import healthy_twin, random_case

__all__ = ["case_engine", "diagnose_as_compare", "loads_told", "one_point"]


def case_engine(engine_toml: str) -> Engine:
    """The engine file a simulated case comes with, loaded as ``engine-monitor`` loads one from disk."""
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "engine.toml"
        path.write_text(engine_toml)
        return load_engine(path)


def diagnose_as_compare(
    recording: Recording,
    engine: Engine,
    baseline: Baseline | OperatingPoints,
    load: float | None,
    truth: dict[str, Any],
) -> Diagnosis:
    """The diagnosis ``compare --baseline`` gives, one document's worth.

    Parameters
    ----------
    recording : Recording
    engine : Engine
    baseline : Baseline or OperatingPoints
        The case's healthy twin's calibration (or several healthy twins' at their points).
    load : float or None
        The load told (None: not told).
    truth : dict
        The case's truth: with a load step, ``step_time_s``, ``segment_loads`` and ``load_given_ratio``.

    Returns
    -------
    Diagnosis
        The whole recording's, or with segments the worst segment's status and every segment's findings
        (the worst of each subject's), with each segment's notes
        (:meth:`monitor.diagnosis.segments.SegmentedDiagnosis.as_one`).
    """
    points = baseline if isinstance(baseline, OperatingPoints) else OperatingPoints.of([baseline])
    whole = diagnose_at_point(recording, engine, points=points, load=load)
    loads: list[float] = []
    if load is not None and truth.get("step_time_s") is not None:
        found, _ = steady_parts(whole, engine)
        if found.segments and not found.at_one_point:
            loads = loads_told(found.segments, truth)
    segmented = diagnose_segments(recording, engine, whole, baseline=points, load=load, loads=loads)
    return segmented.as_one()


def one_point(
    seed: int, length_s: float, *, told: bool = True, vee: bool = False
) -> tuple[dict[str, Any], Diagnosis]:
    """A case of the validation population off its point (a V engine's with ``vee``), diagnosed told its
    load (or not, ``told`` False) against its healthy twin alone (one calibrated point), as the bench
    diagnoses it; with the truth as the bench judges it (:func:`benchmarks.judging.vibrating`)."""
    case = random_case(seed, duration_s=length_s, operating="random", vee=vee)
    twin = healthy_twin(case, seed=seed + 1_000_000)
    engine = case_engine(case.engine_toml)
    baseline = OperatingPoints.of([calibrate(twin.recording, engine, load=twin.load_given)])
    truth = vibrating(case.truth)
    load = case.load_given if told else None
    return truth, diagnose_as_compare(case.recording, engine, baseline, load, truth)


def loads_told(segments: Sequence[Segment], truth: dict[str, Any]) -> list[float]:
    """The load an operator tells for each segment found: the load run on its side of the step.

    Parameters
    ----------
    segments : sequence of Segment
        The steady segments the product found, in time order.
    truth : dict
        The case's truth: ``step_time_s`` [s], ``segment_loads`` (the loads run on each side of the
        step, a side without whole cycles inside the recording left out) and ``test_loads`` (the
        loads set on each side) [-], and ``load_given_ratio`` (the told load's error) [-].

    Returns
    -------
    list of float
        One load per segment [-], fraction of rated: the load run before the step for a segment whose
        middle is before it, else the load run after it (the load set after it where no whole cycle
        after the step is inside the recording), times the told load's error.
    """
    ratio = float(truth["load_given_ratio"])
    run = [float(v) for v in truth["segment_loads"]]
    before = run[0]
    after = run[1] if len(run) > 1 else float(truth["test_loads"][-1])
    step = float(truth["step_time_s"])
    return [ratio * (before if 0.5 * (s.start_s + s.stop_s) < step else after) for s in segments]
