"""The diagnosis per steady segment of a recording that crosses operating points.

A recording whose load or speed changes inside it (a load step on a generator, a manoeuvre) is
not one operating point: the model at its mean speed and load describes neither part. The whole
recording's angle map gives its operating point cycle by cycle, and from it the steady segments
and the transitions between them (:mod:`monitor.signal.steady`). When there are two segments or
more, each is cut out of the recording by time (:func:`monitor.io.timespan.between`) and
diagnosed at its own operating point: the model at its own mean speed (the diagnosis takes the
speed from the segment itself) and at its own load where the user gave one per segment
(``compare --segment-loads``), else at the load given for the recording, with a note that says so
and gives the segment's load indicator against the recording's. The load indicator is not turned
into a load: the fluctuation at the firing harmonic holds the reciprocating parts' inertia torque
as well as the gas torque, and the cylinders' pressure moves with the load by the charge pressure
as well as the heat release, so its ratio between two segments is not theirs of the load. A
segment judged at a load it did not run at reads every cylinder's strength off by one factor:
the cylinders' contrast still names a misfire, but the balance's errors, relative to the
strengths, can grow until the segment is inconclusive (never healthy for that reason alone).

The overall status is the worst segment's (alarm, warning, inconclusive, healthy in that order);
its findings are each subject's worst over the segments (:attr:`SegmentedDiagnosis.findings`, with
the segments it was found in); a transition is reported as such and is no finding. A recording at one
steady point throughout, or with no steady span long enough (a run-up), is the whole recording's
diagnosis, unchanged. One with a single steady segment and the rest of it elsewhere (a load step
whose other side is too short to diagnose, the speed's dip and recovery after it) is that segment's
diagnosis, with a note that the rest is not judged: the whole recording's would compare two points'
mix with the model at one. One whose point changes too soon to cut two segments is the whole
recording's diagnosis, with a note where it changed (:func:`_across_a_change`), unless its speed
changed too much for the whole to be judged: then sides of :data:`SHORT_SEGMENT` cycles or more are
segments (:func:`steady_parts`), each judged at its own speed with the wider errors of fewer cycles.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, replace

from monitor.diagnosis.analysis import CyclePhase
from monitor.diagnosis.at_point import diagnose_at_point
from monitor.diagnosis.balance import Transfer
from monitor.diagnosis.diagnose import Diagnosis, unsteady_speeds
from monitor.diagnosis.findings import SEVERITIES, Finding
from monitor.diagnosis.operating_points import OperatingPoints
from monitor.errors import DiagnosisError
from monitor.io.recording import Recording
from monitor.io.timespan import between
from monitor.model.engine import Engine
from monitor.signal.steady import (
    MIN_CYCLES,
    Segment,
    Segmentation,
    Transition,
    cycle_series,
    steady_segments,
)

__all__ = [
    "STATUS_RANK",
    "SegmentDiagnosis",
    "SegmentedDiagnosis",
    "SegmentsFinding",
    "diagnose_segments",
    "segmentation_of",
    "steady_parts",
]

STATUS_RANK = {"healthy": 0, "inconclusive": 1, "warning": 2, "alarm": 3}
"""How bad each status is, for the worst over the segments."""
#: Cycles a side of a change needs to tell it in a recording too short to cut in segments [-].
SHORT_SIDE = 3
#: Cycles a segment needs where the speed changes too much to judge the recording whole and no
#: segment of MIN_CYCLES is in it (a manoeuvre in a short recording): a whole recording this short
#: is diagnosed too [-].
SHORT_SEGMENT = 12


@dataclass(frozen=True)
class SegmentDiagnosis:
    """One steady segment with its diagnosis.

    Attributes
    ----------
    index : int
        Its place among the segments, from 1 [-].
    segment : Segment
    diagnosis : Diagnosis
    """

    index: int
    segment: Segment
    diagnosis: Diagnosis


@dataclass(frozen=True)
class SegmentsFinding:
    """A subject's finding over the segments: its worst, and the segments it was found in.

    Attributes
    ----------
    finding : Finding
        The most severe of the subject's findings (the first of them when equally severe).
    segments : tuple of int
        The indexes of the segments it was found in, in their order [-].
    """

    finding: Finding
    segments: tuple[int, ...]


@dataclass(frozen=True)
class SegmentedDiagnosis:
    """A recording's diagnosis segment by segment (none: the whole recording's stands alone).

    Attributes
    ----------
    whole : Diagnosis
        The whole recording's diagnosis (its spectra, its plot).
    segments : tuple of SegmentDiagnosis
        One or more when the recording crosses operating points (one: the only steady one, the rest
        not judged); empty otherwise.
    transitions : tuple of Transition
    """

    whole: Diagnosis
    segments: tuple[SegmentDiagnosis, ...] = ()
    transitions: tuple[Transition, ...] = ()

    @property
    def status(self) -> str:
        """The worst segment's status, or the whole recording's when it is not segmented."""
        if not self.segments:
            return self.whole.status
        return max((s.diagnosis.status for s in self.segments), key=STATUS_RANK.__getitem__)

    @property
    def findings(self) -> tuple[SegmentsFinding, ...]:
        """Each subject's worst finding over the segments, with the segments it was found in.

        A subject is a finding's kind and subject. The subjects are in the order they are first
        found (segment by segment, each segment's findings in its own order); a finding replaces
        the one kept only when it is more severe. Empty when the recording is not segmented.
        """
        worst: dict[tuple[str, str], Finding] = {}
        found: dict[tuple[str, str], list[int]] = {}
        for part in self.segments:
            for finding in part.diagnosis.findings:
                key = (finding.kind, finding.subject)
                kept = worst.get(key)
                if kept is None or SEVERITIES.index(finding.severity) > SEVERITIES.index(kept.severity):
                    worst[key] = finding
                found.setdefault(key, []).append(part.index)
        return tuple(SegmentsFinding(worst[key], tuple(found[key])) for key in worst)

    def as_one(self) -> Diagnosis:
        """The segmented diagnosis as one: the worst status, each subject's worst finding, all the notes.

        Returns
        -------
        Diagnosis
            The whole recording's, unchanged when it is not segmented; else the whole recording's
            with the worst segment's status, :attr:`findings` ordered as :func:`monitor.diagnosis.diagnose`
            orders a diagnosis' (alarms first, then by falling confidence, then by subject) and every
            segment's notes in segment order.
        """
        if not self.segments:
            return self.whole
        findings = sorted(
            (item.finding for item in self.findings),
            key=lambda f: (f.severity != "alarm", -f.confidence, f.subject),
        )
        notes = [note for part in self.segments for note in part.diagnosis.notes]
        return replace(self.whole, status=self.status, findings=findings, notes=notes)


def segmentation_of(
    diagnosis: Diagnosis, engine: Engine, *, min_cycles: int = MIN_CYCLES, drift_over: int = 0
) -> Segmentation:
    """The steady segments of a diagnosed recording, from the angle map its diagnosis built.

    Parameters
    ----------
    diagnosis : Diagnosis
        The whole recording's.
    engine : Engine
        Its cycle and cylinders (the firing harmonic: one impulse per cylinder a cycle).
    min_cycles : int, optional
        Cycles a segment needs [-].
    drift_over : int, optional
        Cycles over which a shorter piece's drift is judged (0: its own;
        :func:`monitor.signal.steady.steady_segments`) [-].

    Returns
    -------
    Segmentation
    """
    reference = diagnosis.spectra.reference
    series = cycle_series(
        reference.angle_map,
        cycle_revolutions=engine.cycle_revolutions,
        firing_harmonic=engine.cylinders,
        pulses_per_revolution=reference.pulses_per_revolution,
    )
    return steady_segments(series, min_cycles=min_cycles, drift_over=drift_over)


def steady_parts(
    whole: Diagnosis, engine: Engine, *, min_cycles: int = MIN_CYCLES
) -> tuple[Segmentation, int]:
    """The steady segments a recording is diagnosed by, and the cycles each needed.

    Segments of ``min_cycles``; where there are none but the recording's speed spreads too much for it
    to be judged whole (:func:`monitor.diagnosis.diagnose.unsteady_speeds`), its steady spans of
    :data:`SHORT_SEGMENT` cycles or more where it holds any: each steady side of a manoeuvre judged
    at its own speed, with the wider errors of fewer cycles, rather than the whole left inconclusive.

    Parameters
    ----------
    whole : Diagnosis
        The whole recording's.
    engine : Engine
    min_cycles : int, optional
        Cycles a segment needs [-].

    Returns
    -------
    segmentation : Segmentation
    cycles : int
        The cycles its segments needed: ``min_cycles``, or :data:`SHORT_SEGMENT` [-].
    """
    found = segmentation_of(whole, engine, min_cycles=min_cycles)
    if (found.segments and not found.at_one_point) or min_cycles <= SHORT_SEGMENT:
        return found, min_cycles
    # a span of a ramp is no steady span however short: its drift is judged over ``min_cycles``
    shorter = segmentation_of(whole, engine, min_cycles=SHORT_SEGMENT, drift_over=min_cycles)
    if not shorter.segments or shorter.at_one_point:
        return found, min_cycles
    if unsteady_speeds(whole.spectra.reference.angle_map) is None:
        return found, min_cycles  # judged whole, across the change (:func:`_across_a_change`)
    return shorter, SHORT_SEGMENT


#: What a segment was judged at, by where its load came from (``load_used_from``, or "segment").
_JUDGED_AT = {
    "segment": "the model at the load given for this segment ({load:.2f})",
    "estimated": "the reference at the load estimated from this segment ({load:.2f})",
    "speed": "the reference at the load this segment's speed reads on the calibrated points ({load:.2f})",
    "raised": "the model at the load estimated from this segment ({load:.2f}), above the load given",
    "stated": "the model at the load given for the recording ({load:.2f}): give each segment's load "
    "(compare --segment-loads) to judge it at its own",
    "baseline": "the reference at its own load ({load:.2f}): this segment's crank-speed orders tell none; "
    "give each segment's load (compare --segment-loads) to judge it at its own",
    "rated": "the model at rated load ({load:.2f}), without a baseline or a load given: give each segment's "
    "load (compare --segment-loads) to judge it at its own",
}


def _note(
    item: Segment, index: int, count: int, load: float, source: str, mean_indicator: float | None
) -> str:
    """What a segment's diagnosis says of its span and of the load it was judged at."""
    judged = _JUDGED_AT[source].format(load=load)
    text = (
        f"segment {index} of {count}: {item.start_s:.2f} to {item.stop_s:.2f} s, {item.cycles} cycles at "
        f"{item.speed * 30 / math.pi:.1f} rpm; {judged}"
    )
    if item.load_indicator is not None and mean_indicator:
        text += (
            f"; this segment's load indicator (the firing harmonic's speed fluctuation) is "
            f"{item.load_indicator / mean_indicator:.2f} times the recording's"
        )
    return text


def diagnose_segments(
    recording: Recording,
    engine: Engine,
    whole: Diagnosis,
    *,
    baseline: OperatingPoints | None = None,
    load: float | None = None,
    transfer: Transfer = "rigid",
    cycle_phase: CyclePhase = None,
    exclude: tuple[str, ...] | list[str] = (),
    loads: Sequence[float] = (),
    min_cycles: int = MIN_CYCLES,
) -> SegmentedDiagnosis:
    """Each steady segment of a recording diagnosed at its own operating point (module docstring).

    Parameters
    ----------
    recording : Recording
    engine : Engine
    whole : Diagnosis
        The whole recording's diagnosis (:func:`monitor.diagnosis.diagnose`, with the same options).
    baseline : OperatingPoints, optional
        The calibrated points; each segment is compared at its own load, estimated where not given
        (:func:`monitor.diagnosis.at_point.diagnose_at_point`).
    load : float, optional
        The load given for the recording [-]; default: each segment's as
        :func:`monitor.diagnosis.at_point.diagnose_at_point` finds it without one.
    transfer : {"rigid", "shaft-line"}, optional
    cycle_phase : float or "unknown", optional
    exclude : sequence of str, optional
        As for :func:`monitor.diagnosis.diagnose`.
    loads : sequence of float, optional
        Each segment's load, in time order [-]; default: ``load`` for every segment.
    min_cycles : int, optional
        Cycles a segment needs [-].

    Returns
    -------
    SegmentedDiagnosis
        Without segments when the recording is at one steady point throughout or has no steady
        segment (``loads`` then unused: a note on the whole diagnosis says so); with one segment when
        the rest of the recording is not at one point long enough.

    Raises
    ------
    DiagnosisError
        When ``loads`` are given and not one per segment.
    """
    found, needed = steady_parts(whole, engine, min_cycles=min_cycles)
    if not found.segments or found.at_one_point:
        if loads:
            whole.notes.append(
                "the loads per segment were not used: the recording "
                + (
                    "is at one steady point"
                    if found.segments
                    else f"has no steady span of {min_cycles} cycles"
                )
                + ", and is diagnosed whole"
            )
        return SegmentedDiagnosis(_across_a_change(whole, engine, min_cycles))
    if loads and len(loads) != len(found.segments):
        spans = ", ".join(f"{s.start_s:.2f}-{s.stop_s:.2f} s" for s in found.segments)
        raise DiagnosisError(
            f"{len(loads)} load(s) given per segment; the recording has {len(found.segments)} steady "
            f"segments ({spans}): give one load for each, in time order"
        )
    indicators = [s.load_indicator for s in found.segments if s.load_indicator is not None]
    cycles = sum(s.cycles for s in found.segments)
    mean_indicator = (
        sum(s.load_indicator * s.cycles for s in found.segments if s.load_indicator is not None) / cycles
        if len(indicators) == len(found.segments)
        else None
    )
    diagnosed = []
    for i, item in enumerate(found.segments, start=1):
        part = diagnose_at_point(
            between(recording, item.start_s, item.stop_s),
            engine,
            points=baseline,
            load=loads[i - 1] if loads else load,
            transfer=transfer,
            cycle_phase=cycle_phase,
            exclude=exclude,
        )
        source = str(part.operating_point.get("load_used_from", "stated"))
        source = "segment" if loads and source == "stated" else source
        part.notes.insert(0, _note(item, i, len(found.segments), part.load, source, mean_indicator))
        if len(found.segments) == 1:
            part.notes.insert(1, _rest_note(item, needed))
        if needed < min_cycles:
            part.notes.insert(1, _short_note(min_cycles))
        diagnosed.append(SegmentDiagnosis(i, item, part))
    return SegmentedDiagnosis(whole, tuple(diagnosed), found.transitions)


def _rest_note(item: Segment, min_cycles: int) -> str:
    """What a recording's one steady segment leaves unjudged: the rest, a change or too short a span."""
    return (
        f"the recording holds one steady point for {min_cycles} cycles or more, from {item.start_s:.2f} to "
        f"{item.stop_s:.2f} s: the rest of it (a change of operating point, or too short a span at "
        "another) is not judged, and the diagnosis is this segment's"
    )


def _short_note(min_cycles: int) -> str:
    """Why a recording's segments are shorter than ``min_cycles``."""
    return (
        f"the speed changed too much to judge the recording whole and it holds no steady span of "
        f"{min_cycles} cycles beside another point: each steady span of {SHORT_SEGMENT} cycles or more is "
        f"judged on its own, with the wider errors of fewer cycles. Record {min_cycles} steady cycles or "
        "more at each point"
    )


def _across_a_change(whole: Diagnosis, engine: Engine, min_cycles: int) -> Diagnosis:
    """The whole recording's diagnosis, noted where its operating point changes too soon to cut segments.

    A change told apart with :data:`SHORT_SIDE` cycles on a side (two short steady spans, or one that
    does not reach the recording's ends), where no two segments of ``min_cycles`` are: the cylinders'
    strengths are read over the whole recording, their mean over both points. Each cycle's speed is
    taken less the drift across it (:mod:`monitor.signal.crank_speed`), so the change's acceleration is
    in no order, and the load moves every cylinder's share alike: a cylinder that reads weak across the
    change is weak (tests/diagnosis/test_unsteady_speed.py). The note says where the point changed.
    """
    short = segmentation_of(whole, engine, min_cycles=SHORT_SIDE)
    if short.at_one_point or not short.segments:  # steady, or no steady span at all (a run-up: noted)
        return whole
    at = ", ".join(f"steady {s.start_s:.1f}-{s.stop_s:.1f} s" for s in short.segments)
    note = (
        f"the operating point changes inside the recording ({at}) with fewer than {min_cycles} steady "
        "cycles on a side: the cylinders' strengths are read over both points, their mean. Record "
        f"{min_cycles} steady cycles or more at each point to judge each at its own"
    )
    return replace(whole, notes=[note, *whole.notes])
