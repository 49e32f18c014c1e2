"""``engine-monitor torsion ...``: the torsion models on the command line.

Subcommands: ``modes``, ``campbell``, ``response`` (of an engine's shaft line),
``stability`` and ``simulate`` (of the variable-inertia crank, paper 002).
Every one prints a table, or with ``--json`` a JSON document (fields in
docs/torsion-json.md), and with ``--plot FILE.png`` draws a figure.
"""

from __future__ import annotations

import argparse
import math
import sys
from typing import TYPE_CHECKING, Any

from monitor.cli.arguments import print_json

if TYPE_CHECKING:  # numpy is imported where a subcommand runs: every command's start-up builds this parser
    import numpy as np

__all__ = ["add_torsion_parser", "run_torsion"]


def _finite(text: str) -> float:
    """A finite number (argparse type): NaN and infinity are refused at the command line."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None
    if not math.isfinite(value):
        raise argparse.ArgumentTypeError(f"{text!r}: expected a finite number")
    return value


def _positive(text: str) -> float:
    """A positive, finite number (argparse type)."""
    value = _finite(text)
    if value <= 0:
        raise argparse.ArgumentTypeError(f"{text!r}: expected a positive number")
    return value


def _count(text: str) -> int:
    """A positive integer (argparse type)."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a whole number") from None
    if value < 1:
        raise argparse.ArgumentTypeError(f"{text!r}: expected a positive whole number")
    return value


def add_torsion_parser(sub: Any) -> None:
    """Register the ``torsion`` subcommands on an argparse subparsers object.

    Parameters
    ----------
    sub : argparse._SubParsersAction
        The top-level subparsers.
    """
    torsion = sub.add_parser(
        "torsion", help="torsional vibration: shaft-line modes, response, Campbell, stability"
    )
    tsub = torsion.add_subparsers(dest="torsion_command", required=True, metavar="TORSION_COMMAND")
    for add in (_add_modes, _add_campbell, _add_response, _add_axial, _add_stability, _add_simulate):
        _common(add(tsub))
    torsion.set_defaults(run=run_torsion)


def _common(p: argparse.ArgumentParser) -> None:
    """The output options every subcommand has."""
    p.add_argument("--json", action="store_true", help="print a JSON document instead of a table")
    p.add_argument("--plot", metavar="FILE.png", help="also draw a figure")


def _add_speed_range(p: argparse.ArgumentParser, low: int, high: int) -> None:
    """--rpm-min and --rpm-max, their defaults ``low`` and ``high`` per cent of the rated speed."""
    p.add_argument(
        "--rpm-min", type=_positive, default=None, help=f"lowest speed [rpm] (default {low} %% of rated)"
    )
    p.add_argument(
        "--rpm-max", type=_positive, default=None, help=f"highest speed [rpm] (default {high} %% of rated)"
    )


def _add_max_order(p: argparse.ArgumentParser) -> None:
    p.add_argument("--max-order", type=_positive, default=12.0, help="highest excitation order (default 12)")


def _add_modes(tsub: Any) -> argparse.ArgumentParser:
    modes = tsub.add_parser("modes", help="natural frequencies and mode shapes of an engine's shaft line")
    modes.add_argument("engine", metavar="ENGINE", help="engine description (TOML) or bundled id")
    modes.add_argument(
        "--reciprocating",
        choices=("mean", "none"),
        default="mean",
        help="add the mean reciprocating inertia to each throw (default) or not",
    )
    return modes


def _add_campbell(tsub: Any) -> argparse.ArgumentParser:
    camp = tsub.add_parser("campbell", help="critical speeds: excitation orders against natural frequencies")
    camp.add_argument("engine", metavar="ENGINE")
    _add_speed_range(camp, 20, 110)
    _add_max_order(camp)
    return camp


def _add_response(tsub: Any) -> argparse.ArgumentParser:
    resp = tsub.add_parser("response", help="forced torsional response over a speed range")
    resp.add_argument("engine", metavar="ENGINE")
    _add_speed_range(resp, 30, 105)
    resp.add_argument("--steps", type=int, default=120, help="speeds computed (default 120)")
    resp.add_argument(
        "--load",
        default="propeller",
        help="fraction of rated IMEP, or 'propeller' for IMEP ~ speed^2 (default)",
    )
    resp.add_argument("--node", default=None, help="node reported (default: the tooth-wheel node)")
    _add_max_order(resp)
    return resp


def _add_axial(tsub: Any) -> argparse.ArgumentParser:
    axial = tsub.add_parser(
        "axial", help="coupled torsional-axial crankshaft (paper 001): modes and axial response"
    )
    axial.add_argument("engine", metavar="ENGINE")
    _add_speed_range(axial, 30, 105)
    axial.add_argument("--steps", type=int, default=60, help="speeds computed (default 60)")
    axial.add_argument("--load", default="propeller", help="fraction of rated IMEP, or 'propeller' (default)")
    _add_max_order(axial)
    return axial


def _add_stability(tsub: Any) -> argparse.ArgumentParser:
    stab = tsub.add_parser(
        "stability", help="Floquet stability chart of the variable-inertia crank (paper 002)"
    )
    stab.add_argument("--r-min", type=_finite, default=0.3)
    stab.add_argument("--r-max", type=_finite, default=1.5)
    stab.add_argument("--eps-min", type=_finite, default=0.0)
    stab.add_argument("--eps-max", type=_finite, default=0.6)
    stab.add_argument("--points", type=int, default=200, help="grid points per axis (default 200)")
    stab.add_argument("--zeta", type=_finite, default=0.0, help="damping ratio (default 0)")
    stab.add_argument(
        "--tolerance",
        type=_positive,
        default=1e-6,
        help="accuracy of the stability boundaries in r; sets the Magnus step count (default 1e-6)",
    )
    stab.add_argument(
        "--steps",
        type=_count,
        default=None,
        help="Magnus steps per period instead of those --tolerance asks for",
    )
    stab.add_argument(
        "--epsilon",
        type=_finite,
        action="append",
        default=None,
        help="also list the instability ranges of r for this epsilon (repeatable)",
    )
    return stab


def _add_simulate(tsub: Any) -> argparse.ArgumentParser:
    sim = tsub.add_parser("simulate", help="time response of the variable-inertia crank (paper 002 Fig. 2-5)")
    sim.add_argument("--epsilon", type=_finite, required=True, help="inertia ratio, 0 <= epsilon < 1")
    sim.add_argument("--r", type=_positive, required=True, help="speed ratio, > 0")
    sim.add_argument("--zeta", type=_finite, default=0.0, help="damping ratio (default 0)")
    sim.add_argument("--revolutions", type=_positive, default=2.0, help="length of the run (default 2)")
    sim.add_argument("--samples", type=int, default=2000, help="output samples per revolution (default 2000)")
    sim.add_argument("--form", choices=("linear", "full"), default="linear")
    sim.add_argument(
        "--integrator",
        choices=("periodic", "RK45", "DOP853", "Radau", "BDF", "LSODA"),
        default=None,
        help="default: periodic for the linear form, DOP853 for the full one",
    )
    sim.add_argument("--rtol", type=_positive, default=1e-10)
    sim.add_argument(
        "--initial",
        type=_finite,
        nargs=2,
        default=(1.0, 0.0),
        metavar=("GAMMA", "GAMMA_PRIME"),
        help="initial twist [rad] and its rate (default 1 0, as paper 002)",
    )
    return sim


def _emit(args: argparse.Namespace, document: dict[str, Any], table: str) -> None:
    if args.json:
        print_json(document)
    else:
        print(table)


def run_torsion(args: argparse.Namespace) -> int:
    """Run a ``torsion`` subcommand.

    Parameters
    ----------
    args : argparse.Namespace
        Parsed arguments.

    Returns
    -------
    int
        Exit status.
    """
    handler = {
        "modes": _modes,
        "campbell": _campbell,
        "response": _response,
        "axial": _axial,
        "stability": _stability,
        "simulate": _simulate,
    }[args.torsion_command]
    handler(args)
    if args.plot:
        print(f"plot written to {args.plot}", file=sys.stderr)
    return 0


def _modes(args: argparse.Namespace) -> None:
    import numpy as np

    from monitor.model.engine import load_engine
    from monitor.report.torsion_plots import plot_modes
    from monitor.torsion.shaft_line import shaft_line_of

    engine = load_engine(args.engine)
    modes = shaft_line_of(engine, reciprocating=args.reciprocating).modes()
    names = modes.node_names
    lines = [f"Torsional modes of {engine.id} (reciprocating inertia: {args.reciprocating})", ""]
    lines.append(f"{'mode':>4} {'frequency [Hz]':>15}   relative twist per node (largest = 1)")
    for i, f in enumerate(modes.frequencies_hz):
        shape = modes.shapes[:, i] / np.abs(modes.shapes[:, i]).max()
        lines.append(f"{i + 1:4d} {f:15.3f}   " + " ".join(f"{v:6.2f}" for v in shape))
    lines.append("nodes: " + ", ".join(names))
    document = {
        "engine": engine.id,
        "nodes": list(names),
        "frequencies_hz": [float(f) for f in modes.frequencies_hz],
        "mode_shapes": [
            [float(v) for v in modes.shapes[:, i] / np.abs(modes.shapes[:, i]).max()]
            for i in range(modes.frequencies.size)
        ],
        "rigid_body_modes": modes.rigid_body_modes,
    }
    _emit(args, document, "\n".join(lines))
    if args.plot:
        plot_modes(modes, args.plot, title=f"{engine.name}: torsional modes")


def _campbell(args: argparse.Namespace) -> None:
    import numpy as np

    from monitor.model.engine import load_engine
    from monitor.report.torsion_plots import plot_campbell
    from monitor.torsion.shaft_line import campbell, shaft_line_of

    engine = load_engine(args.engine)
    rated = engine.operation.rated_speed_rpm
    lo = args.rpm_min if args.rpm_min is not None else 0.2 * rated
    hi = args.rpm_max if args.rpm_max is not None else 1.1 * rated
    step = 1 / engine.cycle_revolutions
    orders = np.arange(step, args.max_order + step / 2, step)
    data = campbell(shaft_line_of(engine).modes(), orders, (lo, hi))
    lines = [f"Campbell data of {engine.id}, {lo:.1f} to {hi:.1f} rpm, orders up to {args.max_order:g}", ""]
    lines.append("natural frequencies [Hz]: " + ", ".join(f"{f:.3f}" for f in data.frequencies_hz[:8]))
    lines.append("")
    lines.append(f"{'mode':>4} {'order':>6} {'critical speed [rpm]':>21}")
    for mode, order, rpm in data.critical_speeds_rpm:
        lines.append(f"{mode:4d} {order:6.1f} {rpm:21.1f}")
    document = {
        "engine": engine.id,
        "speed_range_rpm": list(data.speed_range_rpm),
        "frequencies_hz": [float(f) for f in data.frequencies_hz],
        "orders": [float(k) for k in data.orders],
        "critical_speeds": [{"mode": m, "order": o, "speed_rpm": s} for m, o, s in data.critical_speeds_rpm],
    }
    _emit(args, document, "\n".join(lines))
    if args.plot:
        plot_campbell(data, args.plot, title=f"{engine.name}: Campbell diagram", rated_rpm=rated)


def _response(args: argparse.Namespace) -> None:
    import numpy as np

    from monitor.model.engine import load_engine
    from monitor.report.torsion_plots import plot_response
    from monitor.torsion.shaft_line import engine_forced_response, shaft_line_of

    engine = load_engine(args.engine)
    speeds = _speed_range(args, engine.operation.rated_speed_rpm)
    load = _load(args.load)
    line = shaft_line_of(engine)
    node_name = (
        args.node or (engine.shaft_line.tooth_wheel if engine.shaft_line else None) or line.node_names[-1]
    )
    node = line.index(node_name)
    response = engine_forced_response(engine, speeds, load=load, max_order=args.max_order, line=line)  # type: ignore[arg-type]
    amplitude = np.abs(response.angle[node])
    fluctuation = np.abs(response.speed_fluctuation[node])
    strongest = np.argsort(amplitude.max(axis=0))[::-1][:6]
    lines = [f"Forced torsional response of {engine.id} at '{node_name}', load {args.load}", ""]
    lines.append(
        f"{'rpm':>8} {'sum [mrad]':>11} "
        + " ".join(f"{'k=' + format(response.orders[j], 'g'):>9}" for j in strongest)
    )
    for i in range(0, speeds.size, max(1, speeds.size // 24)):
        lines.append(
            f"{speeds[i] * 30 / math.pi:8.1f} {amplitude[i].sum() * 1e3:11.4f} "
            + " ".join(f"{amplitude[i, j] * 1e3:9.4f}" for j in strongest)
        )
    peak = int(np.argmax(amplitude.sum(axis=1)))
    lines.append("")
    lines.append(
        f"largest: {amplitude[peak].sum() * 1e3:.4f} mrad at {speeds[peak] * 30 / math.pi:.1f} rpm; "
        f"speed fluctuation there {fluctuation[peak].sum() * 30 / math.pi:.4f} rpm (sum of orders)"
    )
    document = {
        "engine": engine.id,
        "node": node_name,
        "load": args.load,
        "speed_rpm": [float(s * 30 / math.pi) for s in speeds],
        "orders": [float(k) for k in response.orders],
        "angle_mrad": {
            "amplitude": (amplitude * 1e3).tolist(),
            "phase_deg": np.degrees(np.angle(response.angle[node])).tolist(),
        },
        "speed_fluctuation_rpm": (fluctuation * 30 / math.pi).tolist(),
        "max_condition_number": float(response.condition.max()),
    }
    _emit(args, document, "\n".join(lines))
    if args.plot:
        plot_response(response, node, args.plot, title=f"{engine.name}: torsional response at {node_name}")


def _speed_range(args: argparse.Namespace, rated: float) -> np.ndarray:
    import numpy as np

    from monitor.errors import ModelError

    lo = args.rpm_min if args.rpm_min is not None else 0.3 * rated
    hi = args.rpm_max if args.rpm_max is not None else 1.05 * rated
    if not 0 < lo < hi or args.steps < 2:
        raise ModelError(f"expected 0 < rpm-min < rpm-max and at least 2 steps, got {lo}, {hi}, {args.steps}")
    return np.linspace(lo, hi, args.steps) * math.pi / 30


def _load(text: str) -> float | str:
    from monitor.errors import ModelError

    if text == "propeller":
        return text
    try:
        return float(text)
    except ValueError:
        raise ModelError(f"--load {text!r}: expected a number 0..1.1 or 'propeller'") from None


def _axial(args: argparse.Namespace) -> None:
    import numpy as np

    from monitor.model.engine import load_engine
    from monitor.torsion.axial_coupling import AxialTorsionalCrankshaft, engine_axial_response

    engine = load_engine(args.engine)
    model = AxialTorsionalCrankshaft.of_engine(engine)
    frequencies, share = model.modes()
    speeds = _speed_range(args, engine.operation.rated_speed_rpm)
    response = engine_axial_response(
        engine, speeds, load=_load(args.load), max_order=args.max_order, model=model
    )
    free_end = np.abs(response.axial[0]) * 1e6  # journal 1 [um]
    lines = [f"Coupled torsional-axial crankshaft of {engine.id} (paper 001)", ""]
    lines.append(f"{'mode':>4} {'frequency [Hz]':>15} {'axial share':>12}")
    for i, (f, s) in enumerate(zip(frequencies[:10], share[:10], strict=False)):
        lines.append(f"{i + 1:4d} {f / (2 * math.pi):15.3f} {s:12.3f}")
    lines.append("")
    lines.append("axial vibration at the free-end journal driven by the torque orders [um]:")
    strongest = np.argsort(free_end.max(axis=0))[::-1][:5]
    head = " ".join(f"{'k=' + format(response.orders[j], 'g'):>9}" for j in strongest)
    lines.append(f"{'rpm':>8} {'sum':>9} {head}")
    for i in range(0, speeds.size, max(1, speeds.size // 20)):
        cells = " ".join(f"{free_end[i, j]:9.2f}" for j in strongest)
        lines.append(f"{speeds[i] * 30 / math.pi:8.1f} {free_end[i].sum():9.2f} {cells}")
    document = {
        "engine": engine.id,
        "frequencies_hz": (frequencies / (2 * math.pi)).tolist(),
        "axial_share": share.tolist(),
        "couplings_m_per_nm": [c.coupling for c in model.cranks],
        "speed_rpm": (speeds * 30 / math.pi).tolist(),
        "orders": response.orders.tolist(),
        "free_end_axial_um": free_end.tolist(),
    }
    _emit(args, document, "\n".join(lines))
    if args.plot:
        from monitor.report.torsion_plots import plot_axial

        plot_axial(
            speeds * 30 / math.pi,
            response.orders,
            free_end,
            args.plot,
            title=f"{engine.name}: axial vibration of the free end driven by torsion",
        )


#: Chart work (cells x Magnus steps per period) above which a progress bar is shown: about 1 s at
#: the ten million cell-steps per second of the chart timings in docs/accuracy-vs-time.md, so about
#: 2 s on a machine half as fast or half as free.
_PROGRESS_WORK = 1e7


def _stability(args: argparse.Namespace) -> None:
    import numpy as np

    from monitor.errors import ModelError
    from monitor.report.torsion_plots import plot_stability
    from monitor.runtime.progress import progress_bar
    from monitor.torsion.stability import boundary_steps, instability_ranges, stability_chart

    if args.points < 2 or not (0 < args.r_min < args.r_max) or not (0 <= args.eps_min < args.eps_max < 1):
        raise ModelError("expected points >= 2, 0 < r-min < r-max and 0 <= eps-min < eps-max < 1")
    if args.zeta < 0:
        raise ModelError(f"--zeta {args.zeta!r}: expected a non-negative damping ratio")
    r = np.linspace(args.r_min, args.r_max, args.points)
    eps = np.linspace(args.eps_min, args.eps_max, args.points)
    steps = args.steps or boundary_steps(args.tolerance, r_min=args.r_min, epsilon_max=args.eps_max)
    if args.points * args.points * steps > _PROGRESS_WORK:
        # the work was estimated long: the bar is shown from the start
        with progress_bar(args.points, "stability chart", unit="row", delay_s=0.0) as report:
            chart = stability_chart(r, eps, zeta=args.zeta, steps=steps, progress=report)
    else:
        chart = stability_chart(r, eps, zeta=args.zeta, steps=steps)
    ranges = {
        e: instability_ranges(
            e, args.r_min, args.r_max, zeta=args.zeta, tolerance=args.tolerance, steps=args.steps
        )
        for e in (args.epsilon or [])
    }
    lines = [
        f"Stability of the variable-inertia crank: r {args.r_min:g}..{args.r_max:g}, epsilon "
        f"{args.eps_min:g}..{args.eps_max:g}, {args.points} x {args.points} points, zeta {args.zeta:g}",
        f"unstable share of the chart: {chart.unstable.mean():.1%} (Magnus steps per period: {chart.steps}, "
        f"boundaries within {chart.boundary_error:.1e} in r)",
    ]
    for e, found in ranges.items():
        lines.append(
            f"epsilon {e:g}: unstable for r in "
            + (", ".join(f"[{a:.7f}, {b:.7f}]" for a, b in found) or "none")
        )
    document = {
        "r": r.tolist(),
        "epsilon": eps.tolist(),
        "zeta": args.zeta,
        "steps": chart.steps,
        "boundary_error": None if math.isnan(chart.boundary_error) else chart.boundary_error,
        "unstable": chart.unstable.astype(int).tolist(),
        "growth_rate": chart.growth_rate.tolist(),
        "instability_ranges": {str(e): [list(x) for x in found] for e, found in ranges.items()},
    }
    _emit(args, document, "\n".join(lines))
    if args.plot:
        marks = {
            f"ranges for epsilon {e:g}": [(x, e) for pair in found for x in pair]
            for e, found in ranges.items()
        }
        plot_stability(chart, args.plot, marks=marks)


def _simulate(args: argparse.Namespace) -> None:
    import numpy as np

    from monitor.errors import ModelError
    from monitor.report.torsion_plots import plot_time_response
    from monitor.torsion.time_response import Integrator, simulate
    from monitor.torsion.variable_inertia import VariableInertiaCrank

    if not (args.revolutions > 0 and args.samples >= 8):
        raise ModelError("expected revolutions > 0 and at least 8 samples per revolution")
    crank = VariableInertiaCrank(args.epsilon, args.r, zeta=args.zeta)
    integrator: Integrator = args.integrator or ("periodic" if args.form == "linear" else "DOP853")
    n = round(args.revolutions * args.samples) + 1
    tau = np.linspace(0, 2 * math.pi * args.revolutions, n)
    out = simulate(
        crank,
        tau,
        initial=tuple(args.initial),
        form=args.form,
        integrator=integrator,
        rtol=args.rtol,
        atol=args.rtol * 1e-2,
    )
    lines = [
        f"Variable-inertia crank: epsilon {args.epsilon:g}, r {args.r:g}, zeta {args.zeta:g}, "
        f"{args.form} form, {integrator}; {args.revolutions:g} revolutions",
        f"largest |gamma| {np.abs(out.gamma).max():.6g} rad; at the end gamma {out.gamma[-1]:.6g} rad",
    ]
    document = {
        "epsilon": args.epsilon,
        "r": args.r,
        "zeta": args.zeta,
        "form": args.form,
        "integrator": integrator,
        "revolutions": (out.tau / (2 * math.pi)).tolist(),
        "gamma_rad": out.gamma.tolist(),
    }
    _emit(args, document, "\n".join(lines))
    if args.plot:
        plot_time_response(out, args.plot, title=f"epsilon {args.epsilon:g}, r {args.r:g} ({args.form})")
