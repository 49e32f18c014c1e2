"""Start-up: the quick commands import none of the heavy libraries (the time is measured by
``benchmarks.startup``, never here); the import times are reported in the test's properties."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
SAMPLE = "recordings/samples/7k98mc-baseline.h5"
# libraries that each cost a tenth of a second or more to import and that these commands do not need
HEAVY = {
    "scipy",
    "numba",
    "llvmlite",
    "matplotlib",
    "sqlalchemy",
    "alembic",
    "fastapi",
    "uvicorn",
    "mcap",
    "tqdm",
    "dask",
    "distributed",
    "asammdf",
    "nptdms",
    "psycopg",
    "google",
}
COMMANDS = [
    ("--help",),
    ("engines",),
    ("orders", "man-b-w-7k98mc", "--rpm", "94"),
    ("simulate", "--truth", SAMPLE),
]


def _imports(args: tuple[str, ...]) -> dict[str, int]:
    """Every module the command imports, with its cumulative import time [us] from -X importtime."""
    out = subprocess.run(
        [sys.executable, "-X", "importtime", "-m", "monitor", *args],
        cwd=ROOT,
        capture_output=True,
        text=True,
        check=False,
        timeout=120,
    )
    assert out.returncode == 0, out.stderr[-2000:]
    modules = {}
    for line in out.stderr.splitlines():
        if line.startswith("import time:") and "|" in line:
            _, cumulative, name = line.split("|")
            if cumulative.strip().isdigit():
                modules[name.strip()] = int(cumulative)
    return modules


@pytest.mark.parametrize("args", COMMANDS, ids=lambda a: " ".join(a))
def test_quick_commands_import_no_heavy_library(
    args: tuple[str, ...], record_property: pytest.RecordProperty
) -> None:
    modules = _imports(args)
    assert "monitor.cli" in modules  # the parse found the product's imports
    heavy = sorted({name.split(".")[0] for name in modules} & HEAVY)
    assert not heavy, f"engine-monitor {' '.join(args)} imports {heavy}: import them where they are used"
    largest = sorted(modules.items(), key=lambda item: -item[1])[:5]
    record_property("largest_imports_us", ", ".join(f"{name} {us}" for name, us in largest))
    print(f"engine-monitor {' '.join(args)}: " + ", ".join(f"{n} {us / 1e3:.0f} ms" for n, us in largest))
