"""``engine-monitor serve``, ``worker`` and ``keys``: the HTTP service, its analysis worker, its API keys.

The only command module that imports the service (:mod:`api`), where a command
runs: the quick commands build this module's parsers without it.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

from monitor.cli.arguments import add_store_option, count, port, positive_float, positive_int, store_url
from monitor.errors import MonitorError

__all__ = ["add_keys_parser", "add_serve_parser", "add_worker_parser", "run_keys", "run_serve", "run_worker"]


def add_serve_parser(sub: Any) -> None:
    """Add the ``serve`` command (uvicorn, with the analysis worker).

    Parameters
    ----------
    sub : argparse subparsers
        The CLI's ``add_subparsers()`` action.
    """
    serve = sub.add_parser(
        "serve",
        help="run the HTTP service (uploads, diagnoses, engines) with its analysis worker",
        description="Run the HTTP service with uvicorn. Recordings are kept under --data; results in the "
        "store. OpenAPI at /openapi.json, pages at /docs.",
    )
    serve.add_argument("--host", default="127.0.0.1", help="address to listen on (default 127.0.0.1)")
    serve.add_argument("--port", type=port, default=8000, help="port, 1 to 65535 (default 8000)")
    add_store_option(serve)
    serve.add_argument(
        "--data", default="data", metavar="DIR", help="folder for recordings and plots (default ./data)"
    )
    serve.add_argument("--max-upload-mb", type=positive_float, default=4096.0, help="upload size limit [MB]")
    serve.add_argument(
        "--workers",
        type=int,
        default=1,
        help="analysis processes in this server (0: a separate worker runs them)",
    )
    serve.add_argument(
        "--lease",
        type=positive_float,
        default=30.0,
        metavar="S",
        help="seconds after which a running analysis whose worker went silent is taken back (default 30)",
    )
    serve.add_argument(
        "--uploads-per-fleet",
        type=positive_int,
        default=4,
        metavar="N",
        help="a fleet's uploads in progress at once; one more is refused with 429 (default 4)",
    )
    serve.add_argument(
        "--upload-idle",
        type=positive_float,
        default=30.0,
        metavar="S",
        help="longest wait for the next bytes of an upload, and the time after which it must have come "
        "at --upload-min-rate (default 30)",
    )
    serve.add_argument(
        "--upload-min-rate",
        type=positive_float,
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
        type=positive_float,
        default=10.0,
        metavar="S",
        help="seconds before an analysis that failed for a passing reason is tried again, "
        "doubled after each attempt (default 10)",
    )
    _add_connection_options(serve)
    serve.set_defaults(run=run_serve)


def add_worker_parser(sub: Any) -> None:
    """Add the ``worker`` command (the analyses apart from the server).

    Parameters
    ----------
    sub : argparse subparsers
        The CLI's ``add_subparsers()`` action.
    """
    work = sub.add_parser(
        "worker",
        help="run the service's analyses apart from the HTTP server (until stopped)",
        description="Take queued analyses from the store and run them, PROCESSES at a time, until SIGTERM "
        "or Ctrl-C; for a server started with --workers 0 (the container's worker).",
    )
    add_store_option(work)
    work.add_argument(
        "--data", default="data", metavar="DIR", help="the service's data folder (default ./data)"
    )
    work.add_argument("--processes", type=positive_int, default=1, help="analyses at a time (default 1)")
    work.add_argument(
        "--lease", type=positive_float, default=30.0, metavar="S", help="as for serve (default 30)"
    )
    work.add_argument(
        "--retry-backoff", type=positive_float, default=10.0, metavar="S", help="as for serve (default 10)"
    )
    work.set_defaults(run=run_worker)


def add_keys_parser(sub: Any) -> None:
    """Add the ``keys`` command and its actions (create, list, revoke).

    Parameters
    ----------
    sub : argparse subparsers
        The CLI's ``add_subparsers()`` action.
    """
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
        add_store_option(action)
        action.add_argument("--data", default="data", metavar="DIR", help="as for serve (default ./data)")
    keys.set_defaults(run=run_keys)


def _add_connection_options(serve: argparse.ArgumentParser) -> None:
    """serve's limits on connections (api/connections.py; docs/service.md, "Connections")."""
    serve.add_argument(
        "--header-timeout",
        type=positive_float,
        default=10.0,
        metavar="S",
        help="longest time for a connection to send a complete request head, from its accept or its "
        "previous response; then 408 and closed [s] (default 10)",
    )
    serve.add_argument(
        "--idle-timeout",
        type=positive_float,
        default=5.0,
        metavar="S",
        help="a connection without a request in progress that sends nothing for this long after its "
        "accept or its previous response is closed [s] (default 5)",
    )
    serve.add_argument(
        "--max-connections",
        type=positive_int,
        metavar="N",
        help="connections held at once; one more closes the oldest idle one (default: what the "
        "open-file limit holds, at most 10000; more than it holds is refused at start-up)",
    )
    serve.add_argument(
        "--connections-per-client",
        type=count,
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


def run_serve(args: argparse.Namespace) -> int:
    """Run ``engine-monitor serve``: the HTTP service, until stopped (SIGTERM or Ctrl-C).

    Parameters
    ----------
    args : argparse.Namespace
        The parsed command line.

    Returns
    -------
    int
        0.
    """
    import signal

    # Before anything heavy: loading uvicorn and the service takes seconds, during which a SIGTERM
    # (``docker compose stop`` of a container just started) would kill the process with status -15.
    signal.signal(signal.SIGTERM, _exit_on_sigterm)
    import uvicorn

    from api.app import create_app
    from api.settings import Settings

    data = Path(args.data)
    data.mkdir(parents=True, exist_ok=True)
    settings = Settings(
        store_url=store_url(args.store, args.data),
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
    if _sigterm_received:  # a SIGTERM whose exit a library swallowed while loading: stop before serving
        return 0
    # uvicorn stops on SIGTERM as on Ctrl-C, then raises the signal again: under the default action the
    # process would die of it there, before its exit handlers release what it holds (the analysis
    # pool's semaphores, which the resource tracker then reports as leaked) and with status -15. The
    # handler installed above, which uvicorn puts back after its shutdown, makes it a normal exit.
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


#: whether serve was sent SIGTERM outside uvicorn's run (:func:`_exit_on_sigterm`)
_sigterm_received = False


def _exit_on_sigterm(*_: object) -> None:
    """serve's SIGTERM outside uvicorn's run: a normal exit, status 0, and any SIGTERM after it ignored.

    While the service loads, nothing runs yet and the exit has nothing to clean up; after uvicorn's
    graceful shutdown (uvicorn raises the signal again), the exit handlers still have to run: a second
    SIGTERM (an impatient ``docker compose stop``, a supervisor sending it again) must neither cut them
    short with an exception of its own nor kill the process once the interpreter, as it finalizes, puts
    the default action back for the signals it handled (it leaves an ignored one ignored). Nothing is
    started after it, so no process inherits the ignored signal. The flag lets serve stop before
    serving should a library's catch-all swallow the exit while it loads.
    """
    import signal

    global _sigterm_received
    _sigterm_received = True
    signal.signal(signal.SIGTERM, signal.SIG_IGN)
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


def run_worker(args: argparse.Namespace) -> int:
    """Run ``engine-monitor worker``: the service's analyses, until stopped (SIGTERM or Ctrl-C).

    Parameters
    ----------
    args : argparse.Namespace
        The parsed command line.

    Returns
    -------
    int
        0.
    """
    import signal
    import threading

    # Before anything heavy: loading the store's and the analyses' modules takes a second or more,
    # during which a SIGTERM (a container stopped right after its start) would kill the process with
    # status -15. One that comes while loading stops the worker before it claims any job.
    stop = threading.Event()
    signal.signal(signal.SIGTERM, lambda *_: stop.set())
    import logging.config
    from datetime import timedelta

    from monitor.jobs.worker import Worker
    from monitor.store import open_store

    data = Path(args.data)
    data.mkdir(parents=True, exist_ok=True)
    store = open_store(store_url(args.store, args.data))
    if stop.is_set():
        store.close()
        return 0
    worker = Worker(
        store,
        data.resolve(),
        max(1, args.processes),
        lease=timedelta(seconds=args.lease),
        backoff=timedelta(seconds=args.retry_backoff),
    )
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


def run_keys(args: argparse.Namespace) -> int:
    """Run ``engine-monitor keys ACTION``: create, list or revoke an API key.

    Parameters
    ----------
    args : argparse.Namespace
        The parsed command line.

    Returns
    -------
    int
        0.
    """
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
    store = open_store(store_url(args.store, args.data))
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
