"""``engine-monitor compare`` and ``calibrate``: a recording's diagnosis; a healthy recording's baseline.

``compare`` is the use case :func:`monitor.jobs.analyse.analyse`, as the batch
and the service run it: its exit status is the health found (0 healthy, 1
warning, 2 alarm, 3 could not diagnose).

What a command needs is imported where it runs: the quick commands build this
module's parsers at start-up (:mod:`monitor.cli.main`).
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path
from typing import Any

from monitor.cli.arguments import (
    ENGINE_MISSING,
    add_cycle_phase,
    add_exclude_channel,
    exit_3_on_usage_error,
    print_json,
)
from monitor.errors import MonitorError
from monitor.runtime.progress import progress_bar

__all__ = ["add_calibrate_parser", "add_compare_parser", "run_calibrate", "run_compare"]


def add_compare_parser(sub: Any) -> None:
    """Add the ``compare`` command (its usage errors exit with 3).

    Parameters
    ----------
    sub : argparse subparsers
        The CLI's ``add_subparsers()`` action.
    """
    compare = sub.add_parser(
        "compare",
        help="diagnose a recording: measured against predicted orders, findings (exit 0/1/2/3)",
        description="Compare a recording's measured orders with the engine's model: crank-speed orders and "
        "the cylinder balance, bearing sensors' orders through a baseline's calibrated transfer, impacts "
        "in each bearing's load-reversal windows, rms velocity against zones. Exit status: 0 healthy, "
        "1 warning, 2 alarm, 3 could not diagnose.",
    )
    compare.add_argument("recording", metavar="RECORDING", help="HDF5 or MCAP recording")
    compare.add_argument("--engine", metavar="E.toml", help="engine description (default: the bundled one)")
    compare.add_argument(
        "--baseline",
        metavar="B",
        help="a healthy baseline: its calibration (.json, from 'calibrate') or a recording to calibrate on",
    )
    compare.add_argument(
        "--load",
        type=float,
        help="load the engine ran at, fraction of rated, as a log reads it (+-0.1); default: read from "
        "the speed on a baseline of several loads along a propeller curve, else estimated from the "
        "crank-speed orders against the baseline, else the baseline's, else 1",
    )
    compare.add_argument(
        "--segment-loads",
        type=_loads,
        default=(),
        metavar="L1,L2,...",
        help="a recording that crosses operating points: the load of each steady segment, in time order",
    )
    compare.add_argument(
        "--transfer",
        choices=("rigid", "shaft-line"),
        default="rigid",
        help="torque to crank speed: the rigid engine side (default) or the shaft line's receptance",
    )
    compare.add_argument("--json", action="store_true", help="print a JSON document instead of tables")
    add_exclude_channel(compare)
    compare.add_argument("--plot", metavar="FILE.png|FILE.html", help="also draw measured against predicted")
    add_cycle_phase(compare, unknown=True)
    compare.error = exit_3_on_usage_error(compare)
    compare.set_defaults(run=run_compare)


def _loads(text: str) -> tuple[float, ...]:
    """``--segment-loads``: loads separated by commas, each a fraction of rated from 0 to 1.1."""
    try:
        loads = tuple(float(part) for part in text.split(","))
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"{text!r}: expected loads separated by commas, e.g. 1.0,0.5"
        ) from None
    if not all(0.0 <= v <= 1.1 for v in loads):
        raise argparse.ArgumentTypeError(f"{text!r}: each load is a fraction of rated, from 0 to 1.1")
    return loads


def run_compare(args: argparse.Namespace) -> int:
    """Run ``engine-monitor compare``: the diagnosis' tables or JSON document, and its figure if asked.

    Parameters
    ----------
    args : argparse.Namespace
        The parsed command line.

    Returns
    -------
    int
        0 healthy, 1 warning, 2 alarm, 3 inconclusive.
    """
    from monitor.jobs.analyse import AnalysisOptions, analyse

    def calibrated(healthy: str) -> None:
        print(
            f"calibrated on {healthy} (store it with 'engine-monitor calibrate' to reuse it)", file=sys.stderr
        )

    analysis = analyse(
        args.recording,
        engine=args.engine,
        baseline=args.baseline,
        options=AnalysisOptions(
            load=args.load,
            transfer=args.transfer,
            cycle_phase=args.cycle_phase,
            exclude=tuple(args.exclude_channel),
            segment_loads=args.segment_loads,
        ),
        engine_missing=ENGINE_MISSING,
        calibrated=calibrated,
        progress=lambda: progress_bar(1.0, "diagnosing", unit="recording"),
    )
    table = analysis.table()
    if args.json:
        print_json(analysis.diagnosis_document())
    else:
        print(table)
    if args.plot:
        from monitor.report.plots import plot_diagnosis

        try:
            path = plot_diagnosis(
                analysis.diagnosis, args.plot, title=analysis.title, table=table, recording=analysis.name
            )
        except OSError as error:
            raise MonitorError(f"--plot {args.plot}: cannot be written ({error.strerror or error})") from None
        print(f"plot written to {path}", file=sys.stderr)
    return analysis.exit_status


def add_calibrate_parser(sub: Any) -> None:
    """Add the ``calibrate`` command.

    Parameters
    ----------
    sub : argparse subparsers
        The CLI's ``add_subparsers()`` action.
    """
    calibrate = sub.add_parser(
        "calibrate",
        help="calibrate a healthy baseline recording's sensors, for later comparisons",
        description="Calibrate, on a healthy recording, the tooth wheel's pitch errors, the crank-speed "
        "model and each main-bearing sensor's transfer from bearing force to its orders, its impact profile "
        "and rms velocity; write them as JSON for 'compare --baseline'. A recording of the crank speed alone "
        "(a tooth wheel, a cam) calibrates without bearing sensors: the main bearings are then not judged.",
    )
    calibrate.add_argument(
        "recording",
        nargs="+",
        metavar="RECORDING",
        help="healthy HDF5 or MCAP recording; several, one per operating point (load), for a baseline "
        "that spans them",
    )
    calibrate.add_argument(
        "-o",
        "--output",
        required=True,
        metavar="BASELINE.json|TRANSFERS.toml",
        help="the baseline (JSON), or its transfers as [[sensor_transfers]] for the engine file (.toml)",
    )
    calibrate.add_argument("--engine", metavar="E.toml", help="engine description (default: the bundled one)")
    calibrate.add_argument(
        "--load",
        type=float,
        action="append",
        help="load it ran at, fraction of rated; once per recording, in the same order (default: 1 for "
        "one recording, estimated from the crank-speed orders for several)",
    )
    calibrate.add_argument(
        "--pitch-from",
        metavar="RUN",
        help="learn the tooth wheel's pitch errors at every order, firing harmonics included, on this "
        "run of the same wheel whose speed changes by a quarter or more: a motored run-up or a "
        "coast-down with the fuel cut (default: on RECORDING, firing harmonics left to the engine)",
    )
    add_cycle_phase(calibrate)
    add_exclude_channel(calibrate)
    calibrate.set_defaults(run=run_calibrate)


def run_calibrate(args: argparse.Namespace) -> int:
    """Run ``engine-monitor calibrate``: the baseline (or its sensor transfers) written.

    Parameters
    ----------
    args : argparse.Namespace
        The parsed command line.

    Returns
    -------
    int
        0.
    """
    from monitor.jobs.calibration import calibrate_recordings

    as_toml = Path(args.output).suffix.lower() == ".toml"  # [[sensor_transfers]] tables for an engine file
    several = len(args.recording) > 1
    if not as_toml and Path(args.output).suffix.lower() != ".json":
        raise MonitorError(f"-o {args.output}: expected a .json (baseline) or .toml (sensor transfers) file")
    if several and as_toml:
        raise MonitorError(
            f"-o {args.output}: an engine file's sensor transfers hold at one speed: calibrate one recording"
        )
    with progress_bar(1.0, "calibrating", unit="recording") as report:
        calibrated = calibrate_recordings(
            args.recording,
            loads=args.load,
            engine=args.engine,
            cycle_phase=args.cycle_phase,
            pitch_from=args.pitch_from,
            exclude=args.exclude_channel,
            engine_missing=ENGINE_MISSING,
            progress=report,
        )
    for note in calibrated.notes:
        print(note, file=sys.stderr)
    points = calibrated.points
    baseline = points.points[-1]
    if as_toml and not baseline.sensors:
        raise MonitorError(
            f"-o {args.output}: {args.recording[0]} has no main-bearing vibration channel, so no sensor "
            "transfer to write; write the baseline (.json) instead"
        )
    try:
        if as_toml:
            path = Path(args.output)
            path.write_text(baseline.to_toml())
        else:
            path = points.write(args.output)
    except OSError as error:
        raise MonitorError(f"-o {args.output}: cannot be written ({error.strerror or error})") from None
    if several:
        at = ", ".join(f"load {p.load:.2f} at {p.speed_rpm:.2f} rpm ({p.source})" for p in points.points)
        print(
            f"baseline of {points.engine_id} at {len(points.points)} operating points: {at}", file=sys.stderr
        )
    sensors = ", ".join(f"{n} (main bearing {s.bearing})" for n, s in baseline.sensors.items())
    print(
        f"baseline of {points.engine_id} at {baseline.speed_rpm:.2f} rpm written to {path}: "
        + (
            sensors
            or "no bearing sensor calibrated (the recording has no main-bearing vibration channel): "
            "the main bearings will not be judged against it, the cylinders and the crank speed will"
        ),
        file=sys.stderr,
    )
    if (crank := baseline.crank) is not None and crank.orders.size:
        print(
            f"crank-speed model ({crank.transfer}) calibrated at orders "
            f"{', '.join(f'{k:g}' for k in crank.orders)}",
            file=sys.stderr,
        )
    if (pitch := baseline.pitch) is not None:
        where = f"the run {args.pitch_from}" if pitch.source == "run-up" else "the baseline"
        kept = (
            f", orders {', '.join(map(str, pitch.kept_orders))} left to the engine"
            if pitch.kept_orders
            else ""
        )
        spread = (
            ""
            if math.isnan(pitch.standard_error)
            else f", standard error {math.degrees(pitch.standard_error):.2g} deg"
        )
        print(
            f"tooth-pitch errors of {baseline.pitch_channel!r} learned on {where} ({pitch.revolutions} "
            f"revolutions{kept}): rms {math.degrees(pitch.rms):.3f} deg, largest "
            f"{math.degrees(pitch.largest):.3f} deg{spread}",
            file=sys.stderr,
        )
    return 0
