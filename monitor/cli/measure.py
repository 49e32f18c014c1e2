"""``engine-monitor spectrum``, ``tdc`` and ``import``: a recording's measured side.

``spectrum`` lists the order spectra of a recording's channels (its JSON
document: :mod:`monitor.report.spectrum_json`, docs/spectrum-json.md), ``tdc``
checks where a cylinder's pressure peaks against the angle reference, and
``import`` converts a test-bench file into a recording.

What a command needs is imported where it runs: the quick commands build this
module's parsers at start-up (:mod:`monitor.cli.main`).
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path
from typing import TYPE_CHECKING, Any, Literal

from monitor.cli.arguments import ENGINE_MISSING, add_cycle_phase, positive_float, print_json
from monitor.cli.simulate import write_recording
from monitor.runtime.progress import progress_bar

if TYPE_CHECKING:
    from monitor.io.recording import Recording
    from monitor.model.engine import Engine
    from monitor.signal.measure import SpectrumResult
    from monitor.signal.pitch import PitchCorrection

__all__ = [
    "add_import_parser",
    "add_spectrum_parser",
    "add_tdc_parser",
    "run_import",
    "run_spectrum",
    "run_tdc",
]


def add_spectrum_parser(sub: Any) -> None:
    """Add the ``spectrum`` command.

    Parameters
    ----------
    sub : argparse subparsers
        The CLI's ``add_subparsers()`` action.
    """
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
    spectrum.add_argument("--max-order", type=positive_float, default=24.0, help="highest order (default 24)")
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
    spectrum.add_argument(
        "--pitch-from",
        metavar="RUN",
        help="correct the tooth wheel's pitch errors at every order with those learned on this run of "
        "the same wheel whose speed changes by a quarter or more (a motored run-up, a coast-down, a "
        "fuel cut); the systematic column then gives what that learning leaves",
    )
    add_cycle_phase(spectrum)
    spectrum.set_defaults(run=run_spectrum)


def run_spectrum(args: argparse.Namespace) -> int:
    """Run ``engine-monitor spectrum``: the tables, or the JSON document, and the figures if asked.

    Parameters
    ----------
    args : argparse.Namespace
        The parsed command line.

    Returns
    -------
    int
        0.
    """
    from monitor.errors import ModelError
    from monitor.io import open_recording
    from monitor.jobs.analyse import recording_engine
    from monitor.report.spectrum_json import spectrum_document
    from monitor.signal.measure import spectra

    with open_recording(args.recording) as recording:
        engine = None
        if args.cycle:
            revolutions = 1 if args.cycle == "two-stroke" else 2
        else:
            missing = "is not bundled: give --engine FILE.toml or --cycle"
            engine = recording_engine(recording, args.engine, missing=missing)
            revolutions = engine.cycle_revolutions
        if args.map_plot and not args.speed_map:
            raise ModelError("--map-plot needs --speed-map BINS")
        correction = _pitch_from(args.pitch_from, engine)
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
                pitch_correction=correction,
                progress=report,
            )
    listed = None
    if args.orders:
        try:
            listed = [float(k) for k in args.orders.split(",")]
        except ValueError:
            raise ModelError(f"--orders {args.orders!r}: expected comma-separated numbers") from None
    document = spectrum_document(
        result,
        recording=Path(args.recording).name,
        engine_id=recording.engine_id,
        start_time=recording.start_time,
        truncated=recording.truncated,
        orders=listed,
        mean=False,
    )
    if args.json:
        print_json(document)
    else:
        print(_spectrum_table(result, recording, listed))
    rpm = result.mean_speed * 30 / math.pi
    if args.map_plot:
        from monitor.report.plots import plot_speed_maps

        print(f"plot written to {plot_speed_maps(result, args.map_plot)}", file=sys.stderr)
    if args.plot:
        from monitor.report.plots import plot_spectra

        path = plot_spectra(result, args.plot, title=f"{recording.engine_id}, {rpm:.1f} rpm")
        print(f"plot written to {path}", file=sys.stderr)
    return 0


def _pitch_from(run: str | None, engine: Engine | None) -> PitchCorrection | Literal["estimate"]:
    """The pitch errors learned on ``--pitch-from RUN`` (said on stderr), else the recording's own
    estimate."""
    if run is None:
        return "estimate"
    from monitor.diagnosis.calibration import pitch_over_speed
    from monitor.errors import SignalError
    from monitor.io import open_recording

    with open_recording(run) as taught:
        try:
            correction = pitch_over_speed(taught, engine)
        except SignalError as error:
            raise SignalError(f"--pitch-from {run}: {error}") from None
    first = [] if correction.order_errors is None else [math.degrees(e) for e in correction.order_errors[:3]]
    print(
        f"tooth-pitch errors learned on {run} ({correction.revolutions} revolutions): rms "
        f"{math.degrees(correction.rms):.3f} deg, standard error "
        f"{math.degrees(correction.standard_error):.2g} deg a tooth"
        + (f" and {', '.join(f'{e:.2g}' for e in first)} deg at orders 1 to {len(first)}" if first else ""),
        file=sys.stderr,
    )
    return correction


def _spectrum_table(result: SpectrumResult, recording: Recording, listed: list[float] | None) -> str:
    """``spectrum``'s tables: the angle reference, then each channel's orders with their spread."""
    from monitor.report.spectrum_json import order_mask

    rpm = result.mean_speed * 30 / math.pi
    correction = result.reference.pitch_correction
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
        keep = order_mask(spectrum, listed, mean=False)
        bounded = spectrum.systematic is not None
        lines += [
            "",
            f"{name} [{result.units[name]}], {spectrum.blocks} blocks of {spectrum.block_cycles} cycle(s):",
            f"{'order':>6} {'amplitude':>12} {'phase':>8} {'spread':>10}"
            + (f" {'systematic':>10}" if bounded else ""),
        ]
        systematic = spectrum.systematic[keep] if spectrum.systematic is not None else None
        for i, (k, a, ph, sd) in enumerate(
            zip(
                spectrum.orders[keep],
                spectrum.magnitude[keep],
                spectrum.phase[keep],
                spectrum.magnitude_std[keep],
                strict=True,
            )
        ):
            line = f"{k:6.1f} {a:12.5g} {math.degrees(ph):8.1f} {sd:10.3g}"
            lines.append(line + (f" {systematic[i]:10.3g}" if systematic is not None else ""))
        if bounded and correction is not None and correction.order_errors is not None:
            lines.append(
                "systematic: the most the error of the tooth-pitch errors learned on the run can put in "
                "each whole order (3 times its standard error); averaging does not remove it, a longer "
                "run or one of wider speed does"
            )
        elif bounded:
            lines.append(
                "systematic: the most the wheel's unlearned tooth-pitch errors can put in each whole order "
                "(3 times their scatter's share of it); averaging does not remove it, a run-up, coast-down "
                "or fuel cut does (--pitch-from)"
            )
    for name, speed_map in result.speed_maps.items():
        lines.append(
            f"{name}: order-speed map over {speed_map.speed.size} speed bins "
            f"{speed_map.speed[0] * 30 / math.pi:.1f}-{speed_map.speed[-1] * 30 / math.pi:.1f} rpm"
        )
    return "\n".join(lines)


def add_import_parser(sub: Any) -> None:
    """Add the ``import`` command.

    Parameters
    ----------
    sub : argparse subparsers
        The CLI's ``add_subparsers()`` action.
    """
    imp = sub.add_parser(
        "import",
        help="convert a test-bench file (MDF4, TDMS, CSV/text, logic-analyser capture) into a recording",
        description="Convert an ASAM MDF file, an NI TDMS file or a text export (CSV: a time column and "
        "one column per channel; or a logic analyser's level changes, sigrok or Saleae, whose edges become "
        "tooth-wheel, cam or keyphasor events) into an engine-monitor recording (HDF5 or MCAP), with a "
        "channel-mapping file (see monitor.io.imports).",
    )
    imp.add_argument("source", metavar="SOURCE", help=".mf4/.mdf/.dat, .tdms or .csv/.txt/.tsv/.dat file")
    imp.add_argument("--map", required=True, metavar="MAP.toml", help="channel-mapping file")
    imp.add_argument(
        "--rate",
        type=positive_float,
        metavar="HZ",
        help="sample rate [Hz] of every channel; overrides the mapping's sample_rate_hz and the file's times",
    )
    imp.add_argument("-o", "--output", required=True, metavar="OUT.h5|OUT.mcap", help="recording to write")
    imp.set_defaults(run=run_import)


def run_import(args: argparse.Namespace) -> int:
    """Run ``engine-monitor import``: the recording written, one line per channel.

    Parameters
    ----------
    args : argparse.Namespace
        The parsed command line.

    Returns
    -------
    int
        0.
    """
    from monitor.io.imports.dispatch import import_file
    from monitor.io.imports.mapping import load_mapping

    mapping = load_mapping(args.map)
    recording = _wheels_read(import_file(args.source, mapping, sample_rate_hz=args.rate))
    output = write_recording(recording, args.output)
    for c in recording.channels:
        if c.sample_rate is None:
            print(f"{c.name:24s} {c.kind:13s} {c.unit:6s} {c.data.size:10d} events")
            continue
        spans = f", {len(c.quality)} unusable span(s) masked" if c.quality else ""
        rate = f"{c.sample_rate:.10g} Hz"
        print(f"{c.name:24s} {c.kind:13s} {c.unit:6s} {c.data.size:10d} samples at {rate}{spans}")
    print(f"recording written to {output}", file=sys.stderr)
    return 0


def _wheels_read(recording: Recording) -> Recording:
    """The recording with each tooth wheel mapped as ``pattern = "infer"`` read off its edges and
    written as found (teeth, missing_teeth, pattern), said on stderr."""
    from dataclasses import replace

    from monitor.io.recording import INFER_PATTERN
    from monitor.signal.reference import declared_as_read

    channels = []
    for channel in recording.channels:
        if channel.kind == "tooth" and channel.fields.get("pattern") == INFER_PATTERN:
            channel, found = declared_as_read(channel)
            print(
                f"{channel.name}: wheel read off its edges: {found.name} ({found.spelled}), written as "
                f"teeth = {found.positions}, missing_teeth = {found.missing}, pattern = {found.name!r}",
                file=sys.stderr,
            )
        channels.append(channel)
    return replace(recording, channels=tuple(channels))


def add_tdc_parser(sub: Any) -> None:
    """Add the ``tdc`` command.

    Parameters
    ----------
    sub : argparse subparsers
        The CLI's ``add_subparsers()`` action.
    """
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
    add_cycle_phase(tdc)
    tdc.add_argument("--json", action="store_true", help="print a JSON document")
    tdc.set_defaults(run=run_tdc)


def run_tdc(args: argparse.Namespace) -> int:
    """Run ``engine-monitor tdc``: where the cylinder's pressure peaks, and the reference's correction.

    Parameters
    ----------
    args : argparse.Namespace
        The parsed command line.

    Returns
    -------
    int
        0.
    """
    from monitor.errors import ModelError
    from monitor.io import open_recording
    from monitor.jobs.analyse import recording_engine
    from monitor.model.banks import tdc_offsets
    from monitor.signal.reference import angle_reference
    from monitor.signal.tdc import PLAUSIBLE_FIRED_PEAK, pressure_peaks

    with open_recording(args.recording) as recording:
        engine = recording_engine(recording, args.engine, missing=ENGINE_MISSING)
        if not 1 <= args.cylinder <= engine.cylinders:
            raise ModelError(f"--cylinder {args.cylinder}: the engine has cylinders 1 to {engine.cylinders}")
        channels = [
            c for c in recording.of_kind("pressure") if int(c.fields.get("cylinder", 0)) == args.cylinder
        ]
        if not channels:
            raise ModelError(f"the recording has no pressure channel of cylinder {args.cylinder}")
        channel = channels[0]
        # where its own TDC is: an articulated rod's slave's lies off its firing angle
        own_tdc = engine.firing_angles + tdc_offsets(engine.cylinders, engine.vee, engine.articulated)
        firing = float(own_tdc[args.cylinder - 1])
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
        print_json(document)
    else:
        print("\n".join(lines))
    return 0
