"""The acceptance of docs/diagnosis-validation.md per operating-point class, with and without the load.

A case off its baseline's point (:mod:`validation.simulator.operating`) is diagnosed twice against
the same baseline: told its load (the true one off by up to 10 %) and not told it (the product
then takes the baseline's); and, where the run asks for it, twice more against a baseline of three
points across the engine's law (not told, the product estimates the load). Each class's table holds
the acceptance rows, each way, with whether each meets its limit; cases the simulator could not
make, and cases the product refused to calibrate on, are counted in rows of their own and left out
of the rates.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Protocol

from monitor.diagnosis.findings import IMPACT_WARNING, LOCALISED, SIGNIFICANCE

#: The weakest cylinder of the "weak at 80 %" row: heat release over a healthy one's above this [-]
#: (the off-point population draws 0.8 exactly; the at-point one 0.5-0.8 uniformly).
WEAK_80_ABOVE = 0.75
#: A misfire at or above this load must never be called healthy [-].
MISFIRE_LOAD = 0.25
#: The edges of the worn bearings' classes by the knocks their recordings hold [-]: fewer than a
#: steady segment's cycles (monitor.signal.steady.MIN_CYCLES, 20), and 50 or more (a minute of a
#: two-stroke at 50 rpm).
KNOCK_BINS = (20, 50)


class Case(Protocol):
    """What a row reads of a case's outcome (benchmarks.diagnosis_validation.Outcome)."""

    duration_s: float
    cylinders: int
    truth: str
    strength: float
    exit_code: int
    named: bool
    alarm: bool
    operating: str
    load_told: bool
    points: int
    failed_at: str
    true_load: float


@dataclass(frozen=True)
class Row:
    """An acceptance row: which cases, what counts, and the limit.

    ``kind`` "rate": hits over cases at least ``limit``; "none": no case may count.
    """

    what: str
    required: str
    pick: Callable[[Case], bool]
    hit: Callable[[Case], bool]
    kind: str
    limit: float = 0.0


ROWS = (
    Row(
        f"misfire at {100 * MISFIRE_LOAD:g} % load or more called healthy (exit 0)",
        "none",
        lambda o: o.truth == "misfire" and o.true_load >= MISFIRE_LOAD,
        lambda o: o.exit_code == 0,
        "none",
    ),
    Row(
        "misfire named at the right cylinder",
        "at least 99 %",
        lambda o: o.truth == "misfire",
        lambda o: o.named,
        "rate",
        0.99,
    ),
    Row(
        "weak cylinder at or below 70 % named, 30 s or longer, 2 or more cylinders",
        "at least 95 %",
        lambda o: o.truth == "weak" and o.duration_s >= 30 and o.strength <= 0.70 and o.cylinders > 1,
        lambda o: o.named,
        "rate",
        0.95,
    ),
    Row(
        f"weak cylinder at 80 % named (above {100 * WEAK_80_ABOVE:g} %), 2 or more cylinders",
        "at least 80 %",
        lambda o: o.truth == "weak" and o.strength > WEAK_80_ABOVE and o.cylinders > 1,
        lambda o: o.named,
        "rate",
        0.80,
    ),
    Row(
        "worn bearing named at the right bearing",
        "at least 95 %",
        lambda o: o.truth == "worn_bearing",
        lambda o: o.named,
        "rate",
        0.95,
    ),
    Row(
        "healthy runs exit 0",
        "at least 98 %",
        lambda o: o.truth == "healthy",
        lambda o: o.exit_code == 0,
        "rate",
        0.98,
    ),
    Row(
        "healthy runs exit 0, 2 or more cylinders",
        "at least 98 %",
        lambda o: o.truth == "healthy" and o.cylinders > 1,
        lambda o: o.exit_code == 0,
        "rate",
        0.98,
    ),
    Row(
        "healthy single-cylinder runs with a finding (exit 1 or 2)",
        "none",
        lambda o: o.truth == "healthy" and o.cylinders == 1,
        lambda o: o.exit_code in (1, 2),
        "none",
    ),
    Row("alarms on healthy runs", "none", lambda o: o.truth == "healthy", lambda o: o.alarm, "none"),
)


def judged(outcomes: Sequence[Case]) -> list[Case]:
    """The cases the product diagnosed or failed to: not those the simulator could not make, nor those
    it refused to calibrate on (each counted in a row of its own)."""
    return [o for o in outcomes if o.failed_at not in ("simulator", "calibration")]


def cell(row: Row, outcomes: Sequence[Case]) -> str:
    """A row's measurement over ``outcomes`` and whether it meets its limit (Markdown)."""
    cases = [o for o in judged(outcomes) if row.pick(o)]
    hits = sum(row.hit(o) for o in cases)
    if row.kind == "none":
        return f"{hits} of {len(cases)}: " + ("meets" if hits == 0 else "**fails**")
    if not cases:
        return "no cases"
    verdict = "meets" if hits >= row.limit * len(cases) else "**fails**"
    return f"{hits}/{len(cases)} ({100 * hits / len(cases):.1f} %): {verdict}"


def ways(outcomes: Sequence[Case]) -> list[tuple[str, list[Case]]]:
    """The ways the cases were diagnosed, each headed: told the load and not, against the one-point
    baseline and, where the run made them, against the three points across the engine's law."""
    heads = []
    for points in sorted({o.points for o in outcomes}):
        against = "" if points == 1 else ", three points"
        if points == 1 and len({o.points for o in outcomes}) > 1:
            against = ", one point"
        heads += [
            (f"told the load (+-10 %){against}", [o for o in outcomes if o.load_told and o.points == points]),
            (f"not told the load{against}", [o for o in outcomes if not o.load_told and o.points == points]),
        ]
    return heads


def class_table(outcomes: Sequence[Case]) -> list[str]:
    """One class's acceptance rows, each way the cases were diagnosed (:func:`ways`; Markdown lines)."""
    heads = ways(outcomes)
    lines = [
        "| what | required | " + " | ".join(head for head, _ in heads) + " |",
        "|---|---|" + "---|" * len(heads),
    ]
    lines += [
        f"| {r.what} | {r.required} | " + " | ".join(cell(r, group) for _, group in heads) + " |"
        for r in ROWS
    ]
    for stage, what in (
        ("simulator", "cases the simulator could not make (left out)"),
        ("calibration", "cases the product refused to calibrate on (left out)"),
        ("diagnosis", "cases the product failed to diagnose (counted as not named)"),
    ):
        lines.append(
            f"| {what} | - | "
            + " | ".join(f"{sum(o.failed_at == stage for o in group)} of {len(group)}" for _, group in heads)
            + " |"
        )
    return lines


def operating_sections(outcomes: Sequence[Case], classes: Sequence[str]) -> list[str]:
    """A table per operating-point class with any case (Markdown lines)."""
    lines: list[str] = []
    for kind in classes:
        group = [o for o in outcomes if o.operating == kind]
        if not group:
            continue
        told = [o for o in group if o.load_told and o.points == 1]
        faults = ", ".join(
            f"{sum(o.truth == t for o in told)} {t}" for t in sorted({o.truth for o in told if o.truth})
        )
        loads = [o.true_load for o in told if math.isfinite(o.true_load)]
        span = f"loads {min(loads):.2f} to {max(loads):.2f} of rated" if loads else "no load measured"
        lines += [f"### {kind}", "", f"{len(told)} cases ({faults}; {span}).", "", *class_table(group), ""]
    return lines


class Scored(Case, Protocol):
    """What the impact limit's table reads besides a row's fields (the bench's Outcome)."""

    impact_true: tuple[float, float, float, float]
    impact_other: tuple[float, float, float, float]


class Missed(Case, Protocol):
    """What the list of cases not named reads besides a row's fields."""

    seed: int
    subject: str
    status: str
    findings: str
    error: str
    inconclusive: str
    knocks: int
    knock_size: float


def missed_table(outcomes: Sequence[Missed], *, limit: int = 250, vee: bool = False) -> list[str]:
    """The cases off the baseline's point not named, either way (Markdown lines, at most ``limit``);
    ``vee``: V engines' cases, which the simulator makes with ``vee=True``."""
    wrong = [o for o in judged(outcomes) if o.operating != "baseline point" and o.truth and not o.named]
    lines = [
        f"### Cases off the baseline's point not named ({len(wrong)} diagnoses)",
        "",
        "Seed, length and class reproduce a case: `validation.simulator.random_case(seed, duration_s=..., "
        f'operating="random"{", vee=True" if vee else ""})`.',
        "",
        "| seed | length [s] | class | true | subject | load told | points | status | findings / error |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for o in sorted(wrong, key=lambda o: (o.operating, o.truth, o.seed, o.points, not o.load_told))[:limit]:
        said = (o.error or o.findings or "-").replace("|", "/")
        lines.append(
            f"| {o.seed} | {o.duration_s:g} | {o.operating} | {put_in(o)} | {o.subject} | "
            f"{'yes' if o.load_told else 'no'} | {o.points} | {o.status} | {said} |"
        )
    return lines


def put_in(o: Missed) -> str:
    """The true class, with a worn bearing's knocks: how many the recording holds and their size over
    the noise of the sensor on the bearing (the simulator's truth)."""
    if o.truth != "worn_bearing":
        return o.truth
    return f"{o.truth} ({o.knocks} knocks, {o.knock_size:.1f} x noise)"


def knock_table(outcomes: Sequence[Missed]) -> list[str]:
    """Worn bearings named against the knocks their recordings hold, every diagnosis of every section
    and way (Markdown lines)."""
    worn = [o for o in judged(outcomes) if o.truth == "worn_bearing"]
    lines = [
        "## Worn bearings by the knocks they put in",
        "",
        "A worn bearing knocks where its journal's load reverses, once or twice a revolution at most, and "
        "not at all at a point where the load does not reverse; a short recording of a slow engine holds "
        "few knocks. The simulator counts the knocks in each recording and gives their size over the "
        "noise of the sensor on the bearing. Every diagnosis of a worn-bearing case (every section, told "
        "the load and not, one point and three):",
        "",
        "| knocks in the recording | diagnoses | named at the right bearing | size over the noise |",
        "|---|---|---|---|",
    ]
    edges = (0, *KNOCK_BINS, math.inf)
    for low, high in itertools.pairwise(edges):
        group = [o for o in worn if low <= o.knocks < high]
        if not group:
            continue
        what = f"{low} to {high - 1}" if math.isfinite(high) else f"{low} or more"
        hits = sum(o.named for o in group)
        sizes = [o.knock_size for o in group]
        lines.append(
            f"| {what} | {len(group)} | {hits}/{len(group)} ({100 * hits / len(group):.1f} %) | "
            f"{min(sizes):.1f} to {max(sizes):.1f} |"
        )
    return lines


def _heard_but_for_the_limit(score: tuple[float, float, float, float]) -> bool:
    """Whether an impact score (score, significance, needed, elsewhere) passes the bearing rule's
    significance and localisation, whatever its size (:func:`monitor.diagnosis.findings.bearing_findings`)."""
    size, significance, needed, elsewhere = score
    localised = math.isnan(elsewhere) or size - 1.0 >= LOCALISED * max(elsewhere - 1.0, 0.0)
    return math.isfinite(size) and significance >= max(SIGNIFICANCE, needed) and localised


def impact_limit_table(outcomes: Sequence[Scored]) -> list[str]:
    """The impact warning limit against what healthy runs and worn bearings read, every diagnosis of the
    whole recording (segments aside), in-line and V engines (Markdown lines)."""
    lines = [
        "## The impact warning limit against the population",
        "",
        f"A knock span is a bearing's finding where it stands out significantly, is localised, and reads "
        f"at least {IMPACT_WARNING:g} x the baseline's power (`IMPACT_WARNING`). The rows give, over every "
        "diagnosis of the whole recording (segments aside; each way of being told the load), the most "
        "significant span that passes the first two: of any bearing on a healthy run, and of the true "
        "bearing on a worn-bearing run. The limit must lie above the first and below the second.",
        "",
        "| where | healthy diagnoses | with such a span | its largest score [x baseline] | at or above the "
        "limit | worn-bearing diagnoses | with such a span at the true bearing | its smallest score | below "
        "the limit |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    places: list[tuple[str, Callable[[Scored], bool]]] = [
        ("at the baseline's point", lambda o: o.operating == "baseline point"),
        ("off it, one point", lambda o: o.operating != "baseline point" and o.points == 1),
        ("off it, three points", lambda o: o.operating != "baseline point" and o.points == 3),
    ]
    for where, pick in places:
        here = [o for o in judged(outcomes) if pick(o)]
        healthy = [o for o in here if o.truth == "healthy"]
        worn = [o for o in here if o.truth == "worn_bearing"]
        loud = [o.impact_other[0] for o in healthy if _heard_but_for_the_limit(o.impact_other)]
        knocks = [o.impact_true[0] for o in worn if _heard_but_for_the_limit(o.impact_true)]
        if not healthy and not worn:
            continue
        lines.append(
            f"| {where} | {len(healthy)} | {len(loud)} | {f'{max(loud):.2f}' if loud else '-'} | "
            f"{sum(s >= IMPACT_WARNING for s in loud)} | {len(worn)} | {len(knocks)} | "
            f"{f'{min(knocks):.2f}' if knocks else '-'} | {sum(s < IMPACT_WARNING for s in knocks)} |"
        )
    return lines


def unjudged_table(outcomes: Sequence[Missed], *, vee: bool = False) -> list[str]:
    """The healthy runs off the baseline's point that did not exit 0 for want of evidence (inconclusive,
    no finding), each with the product's reason (Markdown lines): the "healthy runs exit 0" rows'
    misses that the list of cases not named leaves out (a healthy run without findings is named)."""
    left = [
        o
        for o in judged(outcomes)
        if o.operating != "baseline point" and o.truth == "healthy" and o.named and o.exit_code != 0
    ]
    lines = [
        f"### Healthy runs off the baseline's point left inconclusive ({len(left)} diagnoses)",
        "",
        "Seed, length and class reproduce a case: `validation.simulator.random_case(seed, duration_s=..., "
        f'operating="random"{", vee=True" if vee else ""})`. The reason is the product\'s own.',
        "",
        "| seed | length [s] | class | cylinders | load told | points | why |",
        "|---|---|---|---|---|---|---|",
    ]
    for o in sorted(left, key=lambda o: (o.operating, o.seed, o.points, not o.load_told)):
        why = (o.inconclusive or o.status).replace("|", "/")
        lines.append(
            f"| {o.seed} | {o.duration_s:g} | {o.operating} | {o.cylinders} | "
            f"{'yes' if o.load_told else 'no'} | {o.points} | {why} |"
        )
    return lines


def operating_part(everything: Sequence[Missed], classes: Sequence[str]) -> list[str]:
    """The document's part off the baseline's point: how its cases were drawn and diagnosed, a table per
    class of ``classes`` each way, and the cases not named or left inconclusive (Markdown lines)."""
    failed = [o for o in everything if o.failed_at == "simulator" and o.load_told]
    lines = [
        "## Acceptance per operating-point class",
        "",
        "A fleet calibrates an engine once: every case's baseline is its healthy twin at the point the "
        "case was first drawn at (load 45-95 %). The case itself runs at a point of its class "
        "(`validation.simulator.operating`): the baseline's point; a propeller engine on its curve at "
        "60-100 % of rated speed (torque as speed squared); a generator at 25-100 % load at rated speed; "
        "a step from one load of the engine's law to another at 30-70 % of the recording; or an engine "
        "with its crank-speed sensors alone, at a load of its law. Off the baseline's point the charge "
        "pressure follows one of two laws, drawn per engine (boost falling with load, or held at its "
        "rated value), and a weak cylinder releases 80 % of a healthy one's heat or 50-70 %. Each case "
        "is diagnosed twice against the same baseline: told its load (the true mean load off by up to "
        "10 %) and not told it (the product estimates it from the recording's crank-speed orders, "
        "where they tell it, and judges the recording there, else at the baseline's load), as `compare` "
        "diagnoses a recording (`benchmarks.diagnosed`): at the recording's point, and segment by "
        "segment where it crosses points. Told the load, a load step is told one load per steady "
        "segment found (the load run at the segment's middle, off by the same error), as `compare "
        "--segment-loads` takes them; not told, each segment's load is estimated from its own orders "
        "the same way. Each case off the baseline's point is then "
        "diagnosed both ways again against a baseline of three points across its engine's law "
        "(`law_baseline`): the twin and two more healthy twins at the law's lowest and highest load "
        "(a propeller engine at 60 % and 100 % of rated speed on its curve, a generator at 25 % and "
        "100 % load), each calibrated told its load, as `engine-monitor calibrate` takes several "
        "recordings; not told its load, the product then estimates it from the recording against the "
        'points. The columns "one point" and "three points" say which baseline.',
        "",
        "A single cylinder not told its load has no others to be compared with: its weaker firing and a "
        "lower load read alike, and the product says so (inconclusive, asking for the load) rather than "
        'call such a reading healthy, as it must not for a weak or dead cylinder. The row "healthy runs '
        'exit 0" counts those runs as misses; the row for 2 or more cylinders leaves them out, and the '
        "row after it asks that a healthy single cylinder never be given a finding.",
        "",
        f"Cases the simulator could not make: {len(failed)}"
        + (
            " (" + "; ".join(sorted({f"seed {o.seed}: {o.error[:80]}" for o in failed})[:10]) + ")"
            if failed
            else ""
        )
        + ".",
        "",
        *operating_sections(everything, classes),
        *missed_table(everything),
        "",
        *unjudged_table(everything),
        "",
    ]
    return lines
