"""What a finding says in the validation simulator's terms, and whether it names what the simulator put in.

The benchmark (:mod:`benchmarks.diagnosis_validation`) simulates a case whose truth it knows (a class:
healthy, misfire, weak, worn bearing, sensor fault; and its subject: a cylinder, a bearing, a
channel) and reads the product's findings back into those terms: each finding's class and subject
(:func:`classify`), the decision rule that made it (:func:`rule_of`), whether the findings name the
truth (:func:`named`). A healthy engine whose structure itself vibrates in zone C or D is judged as
such (:func:`vibrating`).
"""

from __future__ import annotations

from typing import Any

from monitor.diagnosis.zones import DEFAULT_BOUNDARIES_MM_S, zone_of

__all__ = ["CLASSES", "RULES", "TRUE_CLASS", "classify", "named", "rule_of", "subjects", "vibrating"]

CLASSES = ("healthy", "misfire", "weak", "worn_bearing", "sensor_fault", "vibration_zone")


def classify(finding: Any) -> tuple[str, str]:
    """A finding's class and subject in the simulator's terms.

    Cylinders that fire too nearly together for the crank speed to tell apart are judged as one group
    (:mod:`monitor.diagnosis.shares`), and its finding names them all: the subject is then the group's
    names joined by " or " (``"A9 or B4"``), and it names each (:func:`subjects`).
    """
    if finding.kind == "sensor":
        return "sensor_fault", finding.subject.removeprefix("sensor ")
    if finding.kind == "cylinder":
        # "(misfiring" or "(misfiring, or nearly", not "(weak, leaking or misfiring"
        what = "misfire" if "(misfiring" in finding.summary else "weak"
        return what, " or ".join(name.removeprefix("cylinder ") for name in finding.subject.split(" or "))
    if finding.kind == "main bearing":
        return "worn_bearing", finding.subject.removeprefix("main bearing ")
    return "vibration_zone", finding.subject


RULES = (
    "cylinder against the others",
    "single cylinder against its reference",
    "bearing impacts",
    "bearing orders",
    "sensor fault",
    "vibration zone",
)
TRUE_CLASS = {  # the simulated fault each rule's finding names rightly
    "cylinder against the others": ("misfire", "weak"),
    "single cylinder against its reference": ("misfire", "weak"),
    "bearing impacts": ("worn_bearing",),
    "bearing orders": ("worn_bearing",),
    "sensor fault": ("sensor_fault",),
    "vibration zone": ("vibration_zone",),
}


def rule_of(finding: Any, cylinders: int) -> str:
    """The decision rule (docs/diagnosis.md) that made a finding."""
    if finding.kind == "cylinder":
        return "cylinder against the others" if cylinders > 1 else "single cylinder against its reference"
    if finding.kind == "main bearing":
        return "bearing impacts" if "impacts" in finding.summary else "bearing orders"
    if finding.kind == "sensor":
        return "sensor fault"
    return "vibration zone"


def subjects(subject: str) -> list[str]:
    """The subjects a finding's subject (as :func:`classify` gives it) names: one, or a group's members."""
    return subject.split(" or ")


def named(truth: dict[str, Any], findings: list[tuple[str, str, str]]) -> bool:
    """Whether the findings, as (class, subject, severity), name the truth's fault on its subject (a
    healthy run: no finding at all)."""
    kind = truth["class"]
    if kind == "healthy":
        return not findings
    subject = {
        "misfire": truth.get("cylinder"),
        "weak": truth.get("cylinder"),
        "worn_bearing": truth.get("bearing"),
        "sensor_fault": truth.get("channel"),
        "vibration_zone": truth.get("channel"),
    }[kind]
    wanted = {"misfire": ("misfire",), "weak": ("weak", "misfire"), "worn_bearing": ("worn_bearing",)}.get(
        kind, (kind,)
    )
    return any(c in wanted and str(subject) in subjects(s) for c, s, _ in findings)


def vibrating(truth: dict[str, Any]) -> dict[str, Any]:
    """A healthy case's truth, as class "vibration_zone" on its loudest channel when the structure's own
    vibration (the simulator's ``velocity_mm_s``) lies in zone C or D of the product's default limits
    (the simulated engine files state none): a healthy engine near a structural resonance vibrates as
    it does, and the zone finding that says so is right. Any other truth is returned as it is."""
    velocity = truth.get("velocity_mm_s") or {}
    loud = {name: v for name, v in velocity.items() if zone_of(v, DEFAULT_BOUNDARIES_MM_S) in ("C", "D")}
    if truth["class"] != "healthy" or not loud:
        return truth
    return {**truth, "class": "vibration_zone", "channel": max(loud, key=loud.__getitem__)}
