"""The ``engine-monitor`` command line.

Subcommands:

- ``orders``: the predicted order table of an engine at an operating point.
- ``engines``: the bundled engine descriptions.
- ``torsion ...``: shaft-line modes, Campbell data and forced response of an
  engine, and the stability chart and time response of the variable-inertia
  crank (see :mod:`monitor.cli.torsion`).
- ``trend``: an engine's quantities over time from the results store, and the
  drift found in them (see :mod:`monitor.cli.trend`).
- ``spectrum``, ``import``, ``simulate``: order spectra of a recording,
  test-bench imports, scenes.
- ``compare``: a recording's measured orders against the model, and the
  findings (:mod:`monitor.diagnosis`); ``calibrate``: a healthy baseline's
  calibration, stored for later comparisons.

Errors the product raises on purpose (bad engine file, out-of-range input)
print one clear message and exit with status 2; the table goes to standard
output, messages to standard error. ``compare`` exits with the health it
found instead: 0 healthy, 1 warning, 2 alarm, and 3 when it cannot diagnose
(an error, a usage error included); ``batch`` likewise with the worst over
the recordings in its scope (see :mod:`monitor.jobs.batch`).
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from collections.abc import Sequence
from contextlib import ExitStack
from pathlib import Path
from typing import TYPE_CHECKING, Any

from monitor import __version__
from monitor.cli.torsion import add_torsion_parser, run_torsion
from monitor.cli.trend import add_trend_parser, run_trend
from monitor.errors import MonitorError
from monitor.runtime.progress import progress_bar, progress_counter

if TYPE_CHECKING:
    from monitor.io.recording import Recording

__all__ = ["main"]

_DIAGNOSING = ("compare", "batch")  # their 2 is an alarm: their errors exit with 3, could not diagnose


def _positive_float(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None
    if not value > 0 or value != value or value == float("inf"):
        raise argparse.ArgumentTypeError(f"{text!r}: expected a positive, finite number")
    return value


def _positive_int(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a whole number") from None
    if value < 1:
        raise argparse.ArgumentTypeError(f"{text!r}: expected 1 or more")
    return value


def _count(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a whole number") from None
    if value < 0:
        raise argparse.ArgumentTypeError(f"{text!r}: expected 0 or more")
    return value


def _seed(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a whole number") from None
    if not 0 <= value < 2**63:
        raise argparse.ArgumentTypeError(f"{text!r}: expected a seed from 0 to 2**63 - 1")
    return value


def _port(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a whole number") from None
    if not 1 <= value <= 65535:
        raise argparse.ArgumentTypeError(f"{value}: expected a TCP port, 1 to 65535")
    return value


def _build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="engine-monitor",
        description="Condition monitoring of large reciprocating engines: predicted and measured orders.",
    )
    parser.add_argument("--version", action="version", version=f"%(prog)s {__version__}")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")

    orders = sub.add_parser(
        "orders",
        help="predicted orders of forces and torque at an operating point",
        description=(
            "Predicted order coefficients of the inertia force of each cylinder, the engine's "
            "torque and the force at each main bearing, with free forces and moments. "
            "Amplitudes are peak values in kN and kN m; phases in degrees relative to TDC of "
            "cylinder 1."
        ),
    )
    orders.add_argument(
        "engine", metavar="ENGINE", help="engine description (TOML file) or a bundled engine id"
    )
    orders.add_argument("--rpm", type=_positive_float, required=True, help="crank speed [rpm]")
    orders.add_argument(
        "--load",
        type=float,
        default=1.0,
        help="fraction of rated IMEP, 0..1.1 (default 1.0); sets the gas pressure of the parametric cycle",
    )
    orders.add_argument("--max-order", type=float, default=24.0, help="highest order reported (default 24)")
    orders.add_argument(
        "--kinematics",
        choices=("exact", "approx"),
        default="exact",
        help="exact slider-crank kinematics (default) or the two-term approximation",
    )
    orders.add_argument(
        "--rod-model",
        choices=("rigid", "two-mass"),
        default=None,
        help="connecting rod as a rigid body (default with exact kinematics) or the two-mass split "
        "(default and required with --kinematics approx)",
    )
    orders.add_argument(
        "--gas",
        choices=("auto", "parametric", "measured", "none"),
        default="auto",
        help="cylinder pressure: measured trace if the engine has one, else parametric (auto); "
        "none for inertia only",
    )
    orders.add_argument("--grid", type=int, default=1024, help="samples per revolution (default 1024)")
    orders.add_argument(
        "--json", action="store_true", help="print the JSON document (docs/orders-json.md) instead of tables"
    )
    orders.add_argument("--plot", metavar="FILE.png", help="also write a figure of the orders")

    spectrum = sub.add_parser(
        "spectrum",
        help="order spectra of a recording's channels",
        description=(
            "Resample a recording's channels to the crank-angle domain and compute their order spectra "
            "(peak amplitude in the channel's unit, phase in degrees relative to TDC of cylinder 1), "
            "with the crank-speed fluctuation orders."
        ),
    )
    spectrum.add_argument("recording", metavar="RECORDING", help="recording file (.h5 or .mcap)")
    spectrum.add_argument(
        "--engine", help="engine description (default: the recording's engine id, if bundled)"
    )
    spectrum.add_argument(
        "--cycle", choices=("two-stroke", "four-stroke"), help="override the engine's cycle"
    )
    spectrum.add_argument("--channel", action="append", help="channel to analyse (repeatable; default: all)")
    spectrum.add_argument(
        "--orders", help="comma-separated orders to list (default: every order to --max-order)"
    )
    spectrum.add_argument(
        "--max-order", type=_positive_float, default=24.0, help="highest order (default 24)"
    )
    spectrum.add_argument("--samples-per-cycle", type=int, default=None, help="angle-domain grid")
    spectrum.add_argument("--block-cycles", type=int, default=1, help="cycles per averaged block (default 1)")
    spectrum.add_argument("--json", action="store_true", help="print a JSON document instead of tables")
    spectrum.add_argument("--plot", metavar="FILE.png", help="also draw the spectra")
    spectrum.add_argument(
        "--speed-map",
        type=int,
        metavar="BINS",
        help="also map order amplitudes against speed in BINS speed bins (run-ups)",
    )
    spectrum.add_argument(
        "--map-plot", metavar="FILE.png", help="draw the order-speed maps (needs --speed-map)"
    )
    _add_cycle_phase(spectrum)

    imp = sub.add_parser(
        "import",
        help="convert a test-bench file (MDF4, TDMS, CSV/text) into a recording",
        description="Convert an ASAM MDF file, an NI TDMS file or a text export (CSV: a time column and "
        "one column per channel) into an engine-monitor recording (HDF5 or MCAP), with a "
        "channel-mapping file (see monitor.io.imports).",
    )
    imp.add_argument("source", metavar="SOURCE", help=".mf4/.mdf/.dat, .tdms or .csv/.txt/.tsv/.dat file")
    imp.add_argument("--map", required=True, metavar="MAP.toml", help="channel-mapping file")
    imp.add_argument(
        "--rate",
        type=_positive_float,
        metavar="HZ",
        help="sample rate [Hz] of every channel; overrides the mapping's sample_rate_hz and the file's times",
    )
    imp.add_argument("-o", "--output", required=True, metavar="OUT.h5|OUT.mcap", help="recording to write")

    sim = sub.add_parser(
        "simulate",
        help="simulate a scene into a recording (only the effects the scene names)",
        description="Simulate a scene (TOML: engine, operating point, sensors, effects) into an "
        "HDF5 or MCAP recording with its ground truth; or print the truth of a simulated recording. "
        "Scenes: recordings/scenes/; effects: monitor.scene.effects.",
    )
    sim.add_argument("scene", nargs="?", metavar="SCENE.toml", help="the scene to simulate")
    sim.add_argument("-o", "--output", metavar="OUT.h5|OUT.mcap", help="recording to write")
    sim.add_argument("--seed", type=_seed, help="noise seed (default: the scene's); same seed, same file")
    sim.add_argument(
        "--duration", type=_positive_float, metavar="S", help="simulate only the first S seconds of the scene"
    )
    sim.add_argument(
        "--truth", metavar="RECORDING", help="print the ground truth stored in a simulated recording (JSON)"
    )

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
    compare.add_argument("--load", type=float, help="load the engine ran at, fraction of rated (default 1)")
    compare.add_argument(
        "--transfer",
        choices=("rigid", "shaft-line"),
        default="rigid",
        help="torque to crank speed: the rigid engine side (default) or the shaft line's receptance",
    )
    compare.add_argument("--json", action="store_true", help="print a JSON document instead of tables")
    _add_exclude_channel(compare)
    compare.add_argument("--plot", metavar="FILE.png|FILE.html", help="also draw measured against predicted")
    _add_cycle_phase(compare, unknown=True)
    compare.error = _exit_3_on_usage_error(compare)  # type: ignore[method-assign]

    calibrate = sub.add_parser(
        "calibrate",
        help="calibrate a healthy baseline recording's sensors, for later comparisons",
        description="Calibrate, on a healthy recording, each main-bearing sensor's transfer from bearing "
        "force to its orders, its impact profile and rms velocity; write them as JSON for 'compare "
        "--baseline'.",
    )
    calibrate.add_argument("recording", metavar="RECORDING", help="healthy HDF5 or MCAP recording")
    calibrate.add_argument(
        "-o",
        "--output",
        required=True,
        metavar="BASELINE.json|TRANSFERS.toml",
        help="the baseline (JSON), or its transfers as [[sensor_transfers]] for the engine file (.toml)",
    )
    calibrate.add_argument("--engine", metavar="E.toml", help="engine description (default: the bundled one)")
    calibrate.add_argument("--load", type=float, default=1.0, help="load it ran at (default 1)")
    calibrate.add_argument(
        "--pitch-from",
        metavar="RUN",
        help="learn the tooth wheel's pitch errors at every order, firing harmonics included, on this "
        "run of the same wheel whose speed changes by a quarter or more: a motored run-up or a "
        "coast-down with the fuel cut (default: on RECORDING, firing harmonics left to the engine)",
    )
    _add_cycle_phase(calibrate)
    _add_exclude_channel(calibrate)

    batch = sub.add_parser(
        "batch",
        help="diagnose every recording not yet diagnosed (a folder, or the store's since a date); "
        "exit 0/1/2/3",
        description="Register the recordings under PATH in the results store (or take the store's "
        "recordings uploaded since --since), and diagnose those without a result at the current analysis "
        "version in a local process pool. Idempotent: run it again, or after a crash, and only what is "
        "missing is done. Ends with a summary of findings per engine (--json: a JSON document); diagnosis "
        "plots are kept in DATA/plots, named after their recordings. Exit status, the worst over the "
        "recordings in scope, those diagnosed by this run and those found diagnosed before it: 0 healthy, "
        "1 warning, 2 alarm, 3 inconclusive or not diagnosed (a job that failed or was set aside, a file "
        "that is not a readable recording, an error).",
    )
    scope = batch.add_mutually_exclusive_group(required=True)
    scope.add_argument("path", nargs="?", metavar="PATH", help="a recording file or a folder of them")
    scope.add_argument(
        "--since", metavar="DATE", help="the store's recordings uploaded since DATE (ISO 8601)"
    )
    batch.add_argument(
        "--store", metavar="URL", help="the store (default: $ENGINE_MONITOR_DB, else DATA/engine-monitor.db)"
    )
    batch.add_argument(
        "--data", default="data", metavar="DIR", help="the service's data folder (default ./data)"
    )
    batch.add_argument(
        "--fleet", default="local", help="the fleet the recordings belong to (default 'local')"
    )
    batch.add_argument(
        "--baseline",
        action="append",
        default=[],
        metavar="B.json",
        help="a baseline (from 'calibrate'), per engine",
    )
    batch.add_argument("--workers", type=int, help="worker processes (default: one per core)")
    batch.add_argument(
        "--scheduler", metavar="ADDRESS", help="run on a Dask distributed cluster (tcp://host:8786) instead"
    )
    batch.add_argument(
        "--json", action="store_true", help="print the summary as a JSON document (docs/service.md)"
    )
    batch.error = _exit_3_on_usage_error(batch)  # type: ignore[method-assign]

    serve = sub.add_parser(
        "serve",
        help="run the HTTP service (uploads, diagnoses, engines) with its analysis worker",
        description="Run the HTTP service with uvicorn. Recordings are kept under --data; results in the "
        "store. OpenAPI at /openapi.json, pages at /docs.",
    )
    serve.add_argument("--host", default="127.0.0.1", help="address to listen on (default 127.0.0.1)")
    serve.add_argument("--port", type=_port, default=8000, help="port, 1 to 65535 (default 8000)")
    serve.add_argument(
        "--store", metavar="URL", help="the store (default: $ENGINE_MONITOR_DB, else DATA/engine-monitor.db)"
    )
    serve.add_argument(
        "--data", default="data", metavar="DIR", help="folder for recordings and plots (default ./data)"
    )
    serve.add_argument("--max-upload-mb", type=_positive_float, default=4096.0, help="upload size limit [MB]")
    serve.add_argument(
        "--workers",
        type=int,
        default=1,
        help="analysis processes in this server (0: a separate worker runs them)",
    )
    serve.add_argument(
        "--lease",
        type=_positive_float,
        default=30.0,
        metavar="S",
        help="seconds after which a running analysis whose worker went silent is taken back (default 30)",
    )
    serve.add_argument(
        "--uploads-per-fleet",
        type=_positive_int,
        default=4,
        metavar="N",
        help="a fleet's uploads in progress at once; one more is refused with 429 (default 4)",
    )
    serve.add_argument(
        "--upload-idle",
        type=_positive_float,
        default=30.0,
        metavar="S",
        help="longest wait for the next bytes of an upload, and the time after which it must have come "
        "at --upload-min-rate (default 30)",
    )
    serve.add_argument(
        "--upload-min-rate",
        type=_positive_float,
        default=1024.0,
        metavar="B/S",
        help="slowest average rate of an upload after --upload-idle [bytes/s] (default 1024)",
    )
    serve.add_argument(
        "--access-log",
        action=argparse.BooleanOptionalAction,
        default=True,
        help="one line per request on the log (default); --no-access-log leaves it out, which saves the "
        "server about a tenth of its CPU per read under load; start-up, errors with their tracebacks and "
        "the analyses' lines are logged either way",
    )
    serve.add_argument(
        "--retry-backoff",
        type=_positive_float,
        default=10.0,
        metavar="S",
        help="seconds before an analysis that failed for a passing reason is tried again, "
        "doubled after each attempt (default 10)",
    )
    _add_connection_options(serve)

    work = sub.add_parser(
        "worker",
        help="run the service's analyses apart from the HTTP server (until stopped)",
        description="Take queued analyses from the store and run them, PROCESSES at a time, until SIGTERM "
        "or Ctrl-C; for a server started with --workers 0 (the container's worker).",
    )
    work.add_argument(
        "--store", metavar="URL", help="the store (default: $ENGINE_MONITOR_DB, else DATA/engine-monitor.db)"
    )
    work.add_argument(
        "--data", default="data", metavar="DIR", help="the service's data folder (default ./data)"
    )
    work.add_argument("--processes", type=_positive_int, default=1, help="analyses at a time (default 1)")
    work.add_argument(
        "--lease", type=_positive_float, default=30.0, metavar="S", help="as for serve (default 30)"
    )
    work.add_argument(
        "--retry-backoff", type=_positive_float, default=10.0, metavar="S", help="as for serve (default 10)"
    )

    keys = sub.add_parser("keys", help="the HTTP service's API keys: create, list, revoke")
    key_actions = keys.add_subparsers(dest="action", required=True, metavar="ACTION")
    create = key_actions.add_parser("create", help="a new key for a fleet (shown once)")
    create.add_argument(
        "--fleet", required=True, help="the fleet (created if new): 1 to 200 printable characters"
    )
    create.add_argument("--label", default="", help="what the key is for (printable, at most 200 characters)")
    listing = key_actions.add_parser("list", help="the keys: id, fleet, label, created (never the key)")
    listing.add_argument("--fleet", help="only this fleet's")
    revoke = key_actions.add_parser("revoke", help="revoke a key by its id (refused at once)")
    revoke.add_argument("id", type=int, help="the key's id, as list shows it")
    for action in (create, listing, revoke):  # the store chosen as serve chooses it
        action.add_argument(
            "--store",
            metavar="URL",
            help="the store (default: $ENGINE_MONITOR_DB, else DATA/engine-monitor.db)",
        )
        action.add_argument("--data", default="data", metavar="DIR", help="as for serve (default ./data)")

    tdc = sub.add_parser(
        "tdc",
        help="where a cylinder's pressure peaks against the angle reference's TDC (find its offset)",
        description="Find each cycle's pressure peak of a cylinder in crank angle after its TDC as the "
        "recording's angle reference places it. On a motored run (--motored: no combustion) the peak "
        "lies the thermodynamic loss angle before TDC, so the reference's stated angle is corrected; on a "
        "fired run the peak is checked against -10 to +45 deg after firing TDC.",
    )
    tdc.add_argument("recording", metavar="RECORDING", help="recording with a pressure channel")
    tdc.add_argument("--engine", metavar="E.toml", help="engine description (default: the bundled one)")
    tdc.add_argument("--cylinder", type=int, default=1, help="the cylinder whose pressure to use (default 1)")
    tdc.add_argument(
        "--motored", action="store_true", help="the run has no combustion: find TDC from the compression peak"
    )
    tdc.add_argument(
        "--loss-angle",
        type=float,
        default=0.7,
        metavar="DEG",
        help="motored: how far the compression peak leads TDC [deg] (default 0.7)",
    )
    _add_cycle_phase(tdc)
    tdc.add_argument("--json", action="store_true", help="print a JSON document")

    sub.add_parser("engines", help="list the bundled engine descriptions")
    add_torsion_parser(sub)
    add_trend_parser(sub)
    return parser


def _exit_3_on_usage_error(parser: argparse.ArgumentParser) -> Any:
    """``compare``'s and ``batch``'s usage errors exit with 3 (could not diagnose), not argparse's 2 (an
    alarm)."""

    def error(message: str) -> Any:
        parser.print_usage(sys.stderr)
        parser.exit(3, f"{parser.prog}: error: {message}\n")

    return error


def _engine_of(recording: Recording, given: str | None) -> Any:
    from monitor.errors import DiagnosisError
    from monitor.model.engine import bundled_engines, load_engine

    if given:
        return load_engine(given)
    if recording.engine_id in bundled_engines():
        return load_engine(bundled_engines()[recording.engine_id])
    raise DiagnosisError(
        f"engine {recording.engine_id!r} is not bundled: give its description with --engine FILE.toml"
    )


def _add_exclude_channel(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--exclude-channel",
        metavar="NAME",
        action="append",
        default=[],
        help="leave this channel out (a sensor known to be faulty); repeat for more",
    )


def _add_cycle_phase(parser: argparse.ArgumentParser, *, unknown: bool = False) -> None:
    """The --cycle-phase option of the commands that read a four-stroke recording."""
    parser.add_argument(
        "--cycle-phase",
        type=_cycle_phase_deg_or_unknown if unknown else _cycle_phase_deg,
        metavar="0|360|unknown" if unknown else "0|360",
        help="four-stroke without a cam or cylinder-1 pressure channel: which revolution holds cylinder 1's "
        "firing TDC, as degrees added to the angle reference's crank angle (0 or 360)"
        + ("; 'unknown' names each cylinder together with the one firing 360 deg from it" if unknown else ""),
    )


def _cycle_phase_deg(text: str) -> float:
    """--cycle-phase 0|360 as the shift of the angle reference [rad]."""
    try:
        value = float(text)
    except ValueError:
        value = math.nan
    if value not in (0.0, 360.0):
        raise argparse.ArgumentTypeError(f"{text!r}: expected 0 or 360 (degrees)")
    return math.radians(value)


def _cycle_phase_deg_or_unknown(text: str) -> float | str:
    """--cycle-phase 0|360|unknown."""
    return "unknown" if text == "unknown" else _cycle_phase_deg(text)


def _run_calibrate(args: argparse.Namespace) -> int:
    from monitor.diagnosis import calibrate
    from monitor.io import open_recording

    if Path(args.output).suffix.lower() not in (".json", ".toml"):
        raise MonitorError(f"-o {args.output}: expected a .json (baseline) or .toml (sensor transfers) file")
    with ExitStack() as stack:
        recording = stack.enter_context(open_recording(args.recording))
        run = None if args.pitch_from is None else stack.enter_context(open_recording(args.pitch_from))
        engine = _engine_of(recording, args.engine)
        report = stack.enter_context(progress_bar(1.0, "calibrating", unit="recording"))
        baseline = calibrate(
            recording,
            engine,
            load=args.load,
            source=Path(args.recording).name,
            cycle_phase=args.cycle_phase,
            pitch_from=run,
            exclude=args.exclude_channel,
            progress=report,
        )
    try:
        if Path(args.output).suffix.lower() == ".toml":  # the [[sensor_transfers]] tables for an engine file
            path = Path(args.output)
            path.write_text(baseline.to_toml())
        else:
            path = baseline.write(args.output)
    except OSError as error:
        raise MonitorError(f"-o {args.output}: cannot be written ({error.strerror or error})") from None
    sensors = ", ".join(f"{n} (main bearing {s.bearing})" for n, s in baseline.sensors.items())
    print(
        f"baseline of {engine.id} at {baseline.speed_rpm:.2f} rpm written to {path}: {sensors}",
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


def _run_batch(args: argparse.Namespace) -> int:
    import os
    from datetime import UTC, datetime

    from monitor.diagnosis import Baseline
    from monitor.errors import ModelError, StoreError
    from monitor.jobs.batch import run_batch
    from monitor.store import DEFAULT_URL_ENV, open_store

    since = None
    if args.since:
        try:
            since = datetime.fromisoformat(args.since)
        except ValueError:
            raise ModelError(
                f"--since {args.since!r}: expected a date or time in ISO 8601 (2026-11-22)"
            ) from None
        if since.tzinfo is None:
            since = since.replace(tzinfo=UTC)
    if args.workers is not None and args.workers < 1:
        raise ModelError(f"--workers {args.workers}: expected at least 1")
    baselines = {}
    for path in args.baseline:
        baseline = Baseline.read(path)
        baselines[baseline.engine_id] = baseline.to_document()
    if args.path and not Path(args.path).exists():  # refused before a store or a fleet is made for it
        raise ModelError(f"{args.path}: no such file or folder")
    data = Path(args.data)
    if args.store is None and DEFAULT_URL_ENV not in os.environ:  # the default SQLite file in DATA
        data.mkdir(parents=True, exist_ok=True)
    store = open_store(_service_store_url(args.store, args.data))
    try:
        try:
            fleet_id = store.fleet_id(args.fleet)
        except StoreError:
            if args.since:  # the store's recordings: a fleet it does not know has none
                raise StoreError(
                    f"no fleet {args.fleet!r} in the store: give the fleet whose recordings to diagnose"
                ) from None
            fleet_id = store.create_fleet(args.fleet)
            print(f"fleet {args.fleet!r} created in the store", file=sys.stderr)
        with progress_counter("diagnosing", unit="recording") as progress:
            summary = run_batch(
                store,
                fleet_id,
                path=Path(args.path) if args.path else None,
                since=since,
                baselines=baselines,
                workers=args.workers,
                progress=progress,
                scheduler=args.scheduler,
                data_dir=data.resolve(),
            )
    finally:
        store.close()
    if args.json:
        json.dump(summary.document(), sys.stdout, indent=1)
        sys.stdout.write("\n")
    else:
        print(summary.text())
    return summary.exit_status


def _add_connection_options(serve: argparse.ArgumentParser) -> None:
    """serve's limits on connections (api/connections.py; docs/service.md, "Connections")."""
    serve.add_argument(
        "--header-timeout",
        type=_positive_float,
        default=10.0,
        metavar="S",
        help="longest time for a connection to send a complete request head, from its accept or its "
        "previous response; then 408 and closed [s] (default 10)",
    )
    serve.add_argument(
        "--idle-timeout",
        type=_positive_float,
        default=5.0,
        metavar="S",
        help="a connection without a request in progress that sends nothing for this long after its "
        "accept or its previous response is closed [s] (default 5)",
    )
    serve.add_argument(
        "--max-connections",
        type=_positive_int,
        metavar="N",
        help="connections held at once; one more closes the oldest idle one (default: what the "
        "open-file limit holds, at most 10000; more than it holds is refused at start-up)",
    )
    serve.add_argument(
        "--connections-per-client",
        type=_count,
        default=64,
        metavar="N",
        help="connections held at once from one client address; one more is answered 503 "
        "(default 64; 0: no cap, behind a proxy that caps them)",
    )


def _connection_protocol(args: argparse.Namespace) -> type:
    """The HTTP protocol with serve's connection limits, the cap sized to the open-file limit."""
    from api.connections import ConnectionLimits, descriptor_budget, protocol_class

    budget = descriptor_budget()
    default = ConnectionLimits.max_connections
    if args.max_connections is not None and args.max_connections > budget.connections:
        raise MonitorError(
            f"--max-connections {args.max_connections}: the open-file limit holds {budget.connections} "
            f"({budget.summary()}); raise the limit (ulimit -n, systemd's LimitNOFILE=, compose's "
            "ulimits) or give fewer"
        )
    if budget.connections < 1:
        raise MonitorError(f"no room for connections: {budget.summary()}; raise the limit (ulimit -n)")
    cap = args.max_connections or min(default, budget.connections)
    limits = ConnectionLimits(
        header_timeout_s=args.header_timeout,
        idle_timeout_s=args.idle_timeout,
        max_connections=cap,
        per_client=args.connections_per_client,
    )
    per_client = limits.per_client or "no cap"
    print(
        f"connections: at most {cap} ({per_client} per client address), request head within "
        f"{limits.header_timeout_s:g} s, idle {limits.idle_timeout_s:g} s; {budget.summary()}",
        file=sys.stderr,
    )
    return protocol_class(limits)


def _service_store_url(given: str | None, data: str) -> str:
    from monitor.store import default_url

    return given or default_url(Path(data))


def _run_serve(args: argparse.Namespace) -> int:
    import signal

    import uvicorn

    from api.app import Settings, create_app

    data = Path(args.data)
    data.mkdir(parents=True, exist_ok=True)
    settings = Settings(
        store_url=_service_store_url(args.store, args.data),
        data_dir=data.resolve(),
        max_upload_bytes=int(args.max_upload_mb * 1e6),
        workers=max(0, args.workers),
        lease_s=args.lease,
        retry_backoff_s=args.retry_backoff,
        uploads_per_fleet=args.uploads_per_fleet,
        upload_idle_s=args.upload_idle,
        upload_min_rate=args.upload_min_rate,
    )
    _check_listening(args.host, args.port)
    app = create_app(settings)
    protocol = _connection_protocol(args)
    # uvicorn stops on SIGTERM as on Ctrl-C, then raises the signal again: under the default action the
    # process would die of it there, before its exit handlers release what it holds (the analysis
    # pool's semaphores, which the resource tracker then reports as leaked) and with status -15. A
    # SIGTERM raised again after the shutdown ends the process as a normal exit, status 0.
    signal.signal(signal.SIGTERM, _exit_on_sigterm)
    try:
        uvicorn.run(
            app,
            host=args.host,
            port=args.port,
            log_level="info",
            access_log=args.access_log,
            http=protocol,
            backlog=4096,  # a flood's handshakes wait here for their accept (net.core.somaxconn caps it)
            ws="none",  # no route upgrades; an upgraded connection would leave the protocol's count
            log_config=_service_log_config(),
        )
    except SystemExit as stop:  # uvicorn's own exit (it could not start): the documented status
        if stop.code not in (0, None):
            raise MonitorError(
                f"the service on {args.host}:{args.port} stopped (uvicorn status {stop.code})"
            ) from None
    return 0


def _exit_on_sigterm(*_: object) -> None:
    raise SystemExit(0)


def _service_log_config() -> dict[str, Any]:
    """uvicorn's logging, with the service's own loggers (``engine_monitor.*``: the worker's job states, the
    uploads' notes) at INFO on its handler: without it their lines reach no handler and are dropped."""
    import copy

    from uvicorn.config import LOGGING_CONFIG

    config: dict[str, Any] = copy.deepcopy(LOGGING_CONFIG)
    config["loggers"]["engine_monitor"] = {"handlers": ["default"], "level": "INFO", "propagate": False}
    return config


def _check_listening(host: str, port: int) -> None:
    """Refuse at once, in one line, an address the service cannot listen on (in use, not this host's)."""
    import socket

    try:
        infos = socket.getaddrinfo(host, port, type=socket.SOCK_STREAM)
    except OSError as error:
        raise MonitorError(f"--host {host}: not an address of this machine ({error})") from None
    family, kind, proto, _, address = infos[0]
    with socket.socket(family, kind, proto) as probe:
        probe.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        try:
            probe.bind(address)
        except OSError as error:
            raise MonitorError(
                f"cannot listen on {host}:{port}: {error.strerror or error} (choose another --port)"
            ) from None


def _worker_log_config() -> dict[str, Any]:
    """The worker's job states (``engine_monitor.*`` at INFO) on standard error, one line each."""
    return {
        "version": 1,
        "disable_existing_loggers": False,
        "formatters": {"plain": {"format": "%(asctime)s %(levelname)s %(name)s: %(message)s"}},
        "handlers": {"stderr": {"class": "logging.StreamHandler", "formatter": "plain"}},
        "loggers": {"engine_monitor": {"handlers": ["stderr"], "level": "INFO", "propagate": False}},
    }


def _run_worker(args: argparse.Namespace) -> int:
    import logging.config
    import signal
    import threading
    from datetime import timedelta

    from monitor.jobs.worker import Worker
    from monitor.store import open_store

    data = Path(args.data)
    data.mkdir(parents=True, exist_ok=True)
    store = open_store(_service_store_url(args.store, args.data))
    worker = Worker(
        store,
        data.resolve(),
        max(1, args.processes),
        lease=timedelta(seconds=args.lease),
        backoff=timedelta(seconds=args.retry_backoff),
    )
    stop = threading.Event()
    signal.signal(signal.SIGTERM, lambda *_: stop.set())
    logging.config.dictConfig(_worker_log_config())
    worker.start()
    print(
        f"worker: {worker.processes} process(es) on {store.dialect}; stop with SIGTERM or Ctrl-C",
        file=sys.stderr,
    )
    try:
        stop.wait()
    except KeyboardInterrupt:
        pass
    finally:
        worker.stop()
        store.close()
    return 0


def _run_keys(args: argparse.Namespace) -> int:
    import os

    from monitor.errors import StoreError
    from monitor.names import check_name
    from monitor.store import DEFAULT_URL_ENV, open_store

    if args.action == "create":  # both names checked before the fleet is made: a refusal stores nothing
        check_name("--fleet", args.fleet)
        if args.label:
            check_name("--label", args.label)
    if args.store is None and DEFAULT_URL_ENV not in os.environ:  # the default SQLite file in DATA
        if args.action != "create" and not Path(args.data).is_dir():
            raise MonitorError(
                f"--data {args.data}: no such folder (the service's data folder, as for serve)"
            )
        Path(args.data).mkdir(exist_ok=True)
    store = open_store(_service_store_url(args.store, args.data))
    try:
        if args.action == "create":
            try:
                fleet_id = store.fleet_id(args.fleet)
            except StoreError:
                fleet_id = store.create_fleet(args.fleet)
            key = store.create_key(fleet_id, args.label)
            print(key)
            print(f"API key of fleet {args.fleet!r}: shown once, stored only as its digest", file=sys.stderr)
        elif args.action == "list":
            rows = store.list_keys(args.fleet)
            print(f"{'id':>5}  {'fleet':20}  {'created (UTC)':20}  label")
            for row in rows:
                print(f"{row.id:>5}  {row.fleet:20}  {row.created_at:%Y-%m-%d %H:%M:%S}  {row.label}")
        elif not store.revoke_key(args.id):
            raise MonitorError(f"no API key with id {args.id} (see 'engine-monitor keys list')")
        else:
            print(f"API key {args.id} revoked: refused from now on", file=sys.stderr)
    finally:
        store.close()
    return 0


def _run_compare(args: argparse.Namespace) -> int:
    from monitor.diagnosis import Baseline, calibrate, diagnose
    from monitor.io import open_recording
    from monitor.report.diagnosis import diagnosis_document, diagnosis_table

    baseline = None
    with open_recording(args.recording) as recording:
        engine = _engine_of(recording, args.engine)
        if args.baseline:
            if Path(args.baseline).suffix.lower() == ".toml":
                raise MonitorError(
                    f"--baseline {args.baseline}: sensor transfers (TOML) belong in the engine file, given "
                    "with --engine; --baseline takes a baseline (.json) or a healthy recording"
                )
            if Path(args.baseline).suffix.lower() == ".json":
                baseline = Baseline.read(args.baseline)
            else:
                with open_recording(args.baseline) as healthy:
                    baseline = calibrate(
                        healthy,
                        _engine_of(healthy, args.engine),
                        load=args.load if args.load is not None else 1.0,
                        transfer=args.transfer,
                        source=Path(args.baseline).name,
                        cycle_phase=args.cycle_phase if isinstance(args.cycle_phase, float) else None,
                        exclude=[n for n in args.exclude_channel if n in {c.name for c in healthy.channels}],
                    )
                print(
                    f"calibrated on {args.baseline} (store it with 'engine-monitor calibrate' to reuse it)",
                    file=sys.stderr,
                )
        with progress_bar(1.0, "diagnosing", unit="recording") as report:
            diagnosis = diagnose(
                recording,
                engine,
                baseline=baseline,
                load=args.load,
                transfer=args.transfer,
                cycle_phase=args.cycle_phase,
                exclude=args.exclude_channel,
                progress=report,
            )
    name = Path(args.recording).name
    table = diagnosis_table(diagnosis, recording=name)
    if args.json:
        json.dump(diagnosis_document(diagnosis, recording=name), sys.stdout, indent=1)
        sys.stdout.write("\n")
    else:
        print(table)
    if args.plot:
        from monitor.report.plots import plot_diagnosis

        try:
            path = plot_diagnosis(
                diagnosis,
                args.plot,
                title=f"{name}: {engine.id} at {diagnosis.speed_rpm:.1f} rpm",
                table=table,
                recording=name,
            )
        except OSError as error:
            raise MonitorError(f"--plot {args.plot}: cannot be written ({error.strerror or error})") from None
        print(f"plot written to {path}", file=sys.stderr)
    return {"healthy": 0, "warning": 1, "alarm": 2, "inconclusive": 3}[diagnosis.status]


def _run_orders(args: argparse.Namespace) -> int:
    import math

    from monitor.model.crankshaft import EngineModel
    from monitor.model.engine import load_engine
    from monitor.model.forces import RodModel
    from monitor.model.predicted import predict_orders
    from monitor.report.tables import model_orders_document, model_orders_table

    engine = load_engine(args.engine)
    rod_model: RodModel = args.rod_model or ("rigid" if args.kinematics == "exact" else "two-mass")
    model = EngineModel(
        engine, grid_size=args.grid, rod_model=rod_model, kinematics=args.kinematics, gas=args.gas
    )
    result = predict_orders(
        model, crank_speed=args.rpm * math.pi / 30, load=args.load, max_order=args.max_order
    )
    if args.json:
        json.dump(model_orders_document(result, engine), sys.stdout, indent=1)
        sys.stdout.write("\n")
    else:
        print(model_orders_table(result, engine))
    if args.plot:
        from monitor.report.plots import plot_model_orders

        path = plot_model_orders(result, model, args.plot)
        print(f"plot written to {path}", file=sys.stderr)
    return 0


def _run_spectrum(args: argparse.Namespace) -> int:
    from monitor.io import open_recording

    with open_recording(args.recording) as recording:
        return _spectrum_of(recording, args)


def _spectrum_of(recording: Recording, args: argparse.Namespace) -> int:
    import math

    import numpy as np

    from monitor.errors import ModelError
    from monitor.model.engine import bundled_engines, load_engine
    from monitor.signal.measure import spectra

    if args.cycle:
        revolutions = 1 if args.cycle == "two-stroke" else 2
    else:
        source = args.engine or (recording.engine_id if recording.engine_id in bundled_engines() else None)
        if source is None:
            raise ModelError(
                f"engine {recording.engine_id!r} is not bundled: give --engine FILE.toml or --cycle"
            )
        revolutions = load_engine(source).cycle_revolutions
    if args.map_plot and not args.speed_map:
        raise ModelError("--map-plot needs --speed-map BINS")
    with progress_bar(1.0, "resampling", unit="recording") as report:
        result = spectra(
            recording,
            speed_bins=args.speed_map,
            cycle_revolutions=revolutions,
            channels=args.channel,
            samples_per_cycle=args.samples_per_cycle,
            max_order=args.max_order,
            block_cycles=args.block_cycles,
            cycle_phase=args.cycle_phase,
            progress=report,
        )
    listed = None
    if args.orders:
        try:
            listed = [float(k) for k in args.orders.split(",")]
        except ValueError:
            raise ModelError(f"--orders {args.orders!r}: expected comma-separated numbers") from None
    rpm = result.mean_speed * 30 / math.pi
    document: dict[str, Any] = {
        "recording": {
            "engine_id": recording.engine_id,
            "start_time": recording.start_time,
            "truncated": recording.truncated,
        },
        "angle_reference": {
            "channel": result.reference.source,
            "repairs": result.reference.repairs,
            "cycle_phase": result.reference.cycle_phase,
            "pitch_correction": None
            if (correction := result.reference.pitch_correction) is None
            else {
                "scope": correction.scope,
                "source": correction.source,
                "revolutions": correction.revolutions,
                "rms_deg": math.degrees(correction.rms),
                "largest_deg": math.degrees(correction.largest),
            },
            "notes": list(result.reference.notes),
        },
        "mean_speed_rpm": rpm,
        "cycle_revolutions": revolutions,
        "channels": {},
    }
    cut = " (truncated)" if recording.truncated else ""
    lines = [
        f"Recording of {recording.engine_id} from {recording.start_time}{cut}",
        f"angle reference: {result.reference.source} ({result.reference.repairs} pulse repairs"
        + (f", cycle phase from {result.reference.cycle_phase}" if result.reference.cycle_phase else "")
        + f"); mean speed {rpm:.2f} rpm",
        *(
            []
            if correction is None
            else [
                f"tooth-pitch correction ({correction.scope} teeth, from the {correction.source}, "
                f"{correction.revolutions} revolutions): largest {math.degrees(correction.largest):.3f} deg, "
                f"rms {math.degrees(correction.rms):.3f} deg"
            ]
        ),
        *(f"note: {note}" for note in result.reference.notes),
        "amplitudes are peak, in each channel's unit; phases relative to TDC of cylinder 1",
    ]
    for name, spectrum in result.spectra.items():
        if listed is None:
            keep = np.ones(spectrum.orders.size, dtype=bool)
            keep[0] = False
        else:
            step = float(spectrum.orders[1]) if spectrum.orders.size > 1 else 1.0
            off_grid = [k for k in listed if abs(k / step - round(k / step)) > 1e-9]
            if off_grid:
                raise ModelError(f"--orders {off_grid}: not on the grid of this spectrum (steps of {step:g})")
            keep = np.isclose(spectrum.orders[:, None], np.asarray(listed)[None, :], atol=1e-9).any(axis=1)
        unit = result.units[name]
        document["channels"][name] = {
            "unit": unit,
            "blocks": spectrum.blocks,
            "orders": spectrum.orders[keep].tolist(),
            "amplitude": spectrum.magnitude[keep].tolist(),
            "phase_deg": np.degrees(spectrum.phase[keep]).tolist(),
            "magnitude_std": spectrum.magnitude_std[keep].tolist(),
        }
        lines += [
            "",
            f"{name} [{unit}], {spectrum.blocks} blocks of {spectrum.block_cycles} cycle(s):",
            f"{'order':>6} {'amplitude':>12} {'phase':>8} {'spread':>10}",
        ]
        for k, a, ph, sd in zip(
            spectrum.orders[keep],
            spectrum.magnitude[keep],
            spectrum.phase[keep],
            spectrum.magnitude_std[keep],
            strict=True,
        ):
            lines.append(f"{k:6.1f} {a:12.5g} {math.degrees(ph):8.1f} {sd:10.3g}")
    for name, speed_map in result.speed_maps.items():
        document.setdefault("speed_maps", {})[name] = {
            "unit": result.units[name],
            "speed_rpm": (speed_map.speed * 30 / math.pi).tolist(),
            "cycles": speed_map.cycles.tolist(),
            "orders": speed_map.orders.tolist(),
            "amplitude": [
                [None if not np.isfinite(v) else float(v) for v in row] for row in speed_map.amplitude
            ],
        }
        lines.append(
            f"{name}: order-speed map over {speed_map.speed.size} speed bins "
            f"{speed_map.speed[0] * 30 / math.pi:.1f}-{speed_map.speed[-1] * 30 / math.pi:.1f} rpm"
        )
    if args.json:
        json.dump(document, sys.stdout, indent=1)
        sys.stdout.write("\n")
    else:
        print("\n".join(lines))
    if args.map_plot:
        from monitor.report.plots import plot_speed_maps

        print(f"plot written to {plot_speed_maps(result, args.map_plot)}", file=sys.stderr)
    if args.plot:
        from monitor.report.plots import plot_spectra

        path = plot_spectra(result, args.plot, title=f"{recording.engine_id}, {rpm:.1f} rpm")
        print(f"plot written to {path}", file=sys.stderr)
    return 0


def _write_recording(recording: Recording, output: str) -> Path:
    """Write to .h5 or .mcap by the file's suffix."""
    from monitor.errors import FormatError
    from monitor.io.hdf5 import write_hdf5
    from monitor.io.mcap.writer import write_mcap

    target = Path(output)
    if target.suffix.lower() in (".h5", ".hdf5"):
        return write_hdf5(recording, target)
    if target.suffix.lower() == ".mcap":
        return write_mcap(recording, target)
    raise FormatError(f"{target}: expected an .h5 or .mcap output file")


def _run_simulate(args: argparse.Namespace) -> int:
    import time

    from monitor.errors import ModelError
    from monitor.io import open_recording  # the reader alone: the truth needs no signal processing

    if args.truth:
        with open_recording(args.truth) as recording:
            if not recording.truth:
                raise ModelError(f"{args.truth}: not a simulated recording (it holds no ground truth)")
            print(json.dumps(json.loads(recording.truth), indent=2, sort_keys=True))
        return 0
    if not args.scene or not args.output:
        raise ModelError("simulate needs SCENE.toml and -o OUT.h5|OUT.mcap (or --truth RECORDING)")
    from monitor.scene import load_scene, simulate

    scene = load_scene(args.scene)
    if args.duration is not None:
        scene = scene.model_copy(update={"duration_s": min(scene.duration_s, args.duration)})
    start = time.perf_counter()
    with progress_bar(len(scene.sensors), "simulating", unit="sensor") as report:
        simulation = simulate(
            scene, seed=args.seed, progress=lambda fraction: report(fraction * len(scene.sensors))
        )
    output = _write_recording(simulation.recording, args.output)
    print(
        f"{scene.duration_s:g} s simulated in {time.perf_counter() - start:.2f} s "
        f"(effects: {', '.join(simulation.evaluated) or 'none'}); recording written to {output}",
        file=sys.stderr,
    )
    return 0


def _run_import(args: argparse.Namespace) -> int:
    from monitor.io.imports.dispatch import import_file
    from monitor.io.imports.mapping import load_mapping

    mapping = load_mapping(args.map)
    recording = import_file(args.source, mapping, sample_rate_hz=args.rate)
    output = _write_recording(recording, args.output)
    for c in recording.channels:
        spans = f", {len(c.quality)} unusable span(s) masked" if c.quality else ""
        rate = f"{c.sample_rate:.10g} Hz"
        print(f"{c.name:24s} {c.kind:13s} {c.unit:6s} {c.data.size:10d} samples at {rate}{spans}")
    print(f"recording written to {output}", file=sys.stderr)
    return 0


def _run_tdc(args: argparse.Namespace) -> int:
    from monitor.errors import ModelError
    from monitor.io import open_recording
    from monitor.signal.reference import angle_reference
    from monitor.signal.tdc import PLAUSIBLE_FIRED_PEAK, pressure_peaks

    with open_recording(args.recording) as recording:
        engine = _engine_of(recording, args.engine)
        if not 1 <= args.cylinder <= engine.cylinders:
            raise ModelError(f"--cylinder {args.cylinder}: the engine has cylinders 1 to {engine.cylinders}")
        channels = [
            c for c in recording.of_kind("pressure") if int(c.fields.get("cylinder", 0)) == args.cylinder
        ]
        if not channels:
            raise ModelError(f"the recording has no pressure channel of cylinder {args.cylinder}")
        channel = channels[0]
        firing = float(engine.firing_angles[args.cylinder - 1])
        # motored: every revolution searched (the compression TDCs give the higher peaks), no phase needed
        revolutions = 1 if args.motored else engine.cycle_revolutions
        reference = angle_reference(recording, cycle_revolutions=revolutions, cycle_phase=args.cycle_phase)
        peaks = pressure_peaks(
            reference.angle_map,
            channel.data,
            float(channel.sample_rate or 0.0),
            start_time=channel.start_offset,
            tdc_angle=math.fmod(firing, 2 * math.pi) if args.motored else firing,
            period=2 * math.pi * revolutions,
            window=math.radians(179.0 if args.motored else 120.0),
            four_stroke=args.motored and engine.cycle_revolutions == 2,
        )
    if args.motored and peaks.spread > math.radians(2.0):
        raise ModelError(
            f"the compression peaks of cylinder {args.cylinder} spread by "
            f"{math.degrees(peaks.spread):.1f} deg over {peaks.angles.size} cycles (expected under 2): not a "
            "steady motored run, or too short"
        )
    stated = {
        "tooth": "first_tooth_angle_deg",
        "encoder": "first_pulse_angle_deg",
        "keyphasor": "pulse_angle_deg",
    }
    source = recording.channel(reference.source)
    key = stated[source.kind]
    document: dict[str, Any] = {
        "cylinder": args.cylinder,
        "channel": channel.name,
        "cycles": int(peaks.angles.size),
        "peak_after_tdc_deg": math.degrees(peaks.median),
        "spread_deg": math.degrees(peaks.spread),
        "reference": {"channel": source.name, key: float(source.fields[key])},
    }
    lines = [
        f"cylinder {args.cylinder} ({channel.name}): pressure peaks {math.degrees(peaks.median):.2f} deg "
        f"after TDC as {source.name!r} places it (spread {math.degrees(peaks.spread):.2f} deg, "
        f"{peaks.angles.size} cycles)"
    ]
    if args.motored:
        offset = peaks.tdc_offset(loss_angle=math.radians(args.loss_angle))
        corrected = float(source.fields[key]) + math.degrees(offset)
        corrected = (corrected + 180.0) % 360.0 - 180.0
        document["loss_angle_deg"] = args.loss_angle
        document["reference"]["corrected"] = corrected
        lines.append(
            f"motored, loss angle {args.loss_angle:g} deg: TDC is {math.degrees(-offset):.2f} deg after the "
            f"reference's; set {source.name!r} {key} = {corrected:.2f} (now {float(source.fields[key]):g})"
        )
    else:
        low, high = PLAUSIBLE_FIRED_PEAK
        plausible = low <= peaks.median <= high
        document["plausible"] = plausible
        lines.append(
            f"fired: a peak {math.degrees(low):.0f} to {math.degrees(high):.0f} deg after firing TDC is "
            + ("plausible" if plausible else "expected: the reference's stated angle is probably wrong")
        )
    if args.json:
        json.dump(document, sys.stdout, indent=1)
        sys.stdout.write("\n")
    else:
        print("\n".join(lines))
    return 0


def _run_engines(_: argparse.Namespace) -> int:
    from monitor.model.engine import bundled_engines, load_engine

    for engine_id, path in bundled_engines().items():
        engine = load_engine(path)
        print(
            f"{engine_id:24s} {engine.cycle:11s} {engine.cylinders:2d} cyl  "
            f"{engine.operation.rated_speed_rpm:7.1f} rpm  {engine.name}"
        )
    return 0


def main(argv: Sequence[str] | None = None) -> int:
    """Run the command line.

    Parameters
    ----------
    argv : sequence of str, optional
        Arguments without the program name; default: ``sys.argv[1:]``.

    Returns
    -------
    int
        Exit status: 0 on success, 2 on a usage or input error; ``compare`` and ``batch``: 0 healthy,
        1 warning, 2 alarm, 3 could not diagnose (``batch``: the worst over its scope).
    """
    parser = _build_parser()
    args = parser.parse_args(argv)
    for option in ("plot", "map_plot"):  # a figure that cannot be written is refused before any work
        if getattr(args, option, None):
            from monitor.errors import PlotError
            from monitor.report.plots import check_figure_path

            formats = ("png", "html", "htm") if args.command == "compare" else None
            try:
                check_figure_path(getattr(args, option), formats=formats)
            except PlotError as error:
                print(f"engine-monitor: error: --{option.replace('_', '-')} {error}", file=sys.stderr)
                return 3 if args.command in _DIAGNOSING else 2
    handlers = {
        "orders": _run_orders,
        "engines": _run_engines,
        "tdc": _run_tdc,
        "torsion": run_torsion,
        "trend": run_trend,
        "spectrum": _run_spectrum,
        "import": _run_import,
        "simulate": _run_simulate,
        "compare": _run_compare,
        "calibrate": _run_calibrate,
        "batch": _run_batch,
        "serve": _run_serve,
        "keys": _run_keys,
        "worker": _run_worker,
    }
    try:
        return handlers[args.command](args)
    except MonitorError as error:
        print(f"engine-monitor: error: {error}", file=sys.stderr)
        return 3 if args.command in _DIAGNOSING else 2
    except KeyboardInterrupt:
        print("engine-monitor: stopped (Ctrl-C)", file=sys.stderr)
        return 130
    except BrokenPipeError:  # the reader went away (e.g. piped into head): stop quietly
        import os

        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 0
    except Exception as error:  # a fault of the product's, not of the input: one line, unless asked
        import os

        if os.environ.get("ENGINE_MONITOR_TRACEBACK"):
            raise
        said = str(error).splitlines()[0][:300] if str(error) else ""
        print(
            f"engine-monitor: error: unexpected {type(error).__name__}{': ' + said if said else ''} "
            "(a fault of engine-monitor: please report it with the command; ENGINE_MONITOR_TRACEBACK=1 "
            "shows where)",
            file=sys.stderr,
        )
        return 3 if args.command in _DIAGNOSING else 2
