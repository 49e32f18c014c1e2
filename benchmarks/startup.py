"""Start-up of the CLI's quick commands, warm; writes its section of docs/performance.md.

Run with ``python -m benchmarks.startup``.  Each command runs once to warm the
operating system's caches, then ``--runs`` times (default 7); the median wall
time is reported beside the interpreter's own start (``python -c pass``, the
floor, measured the same way in the same run) and the import time that
``python -X importtime`` attributes to the product's modules.  The command
exits with status 1 when a command's median is 1 s or more (the speed
issue's target), after writing the table.
"""

from __future__ import annotations

import argparse
import platform
import statistics
import subprocess
import sys
import time
from datetime import UTC, datetime
from pathlib import Path

from benchmarks.sections import replace_section

ROOT = Path(__file__).resolve().parents[1]
DOC = ROOT / "docs" / "performance.md"
START, END = "<!-- startup: start -->", "<!-- startup: end -->"
TARGET_S = 1.0
SAMPLE = "recordings/samples/7k98mc-baseline.h5"
COMMANDS = (
    ("--help",),
    ("engines",),
    ("orders", "man-b-w-7k98mc", "--rpm", "94"),
    ("simulate", "--truth", SAMPLE),
)


def _wall(argv: list[str]) -> float:
    start = time.perf_counter()
    subprocess.run(argv, cwd=ROOT, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    return time.perf_counter() - start


def _import_seconds(args: tuple[str, ...]) -> float:
    """Seconds that ``-X importtime`` gives the top-level imports of one run (cumulative, summed)."""
    out = subprocess.run(
        [sys.executable, "-X", "importtime", "-m", "monitor", *args],
        cwd=ROOT,
        check=True,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        text=True,
    )
    total = 0
    for line in out.stderr.splitlines():
        if line.startswith("import time:") and "|" in line:
            _, cumulative, name = line.split("|")
            if cumulative.strip().isdigit() and not name.startswith("  "):  # a top-level import
                total += int(cumulative)
    return total / 1e6


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=7, help="timed runs of each command (default 7)")
    args = parser.parse_args()
    if args.runs < 1:
        parser.error("--runs: expected at least 1")
    floor_argv = [sys.executable, "-c", "pass"]
    _wall(floor_argv)
    floor = statistics.median(_wall(floor_argv) for _ in range(args.runs))
    rows = []
    for command in COMMANDS:
        argv = [sys.executable, "-m", "monitor", *command]
        _wall(argv)  # warm
        times = [_wall(argv) for _ in range(args.runs)]
        rows.append((" ".join(command), statistics.median(times), max(times), _import_seconds(command)))
        print(f"{rows[-1][0]}: median {rows[-1][1]:.3f} s", flush=True)
    stamp = datetime.now(UTC).strftime("%Y-%m-%d %H:%M UTC")
    slow = [r for r in rows if r[1] >= TARGET_S]
    lines = [
        START,
        "## Start-up of the quick commands",
        "",
        f"Written by `python -m benchmarks.startup --runs {args.runs}` on {stamp}, Python "
        f"{platform.python_version()}, {platform.machine()} (shared machine). Each command ran once to warm "
        f"the caches, then {args.runs} times, as `python -m monitor ...` (what the `engine-monitor` script "
        "runs); the median and the slowest wall time are shown, with the "
        "interpreter's own start (`python -c pass`, the floor, measured the same way) and the time "
        "`python -X importtime` gives the command's imports in one more run.",
        "",
        "| command | median | slowest | ratio to the floor | imports |",
        "|---|---|---|---|---|",
        f"| `python -c pass` (the floor) | {floor:.3f} s | | 1.0 | |",
        *(
            f"| `engine-monitor {name}` | {median:.3f} s | {worst:.3f} s | {median / floor:.1f} | "
            f"{imports:.3f} s |"
            for name, median, worst, imports in rows
        ),
        "",
        f"Target (the speed issue): each under {TARGET_S:g} s warm: "
        + ("met." if not slow else "**not met** (" + ", ".join(r[0] for r in slow) + ")."),
        END,
    ]
    replace_section(DOC, START, END, "\n".join(lines))
    print(f"wrote {DOC.relative_to(ROOT)}")
    if slow:
        raise SystemExit(1)


if __name__ == "__main__":
    main()
