"""Findings: the decision rules that turn the diagnosis' estimates into findings with a severity.

Each rule (docs/diagnosis.md, "Findings") compares an estimate with an engineering threshold and
asks that it be at least :data:`SIGNIFICANCE` standard errors from the healthy value; a finding's
confidence is the probability, with normal errors, that the true value lies beyond the threshold it
crossed.  The estimates come from :mod:`monitor.diagnosis.diagnose` (cylinder balance, bearing
orders and impacts, sensor screening); the rules and their thresholds are here.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from monitor.diagnosis.balance import CylinderBalance
from monitor.diagnosis.bearings import ImpactScore, OrderDeviation
from monitor.diagnosis.misfire import MissingFiring, missing_firing
from monitor.diagnosis.sensors import SensorFault
from monitor.diagnosis.shares import one_of
from monitor.io.recording import Recording

__all__ = [
    "MISSING_IMPULSE",
    "RELATIVE_STRENGTH",
    "BearingResult",
    "Finding",
    "bearing_findings",
    "confidence_beyond",
    "cylinder_findings",
    "missing_firing_doubt",
    "missing_firing_findings",
    "sensor_finding",
    "single_cylinder_findings",
    "worse",
]

MISSING_IMPULSE = "share of the others' firing impulse"  # the missing-firing pattern's evidence [-]
RELATIVE_STRENGTH = "relative strength"  # a cylinder's strength against those that fire alike [-]
SIGNIFICANCE = 4.0  # standard errors between a finding's estimate and the healthy value [-]
CYLINDER_WARNING = (0.85, 1.15)  # strength against those that fire alike [-]
CYLINDER_ALARM = (0.5, 1.3)
# below this share of the others a cylinder is called misfiring [-]: between what motored cylinders and
# cylinders with half a healthy heat release read on the validation population (docs/diagnosis-validation.md
# gives both ranges; the product's heat-release strength meets another engine's gas exchange and losses)
MISFIRE_BELOW = 0.3
BEARING_WARNING, BEARING_ALARM = 0.5, 1.0  # order deviation from the calibrated prediction [-]
# a knock span's high-frequency power against the baseline's, where it stands out of the noise by more
# than chance over the windows allows (bearings.FAMILY_FALSE_ALARM) [-]: healthy runs at their own
# baseline's point read up to 1.4 x in one span, localised and significant (the engine's noise differs
# from run to run by more than its statistics within a run); docs/diagnosis-validation.md
IMPACT_WARNING, IMPACT_ALARM = 1.5, 10.0
# with a cylinder finding: its changed combustion changes the structure's own high-frequency noise near
# it (heard loudest on the nearest sensor), so only a clearer knock is a bearing's [-]
IMPACT_WITH_CYLINDER_FINDING = 2.0
# without a baseline: against the recording's own median, a warning at most [-]
IMPACT_WITHOUT_BASELINE = 10.0
# and always: the span's excess over its reference on the bearing's own sensor at least this many times
# its excess on any other bearing sensor (a knock is heard loudest where it is; the engine's own noise,
# moved by a misfire or a load change, alike on all); and as many times the excess of its own sensor
# away from every window it is scored for (bearings.AWAY_SHARE: a knock is heard where a load reverses) [-]
LOCALISED = 2.0
SEVERITIES = ("healthy", "warning", "alarm")
NEARLY_PATTERN = "it lacks most of its firing impulse"  # the pattern's label between 30 and 50 %
# a share whose 95 % interval reaches further than this either side says nothing of its size (the
# others' level read near nothing): the summary gives the deficit in the model's terms instead [-]
SHARE_READABLE = 1.0
# a missing impulse's pattern explains at least this share of the weighted power at the orders where
# the cylinders cancel: a disturbance of another shape there (a transfer that is not the engine's, a
# torsional resonance) is not one cylinder's missing impulse [-]
PATTERN_EXPLAINED = 0.5
ABSOLUTE_UNCERTAINTY = 0.15  # a single cylinder's strength against the model: model and stated load [-]
BASELINE_UNCERTAINTY = 0.10  # a single cylinder's strength against its baseline's: the stated loads [-]
SINGLE_BEYOND = 2.0  # a single cylinder's errors beyond a limit: 97.7 % (one-sided) that it is beyond [-]


@dataclass(frozen=True)
class Finding:
    """A deviation the product reports.

    Attributes
    ----------
    kind : str
        "cylinder", "main bearing" or "vibration zone".
    subject : str
        What it names: "cylinder 4", "main bearing 5", or the channel for a zone.
    severity : str
        "warning" or "alarm".
    summary : str
        One line for people.
    confidence : float
        Probability that the true value lies beyond the threshold crossed [-].
    evidence : list of dict
        What was measured, against what prediction and threshold, in which unit.
    """

    kind: str
    subject: str
    severity: str
    summary: str
    confidence: float
    evidence: list[dict[str, Any]]


@dataclass(frozen=True)
class BearingResult:
    """One bearing sensor's results.

    Attributes
    ----------
    channel : str
    bearing : int
    orders : OrderDeviation or None
        None without a usable calibration (the reason is in the diagnosis' notes).
    impacts : list of ImpactScore
        The sensor's own bearing's windows and its neighbours'.
    elsewhere : float
        The highest score of its own bearing's windows on the other bearing sensors (NaN without
        others): an impact that is the bearing's own is heard loudest on the sensor on it [-].
    """

    channel: str
    bearing: int
    orders: OrderDeviation | None
    impacts: list[ImpactScore]
    elsewhere: float = math.nan


def confidence_beyond(z: float) -> float:
    """A finding's confidence: the probability that a normal estimate lies beyond its threshold.

    Parameters
    ----------
    z : float
        How far the estimate lies beyond the threshold, in its standard errors [-].

    Returns
    -------
    float
        The standard normal distribution function at ``z`` [-].
    """
    return 0.5 * math.erfc(-z / math.sqrt(2))


def worse(a: str, b: str) -> str:
    """The more severe of two severities.

    Parameters
    ----------
    a, b : str
        Each one of :data:`SEVERITIES`.

    Returns
    -------
    str
    """
    return a if SEVERITIES.index(a) >= SEVERITIES.index(b) else b


def cylinder_findings(balance: CylinderBalance, partners: list[int | None] | None = None) -> list[Finding]:
    """Each cylinder whose share of those that fire alike crosses a threshold, significantly.

    Two cylinders are each other's only reference, and the crank speed measures their difference
    well but their common level poorly (a 2-cylinder engine's low orders through a gas model off by
    a factor): a weak one makes the other read strong, or a share of a negative reference.  Of two
    findings only the weaker cylinder's is kept: a cylinder that fires less than its partner is the
    fault a crank speed shows (misfire, weak, leaking), one stronger than the model's is not.

    Parameters
    ----------
    balance : CylinderBalance
    partners : list of int or None, optional
        A four-stroke whose cycle phase is unknown: each cylinder's partner (index) that fires
        360 deg from it, named beside it.

    Returns
    -------
    list of Finding
    """
    findings = _each_cylinder(balance, partners)
    weaker = int(np.argmin(balance.strength)) + 1
    # a missing firing impulse is never hidden by the model's fit: its pattern's alarm stands in for
    # a milder finding on the cylinder, or for none, or for an alarm that reads it higher, not misfiring
    for missing in missing_firing_findings(balance, partners):
        weaker = missing.evidence[0]["cylinder"]
        share = max(missing.evidence[0]["measured"], MISFIRE_BELOW)
        same = [f for f in findings if f.evidence[0]["cylinder"] - 1 in balance.group(weaker - 1)]
        if not any(f.severity == "alarm" and f.evidence[0]["measured"] < share for f in same):
            findings = [f for f in findings if f not in same] + [missing]
    if balance.strength.size == 2 and len(findings) == 2:
        findings = [f for f in findings if f.evidence[0]["cylinder"] == weaker]
    return findings


def missing_firing_findings(
    balance: CylinderBalance, partners: list[int | None] | None = None
) -> list[Finding]:
    """A cylinder that lacks most of its firing impulse, by its pattern in the crank-speed orders.

    The test (:mod:`monitor.diagnosis.misfire`) does not rest on the model's level: the cylinder
    whose missing impulse's pattern is the most significant is an alarm when that deficit stands
    :data:`SIGNIFICANCE` standard errors above nothing, its pattern explains at least
    :data:`PATTERN_EXPLAINED` of the orders where the cylinders cancel, and the share of the
    others' impulse it fires is below the alarm limit (:data:`CYLINDER_ALARM`); "misfiring" below
    :data:`MISFIRE_BELOW`.  Its errors are the measurement's, never scaled by the model's misfit.
    In :func:`cylinder_findings` it stands in for the balance's finding on the same cylinder
    unless that is an alarm reading the cylinder lower, or misfiring.

    Parameters
    ----------
    balance : CylinderBalance
        With its parts (:attr:`CylinderBalance.columns`); none without them.
    partners : list of int or None, optional
        A four-stroke whose cycle phase is unknown: each cylinder's 360 deg partner (index).

    Returns
    -------
    list of Finding
        At most one.
    """
    test = missing_firing(balance)
    if test is None:
        return []
    c = test.candidate
    a, share = float(test.deficit[c]), float(test.share[c])
    if not _lacks_most(test) or float(test.explained[c]) < PATTERN_EXPLAINED:
        return []
    e = max(float(test.share_error[c]), 1e-12)
    named = _named(balance, c, partners)
    what = "misfiring" if share < MISFIRE_BELOW else f"misfiring, or nearly: {NEARLY_PATTERN}"
    told = f"{named} at {round(100 * share)} % +- {round(196 * e)} % of the others' firing impulse"
    if 1.96 * e > SHARE_READABLE:
        told = (
            f"{named} lacks {a:.2f} +- {1.96 * float(test.deficit_error[c]):.2f} of a cylinder's firing "
            f"impulse in the model at the load used, the others firing {float(test.level[c]):.2f} +- "
            f"{1.96 * float(test.level_error[c]):.2f} of it: too uncertain a level to give a share"
        )
    return [
        Finding(
            kind="cylinder",
            subject=named,
            severity="alarm",
            summary=(
                f"{told} ({what}; the pattern of a missing impulse in the crank-speed orders, "
                "whatever the model's level)" + _either(balance, c, partners)
            ),
            confidence=confidence_beyond((CYLINDER_ALARM[0] - share) / e),
            evidence=[
                {
                    "quantity": MISSING_IMPULSE,
                    "measured": share,
                    "standard_error": e,
                    "predicted": 1.0,
                    "threshold": CYLINDER_ALARM[0],
                    "unit": "-",
                    "deficit": a,
                    "deficit_standard_error": float(test.deficit_error[c]),
                    "level": float(test.level[c]),
                    "level_standard_error": float(test.level_error[c]),
                    "explained": float(test.explained[c]),
                    "orders": test.orders[test.cancelling].tolist(),
                    "cylinder": c + 1,
                    "cylinder_name": balance.name(c),
                    "model_chi2_reduced": balance.chi2_reduced,
                }
            ],
        )
    ]


#: What a group that fires together is called when it lacks more than one member's firing.
SEVERAL = "more than one of them weak, leaking or misfiring: together they lack more than a cylinder's firing"


def _named(balance: CylinderBalance, c: int, partners: list[int | None] | None) -> str:
    """The subject: ``cylinder 3`` (``cylinder B3`` on a V), with the cylinders that fire together
    with it (judged as one) and, where the cycle phase is unknown, their 360 deg partners."""
    group = balance.group(c)
    named = [c, *(o for o in group if o != c)]
    named += [p for m in group if partners is not None and (p := partners[m]) is not None and p not in named]
    return " or ".join(f"cylinder {balance.name(o)}" for o in named)


def _either(
    balance: CylinderBalance, c: int, partners: list[int | None] | None, together: float | None = None
) -> str:
    """Why a finding names more than one cylinder ("" when it names one), with the group's own share
    where the finding reads it as one member's (``together``)."""
    size = len(balance.group(c))
    unknown = partners is not None and partners[c] is not None
    phase = "; the cycle phase is unknown, so either may be it" * unknown
    if size == 1:
        return phase
    apart = "; they fire too nearly together for the crank speed to tell apart, judged as one"
    if together is not None:
        apart += (
            f" (together at {round(100 * together)} % of the others: one of them at "
            f"{round(100 * one_of(together, size))} % if the others fire as the reference, or all alike)"
        )
    return apart + phase


def _reference(balance: CylinderBalance, c: int) -> str:
    """What cylinder ``c``'s share is of: the cylinders that fire alike, on a V those of its bank."""
    bank = balance.banks[c] if c < len(balance.banks) and len(balance.group(c)) == 1 else ""
    return f"bank {bank}'s cylinders that fire alike" if bank else "the cylinders that fire alike"


def _each_cylinder(balance: CylinderBalance, partners: list[int | None] | None) -> list[Finding]:
    findings = []
    member_contrast = balance.member_contrast_error()
    for c in range(balance.strength.size):
        if balance.group(c)[0] != c:  # judged as one with the group's first cylinder
            continue
        named = _named(balance, c, partners)
        together, size = float(balance.relative[c]), len(balance.group(c))
        # a group's deficit read as one member's, the others firing as the reference: the single fault
        # looked for first, n times the group's departure and errors (the limits then mean for a
        # member of a group what they mean for a cylinder alone; the significance is the group's)
        r = one_of(together, size)
        e = size * max(float(balance.relative_error[c]), 1e-12)
        contrast = max(float(member_contrast[c]), 1e-12)
        severity, threshold = "healthy", None
        if r < CYLINDER_WARNING[0]:
            severity, threshold = "warning", CYLINDER_WARNING[0]
            if r < CYLINDER_ALARM[0]:
                severity, threshold = "alarm", CYLINDER_ALARM[0]
        elif r > CYLINDER_WARNING[1]:
            severity, threshold = "warning", CYLINDER_WARNING[1]
            if r > CYLINDER_ALARM[1]:
                severity, threshold = "alarm", CYLINDER_ALARM[1]
        # different from the others beyond what the data leave open: the contrast, whose error does not
        # carry the uncertainty of the cylinders' common level
        if threshold is None or abs(r - 1.0) < SIGNIFICANCE * contrast:
            continue
        low = r < 1.0
        # a group that lacks more than one member's firing beyond its errors (read as one member's,
        # significantly less than nothing) has more than one weak member: its share is given as the
        # group's, its member reading stops at a whole cylinder missing. One member missing whole
        # departs by one cylinder's combustion as the model carries it to the crank speed, known to the
        # model's uncertainty beside the contrast's
        several = size > 1 and -r >= SIGNIFICANCE * math.hypot(contrast, balance.model_uncertainty)
        if several:
            what = SEVERAL
        elif r < MISFIRE_BELOW:
            what = "misfiring"
        elif severity == "alarm" and low and r < 1.96 * e:
            what = "misfiring, or nearly: no firing is within its 95 % interval"
        else:
            what = "weak, leaking or misfiring" if low else "stronger than the others"
        share = (
            f"together at {round(100 * together)} % +- {round(196 * e / size)} %"
            if several
            else f"at {round(100 * r)} % +- {round(196 * e)} %"
        )
        confidence = confidence_beyond((threshold - r) / e) if low else confidence_beyond((r - threshold) / e)
        findings.append(
            Finding(
                kind="cylinder",
                subject=named,
                severity=severity,
                summary=(
                    f"{named} {share} of {_reference(balance, c)} "
                    f"({what}; {balance.strength_meaning} from the crank-speed orders)"
                    + _either(balance, c, partners, None if several else together)
                ),
                confidence=confidence,
                evidence=[
                    {
                        "quantity": RELATIVE_STRENGTH,
                        "measured": max(r, 0.0) if several else r,
                        "standard_error": e,
                        "predicted": 1.0,
                        "threshold": threshold,
                        "unit": "-",
                        "contrast_standard_error": contrast,
                        "orders": balance.orders.tolist(),
                        "strength": float(balance.strength[list(balance.group(c))].mean()),
                        "group_relative": together,
                        "group_size": size,
                        "cylinder": c + 1,
                        "cylinder_name": balance.name(c),
                        "condition_number": balance.condition,
                    }
                ],
            )
        )
    return findings


def _lacks_most(test: MissingFiring) -> bool:
    """Whether the candidate's deficit is significant and most of the others' impulse."""
    c = test.candidate
    share = float(test.share[c])
    significant = float(test.deficit[c]) >= SIGNIFICANCE * float(test.deficit_error[c])
    return math.isfinite(share) and significant and share < CYLINDER_ALARM[0]


def missing_firing_doubt(balance: CylinderBalance) -> str | None:
    """Why a run without findings is not healthy: a deficit its pattern does not explain, if any.

    A cylinder whose deficit would be an alarm (:func:`missing_firing_findings`) but whose pattern
    explains less than :data:`PATTERN_EXPLAINED` of the orders where the cylinders cancel is
    neither named nor let pass: the orders carry a missing impulse and something else (a transfer
    that is not the engine's, a torsional resonance).

    Parameters
    ----------
    balance : CylinderBalance

    Returns
    -------
    str or None
        The reason, or None.
    """
    test = missing_firing(balance)
    if test is None or not _lacks_most(test):
        return None
    c = test.candidate
    if float(test.explained[c]) >= PATTERN_EXPLAINED:
        return None
    return (
        f"cylinder {balance.name(c)} reads {round(100 * float(test.share[c]))} % of the others' firing "
        f"impulse by its pattern, {float(test.significance[c]):.0f} standard errors, but the pattern "
        f"explains only {round(100 * float(test.explained[c]))} % of the orders where the cylinders cancel: "
        "a missing impulse and something else (near a torsional resonance try the shaft-line transfer)"
    )


def single_cylinder_findings(
    balance: CylinderBalance, load: float, calibrated: float | None
) -> list[Finding]:
    """A single cylinder has no others to be compared with: its strength against the baseline's (which
    calibrates the model's level on this engine; an error of at least :data:`BASELINE_UNCERTAINTY`, the
    stated loads), or without one against the model's at the stated load (at least
    :data:`ABSOLUTE_UNCERTAINTY`, the model and the stated load); a limit is crossed :data:`SINGLE_BEYOND`
    such errors beyond it (the floor is systematic: 4 of them from 100 % would decide before any limit).

    Parameters
    ----------
    balance : CylinderBalance
    load : float
        The load stated [-].
    calibrated : float or None
        The baseline's strength of the cylinder (its reference), or None without a baseline [-].

    Returns
    -------
    list of Finding
    """
    reference = calibrated if calibrated is not None and calibrated > MISFIRE_BELOW else 1.0
    s = float(balance.strength[0]) / reference
    floor = BASELINE_UNCERTAINTY if reference != 1.0 or calibrated is not None else ABSOLUTE_UNCERTAINTY
    e = max(float(balance.strength_error[0]) / reference, floor)
    against = "the baseline's" if calibrated is not None else f"the model's {balance.strength_meaning}"
    margin = SINGLE_BEYOND * e
    severity, threshold = "healthy", None
    if s < CYLINDER_WARNING[0] - margin:
        severity, threshold = "warning", CYLINDER_WARNING[0]
        if s < CYLINDER_ALARM[0] - margin:
            severity, threshold = "alarm", CYLINDER_ALARM[0]
    elif s > CYLINDER_ALARM[1] + margin:  # stronger than the model: only an alarm-sized excess is a finding
        severity, threshold = "warning", CYLINDER_ALARM[1]
    if threshold is None:
        return []
    low = s < 1.0
    what = (
        "misfiring"
        if s < MISFIRE_BELOW
        else ("weak, leaking or misfiring" if low else "stronger than the model")
    )
    return [
        Finding(
            kind="cylinder",
            subject="cylinder 1",
            severity=severity,
            summary=(
                f"cylinder 1 at {round(100 * s)} % +- {round(196 * e)} % of {against} at load {load:.2f} "
                f"({what}; from the crank-speed orders; a single cylinder is judged against "
                f"{'its baseline' if calibrated is not None else 'the model'}, not against others)"
            ),
            confidence=confidence_beyond((threshold - s) / e)
            if low
            else confidence_beyond((s - threshold) / e),
            evidence=[
                {
                    "quantity": "strength against the model",
                    "measured": s,
                    "standard_error": e,
                    "predicted": 1.0,
                    "threshold": threshold,
                    "unit": "-",
                    "orders": balance.orders.tolist(),
                    "load": load,
                }
            ],
        )
    ]


def sensor_finding(fault: SensorFault, recording: Recording) -> Finding:
    """A faulty sensor (clipped, dead, implausibly scaled): a warning, the channel left out.

    Parameters
    ----------
    fault : SensorFault
    recording : Recording
        The recording the channel is in (its location is named).

    Returns
    -------
    Finding
    """
    channel = recording.channel(fault.channel)
    where = channel.location or "location not given"
    return Finding(
        kind="sensor",
        subject=f"sensor {fault.channel}",
        severity="warning",
        summary=(
            f"sensor {fault.channel} ({where}): {fault.fault}: {fault.detail}; left out of the diagnosis "
            "(check the sensor, or leave it out with --exclude-channel)"
        ),
        confidence=1.0,
        evidence=[{"quantity": fault.fault, "channel": fault.channel, "detail": fault.detail}],
    )


def bearing_findings(
    results: list[BearingResult], *, with_baseline: bool, cylinders_changed: bool = False
) -> list[Finding]:
    """Bearing findings from each sensor's orders and impacts, its own bearing's evidence first.

    Parameters
    ----------
    results : list of BearingResult
    with_baseline : bool
        Whether the impacts were scored against a baseline (else the recording's own median: a
        warning at most, at :data:`IMPACT_WITHOUT_BASELINE`).
    cylinders_changed : bool, optional
        Whether a cylinder is a finding (a knock must then reach
        :data:`IMPACT_WITH_CYLINDER_FINDING`).

    Returns
    -------
    list of Finding
        One per bearing, the most severe.
    """
    by_subject: dict[str, Finding] = {}
    sensed = {result.bearing for result in results}
    for result in results:
        for finding in (
            _order_finding(result),
            _impact_finding(result, sensed, with_baseline=with_baseline, cylinders_changed=cylinders_changed),
        ):
            if finding is not None:
                _add(by_subject, finding)
    return list(by_subject.values())


def _add(by_subject: dict[str, Finding], finding: Finding) -> None:
    """Keep one finding per subject: the most severe, with the highest confidence and all the evidence."""
    old = by_subject.get(finding.subject)
    if old is None:
        by_subject[finding.subject] = finding
        return
    keep = finding if SEVERITIES.index(finding.severity) > SEVERITIES.index(old.severity) else old
    by_subject[finding.subject] = Finding(
        keep.kind,
        keep.subject,
        keep.severity,
        keep.summary,
        max(old.confidence, finding.confidence),
        old.evidence + finding.evidence,
    )


def _order_finding(result: BearingResult) -> Finding | None:
    """A bearing finding from the sensor's orders that deviate from the calibrated model, if any."""
    dev = result.orders
    if dev is None or not dev.orders.size:
        return None
    error = np.maximum(dev.deviation_error, 1e-12)
    beyond = (dev.deviation >= BEARING_WARNING) & (dev.deviation >= SIGNIFICANCE * error)
    if not beyond.any():
        return None
    worst = int(np.argmax(np.where(beyond, dev.deviation, -1)))
    d = float(dev.deviation[worst])
    severity = "alarm" if d >= BEARING_ALARM else "warning"
    threshold = BEARING_ALARM if severity == "alarm" else BEARING_WARNING
    orders = ", ".join(f"{k:g}" for k in dev.orders[beyond])
    return Finding(
        kind="main bearing",
        subject=f"main bearing {result.bearing}",
        severity=severity,
        summary=(
            f"main bearing {result.bearing}: orders {orders} of {result.channel} deviate "
            f"from the calibrated model, up to {100 * d:.0f} % (order {dev.orders[worst]:g})"
        ),
        confidence=confidence_beyond((d - threshold) / float(error[worst])),
        evidence=[
            {
                "quantity": "order deviation",
                "channel": result.channel,
                "order": float(k),
                "measured": abs(complex(m)),
                "predicted": abs(complex(p)),
                "deviation": float(v),
                "standard_error": float(s),
                "threshold": BEARING_WARNING,
                "unit": "-",
            }
            for k, m, p, v, s in zip(
                dev.orders[beyond],
                dev.measured[beyond],
                dev.predicted[beyond],
                dev.deviation[beyond],
                error[beyond],
                strict=True,
            )
        ],
    )


def _heard(score: ImpactScore, *, with_baseline: bool, cylinders_changed: bool) -> bool:
    """Whether a knock span stands out enough, significantly, and loudest on its own bearing."""
    least = IMPACT_WARNING if with_baseline else IMPACT_WITHOUT_BASELINE
    if cylinders_changed:  # a cylinder that fires unlike before moves the engine's own noise
        least = max(least, IMPACT_WITH_CYLINDER_FINDING)
    excess = score.score - 1.0
    localised = all(
        math.isnan(x) or excess >= LOCALISED * max(x - 1.0, 0.0) for x in (score.elsewhere, score.away)
    )
    return (
        score.score >= least
        and score.significance >= max(SIGNIFICANCE, score.significance_needed)
        and localised
    )


def _impact_finding(
    result: BearingResult, sensed: set[int], *, with_baseline: bool, cylinders_changed: bool
) -> Finding | None:
    """A bearing finding from the impacts the sensor hears, its own bearing's first, if any."""
    if not result.impacts:
        return None
    own = next(s for s in result.impacts if s.bearing == result.bearing)

    def heard(score: ImpactScore) -> bool:
        return _heard(score, with_baseline=with_baseline, cylinders_changed=cylinders_changed)

    # a bearing is named from its own sensor's evidence first; a neighbour only where no sensor sits on
    # it (one that does speaks for it) and this sensor clearly hears it louder than its own bearing
    best = own
    if not heard(own):
        others = [
            s
            for s in result.impacts
            if s.bearing != result.bearing and s.bearing not in sensed and s.score >= 1.5 * own.score
        ]
        best = max(others, key=lambda s: s.score) if others else own
    if best is own and not with_baseline and math.isnan(own.elsewhere):
        return None  # against its own median only, a knock must be shown to be this sensor's alone
    if not heard(best):
        return None
    e = max(best.score_error, 1e-12)
    severity = "alarm" if with_baseline and best.score >= IMPACT_ALARM else "warning"
    threshold = (
        (IMPACT_ALARM if severity == "alarm" else IMPACT_WARNING)
        if with_baseline
        else IMPACT_WITHOUT_BASELINE
    )
    return Finding(
        kind="main bearing",
        subject=f"main bearing {best.bearing}",
        severity=severity,
        summary=(
            f"main bearing {best.bearing}: impacts where its load reverses, {best.score:.1f} x "
            f"the {best.reference}'s high-frequency power at {best.angle_deg:.0f} deg "
            f"({result.channel}; clearance or wear)"
        ),
        confidence=confidence_beyond((best.score - threshold) / e),
        evidence=[
            {
                "quantity": "impact power in load-reversal windows",
                "channel": result.channel,
                "measured": best.score,
                "standard_error": best.score_error,
                "predicted": 1.0,
                "threshold": threshold,
                "unit": f"x {best.reference}",
                "reversal_angles_deg": best.reversal_angles_deg,
                "angle_deg": best.angle_deg,
                "significance": best.significance,
                "significance_needed": best.significance_needed,
            }
        ],
    )
