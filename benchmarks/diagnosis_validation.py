"""The diagnosis on engines it was not built with; writes docs/diagnosis-validation.md.

Every case comes from the validation simulator (:mod:`validation.simulator`), written apart from the
product's scenes and physics: its own gas model, structure, sensors and noise, random engines of 1 to
12 cylinders, two- and four-stroke, and engine files that differ from the simulated engine as real
ones do. For each case the product is given what a user has: the engine file, a healthy recording
of the same engine to calibrate on (the case's healthy twin), the recording, and a load that is
off by up to 10 %. Its verdict is compared with what the simulator put in.

    python -m benchmarks.diagnosis_validation [--cases 540] [--off-point-cases 540] [--vee-cases 0]
        [--vee-off-point-cases 0]

Cases off the baseline's operating point (another load or speed, a load step mid-recording, crank
speed alone) are diagnosed told their load and not told it: benchmarks/diagnosis_operating.py. V
engines' cases (12-20 cylinders, named by bank) have rows of their own: benchmarks/diagnosis_vee.py.

Every number in the document comes from the run that wrote it; each case's row is written beside it
as JSON (docs/diagnosis-validation.json, not kept in the repository).
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
import traceback
from collections import Counter, defaultdict
from collections.abc import Callable
from concurrent.futures import ProcessPoolExecutor, as_completed
from dataclasses import asdict, dataclass, replace
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

import numpy as np

from benchmarks.diagnosed import case_engine, diagnose_as_compare
from benchmarks.diagnosis_operating import impact_limit_table, knock_table, operating_part, put_in
from benchmarks.diagnosis_vee import (
    VEE_FIRST_SEED,
    VEE_OFF_POINT_FIRST_SEED,
    vee_length,
    vee_off_point_section,
    vee_section,
)
from benchmarks.judging import CLASSES, RULES, TRUE_CLASS, classify, named, rule_of, subjects, vibrating
from monitor.diagnosis import Baseline, calibrate
from monitor.diagnosis.findings import MISFIRE_BELOW
from monitor.diagnosis.operating_points import OperatingPoints
from monitor.errors import MonitorError
from monitor.model.engine import Engine
from validation.simulator import Case, healthy_twin, law_loads, random_case
from validation.simulator.operating import OPERATING_CLASSES

DOCS = Path(__file__).resolve().parents[1] / "docs"
DURATIONS = (10.0, 30.0, 60.0)
# off the baseline's point: shorter recordings (the weak row needs 30 s, no row 60 s), a seed range of
# their own (dated, like the first, by their seed modulo 100,000 minutes after 2026-01-01)
OFF_POINT_DURATIONS = (10.0, 30.0)
OFF_POINT_FIRST_SEED = 200_000
EXIT = {"healthy": 0, "warning": 1, "alarm": 2, "inconclusive": 3}
# a healthy twin at an end of the engine's law this close to the baseline's load is the same point [-]
SAME_POINT = 0.05
# the highest load the product's model takes (fraction of rated IMEP), an engine's overload rating [-]
OVERLOAD = 1.1


def case_length(index: int) -> float:
    """The recording's length [s] of the run's ``index``-th case (its seed less ``--first-seed``)."""
    return DURATIONS[index % len(DURATIONS)]


def off_point_length(index: int) -> float:
    """The recording's length [s] of the ``index``-th case off the baseline's point."""
    return OFF_POINT_DURATIONS[index % len(OFF_POINT_DURATIONS)]


@dataclass(frozen=True)
class Outcome:
    """One case: what was put in and what the product said."""

    seed: int
    duration_s: float
    cylinders: int
    cycle: str
    speed_rpm: float
    truth: str
    subject: str  # the true cylinder, bearing or sensor channel ("" for a healthy run)
    strength: float  # a weak cylinder's heat release over a healthy one's (NaN otherwise)
    status: str  # healthy, warning, alarm, inconclusive, or error
    exit_code: int
    predicted: str  # the top finding's class, or healthy / inconclusive / error
    named: bool  # the fault was named on the right subject (for a healthy run: no finding at all)
    alarm: bool  # any alarm
    findings: str  # the findings' subjects and severities, for the record
    seconds: float
    error: str = ""
    rules: str = ""  # each finding as rule|subject|severity, "; "-separated (:func:`rule_of`)
    share: float = math.nan  # a misfiring or weak cylinder's strength over the others', as read [-]
    inconclusive: str = ""  # why a run without findings was not called healthy
    operating: str = "baseline point"  # the operating-point class (validation.simulator.OPERATING_CLASSES)
    load_told: bool = True  # whether the product was told the load
    failed_at: str = ""  # an error's stage: simulator, calibration or diagnosis
    true_load: float = math.nan  # mean IMEP over rated, as run [-]
    load_type: str = ""  # propeller or generator
    charge_law: str = ""  # the simulator's charge pressure against load
    points: int = 1  # the baseline's calibrated points (3: across the engine's law, law_baseline)
    vee: bool = False  # a V engine's case (benchmarks.diagnosis_vee)
    rods: str = ""  # a V engine's rods: side-by-side, fork-and-blade or articulated
    knocks: int = 0  # a worn bearing's knocks in the recording (the simulator's burst_count) [-]
    knock_size: float = math.nan  # their size over the noise of the sensor on the bearing [-]
    # the bearings' impact scores of the whole recording (segments aside), for studying their rule: the
    # true bearing's most significant over its sensors, and the most significant of any other bearing,
    # each as (score, significance, significance needed, elsewhere) (:class:`ImpactScore`; NaN: none)
    impact_true: tuple[float, float, float, float] = (math.nan,) * 4
    impact_other: tuple[float, float, float, float] = (math.nan,) * 4


def _false(o: Outcome, rule: str, subject: str) -> bool:
    """Whether a finding of ``rule`` on ``subject`` names something the simulator did not put in."""
    return o.truth not in TRUE_CLASS[rule] or o.subject not in subjects(subject)


def _said(error: Exception) -> str:
    """The error's first line; for one the product does not raise on purpose, where it came from."""
    said = f"{type(error).__name__}: {error}".splitlines()[0][:300]
    if not isinstance(error, MonitorError):
        said += " at " + traceback.format_exc(limit=-1).strip().splitlines()[-3].strip()[:150]
    return said


def run_case(seed: int, duration_s: float) -> Outcome:
    """Simulate one case at its baseline's point and its healthy twin, calibrate on the twin and diagnose
    the case, told its load (as the at-point population always was)."""
    return run_ways(seed, duration_s, "baseline point", (True,))[0]


def run_ways(
    seed: int,
    duration_s: float,
    operating: str,
    ways: tuple[bool, ...],
    *,
    across_law: bool = False,
    vee: bool = False,
) -> list[Outcome]:
    """Simulate one case and its healthy twin, calibrate on the twin and diagnose the case each way.

    ``operating`` as :func:`~validation.simulator.random_case` takes it; ``ways`` whether the product
    is told the load (the true load off by up to 10 %), once per way. With ``across_law`` a case off
    its baseline's point is diagnosed each way again against a baseline of three points: the twin and
    two more healthy twins at the lowest and the highest load of the engine's law
    (:func:`law_baseline`). ``vee`` simulates the seed's V engine. A case the simulator cannot make
    is an outcome of status "error" failed at "simulator"; one the product cannot calibrate on or
    diagnose fails at "calibration" or "diagnosis".
    """
    start = time.perf_counter()
    plan = [(told, 1) for told in ways]
    if across_law and operating != "baseline point":
        plan += [(told, 3) for told in ways]
    try:
        case = random_case(seed, duration_s=duration_s, operating=operating, vee=vee)
        twin = healthy_twin(case, seed=seed + 1_000_000)
    except Exception as error:  # the simulator's failure, not the product's: counted apart
        spent = time.perf_counter() - start
        failed = Outcome(
            seed, duration_s, 0, "", math.nan, "", "", math.nan, "error", 3, "error", False, False, "", spent
        )
        failed = replace(failed, error=_said(error), failed_at="simulator", operating=operating, vee=vee)
        return [replace(failed, load_told=told, points=points) for told, points in plan]
    truth = vibrating(case.truth)
    # the true cylinder, bearing or channel, as the findings name it
    subject = str(
        {
            "misfire": truth.get("cylinder"),
            "weak": truth.get("cylinder"),
            "worn_bearing": truth.get("bearing"),
        }.get(truth["class"], truth.get("channel"))
        or ""
    )
    # a weak cylinder's heat release as a share of the healthy one's (the simulator's "weak_factor")
    strength = float(truth["weak_factor"]) if truth["class"] == "weak" else math.nan

    def about(outcome: Outcome, told: bool, points: int) -> Outcome:
        """The outcome with where the case ran, whether the product was told its load, and against how
        many calibrated points."""
        return replace(
            outcome,
            load_told=told,
            points=points,
            operating=str(truth["operating_class"]),
            true_load=float(truth["true_load"]),
            load_type=str(truth["load_type"]),
            charge_law=str(truth["charge_law"]),
            vee=vee,
            rods=str(truth.get("rods", "")),
            knocks=int(truth.get("burst_count") or 0),
            knock_size=float(truth["strength"]) if truth["class"] == "worn_bearing" else math.nan,
        )

    cylinders = 0
    stage = "calibration"
    outcomes: list[Outcome] = []
    try:
        engine = case_engine(case.engine_toml)
        cylinders = engine.cylinders
        baselines = {1: OperatingPoints.of([calibrate(twin.recording, engine, load=twin.load_given)])}
        for told, points in plan:
            if points not in baselines:
                stage = "calibration"
                baselines[points] = law_baseline(case, engine, baselines[1].points[0], seed)
            stage = "diagnosis"
            diagnosis = diagnose_as_compare(
                case.recording, engine, baselines[points], case.load_given if told else None, truth
            )
            said = _outcome(seed, duration_s, engine, truth, subject, strength, diagnosis)
            # each way's time: the first's the simulation and calibration too
            outcomes.append(about(replace(said, seconds=time.perf_counter() - start), told, points))
            start = time.perf_counter()
    except Exception as error:  # a case the product cannot diagnose is recorded, not fatal
        failed = Outcome(
            seed,
            duration_s,
            int(cylinders or 0),
            str(truth.get("cycle", "")),
            float(truth.get("speed_rpm", math.nan)),
            truth["class"],
            subject,
            strength,
            "error",
            3,
            "error",
            False,
            False,
            "",
            time.perf_counter() - start,
            _said(error),
            failed_at=stage,
        )
        outcomes += [about(failed, told, points) for told, points in plan[len(outcomes) :]]
    return outcomes


def law_baseline(case: Case, engine: Engine, baseline: Baseline, seed: int) -> OperatingPoints:
    """The baseline a fleet calibrates across the engine's range: the twin's point, and healthy twins at
    the lowest and the highest load of the engine's law (propeller curve or generator), each calibrated
    told its load as the twin is; an end within :data:`SAME_POINT` of the twin's load is left out."""
    points = [baseline]
    for k, load in enumerate(law_loads(case), start=2):
        if abs(load - baseline.load) < SAME_POINT:
            continue
        end = healthy_twin(case, seed=seed + k * 1_000_000, load=load)
        # an operator reads the load from the engine's log, which shows no more than its overload rating
        points.append(calibrate(end.recording, engine, load=min(end.load_given, OVERLOAD)))
    return OperatingPoints.of(points)


def _outcome(
    seed: int,
    duration_s: float,
    engine: Any,
    truth: dict[str, Any],
    subject: str,
    strength: float,
    diagnosis: Any,
) -> Outcome:
    """What the product said of one case, against what the simulator put in (its time left 0)."""
    findings = [(*classify(f), f.severity) for f in diagnosis.findings]
    rules = "; ".join(
        f"{rule_of(f, engine.cylinders)}|{s}|{f.severity}"
        for f, (_, s, _) in zip(diagnosis.findings, findings, strict=True)
    )
    why = [n.removeprefix("inconclusive: ") for n in diagnosis.notes if n.startswith("inconclusive: ")]
    share = math.nan
    if truth["class"] in ("misfire", "weak") and diagnosis.balance is not None:
        share = float(diagnosis.balance.relative[int(truth.get("cylinder_index", truth["cylinder"])) - 1])
    top = findings[0][0] if findings else diagnosis.status
    return Outcome(
        seed,
        duration_s,
        engine.cylinders,
        engine.cycle,
        float(np.round(diagnosis.speed_rpm, 1)),
        truth["class"],
        subject,
        strength,
        diagnosis.status,
        EXIT[diagnosis.status],
        top,
        named(truth, findings),
        any(f.severity == "alarm" for f in diagnosis.findings),
        "; ".join(f"{c} {s} ({v})" for c, s, v in findings),
        0.0,
        rules=rules,
        inconclusive="; ".join(why),
        share=share,
        impact_true=_most_significant(diagnosis, lambda b: str(b) == subject),
        impact_other=_most_significant(diagnosis, lambda b: str(b) != subject),
    )


def _most_significant(diagnosis: Any, which: Callable[[int], bool]) -> tuple[float, float, float, float]:
    """The most significant impact score over every sensor of the bearings ``which`` takes, as
    (score, significance, significance needed, elsewhere); NaN where there is none."""
    scores = [i for b in diagnosis.bearings for i in b.impacts if which(i.bearing)]
    if not scores:
        return (math.nan,) * 4
    best = max(scores, key=lambda i: i.significance)
    return (best.score, best.significance, best.significance_needed, best.elsewhere)


def _shares(outcomes: list[Outcome]) -> str:
    """What a misfiring and a weak cylinder read (their share of the others), 2 or more cylinders."""

    def span(group: list[float]) -> str:
        return f"{min(group):.2f} to {max(group):.2f} ({len(group)} cases)" if group else "none"

    read = [o for o in outcomes if o.cylinders > 1 and math.isfinite(o.share)]
    misfire = [o.share for o in read if o.truth == "misfire"]
    weak = [o.share for o in read if o.truth == "weak"]
    return (
        "The faulty cylinder's share of the others as read (2 or more cylinders): misfiring "
        f"{span(misfire)}; weak, heat release 50 to 80 % of a healthy one's, {span(weak)}. A share below "
        f"{MISFIRE_BELOW:g} is called misfiring (`MISFIRE_BELOW`)."
    )


def _zone_sentence(everything: list[Outcome]) -> str:
    """How many healthy cases vibrate in zone C or D by the simulator's own measure, and which."""
    zoned = sorted({(o.seed, o.duration_s, o.operating) for o in everything if o.truth == "vibration_zone"})
    listed = ", ".join(f"{seed} ({length:g} s, {where})" for seed, length, where in zoned) or "none"
    return (
        "A healthy case whose simulated structure itself vibrates in zone C or D of the product's default "
        "limits (the simulator's own rms velocity over 2-1000 Hz, before noise: `velocity_mm_s` in its "
        "truth) is of class `vibration_zone`, named when a zone finding names its loudest channel, and is "
        f"left out of the healthy rows: {len(zoned)} such case(s) in this run, {listed}."
    )


def _rate(hits: int, total: int) -> str:
    return f"{hits}/{total} ({100 * hits / total:.1f} %)" if total else "-"


def _named_rate(group: list[Outcome]) -> str:
    return _rate(sum(o.named for o in group), len(group))


def _short_reason(reason: str) -> str:
    """An inconclusive run's reason, without its numbers."""
    for key, short in (
        ("not steady", "the speed not steady"),
        ("do not resolve", "the cylinders not resolved (model misfit, or orders that do not separate them)"),
        ("uncertain by", "the cylinders' differences too uncertain"),
        ("not compared", "the cylinders not compared"),
        ("not judged", "the cylinder not judged"),
    ):
        if key in reason:
            return short
    return reason


def rule_table(outcomes: list[Outcome]) -> list[str]:
    """Each rule's false findings over every case, and why healthy runs were inconclusive (Markdown)."""
    done = [o for o in outcomes if o.status != "error"]
    lines = [
        f"False findings per rule over the {len(done)} cases diagnosed: a finding that names a fault "
        "the simulator did not put in, or puts it on the wrong subject (a healthy run's every finding; a "
        "misfire run's bearing finding; a worn bearing named on its neighbour).",
        "",
        "| rule | cases with a false warning or alarm | of them an alarm | rate |",
        "|---|---|---|---|",
    ]
    for rule in RULES:
        false = alarms = 0
        for o in done:
            hits = [part.split("|") for part in o.rules.split("; ") if part.startswith(rule + "|")]
            wrong = [h for h in hits if _false(o, rule, h[1])]
            false += bool(wrong)
            alarms += any(h[2] == "alarm" for h in wrong)
        lines.append(f"| {rule} | {false} | {alarms} | {100 * false / max(len(done), 1):.1f} % |")
    healthy = [o for o in done if o.truth == "healthy"]
    reasons = Counter(
        _short_reason(r) for o in healthy if o.status == "inconclusive" for r in o.inconclusive.split("; ")
    )
    lines += [
        "",
        f"Healthy runs not called healthy for want of evidence (inconclusive), of {len(healthy)}:",
        "",
        "| reason | runs |",
        "|---|---|",
    ]
    lines += [f"| {reason} | {count} |" for reason, count in reasons.most_common()] or ["| none | 0 |"]
    return lines


RULES_BEGIN = "<!-- false-alarm table: written by make bench-diagnosis -->"
RULES_END = "<!-- end of false-alarm table -->"


def update_rules_doc(path: Path, outcomes: list[Outcome], *, when: str) -> None:
    """Replace the marked block of ``path`` (docs/diagnosis.md) with this run's rule table."""
    text = path.read_text()
    if RULES_BEGIN not in text or RULES_END not in text:
        raise SystemExit(
            f"{path}: no block between {RULES_BEGIN!r} and {RULES_END!r} to write the table into"
        )
    head, rest = text.split(RULES_BEGIN, 1)
    _, tail = rest.split(RULES_END, 1)
    block = [
        RULES_BEGIN,
        "",
        f"Measured by `make bench-diagnosis` on {when}:",
        "",
        *rule_table(outcomes),
        "",
        RULES_END,
    ]
    path.write_text(head + "\n".join(block) + tail)


def at_point(everything: list[Outcome]) -> list[Outcome]:
    """The cases at their baseline's point, told the load, that the simulator made: the population the
    tables before the operating-point classes were measured on."""
    return [
        o
        for o in everything
        if o.operating == "baseline point" and o.load_told and o.failed_at != "simulator" and not o.vee
    ]


def report(everything: list[Outcome], *, cases: int, off_point: int, seconds: float, workers: int) -> str:
    """The Markdown document: the at-point population's tables as they always were, then one per
    operating-point class with and without the load."""
    outcomes = at_point(everything)
    by = defaultdict(list)
    for o in outcomes:
        by[(o.truth, o.duration_s)].append(o)
    vee = sum(1 for o in everything if o.vee and o.operating == "baseline point")
    vee_off = len({o.seed for o in everything if o.vee and o.operating != "baseline point"})
    lines = [
        "# Diagnosis validation on engines it was not built with",
        "",
        "Written by `make bench-diagnosis` (`python -m benchmarks.diagnosis_validation --cases "
        f"{cases} --off-point-cases {off_point}"
        + (f" --vee-cases {vee}" if vee else "")
        + (f" --vee-off-point-cases {vee_off}" if vee_off else "")
        + f"`) on {datetime.now(UTC):%Y-%m-%d}: {cases} cases at their baseline's operating point and "
        f"{off_point} off it"
        + (f", {vee} V engines' cases at theirs" if vee else "")
        + (f" and {vee_off} off it" if vee_off else "")
        + f", in {seconds / 60:.1f} min on {workers} worker(s). Every number below comes from that run.",
        "",
        "Each case is simulated by `validation.simulator`, written apart from the product's scenes and "
        "physics (its own gas model, structure, sensors and noise): a random engine of 1 to 12 "
        "cylinders, two- or four-stroke, 60 to 1500 rpm; the engine file given to the product differs "
        "from the simulated engine (geometry +-2 %, masses and inertias +-10 %, combustion timing "
        "+-3 deg, compression ratio +-3 %) and so does the stated load (+-10 %). The product "
        "calibrates on a healthy recording of the same engine (another seed) and diagnoses the case.",
        "",
        "The decision rules' limits are tested apart from this population, one rule at a time and by "
        "mutation (`make mutation`): docs/mutation-testing.md.",
        "",
        "## Acceptance at the baseline's operating point",
        "",
        "The cases below run where their baseline was calibrated (the same load and speed), and the "
        "product is told their load; the cases off that point are in the last section.",
        "",
    ]

    def pick(truth: str, least: float = 0.0, weak_below: float | None = None) -> list[Outcome]:
        chosen = [o for o in outcomes if o.truth == truth and o.duration_s >= least]
        if weak_below is not None:
            chosen = [o for o in chosen if o.strength <= weak_below]
        return chosen

    misfires = pick("misfire")
    weak_all = pick("weak", 30.0, 0.70)
    # a single cylinder has no others to be compared with, and the load the product is told is the
    # simulator's delivered one (mean IMEP over rated): its weakness is that load, not a shortfall
    weak = [o for o in weak_all if o.cylinders > 1]
    alone = [o for o in weak_all if o.cylinders == 1]
    worn = pick("worn_bearing")
    healthy = pick("healthy")
    lines += [
        "| what | required | measured |",
        "|---|---|---|",
        f"| misfire named (right cylinder) | 100 % | {_named_rate(misfires)} |",
        f"| weak cylinder at or below 70 % named, 30 s or longer, 2 or more cylinders | at least 95 % | "
        f"{_named_rate(weak)} |",
        f"| worn bearing named at the right bearing | at least 95 % | {_named_rate(worn)} |",
        f"| healthy runs exit 0 | at least 98 % | "
        f"{_rate(sum(o.exit_code == 0 for o in healthy), len(healthy))} |",
        f"| alarms on healthy runs | none | {sum(o.alarm for o in healthy)} |",
        "",
        f"Not in the weak row: {len(alone)} single-cylinder engines with a weak cylinder, of which "
        f"{sum(o.named for o in alone)} named. The load the product is told is the one the engine "
        "delivered (the simulator's mean IMEP over the rated, +-10 %), and a single cylinder has no "
        "others to be compared with: at that load its torque is what the model expects, so its weakness "
        "cannot be seen in the crank speed (a generator's governor even restores its IMEP with more "
        "fuel). docs/diagnosis.md says what a single cylinder is judged against.",
        "",
        _shares(outcomes),
        "",
        "## Per class and length",
        "",
        "`named`: the fault found on the right subject (a healthy run: no finding at all). A finding on "
        "cylinders the crank speed cannot tell apart (that fire too nearly together, or a four-stroke's "
        "360 deg partners where the cycle phase is unknown) names each of them and names the truth if it "
        f"is one of them: {sum(o.named and ' or ' in o.findings for o in everything)} named case(s) of "
        "this run, every section, had such a finding. Exit codes as `compare` gives them: 0 healthy, "
        "1 warning, 2 alarm, 3 inconclusive or not diagnosed.",
        "",
        _zone_sentence(everything),
        "",
        "| true class | length [s] | cases | named | exit 0 | exit 1 | exit 2 | exit 3 |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for truth in CLASSES:
        for duration in sorted({o.duration_s for o in outcomes}):
            group = by.get((truth, duration), [])
            if not group:
                continue
            exits = Counter(o.exit_code for o in group)
            lines.append(
                f"| {truth} | {duration:g} | {len(group)} | {_named_rate(group)} | "
                + " | ".join(str(exits.get(code, 0)) for code in range(4))
                + " |"
            )
    lines += ["", "## False findings per rule", "", *rule_table(outcomes)]
    lines += _confusion(outcomes)
    failures = [o for o in outcomes if not o.named]
    lines += [
        "",
        f"## Cases not named ({len(failures)})",
        "",
        "Seed and length reproduce a case: `validation.simulator.random_case(seed, duration_s=...)`.",
        "",
        "| seed | length [s] | engine | true | subject | status | findings / error |",
        "|---|---|---|---|---|---|---|",
    ]
    for o in sorted(failures, key=lambda o: (o.truth, o.seed))[:200]:
        said = o.error or o.findings or "-"
        lines.append(
            f"| {o.seed} | {o.duration_s:g} | {o.cylinders} cyl {o.cycle}, {o.speed_rpm:g} rpm | "
            f"{put_in(o)} | {o.subject} | {o.status} | {said.replace('|', '/')} |"
        )
    lines += ["", *knock_table(everything), "", *impact_limit_table(everything), ""]
    lines += operating_part([o for o in everything if not o.vee], OPERATING_CLASSES)
    lines += [*vee_section(everything), *vee_off_point_section(everything, OPERATING_CLASSES)]
    return "\n".join(lines)


def _confusion(outcomes: list[Outcome]) -> list[str]:
    """The confusion matrix of the true classes against the first finding's (Markdown lines)."""
    predicted_classes = sorted({o.predicted for o in outcomes}, key=lambda c: (c not in CLASSES, c))
    lines = [
        "",
        "## Confusion matrix",
        "",
        "Rows: what the simulator put in; columns: the class of the product's first finding (alarms "
        "first, then by confidence), or its status when it found nothing.",
        "",
        "| true \\ said | " + " | ".join(predicted_classes) + " |",
        "|---|" + "---|" * len(predicted_classes),
    ]
    for truth in CLASSES:
        row = Counter(o.predicted for o in outcomes if o.truth == truth)
        if row:
            lines.append(f"| {truth} | " + " | ".join(str(row.get(c, 0)) for c in predicted_classes) + " |")
    return lines


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cases", type=int, default=540, help="cases, spread over the lengths (default 540)")
    parser.add_argument("--workers", type=int, default=2, help="processes (default 2)")
    parser.add_argument("--first-seed", type=int, default=0)
    parser.add_argument(
        "--off-point-cases",
        type=int,
        default=540,
        help="cases off the baseline's operating point, each class equally likely (default 540)",
    )
    parser.add_argument("--off-point-first-seed", type=int, default=OFF_POINT_FIRST_SEED)
    parser.add_argument(
        "--vee-cases", type=int, default=0, help="V engines' cases at their point (default 0)"
    )
    parser.add_argument("--vee-first-seed", type=int, default=VEE_FIRST_SEED)
    parser.add_argument(
        "--vee-off-point-cases",
        type=int,
        default=0,
        help="V engines' cases off their baseline's point (default 0)",
    )
    parser.add_argument("--vee-off-point-first-seed", type=int, default=VEE_OFF_POINT_FIRST_SEED)
    parser.add_argument("--out", type=Path, default=DOCS / "diagnosis-validation.md")
    parser.add_argument(
        "--rules-doc",
        type=Path,
        default=None,
        help="a document whose marked false-alarm block gets this run's table (default: docs/diagnosis.md "
        "when --out is the default)",
    )
    args = parser.parse_args(argv)
    if args.rules_doc is None and args.out == DOCS / "diagnosis-validation.md":
        args.rules_doc = DOCS / "diagnosis.md"
    ways = (True, False)
    jobs = [(args.first_seed + i, case_length(i), "baseline point", False) for i in range(args.cases)]
    jobs += [
        (args.off_point_first_seed + i, off_point_length(i), "random", False)
        for i in range(args.off_point_cases)
    ]
    jobs += [(args.vee_first_seed + i, vee_length(i), "baseline point", True) for i in range(args.vee_cases)]
    jobs += [
        (args.vee_off_point_first_seed + i, off_point_length(i), "random", True)
        for i in range(args.vee_off_point_cases)
    ]
    outcomes: list[Outcome] = []
    start = time.perf_counter()
    with ProcessPoolExecutor(max_workers=args.workers) as pool:
        futures = [
            pool.submit(
                run_ways,
                seed,
                duration,
                operating,
                ways[: 1 if vee and operating == "baseline point" else 2],
                across_law=True,
                vee=vee,
            )
            for seed, duration, operating, vee in jobs
        ]
        for done, future in enumerate(as_completed(futures), start=1):
            outcomes += future.result()
            elapsed = time.perf_counter() - start
            print(
                f"\r{done}/{len(jobs)} cases, {elapsed / 60:.1f} min, about "
                f"{elapsed / done * (len(jobs) - done) / 60:.1f} min left",
                end="",
                file=sys.stderr,
                flush=True,
            )
    print(file=sys.stderr)
    outcomes.sort(key=lambda o: (o.seed, o.points, not o.load_told))
    seconds = time.perf_counter() - start
    args.out.write_text(
        report(
            outcomes,
            cases=args.cases,
            off_point=args.off_point_cases,
            seconds=seconds,
            workers=args.workers,
        )
    )
    if args.rules_doc is not None:
        at = at_point(outcomes)
        update_rules_doc(args.rules_doc, at, when=f"{datetime.now(UTC):%Y-%m-%d}, {len(at)} cases")
    rows = args.out.with_suffix(".json")

    rows.write_text(json.dumps([asdict(o) for o in outcomes], indent=0, default=str))
    print(
        f"{len(jobs)} cases ({len(outcomes)} diagnoses) in {seconds / 60:.1f} min; written to {args.out} "
        f"and {rows}",
        file=sys.stderr,
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
