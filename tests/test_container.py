"""The container files, checked without a Docker engine (none runs here): structure and commands.

The image runs as a user without privileges; the compose file has the API, a worker, PostgreSQL
and a Dask scheduler with workers; every engine-monitor command in it parses with the CLI.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from monitor.cli import _build_parser

ROOT = Path(__file__).resolve().parents[1]
DOCKER = ROOT / "docker"


def test_the_image_runs_as_a_user_without_privileges() -> None:
    lines = [line.strip() for line in (DOCKER / "Dockerfile").read_text().splitlines()]
    users = [line.split()[1] for line in lines if line.startswith("USER ")]
    assert users and users[-1] == "monitor"
    last_user = max(i for i, line in enumerate(lines) if line.startswith("USER "))
    assert last_user < min(i for i, line in enumerate(lines) if line.startswith(("ENTRYPOINT", "CMD")))
    assert any("useradd --system" in line for line in lines)
    assert any(line.startswith("RUN pip install -c constraints.txt") for line in lines)  # the pinned versions


def test_the_compose_file_has_every_service_and_their_commands_parse() -> None:
    yaml = pytest.importorskip("yaml", reason="PyYAML comes with the test dependencies")
    compose = yaml.safe_load((DOCKER / "compose.yaml").read_text())
    services = compose["services"]
    assert {"api", "worker", "postgres", "dask-scheduler", "dask-worker", "batch"} <= set(services)
    assert services["postgres"]["image"].startswith("postgres:")
    parser = _build_parser()
    for name in ("api", "worker", "batch"):
        command = services[name]["command"]
        args = parser.parse_args(command)  # raises SystemExit on an option the CLI does not have
        assert args.command == command[0]
    url = services["api"]["environment"]["ENGINE_MONITOR_DB"]
    assert url.startswith("postgresql+psycopg://") and "@postgres:5432/" in url
    assert services["dask-worker"]["entrypoint"][:3] == ["dask", "worker", "tcp://dask-scheduler:8786"]
    assert "--scheduler" in services["batch"]["command"]
    assert all(service.get("volumes") for key, service in services.items() if key != "dask-scheduler")
