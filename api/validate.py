"""Validate an uploaded file with the product's readers, in a process of its own.

``python -m api.validate MEMORY_BYTES MAX_EXPANSION PATH`` limits its own
address space and lowers its own CPU priority (:data:`NICE`: the server's
reads go first where both want a core), then prints the recording's engine, start time and channels
as JSON (exit 0), or the reader's refusal (exit 3). The service runs it with
that memory limit (``RLIMIT_AS``) and a time limit, awaiting it without
holding a thread: a malformed file that makes a reader allocate without
bound or loop cannot take the server down, nor keep the read routes waiting.

Before any sample is read, the samples the file declares (every channel's
count times its sample size) are compared with the file's size: more than
``MAX_EXPANSION`` times the file (a dataset declared with 10^12 samples it
never wrote, a compression bomb) is refused at once. A recording's samples
compress little (noise does not compress; our HDF5 is not compressed at
all; a channel of zeros among five makes 1.25), so only a file of almost
nothing but constant samples comes near the limit of 100, while a gzip bomb
of zeros reaches about 1000.

Before all that, the bytes themselves must be a recording's: HDF5 or MCAP by
their signatures (:func:`format_refusal`), whatever the request's content type
said; anything else is refused unread, its message saying what the bytes look
like.
"""

from __future__ import annotations

import asyncio
import json
import os
import resource
import sys
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from monitor.runtime.processes import NICE

__all__ = ["MAX_EXPANSION", "Validation", "format_refusal", "validate"]

#: Declared samples [bytes] per byte of file beyond which a file is refused unread.
MAX_EXPANSION = 100.0


@dataclass(frozen=True)
class Validation:
    """What the validator said: the metadata of a readable recording, or why it is not one."""

    ok: bool
    engine_id: str = ""
    start_time: str = ""
    channels: tuple[str, ...] = ()
    message: str = ""


def format_refusal(path: Path) -> str | None:
    """Why an uploaded file is not a recording by its signature (what its bytes look like), or None for
    HDF5 or MCAP bytes.

    Parameters
    ----------
    path : Path
        The uploaded file.

    Returns
    -------
    str or None
    """
    from monitor.io import looks_like, recording_format

    if recording_format(path) is not None:
        return None
    with open(path, "rb") as fh:
        seen = looks_like(fh.read(64))
    return (
        f"the body's bytes look like {seen}, not a recording: expected HDF5 (signature "
        "\\x89HDF\\r\\n\\x1a\\n at byte 0, 512, 1024, ...) or MCAP (\\x89MCAP0\\r\\n at byte 0), the "
        "file itself as the request body (curl --data-binary @FILE)"
    )


def _check(path: str, max_expansion: float) -> dict[str, object]:
    from monitor.errors import MonitorError
    from monitor.io import open_recording

    with open_recording(path) as recording:  # every sample read by slices: checksums checked, memory bounded
        declared = sum(int(c.data.shape[0]) * np.dtype(c.data.dtype).itemsize for c in recording.channels)
        size = max(1, os.path.getsize(path))
        if declared > max_expansion * size:
            raise MonitorError(
                f"{path}: its channels declare {declared} bytes of samples, {declared / size:.3g} times "
                f"the file's {size} bytes (at most {max_expansion:g}): refused unread, as a compression "
                "bomb or a dataset declared larger than it was written"
            )
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


async def validate(
    path: Path, *, memory_bytes: int, timeout_s: float, max_expansion: float = MAX_EXPANSION
) -> Validation:
    """Run the validator on ``path`` in a child process with the given limits, awaiting it."""
    child = await asyncio.create_subprocess_exec(  # the child sets its own memory limit first
        sys.executable,
        "-m",
        "api.validate",
        str(memory_bytes),
        repr(float(max_expansion)),
        str(path),
        stdout=asyncio.subprocess.PIPE,
        stderr=asyncio.subprocess.PIPE,
        cwd=Path(__file__).resolve().parents[1],
    )
    try:
        stdout, stderr = await asyncio.wait_for(child.communicate(), timeout_s)
    except (TimeoutError, asyncio.CancelledError) as stop:
        child.kill()
        await child.wait()
        if isinstance(stop, asyncio.CancelledError):  # the client went away: stop reading its file
            raise
        return Validation(False, message=f"the file took longer than {timeout_s:g} s to read: refused")
    out, err = stdout.decode("utf-8", "replace"), stderr.decode("utf-8", "replace")
    if child.returncode == 0:
        data = json.loads(out)
        if data["truncated"]:
            return Validation(False, message="the recording is truncated (cut short): refused")
        return Validation(True, str(data["engine_id"]), str(data["start_time"]), tuple(data["channels"]))
    reason = err.strip().splitlines()[-1] if err.strip() else f"exit status {child.returncode}"
    if child.returncode != 3:
        reason = f"the reader failed ({reason}); the file is not a recording the product can read"
    return Validation(False, message=reason)


def main() -> None:
    limit = int(sys.argv[1])
    resource.setrlimit(resource.RLIMIT_AS, (limit, limit))
    os.setpriority(os.PRIO_PROCESS, 0, max(NICE, os.getpriority(os.PRIO_PROCESS, 0)))
    from monitor.errors import MonitorError

    try:
        data = _check(sys.argv[3], float(sys.argv[2]))
    except (MonitorError, OSError, ValueError) as error:
        print(str(error), file=sys.stderr)
        sys.exit(3)
    except MemoryError:
        print("the file needs more memory than a recording of its size should: refused", file=sys.stderr)
        sys.exit(3)
    print(json.dumps(data))


if __name__ == "__main__":
    main()
