"""Accuracy against time of the physics core; writes docs/accuracy-vs-time.md and its figure.

Run with ``make bench`` (or ``python -m benchmarks.accuracy_vs_time``). Every
number in the document comes from this run. Times are the best of several
repeats (the machine is shared); ratios are taken within the run.
"""

from __future__ import annotations

import math
import os
import platform
import time
import timeit
from collections.abc import Callable
from datetime import UTC, datetime
from pathlib import Path

import numpy as np

from benchmarks.angle_domain import sections as angle_domain_sections
from benchmarks.scenes import sections as scene_sections
from benchmarks.torsion import sections as torsion_sections
from monitor import __version__
from monitor.fourier import cycle_grid, order_coefficients, synthesize
from monitor.model import kinematics as kin
from monitor.model.crankshaft import EngineModel
from monitor.model.engine import Engine, bundled_engines, load_engine
from monitor.model.forces import STANDARD_GRAVITY, CrankTrain
from monitor.model.predicted import predict_orders

ROOT = Path(__file__).resolve().parents[1]
DOC = ROOT / "docs" / "accuracy-vs-time.md"
FIGURE = ROOT / "docs" / "accuracy-vs-time.png"


def best_time(function: Callable[[], object], *, repeat: int = 7, min_seconds: float = 0.05) -> float:
    """Best time of one call [s], from ``repeat`` rounds of enough calls to last ``min_seconds``."""
    timer = timeit.Timer(function)
    number, _ = timer.autorange()
    number = max(1, int(number * min_seconds / 0.2))
    return min(timer.repeat(repeat=repeat, number=number)) / number


def _fmt_time(seconds: float) -> str:
    if seconds < 1e-3:
        return f"{seconds * 1e6:.1f} µs"
    return f"{seconds * 1e3:.2f} ms"


def kinematics_table() -> list[str]:
    rows = [
        "| engine | lambda | rpm | peak accel. [m/s²] | largest error [m/s²] | error / peak | "
        "inertia-force error [kN] | exact | approx | time ratio exact/approx |",
        "|---|---|---|---|---|---|---|---|---|---|",
    ]
    alpha = cycle_grid(3600)
    for engine_id in bundled_engines():
        e = load_engine(engine_id)
        w, r, lam = e.rated_speed, e.crank_radius, e.rod_ratio
        exact = kin.piston_acceleration(alpha, w, r, lam)
        approx = kin.piston_acceleration_approx(alpha, w, r, lam)
        err = float(np.max(np.abs(exact - approx)))
        peak = float(np.max(np.abs(exact)))
        args = (alpha, w, r, lam)
        t_exact = best_time(lambda args=args: kin.piston_acceleration(*args))
        t_approx = best_time(lambda args=args: kin.piston_acceleration_approx(*args))
        rows.append(
            f"| {e.id} | {lam:.4f} | {e.operation.rated_speed_rpm:g} | {peak:.2f} | {err:.3f} | "
            f"{err / peak:.2%} | {e.reciprocating_mass * err / 1e3:.3f} | {_fmt_time(t_exact)} | "
            f"{_fmt_time(t_approx)} | {t_exact / t_approx:.2f} |"
        )
    return rows


def truncation_table(e: Engine) -> tuple[list[str], dict[str, list[float]]]:
    w, r, lam = e.rated_speed, e.crank_radius, e.rod_ratio
    alpha = cycle_grid(4096)
    accel = kin.piston_acceleration(alpha, w, r, lam)
    check = cycle_grid(3600) + 0.3e-3  # off the FFT grid
    truth = kin.piston_acceleration(check, w, r, lam)
    t_exact = best_time(lambda: kin.piston_acceleration(check, w, r, lam))
    rows = [
        "| orders kept | truncation bound [m/s²] | measured largest error [m/s²] | "
        "time to evaluate the series | time ratio series/exact |",
        "|---|---|---|---|---|",
    ]
    data: dict[str, list[float]] = {"orders": [], "bound": [], "error": []}
    for k in (1, 2, 4, 6, 8, 10, 12, 16, 24):
        oc = order_coefficients(accel, max_order=k)
        err = float(np.max(np.abs(synthesize(oc, check) - truth)))
        t = best_time(lambda oc=oc: synthesize(oc, check))
        rows.append(
            f"| 1..{k} | {float(oc.truncation_error):.3g} | {err:.3g} | {_fmt_time(t)} | {t / t_exact:.1f} |"
        )
        data["orders"].append(k)
        data["bound"].append(float(oc.truncation_error))
        data["error"].append(max(err, 1e-16))
    rows.append("")
    rows.append(
        f"Exact closed form on the same 3600 angles: {_fmt_time(t_exact)}. The bound is the sum of "
        "the dropped orders' magnitudes; the measured error is on angles off the FFT grid."
    )
    return rows, data


def grid_table(e: Engine) -> tuple[list[str], dict[str, list[float]]]:
    speed = e.rated_speed
    reference = predict_orders(EngineModel(e, grid_size=1 << 16), crank_speed=speed, load=1.0, max_order=24)
    scale = float(np.abs(reference.engine_torque[1:]).max())
    rows = [
        "| samples per revolution | largest torque-order error [N m] | relative to largest order | "
        "model's own estimate [N m] | set-up | per operating point |",
        "|---|---|---|---|---|---|",
    ]
    data: dict[str, list[float]] = {"grid": [], "error": [], "estimate": [], "time": []}
    for n in (128, 256, 512, 1024, 2048, 4096, 8192):
        setup = best_time(lambda n=n: EngineModel(e, grid_size=n), repeat=3, min_seconds=0.02)
        model = EngineModel(e, grid_size=n)
        result = predict_orders(model, crank_speed=speed, load=1.0, max_order=24)
        cyl = np.abs(result.cylinder_torque - reference.cylinder_torque).max()
        per_point = best_time(
            lambda model=model: predict_orders(model, crank_speed=speed, load=1.0, max_order=24)
        )
        rows.append(
            f"| {n} | {cyl:.3g} | {cyl / scale:.2e} | {result.aliasing_error['torque']:.3g} | "
            f"{_fmt_time(setup)} | {_fmt_time(per_point)} |"
        )
        data["grid"].append(n)
        data["error"].append(max(float(cyl), 1e-16))
        data["estimate"].append(max(result.aliasing_error["torque"], 1e-16))
        data["time"].append(per_point)
    rows.append("")
    rows.append(
        "Error: largest difference of any cylinder-torque order 1..24 from a 65 536-point reference; "
        "the gas-pressure rise is the least smooth part and sets the convergence."
    )
    return rows, data


def order_table_cost() -> list[str]:
    rows = [
        "| engine | cycle | orders | main bearings | samples per cycle | set-up | per operating point |",
        "|---|---|---|---|---|---|---|",
    ]
    for engine_id in bundled_engines():
        e = load_engine(engine_id)
        setup = best_time(lambda e=e: EngineModel(e), repeat=3, min_seconds=0.02)
        model = EngineModel(e)
        per_point = best_time(
            lambda model=model, e=e: predict_orders(model, crank_speed=e.rated_speed, load=0.8)
        )
        rows.append(
            f"| {e.id} | {e.cycle} | 24 (step {1 / e.cycle_revolutions:g}) | {e.bearing_count} | "
            f"{model.grid_size} | {_fmt_time(setup)} | {_fmt_time(per_point)} |"
        )
    return rows


def rod_model_table() -> list[str]:
    rows = [
        "| engine | I_G [kg m²] | two-mass I [kg m²] | largest torque difference [kN m] | of peak torque | "
        "largest bearing-force difference [kN] | of peak bearing force |",
        "|---|---|---|---|---|---|---|",
    ]
    for engine_id in bundled_engines():
        e = load_engine(engine_id)
        out = {}
        for rod in ("rigid", "two-mass"):
            model = EngineModel(e, rod_model=rod)  # type: ignore[arg-type]
            out[rod] = model.cylinder_forces(e.rated_speed, 1.0)
        model = EngineModel(e)
        dt = np.abs(out["rigid"].torque - out["two-mass"].torque).max()
        peak_t = np.abs(out["rigid"].torque).max()
        fb = np.hypot(
            out["rigid"].pin_force_x - out["two-mass"].pin_force_x,
            out["rigid"].pin_force_y - out["two-mass"].pin_force_y,
        ).max()
        peak_f = np.hypot(out["rigid"].pin_force_x, out["rigid"].pin_force_y).max()
        rows.append(
            f"| {e.id} | {e.masses.conrod_inertia_kgm2:g} | {model.train.two_mass_inertia:.4g} | "
            f"{dt / 1e3:.4g} | {dt / peak_t:.2%} | {fb / 1e3:.4g} | {fb / peak_f:.2%} |"
        )
    return rows


def published_values() -> list[str]:
    rows = ["| source | quantity | published | this model |", "|---|---|---|---|"]
    k98 = load_engine("man-b-w-7k98mc")
    alpha = cycle_grid(36000)
    exact = kin.piston_acceleration(alpha, k98.rated_speed, k98.crank_radius, k98.rod_ratio)
    approx = kin.piston_acceleration_approx(alpha, k98.rated_speed, k98.crank_radius, k98.rod_ratio)
    diff = float(np.max(np.abs(exact - approx)))
    relative = diff / np.abs(exact).max()
    rows.append(f"| 000, Fig. 7 | 7K98MC exact − approx. acceleration | over 5 m/s² | {diff:.2f} m/s² |")
    rows.append(f"| 000, sec. 3 | the same, relative to the peak | about 3 % | {relative:.2%} |")
    rows.append(
        f"| 000, sec. 4 | inertia-force error of one cylinder | over 50 kN | "
        f"{k98.reciprocating_mass * diff / 1e3:.1f} kN (m_rec = {k98.reciprocating_mass:.0f} kg) |"
    )
    kl = load_engine("kluczyk-1cyl-4stroke")
    w = 1189 * math.pi / 30
    a = kin.piston_acceleration(alpha, w, kl.crank_radius, kl.rod_ratio)
    peak_inertia = kl.reciprocating_mass * np.abs(a).max()
    weight = kl.reciprocating_mass * STANDARD_GRAVITY
    rows.append(f"| 004 | peak reciprocating inertia force, 1189 rpm | 4601 N | {peak_inertia:.1f} N |")
    rows.append(f"| 004 | reciprocating weight | 44.28 N | {weight:.2f} N |")
    model = EngineModel(kl)
    f = model.cylinder_forces(w, 1.0)
    rows.append(f"| 004 | peak gas force | 19 830 N | {f.gas_force.max():.0f} N (combustion start tuned) |")
    rows += paper_003_rows()
    return rows


def paper_003_rows() -> list[str]:
    """Paper 003's printed numbers for the moving parts at 500 rpm, motored with the spark-plug hole open
    (no gas force: ``--gas none``), beside the model (its inertia forces of piston and rod summed at the
    crank pin, as the paper's F12: no weight, no crank unbalance; tests/model/test_paper003.py)."""
    train = CrankTrain.of(load_engine("zubaydi-1cyl-2stroke"))
    w = 500 * math.pi / 30
    alpha = cycle_grid(36000)
    piston = kin.piston_acceleration(alpha, w, train.crank_radius, train.rod_ratio)
    ax, ay = kin.rod_cg_acceleration(alpha, w, train.crank_radius, train.rod_ratio, train.rod_cg_fraction)
    rod = np.hypot(ax, ay)
    vertical = np.abs(train.piston_mass * -piston + train.rod_mass * ay).max()
    inferred = "(the engine file's value is inferred from it)"
    disagrees = "(disagrees with the paper's other numbers: engines.md)"
    values = [
        ("Fig. 8", "piston acceleration at TDC", "293 m/s²", f"{piston[0]:.1f} m/s² {inferred}"),
        ("Fig. 8", "piston acceleration, other extreme", "170 m/s²", f"{-piston.min():.1f} m/s² {inferred}"),
        (
            "Fig. 9",
            "rod centre-of-gravity acceleration, largest",
            "260 m/s²",
            f"{rod.max():.1f} m/s² {inferred}",
        ),
        ("Fig. 9", "the same, smallest", "121 m/s²", f"{rod.min():.1f} m/s² {inferred}"),
        (
            "Fig. 10",
            "piston inertia force at TDC",
            "59 N",
            f"{train.piston_mass * piston[0]:.2f} N {inferred}",
        ),
        (
            "Fig. 10",
            "the same, other extreme",
            "35 N",
            f"{-train.piston_mass * piston.min():.2f} N {inferred}",
        ),
        ("Fig. 11", "rod inertia force, largest", "27.5 N", f"{train.rod_mass * rod.max():.2f} N {inferred}"),
        (
            "Fig. 12",
            "main-bearing force, horizontal",
            "±12.5 N",
            f"±{np.abs(train.rod_mass * ax).max():.2f} N {disagrees}",
        ),
        (
            "Fig. 13",
            "main-bearing force, vertical, at 0°",
            "89 N",
            f"{vertical:.2f} N {disagrees}",
        ),
    ]
    return [f"| 003, {where} | {what} | {printed} | {model} |" for where, what, printed, model in values]


def figure(trunc: dict[str, list[float]], grid: dict[str, list[float]]) -> None:
    # matplotlib is heavy and wants its backend chosen before pyplot is imported: imported here only
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(12, 4.5), constrained_layout=True)
    ax = axes[0]
    ax.semilogy(trunc["orders"], trunc["bound"], "o-", label="truncation bound")
    ax.semilogy(trunc["orders"], trunc["error"], "s--", label="measured error")
    ax.set(
        xlabel="orders kept",
        ylabel="largest acceleration error [m/s²]",
        title="7K98MC exact piston acceleration: orders kept",
    )
    ax.grid(alpha=0.3, which="both")
    ax.legend()
    ax = axes[1]
    ax.loglog(grid["grid"], grid["error"], "o-", label="error against reference")
    ax.loglog(grid["grid"], grid["estimate"], "s--", label="model's own estimate")
    ax.set(
        xlabel="samples per revolution",
        ylabel="largest torque-order error [N m]",
        title="7K98MC torque orders: grid size",
    )
    ax.grid(alpha=0.3, which="both")
    ax2 = ax.twinx()
    ax2.loglog(grid["grid"], np.array(grid["time"]) * 1e3, "^:", color="tab:red", label="time per point")
    ax2.set_ylabel("time per operating point [ms]", color="tab:red")
    ax.legend(loc="lower left")
    fig.savefig(FIGURE, dpi=100)
    plt.close(fig)


def main() -> None:
    start = time.perf_counter()
    k98 = load_engine("man-b-w-7k98mc")
    print("kinematics ...", flush=True)
    kinem = kinematics_table()
    print("published values ...", flush=True)
    published = published_values()
    print("orders kept ...", flush=True)
    trunc_rows, trunc = truncation_table(k98)
    print("grid size ...", flush=True)
    grid_rows, grid = grid_table(k98)
    print("order-table cost ...", flush=True)
    cost = order_table_cost()
    print("rod models ...", flush=True)
    rods = rod_model_table()
    print("torsion ...", flush=True)

    torsion = torsion_sections()
    print("angle domain ...", flush=True)

    angle_domain = angle_domain_sections()
    print("scenes ...", flush=True)

    scenes = scene_sections()
    figure(trunc, grid)
    stamp = datetime.now(UTC).strftime("%Y-%m-%d %H:%M UTC")
    lines = [
        "# Accuracy against time",
        "",
        f"Written by `make bench` (`python -m benchmarks.accuracy_vs_time`) on {stamp}, engine-monitor "
        f"{__version__}, Python {platform.python_version()}, numpy {np.__version__}, "
        f"{platform.machine()} with {os.cpu_count()} cores (shared machine: times are the best of "
        "several repeats; "
        "compare ratios within this run). Do not edit by hand.",
        "",
        "## Published values",
        "",
        *published,
        "",
        "Paper 003's rows are its engine as the paper ran it: turned by a motor with the spark-plug hole "
        "open, so no gas force (`--gas none`; `--load 0` still compresses), at 500 rpm. Its bearing forces "
        "(F12, eq. 11-15) are the piston's and the rod's inertia forces summed at the crank pin and taken by "
        "one bearing; the product's `main_bearings` output also holds the crank's unbalance less its "
        "counterweight, the rod's inertia torque and the weights, and splits the throw's force over its two "
        "bearings. The paper's weights (17.285 N; -7.007 and -5.375 N) cannot be reconstructed: eq. 17-19 "
        "need lengths and weights the paper does not print. [engines.md](engines.md) derives the engine's "
        "values from the figures and says why two numbers disagree with the others.",
        "",
        "## Exact against approximate kinematics",
        "",
        "Largest difference over 3600 crank angles at rated speed between the exact acceleration "
        "(paper 000 eq. 10) and the two-term one (eq. 9); inertia-force error with the two-mass "
        "reciprocating mass; time of one evaluation on 3600 angles.",
        "",
        *kinem,
        "",
        "## Orders kept against truncation error",
        "",
        "Exact piston acceleration of the 7K98MC at 104 rpm represented by its orders 1..K.",
        "",
        *trunc_rows,
        "",
        "## Angular grid against order-coefficient error",
        "",
        "Torque orders of the 7K98MC at 104 rpm and rated load (rigid rod, parametric gas pressure).",
        "",
        *grid_rows,
        "",
        "![accuracy against time](accuracy-vs-time.png)",
        "",
        "## The whole order table per operating point",
        "",
        "All 24 orders of every cylinder's inertia force and torque, the engine torque, every main "
        "bearing's force and the free forces and moments (`predict_orders`), after set-up "
        "(`EngineModel`: kinematics and pressure basis on the grid, once per engine). Default grid "
        "1024 samples per revolution.",
        "",
        *cost,
        "",
        "## Rigid connecting rod against the two-mass split",
        "",
        "Rated speed and load. The two-mass split keeps mass and centre of gravity but implies the "
        "moment of inertia m k (1 − k) L²; the difference is the rod's inertia torque "
        "(I_G − m k (1 − k) L²) β''. Bearing force: the force on the crank pin.",
        "",
        *rods,
        "",
        *torsion,
        *angle_domain,
        *scenes,
        f"Benchmark run time: {time.perf_counter() - start:.0f} s.",
        "",
    ]
    DOC.write_text("\n".join(lines), encoding="utf-8")
    print(f"wrote {DOC.relative_to(ROOT)} and {FIGURE.relative_to(ROOT)}")


if __name__ == "__main__":
    main()
