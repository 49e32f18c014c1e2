"""``engine-monitor batch``: diagnose every recording of a folder, or of the store since a date.

The run itself is :func:`monitor.jobs.batch.run_batch`; its exit status is the
worst health over the recordings in its scope (0 healthy, 1 warning, 2 alarm,
3 inconclusive or not diagnosed).

What a command needs is imported where it runs: the quick commands build this
module's parsers at start-up (:mod:`monitor.cli.main`).
"""

from __future__ import annotations

import argparse
import os
import sys
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

from monitor.cli.arguments import add_store_option, exit_3_on_usage_error, print_json, store_url
from monitor.errors import ModelError, StoreError
from monitor.runtime.progress import progress_counter

__all__ = ["add_batch_parser", "run_batch"]


def add_batch_parser(sub: Any) -> None:
    """Add the ``batch`` command (its usage errors exit with 3).

    Parameters
    ----------
    sub : argparse subparsers
        The CLI's ``add_subparsers()`` action.
    """
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
    add_store_option(batch)
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
    batch.error = exit_3_on_usage_error(batch)
    batch.set_defaults(run=run_batch)


def _since(text: str | None) -> datetime | None:
    """--since as a time (UTC when it names no zone)."""
    if not text:
        return None
    try:
        since = datetime.fromisoformat(text)
    except ValueError:
        raise ModelError(f"--since {text!r}: expected a date or time in ISO 8601 (2026-11-22)") from None
    return since if since.tzinfo is not None else since.replace(tzinfo=UTC)


def run_batch(args: argparse.Namespace) -> int:
    """Run ``engine-monitor batch``: the summary, as text or JSON.

    Parameters
    ----------
    args : argparse.Namespace
        The parsed command line.

    Returns
    -------
    int
        The worst over the scope: 0 healthy, 1 warning, 2 alarm, 3 inconclusive or not diagnosed.
    """
    from monitor.diagnosis.operating_points import read_baseline
    from monitor.jobs import batch
    from monitor.store import DEFAULT_URL_ENV, open_store

    since = _since(args.since)
    if args.workers is not None and args.workers < 1:
        raise ModelError(f"--workers {args.workers}: expected at least 1")
    baselines = {}
    for path in args.baseline:
        baseline = read_baseline(path)
        baselines[baseline.engine_id] = baseline.to_document()
    if args.path and not Path(args.path).exists():  # refused before a store or a fleet is made for it
        raise ModelError(f"{args.path}: no such file or folder")
    data = Path(args.data)
    if args.store is None and DEFAULT_URL_ENV not in os.environ:  # the default SQLite file in DATA
        data.mkdir(parents=True, exist_ok=True)
    store = open_store(store_url(args.store, args.data))
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
            summary = batch.run_batch(
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
        print_json(summary.document())
    else:
        print(summary.text())
    return summary.exit_status
