"""``engine-monitor trend ENGINE``: an engine's condition over time, from the results store.

Every diagnosis the store holds for the engine (from ``batch`` or the HTTP
service) gives its quantities at the recording's time (:mod:`monitor.diagnosis.trends`).
The command prints, for each quantity, how many recordings gave it, its
baseline period's mean and spread, its latest value and the drift the CUSUM
rule found, if any, then the trend findings in the order they were found; with
``--quantity`` the series themselves; with ``--json`` all of it as a document;
with ``--plot FILE.png`` a figure with one panel per quantity.
"""

from __future__ import annotations

import argparse
from datetime import datetime
from typing import Any

from monitor.cli.arguments import add_store_option, print_json, store_url

__all__ = ["add_trend_parser", "run_trend"]

_PLOTTED = 12  # panels at most in a figure of the judged quantities


def add_trend_parser(sub: Any) -> None:
    """Add the ``trend`` command to the CLI's subparsers.

    Parameters
    ----------
    sub : argparse subparsers
        The CLI's ``add_subparsers()`` action.
    """
    trend = sub.add_parser(
        "trend",
        help="an engine's quantities over time and the drift found in them, from the store",
        description="Each diagnosis in the results store (from 'batch' or the HTTP service) of ENGINE, at "
        "its recording's time: speed, load, each cylinder's strength, each bearing sensor's order "
        "deviation, impact score and rms velocity. After the baseline period (the engine's first 10 "
        "recordings) each judged quantity is followed by a two-sided CUSUM of its values standardised by its "
        "own history (docs/trends.md): a trend finding says what moved, since when and by how much.",
    )
    trend.add_argument("engine", metavar="ENGINE", help="the engine's id (as its recordings name it)")
    add_store_option(trend)
    trend.add_argument(
        "--data", default="data", metavar="DIR", help="the service's data folder (default ./data)"
    )
    trend.add_argument(
        "--fleet",
        help="the fleet the engine belongs to (default: the store's only fleet: 'local' of 'batch', or the "
        "service's fleet of 'keys create --fleet')",
    )
    trend.add_argument("--since", metavar="DATE", help="only recordings from DATE on (ISO 8601, UTC)")
    trend.add_argument(
        "--quantity",
        action="append",
        default=[],
        metavar="NAME",
        help="only this quantity, its series printed (repeat for more; names as the summary lists them)",
    )
    trend.add_argument("--json", action="store_true", help="print a JSON document instead of tables")
    trend.add_argument("--plot", metavar="FILE.png", help="also draw the quantities against time")
    trend.set_defaults(run=run_trend)


def _since(text: str | None) -> datetime | None:
    from monitor.errors import MonitorError
    from monitor.store.trends import parse_since  # the store loads SQLAlchemy: not for the quick commands

    if text is None:
        return None
    try:
        return parse_since(text)
    except ValueError:
        raise MonitorError(f"--since {text!r}: expected a date or time in ISO 8601 (2026-11-01)") from None


def run_trend(args: argparse.Namespace) -> int:
    """Run ``engine-monitor trend`` (see the module docstring).

    Parameters
    ----------
    args : argparse.Namespace
        The parsed command line.

    Returns
    -------
    int
        0 (an error is raised as :class:`monitor.errors.MonitorError`, which the CLI reports with 2).
    """
    from monitor.diagnosis import ANALYSIS_VERSION
    from monitor.errors import MonitorError, StoreError
    from monitor.store import open_store
    from monitor.store.trends import fill_trend_points, read_trend, trend_document

    since = _since(args.since)
    store = open_store(store_url(args.store, args.data))
    try:
        fleet = args.fleet if args.fleet is not None else _only_fleet(store.fleet_names())
        try:
            fleet_id = store.fleet_id(fleet)
        except StoreError:
            raise MonitorError(
                f"--fleet {fleet!r}: no such fleet in the store; its fleets: {_listed(store.fleet_names())}"
            ) from None
        with store.transaction() as c:
            fill_trend_points(c, fleet_id)  # results stored before the trend table
            rows = read_trend(
                c,
                fleet_id,
                args.engine,
                analysis_version=ANALYSIS_VERSION,
                quantities=args.quantity or None,
                since=since,
            )
    finally:
        store.close()
    if not rows:
        wanted = f" of {', '.join(repr(q) for q in args.quantity)}" if args.quantity else ""
        raise MonitorError(
            f"no diagnosis{wanted} of engine {args.engine!r} in fleet {fleet!r}"
            + (f" since {since:%Y-%m-%d %H:%M}" if since else "")
            + " in the store: run 'engine-monitor batch' on its recordings first (quantity names as "
            "'engine-monitor trend ENGINE' lists them)"
        )
    document, series, findings = trend_document(
        rows, engine_id=args.engine, fleet=fleet, analysis_version=ANALYSIS_VERSION, since=since
    )
    if args.plot:
        _plot(series, {f.quantity: f for f in findings}, args.plot, args.engine)
    if args.json:
        print_json(document, indent=2)
        return 0
    print(_table(series, document, args.quantity))
    return 0


def _listed(names: list[str]) -> str:
    return ", ".join(repr(name) for name in names) if names else "none"


def _only_fleet(names: list[str]) -> str:
    """The fleet ``trend`` reads without ``--fleet``: the store's only one, else an error naming them."""
    from monitor.errors import MonitorError

    if len(names) == 1:
        return names[0]
    if not names:
        raise MonitorError(
            "the store holds no fleet: diagnose recordings first ('engine-monitor batch', or upload them to "
            "the service)"
        )
    raise MonitorError(f"the store holds the fleets {_listed(names)}: choose one with --fleet")


def _table(series: dict[str, list[Any]], document: dict[str, Any], shown: list[str]) -> str:
    import numpy as np

    from monitor.diagnosis.trends import BASELINE_RECORDINGS

    recordings = {p.recording_id for points in series.values() for p in points}
    times = [p.recorded_at for points in series.values() for p in points]
    lines = [
        f"engine {document['engine_id']} (fleet {document['fleet']}): {len(recordings)} diagnosed recordings "
        f"from {min(times):%Y-%m-%d %H:%M} to {max(times):%Y-%m-%d %H:%M} UTC",
        "",
        f"{'quantity':<34} {'unit':>5} {'n':>4} {'baseline mean':>14} {'spread':>10} {'latest':>11}  drift",
    ]
    for quantity, points in series.items():
        values = np.array([p.value for p in points])
        base = values[:BASELINE_RECORDINGS]
        spread = float(base.std(ddof=1)) if base.size > 1 else float("nan")
        found = document["quantities"][quantity]["drift"]
        verdict = "(not judged)" if not document["quantities"][quantity]["judged"] else "none"
        if found is not None:
            verdict = (
                f"{found['direction']} {abs(found['shift_sigmas']):.1f} sigma since {found['since'][:10]}"
            )
        lines.append(
            f"{quantity:<34} {points[0].unit:>5} {values.size:>4} {base.mean():>14.4g} {spread:>10.3g} "
            f"{values[-1]:>11.4g}  {verdict}"
        )
    lines += ["", "trend findings:" if document["findings"] else "trend findings: none"]
    lines += [f"  {summary}" for summary in document["findings"]]
    for quantity in shown:
        if quantity not in series:
            continue
        lines += ["", f"{quantity} [{series[quantity][0].unit}]:"]
        for p in series[quantity]:
            error = f" +- {p.standard_error:.3g}" if p.standard_error is not None else ""
            lines.append(
                f"  {p.recorded_at:%Y-%m-%d %H:%M}  recording {p.recording_id:>6}  {p.value:.6g}{error}"
            )
    return "\n".join(lines)


def _plot(series: dict[str, list[Any]], drifts: dict[str, Any], path: str, engine: str) -> None:
    """One panel per quantity (the judged ones, at most _PLOTTED, unless chosen): values against time."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np

    from monitor.diagnosis.trends import BASELINE_RECORDINGS, judged

    chosen = [q for q in series if judged(q)] or list(series)
    chosen = chosen[:_PLOTTED]
    figure, axes = plt.subplots(
        len(chosen), 1, figsize=(9, 1.9 * len(chosen) + 0.8), sharex=True, squeeze=False
    )
    for axis, quantity in zip(axes[:, 0], chosen, strict=True):
        points = series[quantity]
        times = [p.recorded_at for p in points]
        values = np.array([p.value for p in points])
        errors = np.array([np.nan if p.standard_error is None else p.standard_error for p in points])
        axis.errorbar(times, values, yerr=np.where(np.isfinite(errors), errors, 0.0), fmt="o-", ms=3, lw=1)
        base = values[:BASELINE_RECORDINGS]
        if base.size > 1:
            mean, spread = base.mean(), base.std(ddof=1)
            axis.axhspan(
                mean - spread, mean + spread, color="0.85", zorder=0, label="baseline mean +- spread"
            )
        found = drifts.get(quantity)
        if found is not None:
            axis.axvspan(
                found.since, found.found_at, color="tab:red", alpha=0.15, label="drift: since to found"
            )
            axis.axvline(found.found_at, color="tab:red", lw=1)
        axis.set_ylabel(f"{quantity}\n[{points[0].unit}]", fontsize=8)
        axis.grid(True, alpha=0.3)
    axes[0, 0].set_title(
        f"{engine}: {len(drifts)} trend finding(s)" + (": " + "; ".join(sorted(drifts)) if drifts else "")
    )
    axes[0, 0].legend(fontsize=7, loc="best")
    axes[-1, 0].set_xlabel("recording time (UTC)")
    figure.autofmt_xdate()
    figure.tight_layout()
    figure.savefig(path, dpi=110)
    plt.close(figure)
