"""``engine-monitor simulate``: a scene into a recording, or the ground truth of a simulated recording.

``simulate --truth`` is a quick command (tests/cli/test_startup.py): it imports
the recording's reader alone, and the scene's simulation is imported where it runs.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path
from typing import TYPE_CHECKING, Any

from monitor.cli.arguments import positive_float, seed
from monitor.runtime.progress import progress_bar

if TYPE_CHECKING:
    from monitor.io.recording import Recording

__all__ = ["add_simulate_parser", "run_simulate", "write_recording"]


def add_simulate_parser(sub: Any) -> None:
    """Add the ``simulate`` command.

    Parameters
    ----------
    sub : argparse subparsers
        The CLI's ``add_subparsers()`` action.
    """
    sim = sub.add_parser(
        "simulate",
        help="simulate a scene into a recording (only the effects the scene names)",
        description="Simulate a scene (TOML: engine, operating point, sensors, effects) into an "
        "HDF5 or MCAP recording with its ground truth; or print the truth of a simulated recording. "
        "Scenes: recordings/scenes/; effects: monitor.scene.effects.",
    )
    sim.add_argument("scene", nargs="?", metavar="SCENE.toml", help="the scene to simulate")
    sim.add_argument("-o", "--output", metavar="OUT.h5|OUT.mcap", help="recording to write")
    sim.add_argument("--seed", type=seed, help="noise seed (default: the scene's); same seed, same file")
    sim.add_argument(
        "--duration", type=positive_float, metavar="S", help="simulate only the first S seconds of the scene"
    )
    sim.add_argument(
        "--load",
        type=_load,
        metavar="L",
        help="simulate the scene at this load instead of its own, fraction of rated IMEP (0 to 1.1)",
    )
    sim.add_argument(
        "--truth", metavar="RECORDING", help="print the ground truth stored in a simulated recording (JSON)"
    )
    sim.set_defaults(run=run_simulate)


def _load(text: str) -> float:
    """A load from the command line: a fraction of rated IMEP from 0 to 1.1 (the scenes' range)."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r}: expected a number") from None
    if not 0.0 <= value <= 1.1:
        raise argparse.ArgumentTypeError(f"{text}: expected a load from 0 to 1.1 (fraction of rated IMEP)")
    return value


def write_recording(recording: Recording, output: str) -> Path:
    """Write a recording to .h5 or .mcap by the file's suffix (``simulate -o``, ``import -o``).

    Parameters
    ----------
    recording : Recording
    output : str
        The file to write.

    Returns
    -------
    Path
        The file written.

    Raises
    ------
    FormatError
        If the suffix is neither.
    """
    from monitor.errors import FormatError
    from monitor.io.hdf5 import write_hdf5
    from monitor.io.mcap.writer import write_mcap

    target = Path(output)
    if target.suffix.lower() in (".h5", ".hdf5"):
        return write_hdf5(recording, target)
    if target.suffix.lower() == ".mcap":
        return write_mcap(recording, target)
    raise FormatError(f"{target}: expected an .h5 or .mcap output file")


def run_simulate(args: argparse.Namespace) -> int:
    """Run ``engine-monitor simulate``: the recording written, or the truth printed (``--truth``).

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
    if args.load is not None:
        point = scene.operating_point.model_copy(update={"load": args.load})
        scene = scene.model_copy(update={"operating_point": point})
    start = time.perf_counter()
    with progress_bar(len(scene.sensors), "simulating", unit="sensor") as report:
        simulation = simulate(
            scene, seed=args.seed, progress=lambda fraction: report(fraction * len(scene.sensors))
        )
    output = write_recording(simulation.recording, args.output)
    print(
        f"{scene.duration_s:g} s simulated in {time.perf_counter() - start:.2f} s "
        f"(effects: {', '.join(simulation.evaluated) or 'none'}); recording written to {output}",
        file=sys.stderr,
    )
    return 0
