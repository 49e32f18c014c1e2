"""A diagnosis as a JSON document and as text tables.

Both say the same: the operating point, the findings with their evidence,
whether the main bearings were judged (not without a sensor on one), the
cylinder balance, and per channel the measured against the predicted
orders with their deviation and its uncertainty (complex amplitudes as
magnitude and phase in degrees, relative to TDC of cylinder 1). A recording
diagnosed per steady segment (:mod:`monitor.diagnosis.segments`) gives each
segment's, with the transitions between them.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from monitor.diagnosis.diagnose import ANALYSIS_VERSION, Diagnosis
from monitor.diagnosis.findings import Finding
from monitor.diagnosis.segments import SegmentedDiagnosis
from monitor.report.jsonsafe import json_ready
from monitor.signal.steady import Segment

__all__ = ["diagnosis_document", "diagnosis_table", "segmented_document", "segmented_table"]


def _finding(finding: Finding) -> dict[str, Any]:
    """A finding as the documents give it."""
    return {
        "kind": finding.kind,
        "subject": finding.subject,
        "severity": finding.severity,
        "summary": finding.summary,
        "confidence": finding.confidence,
        "evidence": finding.evidence,
    }


def diagnosis_document(diagnosis: Diagnosis, *, recording: str = "") -> dict[str, Any]:
    """The diagnosis as a JSON-ready document (documented in docs/diagnosis.md).

    Parameters
    ----------
    diagnosis : Diagnosis
    recording : str, optional
        The recording's name.

    Returns
    -------
    dict
    """
    balance = diagnosis.balance
    document: dict[str, Any] = {
        "analysis_version": ANALYSIS_VERSION,
        "recording": recording,
        "engine_id": diagnosis.engine_id,
        "speed_rpm": diagnosis.speed_rpm,
        "load": diagnosis.load,
        "baseline": diagnosis.baseline,
        "status": diagnosis.status,
        "findings": [_finding(f) for f in diagnosis.findings],
        "notes": list(diagnosis.notes),
        "main_bearings": {
            "judged": not diagnosis.bearings_not_judged,
            "not_judged_because": diagnosis.bearings_not_judged or None,
        },
        "operating_point": dict(diagnosis.operating_point) or None,
        "cylinder_balance": None,
        "channels": {},
        "impacts": {},
        "velocity_rms": {
            name: {
                "value_mm_s": v.value,
                "standard_error_mm_s": v.error,
                "band_hz": list(v.band_hz),
                "zone": zone,
            }
            for name, (v, zone) in diagnosis.velocity.items()
        },
        "zone_boundaries_mm_s": list(diagnosis.zone_boundaries_mm_s),
    }
    if balance is not None:
        document["cylinder_balance"] = {
            "transfer": balance.transfer,
            "strength_meaning": balance.strength_meaning,
            "names": [balance.name(c) for c in range(balance.strength.size)],
            # each cylinder's bank ("" in line): "relative" is against its own bank's cylinders
            "banks": list(balance.banks),
            # cylinders that fire too nearly together to tell apart, each group judged as one
            "judged_as_one": [[balance.name(c) for c in g] for g in balance.together],
            "strength": balance.strength,
            "strength_standard_error": balance.strength_error,
            "relative": balance.relative,
            "relative_standard_error": balance.relative_error,
            "contrast_standard_error": balance.contrast_error,
            "model_uncertainty": balance.model_uncertainty,
            "orders": balance.orders,
            "condition_number": balance.condition,
            "chi2_reduced": balance.chi2_reduced,
            "separable": balance.separable,
        }
    for c in diagnosis.comparisons:
        document["channels"][c.channel] = {
            "unit": c.unit,
            "basis": c.basis,
            "orders": c.orders,
            "measured_amplitude": np.abs(c.measured),
            "measured_phase_deg": np.degrees(np.angle(c.measured)),
            "predicted_amplitude": np.abs(c.predicted),
            "predicted_phase_deg": np.degrees(np.angle(c.predicted)),
            "standard_error": c.standard_error,
            "deviation_of_largest": c.deviation,
        }
    for b in diagnosis.bearings:
        document["impacts"][b.channel] = [
            {
                "bearing": s.bearing,
                "score": s.score,
                "standard_error": s.score_error,
                "reference": s.reference,
                "reversal_angles_deg": s.reversal_angles_deg,
            }
            for s in b.impacts
        ]
    return dict(json_ready(document))


def diagnosis_table(diagnosis: Diagnosis, *, recording: str = "", max_rows: int = 12) -> str:
    """The diagnosis as text: findings first, then the balance and the order tables.

    Parameters
    ----------
    diagnosis : Diagnosis
    recording : str, optional
    max_rows : int, optional
        Orders listed per channel (the largest measured or predicted ones, in order).

    Returns
    -------
    str
    """
    lines = [
        f"{recording or 'recording'}: {diagnosis.engine_id} at {diagnosis.speed_rpm:.2f} rpm, model at load "
        f"{diagnosis.load:.2f}" + (f", baseline {diagnosis.baseline}" if diagnosis.baseline else ""),
        f"status: {diagnosis.status.upper()}",
    ]
    if diagnosis.findings:
        lines.append("findings:")
        for f in diagnosis.findings:
            lines.append(f"  [{f.severity}] {f.summary} (confidence {100 * f.confidence:.0f} %)")
    else:
        lines.append("findings: none")
    if diagnosis.bearings_not_judged:
        lines.append(f"main bearings: NOT JUDGED: {diagnosis.bearings_not_judged}")
    for note in diagnosis.notes:
        lines.append(f"note: {note}")
    balance = diagnosis.balance
    if balance is not None:
        lines += [
            "",
            f"cylinder balance ({balance.strength_meaning} from crank-speed orders "
            f"{', '.join(f'{k:g}' for k in balance.orders)}; {balance.transfer} transfer; "
            f"condition number {balance.condition:.3g}):",
            f"{'cylinder':>8} {'strength':>9} {'+-':>6} {'of alike':>9} {'+- (95 %)':>10}",
        ]
        for c in range(balance.strength.size):
            lines.append(
                f"{balance.name(c):>8} {balance.strength[c]:9.3f} {balance.strength_error[c]:6.3f} "
                f"{100 * balance.relative[c]:8.1f}% {196 * balance.relative_error[c]:9.1f}%"
            )
        if any(balance.banks):
            lines.append("  (of alike: against the cylinders of its own bank that fire alike)")
        if balance.together:
            judged = ", ".join("+".join(balance.name(c) for c in g) for g in balance.together)
            lines.append(f"  (fire too nearly together to tell apart, each judged as one: {judged})")
    for comparison in diagnosis.comparisons:
        size = np.abs(comparison.predicted)
        if size.size == 0:
            continue
        shown = np.maximum(size, np.abs(comparison.measured))
        top = np.sort(np.argsort(shown)[::-1][:max_rows])
        lines += [
            "",
            f"{comparison.channel} [{comparison.unit}], measured against predicted ({comparison.basis}):",
            f"{'order':>6} {'measured':>11} {'phase':>7} {'predicted':>11} {'phase':>7} "
            f"{'deviation':>10} {'+-':>8}",
        ]
        largest = float(size.max()) or 1.0
        for i in top:
            m, p = comparison.measured[i], comparison.predicted[i]
            lines.append(
                f"{comparison.orders[i]:6.1f} {abs(m):11.4g} {math.degrees(np.angle(m)):7.1f} {abs(p):11.4g} "
                f"{math.degrees(np.angle(p)):7.1f} {100 * comparison.deviation[i]:9.2f}% "
                f"{100 * comparison.standard_error[i] / largest:7.2f}%"
            )
        lines.append("  (deviation: |measured - predicted| in % of the channel's largest predicted order)")
    if diagnosis.bearings:
        lines += ["", "impact power in load-reversal windows (1 = reference):"]
        for b in diagnosis.bearings:
            scores = ", ".join(f"bearing {s.bearing} {s.score:.2f} +- {s.score_error:.2f}" for s in b.impacts)
            reference = b.impacts[0].reference if b.impacts else ""
            lines.append(f"  {b.channel} (main bearing {b.bearing}, against {reference}): {scores}")
    if diagnosis.velocity:
        a, bc, cd = diagnosis.zone_boundaries_mm_s
        lines += ["", f"rms velocity (zones A/B {a:g}, B/C {bc:g}, C/D {cd:g} mm/s):"]
        for name, (v, zone) in diagnosis.velocity.items():
            lines.append(
                f"  {name}: {v.value:.3f} +- {v.error:.3f} mm/s over {v.band_hz[0]:g}-{v.band_hz[1]:g} Hz, "
                f"zone {zone}"
            )
    return "\n".join(lines)


def _point(segment: Segment) -> dict[str, Any]:
    """A segment's operating point as the documents give it."""
    return {"speed_rpm": segment.speed * 30 / math.pi, "load_indicator": segment.load_indicator}


def segmented_document(segmented: SegmentedDiagnosis, *, recording: str = "") -> dict[str, Any]:
    """The diagnosis document, with its steady segments and transitions when it has them (docs/diagnosis.md).

    Without segments it is :func:`diagnosis_document` of the whole recording, unchanged. With them,
    the whole recording's document (its spectra's comparisons and balance) whose ``status`` is the
    worst segment's and whose ``findings`` are the segments' (each named once, at its worst, with
    the ``segments`` it was found in: :attr:`monitor.diagnosis.segments.SegmentedDiagnosis.findings`,
    in its order), and two more entries: ``segments`` (each with its span, its operating point and
    its own diagnosis document) and ``transitions``.

    Parameters
    ----------
    segmented : SegmentedDiagnosis
    recording : str, optional
        The recording's name.

    Returns
    -------
    dict
    """
    document = diagnosis_document(segmented.whole, recording=recording)
    if not segmented.segments:
        return document
    parts = [diagnosis_document(s.diagnosis, recording=recording) for s in segmented.segments]
    document["status"] = segmented.status
    document["findings"] = [
        {**_finding(item.finding), "segments": list(item.segments)} for item in segmented.findings
    ]
    said = (
        f"diagnosed per steady segment: {len(parts)} segment{'s' * (len(parts) != 1)}, "
        f"{len(segmented.transitions)} "
        "transition(s); the status and findings are the segments'"
    )
    document["notes"] = [said, *document["notes"]]
    document["segments"] = [
        {
            "index": item.index,
            "start_s": item.segment.start_s,
            "stop_s": item.segment.stop_s,
            "cycles": item.segment.cycles,
            **_point(item.segment),
            "diagnosis": part,
        }
        for item, part in zip(segmented.segments, parts, strict=True)
    ]
    document["transitions"] = [
        {"start_s": t.start_s, "stop_s": t.stop_s, "from": _point(t.before), "to": _point(t.after)}
        for t in segmented.transitions
    ]
    return dict(json_ready(document))


def segmented_table(segmented: SegmentedDiagnosis, *, recording: str = "", max_rows: int = 12) -> str:
    """The diagnosis as text: :func:`diagnosis_table` of the whole, or of each steady segment.

    Parameters
    ----------
    segmented : SegmentedDiagnosis
    recording : str, optional
    max_rows : int, optional
        Orders listed per channel.

    Returns
    -------
    str
    """
    if not segmented.segments:
        return diagnosis_table(segmented.whole, recording=recording, max_rows=max_rows)

    def point(segment: Segment) -> str:
        text = f"{segment.speed * 30 / math.pi:.1f} rpm"
        return text + (
            "" if segment.load_indicator is None else f", load indicator {segment.load_indicator:.4g} rad/s"
        )

    lines = [
        f"{recording or 'recording'}: {segmented.whole.engine_id}, diagnosed per steady segment "
        f"({len(segmented.segments)} segment{'s' * (len(segmented.segments) != 1)})",
        f"status: {segmented.status.upper()} (the worst segment's)",
    ]
    for t in segmented.transitions:
        lines.append(
            f"transition {t.start_s:.2f} to {t.stop_s:.2f} s: from {point(t.before)} to {point(t.after)}"
        )
    for item in segmented.segments:
        lines += [
            "",
            f"--- segment {item.index}: {item.segment.start_s:.2f} to {item.segment.stop_s:.2f} s, "
            f"{item.segment.cycles} cycles, {point(item.segment)}",
            diagnosis_table(
                item.diagnosis,
                recording=f"{recording or 'recording'} segment {item.index}",
                max_rows=max_rows,
            ),
        ]
    return "\n".join(lines)
