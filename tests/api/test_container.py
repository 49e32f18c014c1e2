"""The container files' structure and commands (the image and the stack are built and run for real
by ``make check-container``, benchmarks/container.py, whose result docs/service.md shows).

The image runs as a user without privileges from a base pinned by digest, installs wheels (the
dependencies in a layer of their own); the compose file has the API, a worker, PostgreSQL and a Dask
scheduler with workers, each with a healthcheck, the database password as a secret file; every
engine-monitor command in it parses with the CLI; nginx in front of the API holds the per-client
limits (docker/nginx.conf, its directives checked here; run by no test).
"""

from __future__ import annotations

import json
import re
from pathlib import Path, PurePosixPath

from monitor.cli.main import _build_parser

ROOT = Path(__file__).resolve().parents[2]
DOCKER = ROOT / "docker"


def test_the_image_runs_as_a_user_without_privileges() -> None:
    lines = [line.strip() for line in (DOCKER / "Dockerfile").read_text().splitlines()]
    users = [line.split()[1] for line in lines if line.startswith("USER ")]
    assert users and users[-1] == "monitor"
    last_user = max(i for i, line in enumerate(lines) if line.startswith("USER "))
    assert last_user < min(i for i, line in enumerate(lines) if line.startswith(("ENTRYPOINT", "CMD")))
    assert any("useradd --system" in line for line in lines)


def test_the_image_is_pinned_and_installs_wheels_dependencies_first() -> None:
    text = (DOCKER / "Dockerfile").read_text()
    lines = [line.strip() for line in text.splitlines()]
    base = next(line for line in lines if line.startswith("ARG BASE="))
    assert re.fullmatch(r"ARG BASE=python:3\.11-slim-bookworm@sha256:[0-9a-f]{64}", base)
    assert "FROM ${BASE}" in lines
    installs = [line for line in lines if line.startswith("RUN pip install")]
    assert installs and all("--no-index" in line and "-e " not in line for line in installs)
    sources = [line.split()[1] for line in lines if line.startswith("COPY")]
    # the dependencies' layer first: it does not change with the code
    assert sources == ["docker/wheelhouse/dependencies/", "docker/wheelhouse/product/"]
    assert any(line.startswith("HEALTHCHECK") for line in lines)
    ignored = [line for line in (ROOT / ".dockerignore").read_text().splitlines() if not line.startswith("#")]
    assert ignored == ["*", "!docker/wheelhouse/", "!docker/test/"]  # wheels; never .venv or build/


def test_the_compose_file_has_every_service_and_their_commands_parse() -> None:
    import yaml

    compose = yaml.safe_load((DOCKER / "compose.yaml").read_text())
    services = compose["services"]
    assert {"api", "worker", "postgres", "dask-scheduler", "dask-worker", "batch"} <= set(services)
    parser = _build_parser()
    for name in ("api", "worker", "batch"):
        command = services[name]["command"]
        args = parser.parse_args(command)  # raises SystemExit on an option the CLI does not have
        assert args.command == command[0]
    url = services["api"]["environment"]["ENGINE_MONITOR_DB"]
    assert url.startswith("postgresql+psycopg://monitor@postgres:5432/")  # no password in the file
    assert "PASSWORD" not in json.dumps(services["postgres"]["environment"]).replace("PASSWORD_FILE", "")
    assert services["api"]["environment"]["ENGINE_MONITOR_DB_PASSWORD_FILE"] == "/run/secrets/db_password"
    assert compose["secrets"]["db_password"]["file"].endswith("./secrets/db_password}")
    assert re.search(r"postgres:16-bookworm@sha256:[0-9a-f]{64}", services["postgres"]["image"])
    for name, service in services.items():  # every service but the batch (a command) says whether it is well
        assert "test" in service.get("healthcheck", {}) or name == "batch", name
    assert services["dask-worker"]["entrypoint"][:3] == ["dask", "worker", "tcp://dask-scheduler:8786"]
    assert "--scheduler" in services["batch"]["command"]
    assert all(service.get("volumes") for key, service in services.items() if key != "dask-scheduler")


def test_the_proxy_in_front_of_the_api_limits_clients_and_the_api_trusts_it_alone() -> None:
    """nginx (Debian's, on the product's pinned base, unprivileged) is the stack's HTTPS entry: TLS
    from secret files, a request head's and a keep-alive connection's timeouts, connections and
    requests per client address; the API behind it leaves the per-client cap to it and publishes its
    own port on the host's loopback alone."""
    import yaml

    compose = yaml.safe_load((DOCKER / "compose.yaml").read_text())
    services = compose["services"]
    proxy, api = services["proxy"], services["api"]
    assert proxy["build"]["dockerfile"] == "docker/nginx.Dockerfile"
    assert proxy["build"]["args"]["BASE"] == services["worker"]["build"]["args"]["BASE"]
    assert proxy["depends_on"]["api"]["condition"] == "service_healthy"
    assert "https://127.0.0.1:8443/health" in " ".join(proxy["healthcheck"]["test"])
    assert proxy["ports"] == ["${ENGINE_MONITOR_HTTPS_PORT:-8443}:8443"]
    assert "./nginx.conf:/etc/nginx/nginx.conf:ro" in proxy["volumes"]
    assert set(proxy["secrets"]) == {"tls_certificate", "tls_key"} <= set(compose["secrets"])
    assert all(not compose["secrets"][name]["file"].startswith("/") for name in proxy["secrets"])
    assert api["ports"] == ["127.0.0.1:${ENGINE_MONITOR_PORT:-8000}:8000"]
    args = _build_parser().parse_args(api["command"])
    assert args.connections_per_client == 0 and api["environment"]["FORWARDED_ALLOW_IPS"] == "*"

    lines = [line.strip() for line in (DOCKER / "nginx.Dockerfile").read_text().splitlines()]
    base = next(line for line in lines if line.startswith("ARG BASE="))
    assert base.removeprefix("ARG BASE=") in api["build"]["args"]["BASE"]  # the product's pinned base
    assert "USER www-data" in lines and not any(line.startswith("COPY") for line in lines)

    conf = (DOCKER / "nginx.conf").read_text()
    directives = {
        m.group(1): m.group(2).strip()
        for m in re.finditer(r"^\s*([a-z_]+)\s+([^;{]*);", conf, flags=re.MULTILINE)
    }
    assert directives["listen"] == "8443 ssl"
    assert directives["ssl_certificate"] == "/run/secrets/tls_certificate"
    assert directives["ssl_certificate_key"] == "/run/secrets/tls_key"
    assert directives["client_header_timeout"] == "10s" and directives["keepalive_timeout"] == "5s"
    assert directives["limit_conn"].startswith("per_client_connections ")
    assert directives["limit_req"].startswith("zone=per_client_requests ")
    assert "$binary_remote_addr" in directives["limit_conn_zone"]
    assert directives["proxy_request_buffering"] == "on" and directives["proxy_pass"] == "http://api"
    # the pid file in the image's temporary folder, which www-data (the user nginx runs as) can write
    pid = PurePosixPath(directives["pid"])
    assert pid.is_absolute() and pid.parent.name == "tmp" and pid.parent.parent == PurePosixPath(pid.anchor)
