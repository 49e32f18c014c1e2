"""``engine-monitor orders`` and ``engines``: an engine's predicted orders, and the bundled engines.

Quick commands: their start-up is checked (tests/cli/test_startup.py), so the
model and the plots are imported where they run, not here.
"""

from __future__ import annotations

import argparse
import math
import sys
from typing import Any

from monitor.cli.arguments import positive_float, print_json

__all__ = ["add_engines_parser", "add_orders_parser", "run_engines", "run_orders"]


def add_orders_parser(sub: Any) -> None:
    """Add the ``orders`` command.

    Parameters
    ----------
    sub : argparse subparsers
        The CLI's ``add_subparsers()`` action.
    """
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
    orders.add_argument("--rpm", type=positive_float, required=True, help="crank speed [rpm]")
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
    orders.set_defaults(run=run_orders)


def run_orders(args: argparse.Namespace) -> int:
    """Run ``engine-monitor orders``: the table, or the JSON document, and the figure if asked.

    Parameters
    ----------
    args : argparse.Namespace
        The parsed command line.

    Returns
    -------
    int
        0.
    """
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
        print_json(model_orders_document(result, engine))
    else:
        print(model_orders_table(result, engine))
    if args.plot:
        from monitor.report.plots import plot_model_orders

        path = plot_model_orders(result, model, args.plot)
        print(f"plot written to {path}", file=sys.stderr)
    return 0


def add_engines_parser(sub: Any) -> None:
    """Add the ``engines`` command.

    Parameters
    ----------
    sub : argparse subparsers
        The CLI's ``add_subparsers()`` action.
    """
    sub.add_parser("engines", help="list the bundled engine descriptions").set_defaults(run=run_engines)


def run_engines(_: argparse.Namespace) -> int:
    """Run ``engine-monitor engines``: one line per bundled engine.

    Parameters
    ----------
    _ : argparse.Namespace
        The parsed command line (no options).

    Returns
    -------
    int
        0.
    """
    from monitor.model.engine import bundled_engines, load_engine

    for engine_id, path in bundled_engines().items():
        engine = load_engine(path)
        print(
            f"{engine_id:24s} {engine.cycle:11s} {engine.cylinders:2d} cyl  "
            f"{engine.operation.rated_speed_rpm:7.1f} rpm  {engine.name}"
        )
    return 0
