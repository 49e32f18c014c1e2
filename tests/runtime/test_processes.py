"""Analysis processes die with their parent and never hold its listening socket (Linux)."""

from __future__ import annotations

import json
import os
import shutil
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import pytest

from tests.conftest import unavailable

ROOT = Path(__file__).resolve().parents[2]

# Linux's /proc: a machine without it skips these; under CI (a Linux machine) a missing /proc fails them
pytestmark = pytest.mark.skipif(
    not Path("/proc/self/fd").is_dir() and not os.environ.get("CI"), reason="needs Linux's /proc"
)

#: A module the pool's processes can import (written beside the parent's script).
PROBE = '''
import os


def probe(_: int) -> dict:
    """This process's id and the inodes of the sockets it holds."""
    sockets = []
    for fd in os.listdir("/proc/self/fd"):
        try:
            target = os.readlink(f"/proc/self/fd/{fd}")
        except OSError:
            continue
        if target.startswith("socket:["):
            sockets.append(int(target[8:-1]))
    return {"pid": os.getpid(), "sockets": sockets}
'''

#: The parent: a listening socket, then a pool; it prints what its processes report, then waits.
PARENT = """
import json, os, socket, sys, time
from monitor.runtime.processes import analysis_pool
from probe import probe

listener = socket.create_server(("127.0.0.1", 0))
pool = analysis_pool(2)
reports = list(pool.map(probe, range(8)))
print(json.dumps({"listener": os.fstat(listener.fileno()).st_ino, "reports": reports}), flush=True)
time.sleep(600)
"""


def _alive(pid: int) -> bool:
    """The process exists and is not a zombie (an orphan's zombie waits for a reaper, if any)."""
    try:
        state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except (FileNotFoundError, ProcessLookupError):
        return False
    return state not in ("Z", "X")


def test_analysis_processes_hold_no_socket_of_the_parent_and_die_with_it(tmp_path: Path) -> None:
    """Issue 14: 40 of 40 worker kills and 26 of 26 server kills left analysis processes behind, the
    server's holding the listening socket. Here the parent is killed alone (not its group)."""
    (tmp_path / "probe.py").write_text(textwrap.dedent(PROBE))
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(ROOT), str(tmp_path)])}
    parent = subprocess.Popen(
        [sys.executable, "-c", PARENT], stdout=subprocess.PIPE, env=env, cwd=tmp_path, start_new_session=True
    )
    try:
        assert parent.stdout is not None
        line = parent.stdout.readline()
        assert line, "the parent printed nothing"
        seen = json.loads(line)
        children = {report["pid"] for report in seen["reports"]}
        assert children and parent.pid not in children
        for report in seen["reports"]:
            assert seen["listener"] not in report["sockets"], "an analysis process holds the listening socket"
        assert all(_alive(pid) for pid in children)
        os.kill(parent.pid, signal.SIGKILL)
        parent.wait()
        deadline = time.monotonic() + 10  # the kernel's signal is at once; the watcher within a second
        while any(_alive(pid) for pid in children) and time.monotonic() < deadline:
            time.sleep(0.05)
        assert not [pid for pid in children if _alive(pid)], "analysis processes outlived their parent"
    finally:
        if parent.poll() is None:
            parent.kill()
        parent.wait()
        if parent.stdout is not None:
            parent.stdout.close()
        try:
            os.killpg(parent.pid, signal.SIGKILL)  # whatever is left of the group, if the test failed
        except ProcessLookupError:
            pass


def test_a_pool_owned_by_process_1_works_as_in_a_container(tmp_path: Path) -> None:
    """In a container the server or worker is process 1, so its analysis processes' parent is 1. Found by
    make check-container: a guard that took a parent of 1 for 'orphaned' killed every analysis process
    at its start, and every job failed as 'the analysis process died'."""
    if shutil.which("unshare") is None or os.geteuid() != 0:
        unavailable("needs unshare and root (a PID namespace)")
    (tmp_path / "probe.py").write_text(textwrap.dedent(PROBE))
    script = (
        "import os\nfrom monitor.runtime.processes import analysis_pool\nfrom probe import probe\n"
        "if __name__ == '__main__':\n"
        "    assert os.getpid() == 1\n"
        "    print(analysis_pool(1).submit(probe, 0).result(timeout=60)['pid'] != 1)\n"
    )
    (tmp_path / "owner.py").write_text(script)
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(ROOT), str(tmp_path)])}
    out = subprocess.run(
        ["unshare", "--pid", "--fork", "--mount-proc", sys.executable, str(tmp_path / "owner.py")],
        capture_output=True,
        text=True,
        env=env,
        timeout=120,
        check=False,
    )
    if "unshare failed" in out.stderr or "Operation not permitted" in out.stderr:
        unavailable(f"no PID namespace here: {out.stderr.strip()}")
    assert out.returncode == 0 and out.stdout.strip() == "True", out.stderr
