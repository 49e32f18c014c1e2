"""Misfires and healthy runs away from the baseline's load, on the independent validation simulator.

``python -m benchmarks.misfire_loads`` simulates engines of the validation simulator
(:mod:`validation.simulator`) calibrated healthy at rated load and recorded at 25, 40, 60, 80 and
100 % load, one cylinder motored (a misfire) or none, and diagnoses each recording twice: told the
load with the simulator's +-10 % error, and told rated load (1.0).  It does so for the
simulator's charge pressure as it is (rising with load, as the product's model assumes) and held
at its rated value at every load (an engine with its boost held: the product's model then has the
wrong charge-pressure law).  It counts misfires reported healthy, misfires named at the right
cylinder, cylinders named on healthy runs (false alarms) and, for the record, how often the
missing-impulse pattern (:mod:`monitor.diagnosis.misfire`) made the finding.  It writes the table
between its markers in docs/diagnosis.md.

The operating point (a load at rated speed) and the charge-pressure law are set by replacing the
simulator's draw of the operating point in its case module for the run (its public cases draw
them at random); nothing in the simulator is changed.
"""

from __future__ import annotations

import argparse
import dataclasses
from collections.abc import Iterator
from concurrent.futures import ProcessPoolExecutor
from contextlib import contextmanager
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

from benchmarks.diagnosed import case_engine
from benchmarks.sections import replace_section
from monitor.diagnosis.calibration import calibrate
from monitor.diagnosis.diagnose import diagnose
from validation.simulator import cases
from validation.simulator.operating import OperatingPoint
from validation.simulator.shared import SimulationError

DOC = Path(__file__).resolve().parents[1] / "docs" / "diagnosis.md"
START = "<!-- misfire-load table: written by python -m benchmarks.misfire_loads -->"
END = "<!-- end of misfire-load table -->"
LOADS = (0.25, 0.4, 0.6, 0.8, 1.0)
GROUPS = (  # (fault, charge pressure held, first seed, engines as a share of --engines)
    ("misfire", False, 10_000, 1.0),
    ("healthy", False, 20_000, 1.0),
    ("misfire", True, 30_000, 1.0),
    ("healthy", True, 40_000, 1.0),
    ("weak", False, 50_000, 0.5),
)
DURATION = 10.0  # [s]: the shortest recording of the validation population
HIGHEST_LOAD = 1.1  # the product's model takes loads up to this [-]


@contextmanager
def _operating(load: float, *, held: bool) -> Iterator[None]:
    """The simulator's cases drawn at ``load`` at rated speed, the charge held at rated when ``held``."""
    draw = cases.draw_operating_point

    def at_load(engine: Any, install: Any, seed: int, fault: str | None, operating: Any) -> Any:
        _, scenario = draw(engine, install, seed, fault, "baseline point")
        point = OperatingPoint("constant speed", (load,), charge_law=_law(held))
        return point, dataclasses.replace(scenario, load=load)

    cases.draw_operating_point = at_load  # type: ignore[assignment]
    try:
        yield
    finally:
        cases.draw_operating_point = draw


def _law(held: bool) -> str:
    return "held" if held else "turbocharged"


def run_case(seed: int, fault: str, held: bool, load: float) -> list[dict[str, Any]]:
    """One engine: its baseline at rated load, its recording at ``load``, diagnosed told two loads.

    Returns one row per told load (empty for an engine the fault cannot be simulated on).
    """
    try:
        with _operating(load, held=held):
            case = cases._simulate(seed, seed, twin=False, duration_s=DURATION, fault=fault)
        rated = OperatingPoint("baseline point", (1.0,), charge_law=_law(held))
        twin = cases._simulate(
            seed, seed + 1_000_000, twin=True, duration_s=DURATION, fault=None, operating=rated
        )
    except SimulationError:  # a misfire on a single-cylinder engine
        return []
    engine = case_engine(case.engine_toml)
    if engine.cylinders < 2:
        return []
    rows = []
    try:
        baseline = calibrate(twin.recording, engine, load=min(twin.load_given, HIGHEST_LOAD))
    except Exception as error:  # a case the product cannot calibrate is recorded
        return [
            {"seed": seed, "fault": fault, "held": held, "load": load, "told": t, "error": str(error)}
            for t in ("given", "rated")
        ]
    for told, stated in (("given", case.load_given), ("rated", 1.0)):
        row: dict[str, Any] = {"seed": seed, "fault": fault, "held": held, "load": load, "told": told}
        try:
            d = diagnose(case.recording, engine, baseline=baseline, load=min(stated, HIGHEST_LOAD))
        except Exception as error:  # a case the product cannot diagnose is recorded
            rows.append({**row, "error": str(error)})
            continue
        cylinders = [f for f in d.findings if f.kind == "cylinder"]
        truth = case.truth.get("cylinder")
        row.update(
            status=d.status,
            named=any(
                f.subject.split(" or ")[0] == f"cylinder {truth}" and "(misfiring" in f.summary
                for f in cylinders
            ),
            wrong=any(f.subject.split(" or ")[0] != f"cylinder {truth}" for f in cylinders),
            cylinder_finding=bool(cylinders),
            pattern=any("pattern of a missing impulse" in f.summary for f in cylinders),
        )
        rows.append(row)
    return rows


def _job(args: tuple[int, str, bool, float]) -> list[dict[str, Any]]:
    return run_case(*args)


def table(rows: list[dict[str, Any]]) -> list[str]:
    """The Markdown table of the rows, one line per fault, charge-pressure law and told load."""
    lines = [
        "| fault | charge pressure | load told | runs | reported healthy | inconclusive | "
        "called misfiring at its cylinder | a cylinder named (healthy: false alarm) | "
        "another cylinder named | by the pattern | errors |",
        "|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for fault, held, _, _ in GROUPS:
        for told in ("given", "rated"):
            group = [r for r in rows if r["fault"] == fault and r["held"] == held and r["told"] == told]
            done = [r for r in group if "error" not in r]
            healthy = sum(r["status"] == "healthy" for r in done)
            inconclusive = sum(r["status"] == "inconclusive" for r in done)
            named = sum(r["named"] for r in done) if fault != "healthy" else "-"
            named_any = sum(r["cylinder_finding"] for r in done)
            wrong = sum(r["wrong"] for r in done) if fault != "healthy" else "-"
            lines.append(
                f"| {fault} | {'held at rated' if held else 'rising with load'} | "
                f"{'+-10 %' if told == 'given' else '1.0'} | {len(done)} | {healthy} | {inconclusive} | "
                f"{named} | {named_any} | {wrong} | {sum(r['pattern'] for r in done)} | "
                f"{len(group) - len(done)} |"
            )
    return lines


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--engines", type=int, default=35, help="engines per fault and charge-pressure law")
    parser.add_argument("--workers", type=int, default=2)
    args = parser.parse_args()
    jobs = [
        (first + i, fault, held, LOADS[i % len(LOADS)])
        for fault, held, first, share in GROUPS
        for i in range(round(share * args.engines))
    ]
    start = datetime.now(UTC)
    with ProcessPoolExecutor(args.workers) as pool:
        rows = [row for result in pool.map(_job, jobs) for row in result]
    minutes = (datetime.now(UTC) - start).total_seconds() / 60
    least = min(LOADS)
    section = "\n".join(
        [
            START,
            "",
            f"{args.engines} engines per fault and charge-pressure law, half as many weak ones (a "
            "cylinder's heat release at 50-80 %; seeds from "
            f"{', '.join(str(g[2]) for g in GROUPS)}), at loads "
            f"{', '.join(f'{100 * x:.0f} %' for x in LOADS)} in turn (each at least {100 * least:.0f} %), "
            f"{DURATION:g} s recordings, the baseline a healthy twin at rated load; single-cylinder "
            "engines left out (a misfire needs others to be seen against). Each run diagnosed told "
            f"the load with the simulator's error and told 1.0; {minutes:.0f} min on {args.workers} "
            f"workers, {datetime.now(UTC):%Y-%m-%d}.",
            "",
            *table(rows),
            "",
            END,
        ]
    )
    replace_section(DOC, START, END, section)
    print(section)


if __name__ == "__main__":
    main()
