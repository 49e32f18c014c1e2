"""Mutation testing of the decision rules (monitor/diagnosis/findings.py); writes docs/mutation-testing.md.

Run with ``python -m benchmarks.mutation`` (``make mutation``).  The tool is cosmic-ray, configured in
pyproject.toml's ``[tool.cosmic-ray]``: it mutates the module's every number (the thresholds at its top
among them) and moves every comparison across its boundary (``<`` and ``<=``, ``>`` and ``>=``), one at a
time, and runs the fast table-driven limit tests (tests/diagnosis/test_rule_limits.py, and
tests/diagnosis/test_shares.py for the groups that fire together) against each mutant; a mutant
that no test fails "survived".
cosmic-ray writes each mutant into the file itself, so the run happens in a copy of the package and the
tests in a temporary folder: the working tree is never touched, even when the run is interrupted.

cosmic-ray's other operators (arithmetic swaps, ``not``, ``and``/``or`` ...) are left out by the
configuration's operators filter: they change no limit, and would make the run about an hour on two
shared cores.  cosmic-ray has no operator for string literals: the finding labels and severities are held
by the limit tests comparing each label whole.  The document lists every surviving mutant with its diff
and, where :data:`ACCEPTED` knows it, the reason it may stay.  The session is kept in out/ and
``--resume`` runs again only its survivors: after adding a test, a minute instead of the whole run.
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import sqlite3
import subprocess
import sys
import tempfile
import time
import tomllib
from collections import Counter
from datetime import UTC, datetime
from importlib.metadata import version
from pathlib import Path
from typing import Any

import toml  # cosmic-ray's own dependency (the test extra): writes its table as cosmic-ray reads it

ROOT = Path(__file__).resolve().parents[1]
DOC = ROOT / "docs" / "mutation-testing.md"
SESSION = ROOT / "out" / "mutation-session.sqlite"  # out/ is ignored by git
COPIED = ("monitor", "tests", "pyproject.toml")

# Surviving mutants that may stay, by the line before and after the mutation (stripped): why, in one line.
_ONE_CYLINDER = "equivalent: a single cylinder's arrays hold one value, index 0 and -1 alike"
_ONE_EVIDENCE = "equivalent: a cylinder finding holds one piece of evidence, index 0 and -1 alike"
_WORST = "worst = int(np.argmax(np.where(beyond, dev.deviation, -1)))"
_APART = "math.isnan(x) or excess >= LOCALISED * max(x - 1.0, 0.0) for x in (score.elsewhere, score.away)"
ACCEPTED: dict[tuple[str, str], str] = {
    (
        "low = r < 1.0",
        "low = r <= 1.0",
    ): "equivalent: a share of exactly 100 % crosses no limit, so has no finding",
    ("low = s < 1.0", "low = s <= 1.0"): "equivalent: a strength of exactly 100 % crosses no limit",
    (
        "return a if SEVERITIES.index(a) >= SEVERITIES.index(b) else b",
        "return a if SEVERITIES.index(a) > SEVERITIES.index(b) else b",
    ): "equivalent: of two equal severities either is the same string",
    **{
        (line, line.replace("evidence[0]", "evidence[ -1]")): _ONE_EVIDENCE
        for line in (
            'findings = [f for f in findings if f.evidence[0]["cylinder"] == weaker]',
            'weaker = missing.evidence[0]["cylinder"]',
            'share = max(missing.evidence[0]["measured"], MISFIRE_BELOW)',
            'same = [f for f in findings if f.evidence[0]["cylinder"] - 1 in balance.group(weaker - 1)]',
            'if not any(f.severity == "alarm" and f.evidence[0]["measured"] < share for f in same):',
        )
    },
    (
        "s = float(balance.strength[0]) / reference",
        "s = float(balance.strength[ -1]) / reference",
    ): _ONE_CYLINDER,
    (
        "e = max(float(balance.strength_error[0]) / reference, floor)",
        "e = max(float(balance.strength_error[ -1]) / reference, floor)",
    ): _ONE_CYLINDER,
    (_WORST, _WORST.replace("-1", "- 2")): "equivalent: the fill of the orders within their limits; any "
    "value below 50 % (the least deviation beyond) picks the same worst order",
    (_WORST, _WORST.replace("-1", "- 0")): "equivalent: as above, 0 is below 50 % too",
    (_APART, _APART.replace("0.0)", "-1.0)")): "equivalent: a heard score is at least 1.5 x, so its "
    "excess is positive and beats 2 x any excess elsewhere or away at or below zero",
}


def _config() -> dict[str, Any]:
    with (ROOT / "pyproject.toml").open("rb") as handle:
        config: dict[str, Any] = tomllib.load(handle)["tool"]["cosmic-ray"]
    return config


def _tool(name: str) -> str:
    """A console script of the environment this interpreter runs in."""
    return str(Path(sys.executable).with_name(name))


def _copy_tree(workdir: Path) -> None:
    for name in COPIED:
        source = ROOT / name
        if source.is_dir():
            shutil.copytree(source, workdir / name, ignore=shutil.ignore_patterns("__pycache__"))
        else:
            shutil.copy2(source, workdir / name)


def _retest_survivors(session: Path) -> int:
    """Make the session's surviving mutants pending again (cosmic-ray's exec runs what is pending)."""
    with sqlite3.connect(session) as db:
        return db.execute("DELETE FROM work_results WHERE test_outcome = 'SURVIVED'").rowcount


def run(workdir: Path, session: Path, *, resume: bool) -> list[tuple[dict[str, Any], dict[str, Any]]]:
    """Copy the package and its tests into ``workdir`` and run the session there; return its rows.

    With ``resume`` and an existing ``session``, only its surviving (and unfinished) mutants are run
    again, against the tests as they are now; otherwise the session starts afresh.
    """
    _copy_tree(workdir)
    config = workdir / "cosmic-ray.toml"
    # cosmic-ray reads its own file with a top-level [cosmic-ray] table; pyproject.toml keeps it under tool.
    settings = _config()
    # the tests run by this interpreter, whatever python the PATH finds first
    settings["test-command"] = settings["test-command"].replace("python", sys.executable, 1)
    config.write_text(toml.dumps({"cosmic-ray": settings}))
    env = {**os.environ, "PYTHONPATH": str(workdir), "PYTEST_DISABLE_PLUGIN_AUTOLOAD": "1"}
    steps = [[_tool("cosmic-ray"), "exec", str(config), str(session)]]
    if resume and session.exists():
        print(f"re-testing {_retest_survivors(session)} surviving mutants of {session}")
    else:
        session.unlink(missing_ok=True)
        steps[:0] = [
            [_tool("cosmic-ray"), "init", str(config), str(session)],
            [_tool("cr-filter-operators"), str(session), str(config)],
        ]
    for step in steps:
        subprocess.run(step, cwd=workdir, env=env, check=True)
    dump = subprocess.run(
        [_tool("cosmic-ray"), "dump", str(session)], cwd=workdir, check=True, capture_output=True, text=True
    )
    return [tuple(json.loads(line)) for line in dump.stdout.splitlines() if line.strip()]


def outcome(result: dict[str, Any] | None) -> str:
    """killed, survived, incompetent (the mutant did not import), skipped (filtered) or pending."""
    if result is None:
        return "pending"
    if result.get("worker_outcome") == "skipped":
        return "skipped"
    return str(result.get("test_outcome") or result.get("worker_outcome"))


def _change(diff: str) -> tuple[str, str]:
    """The line a mutant changes, before and after, stripped: what :data:`ACCEPTED` is keyed by."""
    removed = [line[1:].strip() for line in diff.splitlines() if line.startswith("-") and line[:3] != "---"]
    added = [line[1:].strip() for line in diff.splitlines() if line.startswith("+") and line[:3] != "+++"]
    return (removed[0] if removed else "", added[0] if added else "")


def report(
    rows: list[tuple[dict[str, Any], dict[str, Any]]],
    *,
    seconds: float,
    module: str,
    test_command: str,
    resumed: bool = False,
) -> str:
    """The document: what was mutated, the counts, every surviving mutant with its diff and reason."""
    counts = Counter(outcome(result) for _, result in rows)
    tested = counts["killed"] + counts["survived"]
    when = datetime.now(UTC).strftime("%Y-%m-%d %H:%M UTC")
    lines = [
        "# Mutation testing of the decision rules",
        "",
        "<!-- Written by `make mutation` (benchmarks/mutation.py); edit the script, not this file. -->",
        "",
        f"cosmic-ray {version('cosmic-ray')} mutated `{module}` one change at a time and ran",
        f"`{test_command}`",
        f"against each mutant ({when}; the run took {seconds / 60:.1f} min"
        + (", re-testing only the mutants an earlier run of the session left alive" if resumed else "")
        + "). A mutant *survives* when no",
        "test fails with it. The mutants are every number of the module (its thresholds among them) and",
        "every comparison moved across its boundary (`<` and `<=`, `>` and `>=`); cosmic-ray's other",
        "operators are filtered out (`[tool.cosmic-ray.filters.operators-filter]` in pyproject.toml).",
        "cosmic-ray does not mutate string literals: the finding labels and severities are held by",
        "tests/diagnosis/test_rule_limits.py, which compares each label whole.",
        "",
        "| Mutants | Killed | Survived | Incompetent (does not import) | Filtered out |",
        "|---:|---:|---:|---:|---:|",
        f"| {len(rows)} | {counts['killed']} | {counts['survived']} | {counts['incompetent']} "
        f"| {counts['skipped']} |",
        "",
    ]
    if tested:
        lines += [
            f"Mutation score: {100 * counts['killed'] / tested:.1f} % of the tested mutants killed.",
            "",
        ]
    if counts["pending"]:
        lines += [f"{counts['pending']} mutants were not run (the run was interrupted).", ""]
    survivors = [(item, result) for item, result in rows if outcome(result) == "survived"]
    lines += ["## Surviving mutants", ""]
    if not survivors:
        lines += ["None.", ""]
    for item, result in sorted(survivors, key=lambda row: row[0]["mutations"][0]["start_pos"]):
        mutation = item["mutations"][0]
        diff = result.get("diff") or ""
        reason = ACCEPTED.get(_change(diff), "not yet explained")
        lines += [
            f"- line {mutation['start_pos'][0]}, `{mutation['operator_name']}`: {reason}",
            "",
            "  ```diff",
            *("  " + line for line in diff.splitlines() if not line.startswith(("---", "+++", "@@"))),
            "  ```",
            "",
        ]
    return "\n".join(lines).rstrip() + "\n"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=DOC)
    parser.add_argument(
        "--session", type=Path, default=SESSION, help="cosmic-ray's session file, kept for --resume"
    )
    parser.add_argument(
        "--resume",
        action="store_true",
        help="run again only the session's surviving mutants (after a new test)",
    )
    args = parser.parse_args(argv)
    args.session.parent.mkdir(parents=True, exist_ok=True)
    config = _config()
    start = time.perf_counter()
    with tempfile.TemporaryDirectory(prefix="mutation-") as tmp:
        rows = run(Path(tmp), args.session.resolve(), resume=args.resume)
    seconds = time.perf_counter() - start
    args.out.write_text(
        report(
            rows,
            seconds=seconds,
            module=config["module-path"],
            test_command=config["test-command"],
            resumed=args.resume,
        )
    )
    survived = sum(outcome(result) == "survived" for _, result in rows)
    print(f"{len(rows)} mutants, {survived} survived, {seconds / 60:.1f} min; wrote {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
