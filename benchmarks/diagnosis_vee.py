"""The V engines of docs/diagnosis-validation.md: their cases' seeds, lengths and table rows.

A V engine's case (``validation.simulator.random_case(seed, ..., vee=True)``) runs at its baseline's
operating point, told its load, from a seed range of its own (:data:`VEE_FIRST_SEED`); the truth
names its cylinders by bank (``"B3"``) as the product's findings do (``cylinder B3``). Its rows stand
apart from the in-line population's, whose tables stay as they always were.
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Sequence
from typing import Protocol

from benchmarks.diagnosis_operating import ROWS, cell, missed_table, operating_sections, unjudged_table
from benchmarks.judging import CLASSES

#: The first seed of the V engines' cases (dated, like the others, by their seed modulo 100,000
#: minutes after 2026-01-01).
VEE_FIRST_SEED = 300_000
#: The first seed of the V engines' cases off their baseline's point.
VEE_OFF_POINT_FIRST_SEED = 310_000
#: Their recordings' lengths, in turn [s].
VEE_DURATIONS = (10.0, 30.0)


class VeeCase(Protocol):
    """What the V rows read of a case's outcome (benchmarks.diagnosis_validation.Outcome; read-only,
    as that frozen dataclass's fields are)."""

    @property
    def duration_s(self) -> float: ...

    @property
    def truth(self) -> str: ...

    @property
    def strength(self) -> float: ...

    @property
    def exit_code(self) -> int: ...

    @property
    def named(self) -> bool: ...

    @property
    def alarm(self) -> bool: ...

    @property
    def failed_at(self) -> str: ...

    @property
    def vee(self) -> bool: ...

    @property
    def load_told(self) -> bool: ...

    @property
    def operating(self) -> str: ...

    @property
    def seed(self) -> int: ...

    @property
    def rods(self) -> str: ...


def vee_length(index: int) -> float:
    """The recording's length [s] of the ``index``-th V engine's case.

    Parameters
    ----------
    index : int

    Returns
    -------
    float
    """
    return VEE_DURATIONS[index % len(VEE_DURATIONS)]


def _rate(group: Sequence[VeeCase]) -> str:
    hits = sum(o.named for o in group)
    return f"{hits}/{len(group)} ({100 * hits / len(group):.0f} %)" if group else "-"


def vee_section(outcomes: Sequence[VeeCase]) -> list[str]:
    """The V engines' rows (Markdown lines), empty when the run had none.

    Parameters
    ----------
    outcomes : sequence of Outcome
        Every outcome of the run; the V engines' are picked out.

    Returns
    -------
    list of str
    """
    vee = [o for o in outcomes if o.vee and o.load_told and o.operating == "baseline point"]
    if not vee:
        return []
    failed = [o for o in vee if o.failed_at == "simulator"]
    made = [o for o in vee if o.failed_at != "simulator"]
    lines = [
        "## V engines",
        "",
        f"{len(vee)} cases of V engines (`--vee-cases`, seeds from {VEE_FIRST_SEED}, "
        "`validation.simulator.random_case(seed, duration_s=..., vee=True)`): medium-speed (45-60 deg V, "
        "500-1000 rpm) and high-speed (60-90 deg V, 1200-1900 rpm) four-strokes of 12 to 20 cylinders, "
        "side-by-side, fork-and-blade or (a third of them) articulated rods, each bank firing as an "
        "in-line engine (an articulated slave at its own TDC); at their baseline's point, told their load. "
        "A cylinder is named by bank (`cylinder B3`); `named` as above. "
        f"Cases the simulator could not make: {len(failed)}.",
        "",
        "| V engines: true class | length [s] | cases | named | exit 0 | exit 1 | exit 2 | exit 3 |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for truth in CLASSES:
        for duration in sorted({o.duration_s for o in made}):
            group = [o for o in made if o.truth == truth and o.duration_s == duration]
            if not group:
                continue
            exits = Counter(o.exit_code for o in group)
            lines.append(
                f"| {truth} | {duration:g} | {len(group)} | {_rate(group)} | "
                + " | ".join(str(exits.get(code, 0)) for code in range(4))
                + " |"
            )
    lines += [
        "",
        "The acceptance rows of the in-line population, at the same limits:",
        "",
        "| what | required | V engines, told the load (+-10 %) |",
        "|---|---|---|",
        *(f"| {row.what} | {row.required} | {cell(row, vee)} |" for row in ROWS),
        "",
        *_rods_table(vee),
    ]
    return lines


def _rods_table(cases: Sequence[VeeCase]) -> list[str]:
    """The acceptance rows by rod arrangement (Markdown lines): the articulated engines' slaves move
    otherwise than a slider-crank (validation.simulator.linkage), so they have a column of their own."""
    kinds = [k for k in ("side-by-side", "fork-and-blade", "articulated") if any(o.rods == k for o in cases)]
    if not kinds:
        return []
    by_kind = {k: [o for o in cases if o.rods == k] for k in kinds}
    return [
        "The same rows by the engines' rods:",
        "",
        "| what | required | " + " | ".join(f"{k} ({len(by_kind[k])} cases)" for k in kinds) + " |",
        "|---|---|" + "---|" * len(kinds),
        *(
            f"| {row.what} | {row.required} | " + " | ".join(cell(row, by_kind[k]) for k in kinds) + " |"
            for row in ROWS
        ),
        "",
    ]


def vee_off_point_section(outcomes: Sequence[VeeCase], classes: Sequence[str]) -> list[str]:
    """The V engines' cases off their baseline's point, a table per operating-point class (Markdown
    lines), empty when the run had none.

    Parameters
    ----------
    outcomes : sequence of Outcome
        Every outcome of the run; the V engines' off their point are picked out.
    classes : sequence of str
        The operating-point classes, in the order of their tables.

    Returns
    -------
    list of str
    """
    off = [o for o in outcomes if o.vee and o.operating != "baseline point"]
    if not off:
        return []
    failed = {o.seed for o in off if o.failed_at == "simulator"}
    return [
        "## V engines off their baseline's point",
        "",
        f"{len({o.seed for o in off})} cases of V engines (`--vee-off-point-cases`, seeds from "
        f"{VEE_OFF_POINT_FIRST_SEED}, `validation.simulator.random_case(seed, duration_s=..., "
        'operating="random", vee=True)`), drawn, calibrated and diagnosed as the in-line cases off '
        "their point are (told the load and not, against one point and three). "
        f"Cases the simulator could not make: {len(failed)}.",
        "",
        *operating_sections(off, classes),  # type: ignore[arg-type]
        *missed_table(off, vee=True),  # type: ignore[arg-type]
        "",
        *unjudged_table(off, vee=True),  # type: ignore[arg-type]
        "",
    ]
