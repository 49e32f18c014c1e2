"""Validate an uploaded file with the product's readers, in a process of its own.

``python -m api.validate MEMORY_BYTES PATH`` limits its own address space,
then prints the recording's engine, start time and channels as JSON (exit 0),
or the reader's refusal (exit 3). The service runs it with that memory limit
(``RLIMIT_AS``) and a time limit: a malformed file that
makes a reader allocate without bound or loop cannot take the server down.
"""

from __future__ import annotations

import json
import resource
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

__all__ = ["Validation", "validate"]


@dataclass(frozen=True)
class Validation:
    """What the validator said: the metadata of a readable recording, or why it is not one."""

    ok: bool
    engine_id: str = ""
    start_time: str = ""
    channels: tuple[str, ...] = ()
    message: str = ""


def _check(path: str) -> dict[str, object]:
    from monitor.io import open_recording

    with open_recording(path) as recording:  # every sample read by slices: checksums checked, memory bounded
        for channel in recording.channels:
            n = int(channel.data.shape[0])
            for start in range(0, n, 1 << 20):
                channel.data[start : start + (1 << 20)]
        return {
            "engine_id": recording.engine_id,
            "start_time": recording.start_time,
            "channels": [c.name for c in recording.channels],
            "truncated": recording.truncated,
        }


def validate(path: Path, *, memory_bytes: int, timeout_s: float) -> Validation:
    """Run the validator on ``path`` in a child process with the given limits."""

    try:
        out = (
            subprocess.run(  # the child sets its own memory limit first (no preexec_fn in a threaded server)
                [sys.executable, "-m", "api.validate", str(memory_bytes), str(path)],
                capture_output=True,
                text=True,
                timeout=timeout_s,
                check=False,
                cwd=Path(__file__).resolve().parents[1],
            )
        )
    except subprocess.TimeoutExpired:
        return Validation(False, message=f"the file took longer than {timeout_s:g} s to read: refused")
    if out.returncode == 0:
        data = json.loads(out.stdout)
        if data["truncated"]:
            return Validation(False, message="the recording is truncated (cut short): refused")
        return Validation(True, str(data["engine_id"]), str(data["start_time"]), tuple(data["channels"]))
    reason = out.stderr.strip().splitlines()[-1] if out.stderr.strip() else f"exit status {out.returncode}"
    if out.returncode != 3:
        reason = f"the reader failed ({reason}); the file is not a recording the product can read"
    return Validation(False, message=reason)


def main() -> None:
    limit = int(sys.argv[1])
    resource.setrlimit(resource.RLIMIT_AS, (limit, limit))
    from monitor.errors import MonitorError

    try:
        data = _check(sys.argv[2])
    except (MonitorError, OSError, ValueError) as error:
        print(str(error), file=sys.stderr)
        sys.exit(3)
    except MemoryError:
        print("the file needs more memory than a recording of its size should: refused", file=sys.stderr)
        sys.exit(3)
    print(json.dumps(data))


if __name__ == "__main__":
    main()
