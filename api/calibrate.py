"""Calibrate a baseline on a stored recording, in a process of its own, as the request waits.

``python -m api.calibrate PARENT MEMORY_BYTES`` reads the engine's
description (the fleet's own, or null for the bundled one), the recordings'
paths and names and their loads (null: each estimated, or rated for one) as
JSON on its standard input, limits its own address space,
lowers its own CPU priority (:data:`monitor.runtime.processes.NICE`, as the analyses), dies
with its parent, and calibrates a point on each recording as
``engine-monitor calibrate`` does (:func:`monitor.jobs.calibration.calibrate_recordings`).
It prints the baseline document
(``calibrate``'s JSON) and exits 0, or prints the product's refusal (an
unhealthy recording, one with neither a bearing channel nor crank-speed orders, a faulty
sensor) and exits 3.

The service awaits it without holding a thread, within a time limit
(:attr:`api.settings.Settings.calibration_timeout_s`), one calibration per fleet
and :attr:`api.settings.Settings.calibrations` in all at once: the answer is the
baseline itself, or the reason there is none, in the same request, and
nothing is stored until the calibration has succeeded.
"""

from __future__ import annotations

import asyncio
import json
import os
import resource
import sys
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from monitor.runtime.processes import NICE

__all__ = ["Calibration", "calibrate_stored"]


@dataclass(frozen=True)
class Calibration:
    """What the calibrating process said: the baseline document, or why there is none."""

    ok: bool
    document: dict[str, Any] = field(default_factory=dict)
    message: str = ""


def _calibrate(
    paths: list[str], engine_description: dict[str, Any] | None, loads: list[float] | None, names: list[str]
) -> dict[str, Any]:
    from monitor.jobs.calibration import calibrate_recordings

    return calibrate_recordings(
        paths, loads=loads, engine=engine_description, names=names
    ).points.to_document()


async def calibrate_stored(
    paths: list[str],
    engine_description: dict[str, Any] | None,
    *,
    loads: list[float] | None,
    names: list[str],
    memory_bytes: int,
    timeout_s: float,
) -> Calibration:
    """Calibrate a baseline on the recordings at ``paths`` (one operating point each) in a child process
    with these limits."""
    child = await asyncio.create_subprocess_exec(
        sys.executable,
        "-m",
        "api.calibrate",
        str(os.getpid()),
        str(memory_bytes),
        stdin=asyncio.subprocess.PIPE,
        stdout=asyncio.subprocess.PIPE,
        stderr=asyncio.subprocess.PIPE,
        cwd=Path(__file__).resolve().parents[1],
    )
    request = {"engine": engine_description, "paths": paths, "names": names, "loads": loads}
    label = ", ".join(names)
    try:
        stdout, stderr = await asyncio.wait_for(
            child.communicate(json.dumps(request).encode("utf-8")), timeout_s
        )
    except (TimeoutError, asyncio.CancelledError) as stop:
        child.kill()
        await child.wait()
        if isinstance(stop, asyncio.CancelledError):  # the client went away: stop calibrating
            raise
        return Calibration(
            False,
            message=f"{label}: the calibration took longer than the service's limit of {timeout_s:g} s: "
            "calibrate on shorter recordings (a few minutes at a steady speed suffice)",
        )
    if child.returncode == 0:
        return Calibration(True, json.loads(stdout))
    err = stderr.decode("utf-8", "replace").strip()
    reason = err.splitlines()[-1] if err else f"exit status {child.returncode}"
    if child.returncode != 3:
        reason = f"{label}: the calibration failed ({reason})"
    for path, name in zip(paths, names, strict=True):
        reason = reason.replace(path, name)
    return Calibration(False, message=reason)


def main() -> None:
    from monitor.runtime.processes import die_with_parent

    die_with_parent(int(sys.argv[1]))
    limit = int(sys.argv[2])
    resource.setrlimit(resource.RLIMIT_AS, (limit, limit))
    os.setpriority(os.PRIO_PROCESS, 0, max(NICE, os.getpriority(os.PRIO_PROCESS, 0)))
    from monitor.errors import MonitorError

    given = json.loads(sys.stdin.read())
    loads = None if given["loads"] is None else [float(v) for v in given["loads"]]
    try:
        document = _calibrate(
            [str(p) for p in given["paths"]], given["engine"], loads, [str(n) for n in given["names"]]
        )
    except (MonitorError, OSError, ValueError) as error:
        print(str(error).replace("\n", " "), file=sys.stderr)
        sys.exit(3)
    except MemoryError:
        print("the calibration needs more memory than the service allows it", file=sys.stderr)
        sys.exit(3)
    print(json.dumps(document))


if __name__ == "__main__":
    main()
