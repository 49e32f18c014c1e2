"""Every shell example in the README and docs/ runs, as written, and succeeds.

The convention the documents follow:

- A fenced ```sh block holds examples. This test runs each of its commands exactly as written, in the
  order of the document, every block of a document in one shell (a variable one block sets, such as
  ``KEY``, is there for the next), in a scratch folder laid out as the repository's root is for a
  reader who has run ``make``: ``recordings/`` (the bundled scenes and sample recordings) and
  ``.venv/bin/engine-monitor`` (the product of this tree), also on the ``PATH`` as ``engine-monitor``.
- A command that starts the service (``engine-monitor serve ...``) runs until the document's end: it is
  started in the background, the next command waits until it answers ``/health``, and after the last
  one it is stopped with SIGTERM. The documents' URLs say ``127.0.0.1:8000``: each document runs in a
  network namespace of its own (``unshare --net``, as root), so their servers and other tests' never
  meet.
- A command succeeds when it exits 0, or with the status its comment states (``# exits 2: ...``), and
  prints no error: no traceback, no ``engine-monitor: error:``, no error body of the service (curl
  answers an HTTP error with a failure and says so: ``fail-with-body`` and ``show-error`` in the
  scratch folder's ``.curlrc``). The
  server's log must hold no traceback, no ERROR line, no leaked resource.
- A usage synopsis with placeholders (``ENGINE.toml``, ``[--opt]``) is not an example: it goes in a
  ```text block.
- The few commands no test can run as written are listed in :data:`NOT_RUN` with the reason and what
  covers them instead; the cover runs in their place. Nothing else is left out.
"""

from __future__ import annotations

import os
import re
import shlex
import shutil
import signal
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

import pytest

from tests.conftest import unavailable

ROOT = Path(__file__).resolve().parents[1]
DOCUMENTS = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
#: fences that would hold shell commands under another name, so escape this test: refused
_OTHER_SHELLS = re.compile(r"^```(bash|shell|console|zsh)\s*$", re.MULTILINE)
_FENCE = re.compile(r"^```(\S*)[^\n]*\n(.*?)^```\s*$", re.MULTILINE | re.DOTALL)
_SERVE = re.compile(r"engine-monitor serve\b")
_EXITS = re.compile(r"#.*\bexits (\d+)\b")
#: what a command may not print (its stdout or stderr): curl says "curl: (22) ..." on an HTTP error, in a
#: pipe too, where its status is not the command's
_ERRORS = re.compile(r"Traceback \(most recent call last\)|engine-monitor: error:|curl: \(\d+\)")
#: what the server's log may not hold
_SERVER_ERRORS = re.compile(r"Traceback|^ERROR|leaked|resource_tracker", re.MULTILINE)
TIMEOUT_S = 600  # a document's commands in all, on a loaded 2-core machine (they take about a minute idle)


@dataclass(frozen=True)
class NotRun:
    """A documented command no test runs as written: why, and what runs in its place."""

    reason: str
    cover: str  # a command run in the repository's root, or a test file that covers it


#: Each documented command that no test runs as written (its text with runs of blanks made one).
NOT_RUN = {
    "make demo": NotRun(
        "it creates .venv/ and installs the product from the package index (minutes, network)",
        "make -n demo",  # the target exists; its two commands are the README's diagnosis examples, run here
    ),
    "make test": NotRun("it runs the whole test suite, this test included", "make -n test"),
    "make wheelhouse && docker compose -f docker/compose.yaml up -d --build": NotRun(
        "it builds the container image and runs the stack (a Docker daemon, minutes)",
        "tests/api/test_container.py",
    ),
    "make wheelhouse": NotRun(
        "it downloads the pinned dependencies as wheels (network, minutes)", "make -n wheelhouse"
    ),
    "docker compose -f docker/compose.yaml up -d --build": NotRun(
        "a Docker daemon and minutes", "tests/api/test_container.py"
    ),
    "docker compose -f docker/compose.yaml exec api engine-monitor keys create --fleet my-fleet": NotRun(
        "the compose stack running", "tests/api/test_container.py"
    ),
}


@dataclass(frozen=True)
class Command:
    text: str
    line: int  # in its document
    status: int  # the exit status that means success


def commands(document: Path) -> list[Command]:
    """The commands of a document's ```sh blocks, in order: continued lines joined, comments kept."""
    text = document.read_text(encoding="utf-8")
    found = []
    for fence in _FENCE.finditer(text):
        if fence.group(1) != "sh":
            continue
        first = text.count("\n", 0, fence.start(2)) + 1
        lines = fence.group(2).splitlines()
        i = 0
        while i < len(lines):
            start = i
            command = lines[i]
            while command.rstrip().endswith("\\") and i + 1 < len(lines):
                i += 1
                command += "\n" + lines[i]
            i += 1
            if command.strip() and not command.lstrip().startswith("#"):
                expected = _EXITS.search(command)
                found.append(Command(command, first + start, int(expected.group(1)) if expected else 0))
    return found


def _key(command: str) -> str:
    """A command as :data:`NOT_RUN` names it: comments and runs of blanks left out."""
    try:
        return " ".join(shlex.split(command, comments=True))
    except ValueError:  # not one shell word list (an unclosed quote): compared as it is
        return " ".join(command.split())


def _documents_with_examples() -> list[Path]:
    return [d for d in DOCUMENTS if commands(d)]


def test_the_documents_use_one_fence_for_shell_examples() -> None:
    """Shell examples are ```sh blocks (run by this test); no ```bash or ```console block escapes it,
    and every command :data:`NOT_RUN` lists is still in a document, with a cover that exists."""
    for document in DOCUMENTS:
        other = _OTHER_SHELLS.search(document.read_text(encoding="utf-8"))
        assert other is None, f"{document.relative_to(ROOT)}: ```{other.group(1)}: write ```sh (or ```text)"
    documented = {_key(c.text) for d in DOCUMENTS for c in commands(d)}
    for key, not_run in NOT_RUN.items():
        assert key in documented, f"NOT_RUN lists {key!r}, which no document holds any more"
        if not_run.cover.startswith("tests/"):
            assert (ROOT / not_run.cover).is_file(), not_run.cover


def _scratch(folder: Path) -> dict[str, str]:
    """Lay out the scratch folder a document's commands run in; their environment."""
    (folder / "recordings").symlink_to(ROOT / "recordings")
    bin_dir = folder / ".venv" / "bin"
    bin_dir.mkdir(parents=True)
    program = bin_dir / "engine-monitor"
    program.write_text(
        "#!/bin/sh\n"
        f"PYTHONPATH={shlex.quote(str(ROOT))}${{PYTHONPATH:+:$PYTHONPATH}} "
        f'exec {shlex.quote(sys.executable)} -m monitor "$@"\n'
    )
    program.chmod(0o755)
    (folder / ".curlrc").write_text("fail-with-body\nsilent\nshow-error\n")
    environment = {
        k: v for k, v in os.environ.items() if not k.startswith(("ENGINE_MONITOR_", "PYTEST_", "COV_"))
    }
    environment.update(
        PATH=f"{bin_dir}:{environment.get('PATH', '/usr/bin:/bin')}",
        CURL_HOME=str(folder),
        HOME=str(folder),
        MPLBACKEND="Agg",
    )
    return environment


def _script(found: list[Command], log: Path) -> str:
    """One bash script for a document: each command as written, its output and status kept in
    ``log/N.*``; a server started in the background and waited for; the first failure stops it."""
    parts = [
        'cd "$(dirname "$0")"',
        "__servers=''",
        '__stop() { for p in $__servers; do kill -TERM "$p" 2>/dev/null; wait "$p"; '
        f"echo $? > {log}/server-$p.status; done; }}",
        "trap __stop EXIT",
    ]
    for n, command in enumerate(found):
        if _key(command.text) in NOT_RUN:
            continue
        out = f"{log}/{n}"
        if _SERVE.search(command.text):
            port = re.search(r"--port[ =](\d+)", command.text)
            url = f"http://127.0.0.1:{port.group(1) if port else 8000}/health"
            parts += [
                "(",  # exec: the server itself is the background process, stopped at the end
                f"exec {command.text}",
                f") > {out}.stdout 2> {out}.stderr < /dev/null &",
                f'__servers="$__servers $!"; echo $! > {out}.server',
                f"for __i in $(seq 600); do curl -q -s -o /dev/null {url} && break; sleep 0.1; done",
                f"curl -q -s -o /dev/null {url}; echo $? > {out}.status",
                f'[ "$(cat {out}.status)" = 0 ] || exit 100',
            ]
            continue
        parts += [
            "{",
            command.text,
            f"}} > {out}.stdout 2> {out}.stderr < /dev/null",
            f"echo $? > {out}.status",
            f'[ "$(cat {out}.status)" = {command.status} ] || exit 100',
        ]
    return "\n".join(parts) + "\n"


def _output(log: Path, n: int | str, limit: int = 4000) -> str:
    """What a command printed (its standard output, then its standard error), the last ``limit``
    characters."""
    text = (log / f"{n}.stdout").read_text(errors="replace") + (log / f"{n}.stderr").read_text(
        errors="replace"
    )
    return text if len(text) <= limit else "..." + text[-limit:]


def _netns_runner() -> list[str]:
    if os.geteuid() != 0 or shutil.which("unshare") is None or shutil.which("ip") is None:
        unavailable("a network namespace of its own needs root, unshare and ip (util-linux, iproute2)")
    probe = subprocess.run(
        ["unshare", "--net", "ip", "link", "set", "lo", "up"], capture_output=True, text=True
    )
    if probe.returncode != 0:
        unavailable(f"this machine allows no network namespace: {probe.stderr.strip()}")
    return ["unshare", "--net", "sh", "-c", 'ip link set lo up && exec bash "$0"']


@pytest.mark.parametrize("document", _documents_with_examples(), ids=lambda d: str(d.relative_to(ROOT)))
def test_the_documents_shell_examples_run_as_written(document: Path, tmp_path: Path) -> None:
    """Each ```sh command of the document, in order, in its scratch folder and network namespace."""
    runner = _netns_runner()
    found = commands(document)
    for command in found:  # the covers of what cannot run here
        not_run = NOT_RUN.get(_key(command.text))
        if not_run is not None and not not_run.cover.startswith("tests/"):
            cover = subprocess.run(shlex.split(not_run.cover), cwd=ROOT, capture_output=True, text=True)
            assert cover.returncode == 0, f"{not_run.cover}: {cover.stderr}"
    folder = tmp_path / "root"
    folder.mkdir()
    environment = _scratch(folder)
    log = tmp_path / "log"
    log.mkdir()
    script = folder / ".commands.sh"
    script.write_text(_script(found, log))
    shell = subprocess.Popen([*runner, str(script)], env=environment, start_new_session=True)
    try:
        shell.wait(timeout=TIMEOUT_S)
    except subprocess.TimeoutExpired:
        os.killpg(shell.pid, signal.SIGKILL)  # its server too, which would outlive it in its namespace
        shell.wait()
        pytest.fail(f"{document.name}: its commands did not end within {TIMEOUT_S} s")
    name = document.relative_to(ROOT)
    for n, command in enumerate(found):
        if _key(command.text) in NOT_RUN:
            continue
        status_file = log / f"{n}.status"
        said = f"{name}:{command.line}: {command.text}"
        assert status_file.exists(), f"{said}\nnot run: an earlier command failed"
        status = int(status_file.read_text())
        output = _output(log, n)
        if (log / f"{n}.server").exists():
            assert status == 0, f"{said}\nthe server did not answer /health:\n{output}"
            continue
        assert status == command.status, f"{said}\nexit status {status}, not {command.status}:\n{output}"
        error = _ERRORS.search(output)
        assert error is None, f"{said}\nprinted an error ({error.group(0)}):\n{output}"
    for server in log.glob("*.server"):
        n = server.name.split(".")[0]
        pid = server.read_text().strip()
        output = _output(log, n)
        stopped = log / f"server-{pid}.status"
        assert stopped.exists() and stopped.read_text().strip() == "0", f"the server's end:\n{output}"
        problem = _SERVER_ERRORS.search(output)
        assert problem is None, f"the server's log holds {problem.group(0)!r}:\n{output}"
