"""The container image and the compose stack, built and run for real (``make check-container``).

On a machine that reaches no image registry, it makes everything from Debian's packages and the
host's wheels:

1. a Docker daemon: the one that answers, else (as root) Debian's ``dockerd`` started with the
   ``vfs`` storage driver, installed with ``apt-get`` if missing, with ``docker-compose`` and
   ``debootstrap``;
2. a base image: ``debootstrap --variant=minbase`` of Debian bookworm with python3, its venv module
   and PostgreSQL, imported with ``docker import`` (kept for the next run);
3. the wheelhouse (``make wheelhouse``: the product and its pinned dependencies, built on the host);
4. the product's image, built from ``docker/Dockerfile`` on that base (``--build-arg BASE``), and a
   stand-in PostgreSQL image (``docker/test/postgres.Dockerfile``) on the same base;
5. the compose stack (``docker/compose.yaml``, those two images in place of the pinned ones, the
   database password as a secret file): PostgreSQL, the API, the worker, the Dask scheduler and a
   Dask worker, each waited for until its healthcheck says healthy;
6. a key made in the API's container, a sample recording uploaded over HTTP, its diagnosis read.

It writes what it found, step by step with the time each took, into docs/service.md (between the
markers of its section), and exits 0 when every step held, 1 when one failed, and 0 with the reason
written where no Docker daemon can run here (not root, no Debian packages).
"""

from __future__ import annotations

import argparse
import json
import os
import secrets
import shutil
import socket
import subprocess
import sys
import time
from datetime import UTC, datetime
from pathlib import Path

import httpx

from benchmarks.sections import replace_section

ROOT = Path(__file__).resolve().parents[1]
WORK = ROOT / "build" / "container"
BASE_IMAGE = "engine-monitor-base:bookworm"
POSTGRES_IMAGE = "engine-monitor-test-postgres:latest"
PROJECT = "emcheck"
SAMPLE = ROOT / "recordings" / "samples" / "7k98mc-misfire-cyl4.h5"
SERVICES = ("postgres", "api", "worker", "dask-scheduler", "dask-worker")
FINAL = ("done", "set_aside")
BEGIN, END = "<!-- check-container: begin -->", "<!-- check-container: end -->"


class Skip(Exception):
    """No Docker daemon can run here: the reason."""


class Failed(Exception):
    """A step did not hold: what was seen."""


def _run(
    command: list[str], *, env: dict[str, str] | None = None, timeout: float = 1800, **kw: object
) -> str:
    """Run a command; its stdout, or Failed with the end of its output."""
    out = subprocess.run(
        command,
        capture_output=True,
        text=True,
        timeout=timeout,
        env=env,
        check=False,
        cwd=ROOT,
        **kw,  # type: ignore[call-overload]
    )
    if out.returncode != 0:
        tail = "\n".join((out.stdout + out.stderr).strip().splitlines()[-15:])
        raise Failed(f"`{' '.join(command)}` exited {out.returncode}:\n{tail}")
    return str(out.stdout)


def _answers(command: list[str]) -> bool:
    try:
        return subprocess.run(command, capture_output=True, timeout=30, check=False).returncode == 0
    except (OSError, subprocess.TimeoutExpired):
        return False


def _daemon() -> str:
    """A Docker daemon that answers, and the tools the check needs: how they were had."""
    daemon = _answers(["docker", "info"])
    missing = [] if daemon or shutil.which("dockerd") else ["docker.io"]
    missing += [] if _compose_command(probe=True) else ["docker-compose"]
    missing += [] if shutil.which("debootstrap") else ["debootstrap"]
    if missing:
        if os.geteuid() != 0 or not shutil.which("apt-get"):
            raise Skip(f"{', '.join(missing)} missing, and this user cannot install Debian's packages")
        _run(
            ["apt-get", "install", "-y", "--no-install-recommends", *missing],
            env={**os.environ, "DEBIAN_FRONTEND": "noninteractive"},
        )
    if daemon:
        return "the running Docker daemon" + (f"; installed {', '.join(missing)}" if missing else "")
    if os.geteuid() != 0:
        raise Skip("no Docker daemon answers and this user cannot start one (not root)")
    WORK.mkdir(parents=True, exist_ok=True)
    log = open(WORK / "dockerd.log", "ab")  # the daemon keeps it
    subprocess.Popen(
        ["dockerd", "--storage-driver=vfs", f"--data-root={WORK / 'docker'}"],
        stdout=log,
        stderr=log,
        start_new_session=True,
    )
    deadline = time.monotonic() + 120
    while not _answers(["docker", "info"]):
        if time.monotonic() > deadline:
            raise Skip(f"dockerd did not start in 120 s (see {WORK / 'dockerd.log'})")
        time.sleep(1)
    return "Debian's dockerd, started here with the vfs storage driver" + (
        f"; installed {', '.join(missing)}" if missing else ""
    )


def _compose_command(*, probe: bool = False) -> list[str]:
    for command in (["docker", "compose"], ["docker-compose"]):
        if _answers([*command, "version"]):
            return command
    if probe:
        return []
    raise Failed("neither `docker compose` nor `docker-compose` answers")


def _base_image() -> str:
    if _answers(["docker", "image", "inspect", BASE_IMAGE]):
        return f"{BASE_IMAGE} (made by an earlier run)"
    rootfs = WORK / "rootfs"
    if rootfs.exists():
        shutil.rmtree(rootfs)
    _run(
        [
            "debootstrap",
            "--variant=minbase",
            "--include=python3,python3-venv,postgresql,ca-certificates",
            "bookworm",
            str(rootfs),
            "http://deb.debian.org/debian",
        ]
    )
    tar = subprocess.Popen(["tar", "-C", str(rootfs), "-c", "."], stdout=subprocess.PIPE)
    _run(["docker", "import", "-", BASE_IMAGE], stdin=tar.stdout)
    tar.wait()
    shutil.rmtree(rootfs)
    return f"{BASE_IMAGE}: debootstrap of bookworm with python3, python3-venv and postgresql"


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def _healthy(compose: list[str], env: dict[str, str], timeout: float) -> dict[str, str]:
    """Each service's container health, once every one is healthy (or Failed at the deadline)."""
    deadline = time.monotonic() + timeout
    states: dict[str, str] = {}
    while time.monotonic() < deadline:
        for service in SERVICES:
            ids = _run([*compose, "ps", "-q", service], env=env).split()
            states[service] = (
                _run(["docker", "inspect", "--format", "{{.State.Health.Status}}", ids[0]]).strip()
                if ids
                else "absent"
            )
        if all(state == "healthy" for state in states.values()):
            return states
        if any(state == "unhealthy" for state in states.values()):
            break
        time.sleep(3)
    raise Failed(f"not every service became healthy: {states}")


def check(steps: list[tuple[str, str, float]]) -> None:
    """The whole check; appends (step, what was seen, seconds) to ``steps``."""

    def step(name: str, action, *args):  # type: ignore[no-untyped-def]
        started = time.monotonic()
        seen = action(*args)
        steps.append((name, str(seen), time.monotonic() - started))
        print(f"check-container: {name}: {seen} ({time.monotonic() - started:.0f} s)", flush=True)
        return seen

    step("Docker daemon", _daemon)
    compose = _compose_command()
    step("base image", _base_image)
    step("wheelhouse", _then, "the product and its pinned dependencies", ["make", "wheelhouse"])
    WORK.mkdir(parents=True, exist_ok=True)
    secret = WORK / "db_password"
    secret.write_text(secrets.token_hex(24))
    secret.chmod(0o444)  # read by PostgreSQL's and the product's users inside the containers
    port = _free_port()
    env = {
        **os.environ,
        "COMPOSE_PROJECT_NAME": PROJECT,
        "ENGINE_MONITOR_BASE": BASE_IMAGE,
        "POSTGRES_IMAGE": POSTGRES_IMAGE,
        "ENGINE_MONITOR_DB_PASSWORD_FILE_HOST": str(secret),
        "ENGINE_MONITOR_PORT": str(port),
    }
    build = [
        "docker",
        "build",
        "-q",
        "-f",
        "docker/test/postgres.Dockerfile",
        "--build-arg",
        f"BASE={BASE_IMAGE}",
    ]
    step("stand-in PostgreSQL image", _then, POSTGRES_IMAGE, [*build, "-t", POSTGRES_IMAGE, "."])
    stack = [*compose, "-f", "docker/compose.yaml"]
    step("product image", _then, "engine-monitor:latest", [*stack, "build"], env)
    step("image runs unprivileged, installed from its wheel", _image_facts)
    _run([*stack, "down", "-v"], env=env)  # what an interrupted run left (its database had another password)
    try:
        step("stack started", _then, ", ".join(SERVICES), [*stack, "up", "-d", *SERVICES], env)
        step("every service healthy", _healthy_with_logs, stack, env)
        make_key = [*stack, "exec", "-T", "api", "engine-monitor", "keys", "create", "--fleet", "check"]
        made: list[str] = []

        def key() -> str:
            made.append(_run(make_key, env=env).split()[-1])
            return "a key of the fleet 'check' (not shown)"

        step("key made in the API's container", key)
        step("sample uploaded and diagnosed over HTTP", _diagnosis, port, made[0])
    finally:
        try:
            _run([*stack, "down", "-v"], env=env)
        except Failed as error:
            print(f"check-container: stopping the stack: {error}", file=sys.stderr)


def _then(seen: str, command: list[str], env: dict[str, str] | None = None) -> str:
    """Run a command (Failed if it fails), then say ``seen``."""
    _run(command, env=env)
    return seen


def _healthy_with_logs(stack: list[str], env: dict[str, str]) -> str:
    """:func:`_healthy`, its failure telling the last lines of each service's log."""
    try:
        return ", ".join(f"{k} {v}" for k, v in _healthy(stack, env, 600).items())
    except Failed as error:
        logs = _run([*stack, "logs", "--no-color", "--tail", "5", *SERVICES], env=env)
        raise Failed(f"{error}; the last lines of their logs:\n{logs}") from None


def _image_facts() -> str:
    uid = _run(["docker", "run", "--rm", "--entrypoint", "id", "engine-monitor:latest", "-u"]).strip()
    if uid == "0":
        raise Failed("the image runs as root")
    where = _run(
        ["docker", "run", "--rm", "--entrypoint", "python3", "engine-monitor:latest", "-c",
         "import monitor, pathlib; print(pathlib.Path(monitor.__file__).parent)"]
    ).strip()  # fmt: skip
    if "site-packages" not in where:
        raise Failed(f"the product is not installed from its wheel: monitor is at {where}")
    return f"uid {uid}, monitor at {where}"


def _diagnosis(port: int, key: str) -> str:
    with httpx.Client(base_url=f"http://127.0.0.1:{port}", headers={"X-API-Key": key}, timeout=60) as client:
        answer = client.post("/recordings", params={"filename": SAMPLE.name}, content=SAMPLE.read_bytes())
        if answer.status_code != 201:
            raise Failed(f"upload answered {answer.status_code}: {answer.text}")
        recording = answer.json()["id"]
        deadline = time.monotonic() + 300
        while (status := client.get(f"/recordings/{recording}").json())["status"] not in (
            "done",
            "set_aside",
        ):
            if time.monotonic() > deadline:
                raise Failed(f"the analysis did not finish in 300 s: {status}")
            time.sleep(2)
        diagnosis = client.get(f"/recordings/{recording}/diagnosis")
        if diagnosis.status_code != 200:
            raise Failed(f"diagnosis answered {diagnosis.status_code}: {diagnosis.text}")
        document = diagnosis.json()
    subjects = [f["subject"] for f in document["findings"]]
    if document["status"] != "alarm" or subjects != ["cylinder 4"]:
        raise Failed(f"the diagnosis is {document['status']} with findings on {subjects}")
    return f"{SAMPLE.name}: {document['status']}, finding on {subjects[0]}"


def _document(steps: list[tuple[str, str, float]], outcome: str) -> str:
    moment = datetime.now(UTC).strftime("%Y-%m-%d %H:%M UTC")
    lines = [
        BEGIN,
        f"Written by `make check-container` (`python -m benchmarks.container`) on {moment}: **{outcome}**.",
        "",
        "| step | what was seen | time [s] |",
        "|---|---|---|",
    ]
    for name, seen, seconds in steps:
        lines.append(f"| {name} | {seen.replace('|', '/').splitlines()[0] if seen else ''} | {seconds:.0f} |")
    lines.append(END)
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--doc", default=str(ROOT / "docs" / "service.md"), help="the document to write into")
    args = parser.parse_args(argv)
    steps: list[tuple[str, str, float]] = []
    status = 0
    try:
        check(steps)
        outcome = "every step held"
    except Skip as reason:
        outcome = f"skipped: {reason}"
    except (Failed, subprocess.TimeoutExpired) as error:
        outcome = f"failed: {str(error).splitlines()[0]}"
        print(f"check-container: {error}", file=sys.stderr)
        status = 1
    doc = Path(args.doc)
    replace_section(doc, BEGIN, END, _document(steps, outcome))
    print(f"check-container: {outcome}; written into {doc}")
    print(json.dumps({"outcome": outcome, "steps": [s[0] for s in steps]}))
    return status


if __name__ == "__main__":
    raise SystemExit(main())
