"""Every public function documents every parameter (numpydoc), with units in the physics modules."""

from __future__ import annotations

import dataclasses
import importlib
import inspect
import pkgutil
import re
from collections.abc import Callable, Iterator
from typing import Any

import pytest

import monitor

# modules whose numeric parameters must state their unit (all but the edges: CLI and reports)
EDGES = {
    "monitor.cli.main",
    "monitor.cli.torsion",
    "monitor.report.tables",
    "monitor.report.plots",
    "monitor.report.torsion_plots",
}


def _public() -> Iterator[tuple[str, str, Callable[..., Any]]]:
    for info in pkgutil.walk_packages(monitor.__path__, "monitor."):
        if info.name.endswith("__main__"):
            continue
        module = importlib.import_module(info.name)
        for name in getattr(module, "__all__", []):
            obj = getattr(module, name)
            if inspect.isfunction(obj):
                yield info.name, name, obj
            elif inspect.isclass(obj) and "__init__" in vars(obj) and not dataclasses.is_dataclass(obj):
                yield info.name, f"{name}.__init__", obj


def _documented(doc: str) -> dict[str, str]:
    """Parameter names of a numpydoc 'Parameters' section, with their description lines."""
    match = re.search(r"Parameters\n\s*-+\n(.*?)(?:\n\s*\n\s*[A-Z][a-z]+\n\s*-+\n|\Z)", doc, re.S)
    if not match:
        return {}
    found: dict[str, str] = {}
    current: list[str] = []
    for line in match.group(1).splitlines():
        head = re.match(
            r"([A-Za-z_][\w, ]*?)\s*:\s*(.*)$", line
        )  # names start the line; descriptions are indented
        if head:
            current = [n.strip() for n in head.group(1).split(",")]
            for n in current:
                found[n] = head.group(2)
        else:
            for n in current:
                found[n] += " " + line.strip()
    return found


CASES = list(_public())


@pytest.mark.parametrize(("module", "name", "obj"), CASES, ids=[f"{m}.{n}" for m, n, _ in CASES])
def test_parameters_are_documented(module: str, name: str, obj: Callable[..., Any]) -> None:
    doc = inspect.getdoc(obj) or ""
    params = [
        p
        for p in inspect.signature(obj).parameters.values()
        if p.name not in ("self", "cls") and p.kind not in (p.VAR_POSITIONAL, p.VAR_KEYWORD)
    ]
    if not params:
        return
    documented = _documented(doc)
    missing = [p.name for p in params if p.name not in documented]
    assert not missing, f"{module}.{name}: undocumented parameters {missing}"
    if module not in EDGES:
        numeric = [p.name for p in params if "float" in str(p.annotation) or "ArrayLike" in str(p.annotation)]
        no_unit = [n for n in numeric if "[" not in documented[n]]
        assert not no_unit, f"{module}.{name}: parameters without a unit in brackets: {no_unit}"


def test_there_are_public_functions_to_check() -> None:
    assert len(CASES) > 25
