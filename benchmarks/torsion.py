"""Accuracy against time of the torsion models (sections of docs/accuracy-vs-time.md).

Called by ``benchmarks.accuracy_vs_time``; every number comes from this run.
"""

from __future__ import annotations

import math
import time

import numpy as np

from monitor.torsion.variable_inertia import (
    VariableInertiaCrank,
    instability_ranges,
    monodromy,
    simulate,
    stability_chart,
)

GRID_R = (0.3, 1.5)
GRID_EPS = (0.0, 0.6)
CHECK_EPS = (0.236, 0.34, 0.5)


def _fmt(seconds: float) -> str:
    return f"{seconds * 1e3:.1f} ms" if seconds < 1 else f"{seconds:.2f} s"


def _bisect(eps: np.ndarray, lo: np.ndarray, hi: np.ndarray, steps: int) -> np.ndarray:
    """Boundaries of the Jury margin (fixed Magnus step count) inside brackets; NaN where no sign change."""
    sign_lo = monodromy(eps, lo, steps=steps).stability_margin < 0
    sign_hi = monodromy(eps, hi, steps=steps).stability_margin < 0
    for _ in range(45):
        mid = 0.5 * (lo + hi)
        same = (monodromy(eps, mid, steps=steps).stability_margin < 0) == sign_lo
        lo, hi = np.where(same, mid, lo), np.where(same, hi, mid)
    return np.where(sign_lo != sign_hi, 0.5 * (lo + hi), np.nan)


def _reference_boundaries() -> tuple[dict[float, list[float]], float]:
    """Boundaries near r = 1/2 and 1 at 4096 steps per period, and their own error (against 8192)."""
    coarse = {
        e: [b for pair in instability_ranges(e, 0.45, 1.8, samples=800, tolerance=1e-6) for b in pair]
        for e in CHECK_EPS
    }
    eps = np.array([e for e, bounds in coarse.items() for _ in bounds])
    guess = np.array([b for bounds in coarse.values() for b in bounds])
    fine = _bisect(eps, guess - 1e-4, guess + 1e-4, 4096)
    finer = _bisect(eps, guess - 1e-4, guess + 1e-4, 8192)
    found: dict[float, list[float]] = {}
    for e, b in zip(eps, fine, strict=True):
        found.setdefault(float(e), []).append(float(b))
    return found, float(np.nanmax(np.abs(fine - finer)))


def _boundaries_fixed_steps(reference: dict[float, list[float]], steps: int) -> np.ndarray:
    """Error of every boundary bisected with ``steps`` per period, in +-0.01 around the reference."""
    eps = np.array([e for e, bounds in reference.items() for _ in bounds])
    truth = np.array([b for bounds in reference.values() for b in bounds])
    # a bracket must hold one boundary only: at most 0.45 of the gap to its neighbours
    half = np.array(
        [
            min(0.01, 0.45 * min(abs(b - other) for other in bounds if other != b))
            for bounds in reference.values()
            for b in bounds
        ]
    )
    return np.abs(_bisect(eps, truth - half, truth + half, steps) - truth)


def chart_section(reference: dict[float, list[float]], reference_error: float) -> list[str]:
    rows = [
        "| Magnus steps per period | largest boundary error in r | 200 x 200 chart | unstable share |",
        "|---|---|---|---|",
    ]
    r = np.linspace(*GRID_R, 200)
    eps = np.linspace(*GRID_EPS, 200)
    for steps in (16, 24, 32, 48, 64, 128, 256):
        errors = _boundaries_fixed_steps(reference, steps)
        shown = "beyond its bracket" if np.any(np.isnan(errors)) else f"{float(errors.max()):.2e}"
        start = time.perf_counter()
        chart = stability_chart(r, eps, steps=steps)
        elapsed = time.perf_counter() - start
        rows.append(f"| {steps} | {shown} | {_fmt(elapsed)} | {chart.unstable.mean():.2%} |")
    rows.append("")
    rows.append(
        f"Chart over r {GRID_R[0]}..{GRID_R[1]}, epsilon {GRID_EPS[0]}..{GRID_EPS[1]}. Boundary error: the "
        "largest distance of the boundaries of the ranges near r = 1/2 and r = 1 for epsilon in "
        f"{CHECK_EPS}, bisected with that step count in a bracket of at most +-0.01 that holds no other "
        "boundary, from the reference (4096 steps per period; its own error, against "
        f"8192 steps, is {reference_error:.1e})."
    )
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
        found = instability_ranges(eps, 0.9, 1.25, samples=60, tolerance=tolerance, trace_tolerance=1e-9)
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


def sections() -> list[str]:
    """The torsion sections of docs/accuracy-vs-time.md."""
    reference, reference_error = _reference_boundaries()
    return [
        "## Variable-inertia crank: paper 002 Table 1",
        "",
        *table_1_section(reference),
        "",
        "## Variable-inertia crank: stability chart against step count",
        "",
        *chart_section(reference, reference_error),
        "",
        "## Variable-inertia crank: Floquet against the amplitude sweep",
        "",
        *floquet_vs_sweep(reference),
        "",
        "## Variable-inertia crank: integrator and tolerance against error",
        "",
        *integrator_section(),
        "",
    ]
