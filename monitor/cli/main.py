"""The ``engine-monitor`` command line.

Subcommands, each parsed and run by its module (its ``add_*_parser`` names its
runner); this module assembles them in the order ``--help`` lists them and runs
the one asked for:

- :mod:`monitor.cli.orders`: ``orders``, the predicted order table of an engine
  at an operating point; ``engines``, the bundled engine descriptions.
- :mod:`monitor.cli.measure`: ``spectrum``, order spectra of a recording;
  ``tdc``, a cylinder's pressure peak against the angle reference; ``import``,
  test-bench files into recordings.
- :mod:`monitor.cli.simulate`: ``simulate``, scenes into recordings.
- :mod:`monitor.cli.compare`: ``compare``, a recording's measured orders
  against the model and the findings (:mod:`monitor.jobs.analyse`);
  ``calibrate``, a healthy baseline's calibration, stored for later comparisons.
- :mod:`monitor.cli.batch`: ``batch``, every recording not yet diagnosed.
- :mod:`monitor.cli.service`: ``serve``, ``worker``, ``keys``: the HTTP service
  (the only command module that imports :mod:`api`).
- :mod:`monitor.cli.torsion`: ``torsion ...``, shaft-line modes, Campbell data
  and forced response of an engine, and the stability chart and time response
  of the variable-inertia crank.
- :mod:`monitor.cli.trend`: ``trend``, an engine's quantities over time from
  the results store, and the drift found in them.

Every module's parsers are built at start-up, so the libraries a command needs
are imported where it runs: the quick commands (``--help``, ``engines``,
``orders``, ``simulate --truth``) import no heavy library
(tests/cli/test_startup.py).

Errors the product raises on purpose (bad engine file, out-of-range input)
print one clear message and exit with status 2; the table goes to standard
output, messages to standard error. ``compare`` exits with the health it
found instead: 0 healthy, 1 warning, 2 alarm, and 3 when it cannot diagnose
(an error, a usage error included); ``batch`` likewise with the worst over
the recordings in its scope (see :mod:`monitor.jobs.batch`).
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence

from monitor import __version__
from monitor.cli import batch, compare, measure, orders, service, simulate
from monitor.cli.torsion import add_torsion_parser
from monitor.cli.trend import add_trend_parser
from monitor.errors import MonitorError

__all__ = ["main"]

_DIAGNOSING = ("compare", "batch")  # their 2 is an alarm: their errors exit with 3, could not diagnose


def _build_parser() -> argparse.ArgumentParser:
    """Every command's parser, in the order ``--help`` lists them; each sets ``run``, its runner."""
    parser = argparse.ArgumentParser(
        prog="engine-monitor",
        description="Condition monitoring of large reciprocating engines: predicted and measured orders.",
    )
    parser.add_argument("--version", action="version", version=f"%(prog)s {__version__}")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    for add in (
        orders.add_orders_parser,
        measure.add_spectrum_parser,
        measure.add_import_parser,
        simulate.add_simulate_parser,
        compare.add_compare_parser,
        compare.add_calibrate_parser,
        batch.add_batch_parser,
        service.add_serve_parser,
        service.add_worker_parser,
        service.add_keys_parser,
        measure.add_tdc_parser,
        orders.add_engines_parser,
        add_torsion_parser,
        add_trend_parser,
    ):
        add(sub)
    return parser


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
    try:
        return int(args.run(args))
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
