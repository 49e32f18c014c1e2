"""Accuracy against time of the torsion models (the torsion sections of docs/accuracy-vs-time.md).

Called by ``benchmarks.accuracy_vs_time`` (``make bench``), or alone with
``python -m benchmarks.torsion``, which rewrites only the torsion sections
(between their markers) and says so in their first line.  Every number comes
from the run that wrote it.  The boundary-error table gives the constants of
``BOUNDARY_ERROR`` in monitor/torsion/stability.py; the run prints them
and flags any row the code's table no longer covers.
"""

from __future__ import annotations

import argparse
import math
import os
import platform
import subprocess
import sys
import time
from datetime import UTC, datetime
from pathlib import Path

import numpy as np

from benchmarks.sections import replace_section
from monitor import __version__
from monitor.torsion.floquet import monodromy
from monitor.torsion.stability import (
    BOUNDARY_ERROR,
    BOUNDARY_WINDOW,
    UNSTABLE_MARGIN,
    instability_ranges,
    stability_chart,
)
from monitor.torsion.time_response import simulate
from monitor.torsion.variable_inertia import VariableInertiaCrank

ROOT = Path(__file__).resolve().parents[1]
DOC = ROOT / "docs" / "accuracy-vs-time.md"
START = "<!-- torsion sections: start -->"
END = "<!-- torsion sections: end -->"

GRID_R = (0.3, 1.5)
GRID_EPS = (0.0, 0.6)
CHECK_EPS = (0.236, 0.34, 0.5)
#: Inertia ratios at which the boundary error is measured, and the rows of BOUNDARY_ERROR.
RELATION_EPS = (0.01, 0.05, *(round(0.1 * k, 2) for k in range(1, 10)), 0.95)
RELATION_ROWS = (0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9, 0.95)
RELATION_STEPS = (16, 24, 32, 48, 64, 96, 128)
REFERENCE_STEPS = 2048


def _fmt(seconds: float) -> str:
    return f"{seconds * 1e3:.1f} ms" if seconds < 1 else f"{seconds:.2f} s"


def _bisect(eps: np.ndarray, lo: np.ndarray, hi: np.ndarray, steps: int) -> np.ndarray:
    """Boundaries of the Jury margin (fixed Magnus step count) inside brackets; NaN where no sign change.

    The public ``monodromy`` with a fixed step count, bisected 50 times: independent of the range
    search of the product except for the margin's sign convention.
    """

    def unstable(r: np.ndarray) -> np.ndarray:
        return np.asarray(monodromy(eps, r, steps=steps).stability_margin < -UNSTABLE_MARGIN)

    sign_lo, sign_hi = unstable(lo), unstable(hi)
    for _ in range(50):
        mid = 0.5 * (lo + hi)
        same = unstable(mid) == sign_lo
        lo, hi = np.where(same, mid, lo), np.where(same, hi, mid)
    return np.where(sign_lo != sign_hi, 0.5 * (lo + hi), np.nan)


def _resolution(r: float, eps: float) -> int:
    """The product's least step count for a window starting at ``r`` (eight steps per fastest cycle)."""
    return max(8, math.ceil(4.0 / (r * math.sqrt(1.0 - eps))))


def _errors(
    reference: list[tuple[float, float]], other: list[tuple[float, float]], window: tuple[float, float]
) -> list[tuple[float, float]]:
    """(boundary, error) of every boundary of ``reference`` inside the window, matched to ``other``.

    Each reference range is matched to the range of ``other`` whose middle is nearest, if that is
    nearer than half the distance to the neighbouring reference ranges; a range with no match (closed
    at that step count) counts its half width as the error of both its boundaries.
    """
    middles = [0.5 * (a + b) for a, b in reference]
    out = []
    for i, (a, b) in enumerate(reference):
        reach = min(
            [abs(middles[i] - m) / 2 for j, m in enumerate(middles) if j != i] + [window[1] - window[0]]
        )
        near = [x for x in other if abs(0.5 * (x[0] + x[1]) - middles[i]) < reach]
        match = min(near, key=lambda x: abs(0.5 * (x[0] + x[1]) - middles[i])) if near else None
        for ours, theirs in ((a, 0), (b, 1)):
            if window[0] < ours < window[1]:
                out.append((ours, abs(match[theirs] - ours) if match else 0.5 * (b - a)))
    return out


def _ranges(e: float, steps: int) -> list[tuple[float, float]]:
    return instability_ranges(e, *BOUNDARY_WINDOW, steps=steps, tolerance=1e-12)


def relation() -> tuple[list[str], dict[float, float]]:
    """Boundary error against step count, measured against a 2048-step reference."""
    start = time.perf_counter()
    reference = {e: _ranges(e, REFERENCE_STEPS) for e in RELATION_EPS}
    check = {e: _ranges(e, 2 * REFERENCE_STEPS) for e in RELATION_EPS}
    reference_error = max(
        err for e in RELATION_EPS for _, err in _errors(reference[e], check[e], BOUNDARY_WINDOW)
    )
    count = sum(len(_errors(reference[e], reference[e], BOUNDARY_WINDOW)) for e in RELATION_EPS)
    rows = [
        "| Magnus steps per period | largest boundary error, r 0.3..1.5, epsilon <= 0.6 | "
        "the same times steps^4 | largest boundary error, every measured boundary | 200 x 200 chart |",
        "|---|---|---|---|---|",
    ]
    constant = {e: 0.0 for e in RELATION_EPS}
    r = np.linspace(*GRID_R, 200)
    e_grid = np.linspace(*GRID_EPS, 200)
    for steps in RELATION_STEPS:
        worst = window = 0.0
        for e in RELATION_EPS:
            for boundary, error in _errors(reference[e], _ranges(e, steps), BOUNDARY_WINDOW):
                if steps < _resolution(boundary, e):
                    continue  # a window reaching down to this boundary takes more steps than that
                constant[e] = max(constant[e], error * steps**4)
                worst = max(worst, error)
                if e <= GRID_EPS[1] and GRID_R[0] <= boundary <= GRID_R[1]:
                    window = max(window, error)
        clock = time.perf_counter()
        stability_chart(r, e_grid, steps=steps)
        elapsed = time.perf_counter() - clock
        rows.append(f"| {steps} | {window:.2e} | {window * steps**4:.3g} | {worst:.2e} | {_fmt(elapsed)} |")
    table = {top: max(c for e, c in constant.items() if e <= top + 1e-12) for top in RELATION_ROWS}
    rows += [
        "",
        f"{count} boundaries: every boundary of every instability range in r {BOUNDARY_WINDOW[0]}.."
        f"{BOUNDARY_WINDOW[1]} at epsilon {', '.join(f'{e:g}' for e in RELATION_EPS)}, found by the range "
        "search with that step count (bisected to 1e-12) and matched range by range to the reference "
        f"({REFERENCE_STEPS} steps per period; its own error, against {2 * REFERENCE_STEPS} steps, is "
        f"{reference_error:.1e}); a range that closes at the step count counts its half width. "
        "'Every measured boundary' keeps the step counts the product uses there (eight steps or more "
        "per cycle of the fastest free oscillation). The error falls as steps^-4, the order of the "
        "Magnus method.",
        "",
        "The step count for a wanted boundary accuracy: the largest steps^4 x error of every inertia "
        "ratio up to epsilon_max (these are `BOUNDARY_ERROR` in monitor/torsion/stability.py; "
        "`boundary_steps` takes the steps that make C / steps^4 half the tolerance):",
        "",
        "| epsilon_max | C = largest steps^4 x boundary error | steps for 1e-6 | in the code |",
        "|---|---|---|---|",
    ]
    code = dict(BOUNDARY_ERROR)
    for top, c in table.items():
        steps_1e6 = math.ceil((2 * c / 1e-6) ** 0.25)
        held = code.get(top)
        if held is None:
            note = "missing"
        else:
            note = f"{held:.3g}" + (" (below the measurement)" if held < c else "")
        rows.append(f"| {top:g} | {c:.3g} | {steps_1e6} | {note} |")
    rows += ["", f"Measured in {time.perf_counter() - start:.0f} s."]
    return rows, table


def speed_section() -> list[str]:
    """The 200 x 200 chart of `torsion stability`: the former trace refinement against the step count
    chosen for the boundary accuracy, in one run."""
    r = np.linspace(*GRID_R, 200)
    eps = np.linspace(*GRID_EPS, 200)
    reference = stability_chart(r, eps, steps=1024)

    def best(function, repeat: int = 3) -> float:  # type: ignore[no-untyped-def]
        times = []
        for _ in range(repeat):
            clock = time.perf_counter()
            function()
            times.append(time.perf_counter() - clock)
        return min(times)

    clock = time.perf_counter()
    former_steps = monodromy(eps[:, None], r[None, :], tolerance=1e-8).steps
    former = time.perf_counter() - clock
    rows = [
        "| chart | Magnus steps per period | boundary error (relation) | cells unlike the 1024-step chart "
        "| time | time / former |",
        "|---|---|---|---|---|---|",
        f"| former default: trace refined to 1e-8 | {former_steps} | - | - | {_fmt(former)} | 1 |",
    ]
    for tolerance in (1e-4, 1e-6, 1e-8):
        chart = stability_chart(r, eps, tolerance=tolerance)
        elapsed = best(lambda tolerance=tolerance: stability_chart(r, eps, tolerance=tolerance))
        unlike = int(np.count_nonzero(chart.unstable != reference.unstable))
        rows.append(
            f"| boundary tolerance {tolerance:g} | {chart.steps} | {chart.boundary_error:.1e} | {unlike} | "
            f"{_fmt(elapsed)} | {elapsed / former:.3f} |"
        )
    command = [sys.executable, "-m", "monitor", "torsion", "stability", "--json"]
    walls = []
    for _ in range(3):
        clock = time.perf_counter()
        subprocess.run(command, check=True, stdout=subprocess.DEVNULL, cwd=ROOT)
        walls.append(time.perf_counter() - clock)
    rows += [
        "",
        f"`engine-monitor torsion stability --json` (200 x 200, default tolerance 1e-6, start-up and "
        f"JSON output included): {_fmt(min(walls))} wall, best of 3; the acceptance bound is 4 s.",
        "",
        "Chart over r 0.3..1.5, epsilon 0..0.6, times the best of 3 (the former default once). The "
        "former default refined the step count until every trace, unstable cells included, converged "
        "to 1e-8. A cell unlike the 1024-step chart has a boundary within the tolerance of it.",
    ]
    return rows


def floquet_vs_sweep(reference: dict[float, list[float]]) -> list[str]:
    eps = 0.34
    truth = reference[eps]
    rows = [
        "| method | setting | largest boundary error in r (range near r = 1) | time |",
        "|---|---|---|---|",
    ]
    for tolerance in (1e-3, 1e-5, 1e-8, 1e-10):
        start = time.perf_counter()
        found = instability_ranges(eps, 0.9, 1.25, tolerance=tolerance)
        elapsed = time.perf_counter() - start
        error = max(abs(found[0][0] - truth[2]), abs(found[0][1] - truth[3]))
        rows.append(
            f"| Floquet (monodromy, bisection) | boundary tolerance {tolerance:g} | {error:.2e} | "
            f"{_fmt(elapsed)} |"
        )
    for step in (0.02, 0.005):
        start = time.perf_counter()
        grid = np.arange(0.9, 1.25 + 1e-12, step)
        unstable = []
        for r in grid:
            crank = VariableInertiaCrank(eps, float(r))
            tau = np.linspace(0, 2 * math.pi * 40, 4001)
            out = simulate(crank, tau, initial=(1e-3, 0.0), integrator="DOP853", rtol=1e-8, atol=1e-11)
            free = (
                out.gamma
                - simulate(crank, tau, initial=(0.0, 0.0), integrator="DOP853", rtol=1e-8, atol=1e-11).gamma
            )
            unstable.append(np.abs(free[-500:]).max() > 10 * np.abs(free[:500]).max())
        elapsed = time.perf_counter() - start
        flags = np.array(unstable)
        inside = grid[flags]
        error = max(abs(inside[0] - truth[2]), abs(inside[-1] - truth[3])) if inside.size else float("nan")
        rows.append(
            "| amplitude sweep (paper 002: direct integration, growth over 40 revolutions) | "
            f"r step {step:g} | "
            f"{error:.2e} | {_fmt(elapsed)} |"
        )
    rows.append("")
    rows.append(
        "Reference range for epsilon 0.34: "
        f"r = {truth[2]:.6f} to {truth[3]:.6f}. The sweep's error is at least half its step and it can "
        "misjudge "
        "points near a boundary where growth over 40 revolutions is slow."
    )
    return rows


def integrator_section() -> list[str]:
    crank = VariableInertiaCrank(0.34, 0.1)
    tau = np.linspace(0, 2 * math.pi * 20, 20001)
    reference = simulate(crank, tau, rtol=1e-13, atol=1e-15).gamma
    rows = ["| integrator | rtol | largest error in gamma [rad] | time |", "|---|---|---|---|"]
    for integrator in ("periodic", "DOP853", "RK45", "Radau", "LSODA"):
        for rtol in (1e-4, 1e-6, 1e-8, 1e-10):
            if integrator in ("Radau",) and rtol < 1e-8:
                continue
            start = time.perf_counter()
            out = simulate(crank, tau, integrator=integrator, rtol=rtol, atol=rtol * 1e-2)  # type: ignore[arg-type]
            elapsed = time.perf_counter() - start
            rows.append(
                f"| {integrator} | {rtol:g} | {np.abs(out.gamma - reference).max():.2e} | {_fmt(elapsed)} |"
            )
    rows.append("")
    rows.append(
        "Linearised equation (002 eq. 6) at epsilon 0.34, r = 1/10 (Fig. 3), 20 revolutions, gamma(0) = 1; "
        "reference: periodic propagation at rtol 1e-13. 'periodic' integrates one period (DOP853) and "
        "propagates it exactly, so its cost hardly grows with the length of the run. Radau at rtol 1e-10 "
        "is not run (Radau is the slowest at every tolerance in the table)."
    )
    return rows


TABLE_1 = {  # paper 002 Table 1: (Goldsbrough experiment, paper's sweep, Gregory's analysis) per range
    (0.34, "1/2"): ("maximum at 0.525", (0.511, 0.521), (0.512, 0.516)),
    (0.34, "1"): ((0.933, 1.154), (0.961, 1.16), (0.966, 1.168)),
    (0.236, "1/2"): ("maximum at 0.507", (0.502, 0.508), (0.506, 0.508)),
    (0.236, "1"): ((0.964, 1.107), (0.963, 1.08), (0.967, 1.09)),
}


def table_1_section(reference: dict[float, list[float]]) -> list[str]:
    def show(value: object) -> str:
        return value if isinstance(value, str) else f"{value[0]:g} to {value[1]:g}"  # type: ignore[index]

    rows = [
        "| epsilon | range | Goldsbrough (experiment) | paper 002 (sweep) | Gregory (analysis) | "
        "this model (Floquet) | largest distance from Gregory |",
        "|---|---|---|---|---|---|---|",
    ]
    for (eps, near), (experiment, sweep, gregory) in TABLE_1.items():
        bounds = reference[eps][:2] if near == "1/2" else reference[eps][2:]
        distance = max(abs(bounds[0] - gregory[0]), abs(bounds[1] - gregory[1]))
        rows.append(
            f"| {eps:g} | r ~ {near} | {show(experiment)} | {show(sweep)} | {show(gregory)} | "
            f"{bounds[0]:.5f} to {bounds[1]:.5f} | {distance:.4f} |"
        )
    return rows


def _reference_boundaries() -> tuple[dict[float, list[float]], float]:
    """Boundaries near r = 1/2 and 1 at 4096 steps per period, and their own error (against 8192)."""
    located = {
        e: [b for pair in instability_ranges(e, 0.45, 1.8, tolerance=1e-8) for b in pair] for e in CHECK_EPS
    }
    eps = np.array([e for e, bounds in located.items() for _ in bounds])
    guess = np.array([b for bounds in located.values() for b in bounds])
    fine = _bisect(eps, guess - 1e-5, guess + 1e-5, 4096)
    finer = _bisect(eps, guess - 1e-5, guess + 1e-5, 8192)
    found: dict[float, list[float]] = {}
    for e, b in zip(eps, fine, strict=True):
        found.setdefault(float(e), []).append(float(b))
    return found, float(np.nanmax(np.abs(fine - finer)))


def sections(*, header: str = "") -> list[str]:
    """The torsion sections of docs/accuracy-vs-time.md, between their markers."""
    reference, _ = _reference_boundaries()
    print("  torsion: boundary error against step count ...", flush=True)
    relation_rows, table = relation()
    print("  torsion: chart speed ...", flush=True)
    speed = speed_section()
    print("  torsion: Floquet against the sweep, integrators ...", flush=True)
    sweep = floquet_vs_sweep(reference)
    integrators = integrator_section()
    print("  torsion: BOUNDARY_ERROR = (" + ", ".join(f"({e:g}, {c:.3g})" for e, c in table.items()) + ")")
    return [
        START,
        *([header, ""] if header else []),
        "## Variable-inertia crank: paper 002 Table 1",
        "",
        *table_1_section(reference),
        "",
        "## Variable-inertia crank: boundary error against step count",
        "",
        *relation_rows,
        "",
        "## Variable-inertia crank: the stability chart's time",
        "",
        *speed,
        "",
        "## Variable-inertia crank: Floquet against the amplitude sweep",
        "",
        *sweep,
        "",
        "## Variable-inertia crank: integrator and tolerance against error",
        "",
        *integrators,
        "",
        END,
        "",
    ]


def main() -> None:
    """Rewrite the torsion sections of docs/accuracy-vs-time.md alone."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.parse_args()
    start = time.perf_counter()
    stamp = datetime.now(UTC).strftime("%Y-%m-%d %H:%M UTC")
    header = (
        f"The torsion sections below were written by `python -m benchmarks.torsion` on {stamp}, "
        f"engine-monitor {__version__}, Python {platform.python_version()}, numpy {np.__version__}, "
        f"{platform.machine()} with {os.cpu_count()} cores (shared machine: times are the best of "
        "several repeats; compare ratios within this run), apart from the rest of this document."
    )
    lines = sections(header=header)
    lines.insert(-2, f"Torsion sections' run time: {time.perf_counter() - start:.0f} s.")
    lines.insert(-2, "")
    replace_section(DOC, START, END, "\n".join(lines).rstrip("\n"))
    print(f"wrote the torsion sections of {DOC.relative_to(ROOT)}")


if __name__ == "__main__":
    main()
