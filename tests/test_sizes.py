"""The layout's size rules (docs/architecture.md): a module holds one concept and stays under about 700
lines, a function under about 120 (its docstring included), so that a reader finds each concept by its
module's name and each step by its function's."""

from __future__ import annotations

import ast
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ("monitor", "api", "benchmarks", "validation")
MAX_MODULE_LINES = 700
MAX_FUNCTION_LINES = 120
#: Modules allowed above the line count because they hold a single concept (none today): path -> why.
SINGLE_CONCEPT: dict[str, str] = {}


def _sources(root: Path, packages: tuple[str, ...]) -> list[Path]:
    """The packages' own modules: not generated code, not the migrations (frozen once released)."""
    return [
        path
        for package in packages
        for path in sorted((root / package).rglob("*.py"))
        if "_pb2" not in path.name and "migrations" not in path.parts
    ]


def _long_modules(root: Path, paths: list[Path]) -> dict[str, int]:
    return {
        str(path.relative_to(root)): lines
        for path in paths
        if (lines := path.read_text().count("\n")) > MAX_MODULE_LINES
    }


def _long_functions(root: Path, paths: list[Path]) -> list[str]:
    long = []
    for path in paths:
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef):
                lines = (node.end_lineno or node.lineno) - node.lineno + 1
                if lines > MAX_FUNCTION_LINES:
                    long.append(f"{path.relative_to(root)}:{node.lineno} {node.name} ({lines} lines)")
    return long


def test_no_module_is_over_the_line_count_unless_it_holds_one_concept() -> None:
    long = _long_modules(ROOT, _sources(ROOT, PACKAGES))
    assert {k: v for k, v in long.items() if k not in SINGLE_CONCEPT} == {}


def test_no_function_is_over_the_line_count() -> None:
    assert _long_functions(ROOT, _sources(ROOT, PACKAGES)) == []


def test_the_rules_find_a_long_module_and_a_long_function_in_a_method(tmp_path: Path) -> None:
    """A package with a module of 800 lines whose class has a method of 130: both are found, a short
    module and function are not, and a migration is left alone."""
    (tmp_path / "pkg" / "migrations").mkdir(parents=True)
    body = "\n".join(f"        x{i} = {i}" for i in range(129))
    (tmp_path / "pkg" / "big.py").write_text("class C:\n    def long(self) -> None:\n" + body + "\n" * 700)
    (tmp_path / "pkg" / "small.py").write_text("def short() -> None:\n    pass\n")
    (tmp_path / "pkg" / "migrations" / "old.py").write_text("\n" * 900)
    paths = _sources(tmp_path, ("pkg",))
    assert _long_modules(tmp_path, paths) == {"pkg/big.py": 830}
    assert _long_functions(tmp_path, paths) == ["pkg/big.py:2 long (130 lines)"]
