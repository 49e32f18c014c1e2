"""The house's layering (pyproject.toml's [tool.importlinter], told in docs/architecture.md) holds, a new
upward import breaks it, and the package face names entry points that resolve."""

from __future__ import annotations

import ast
import os
import shutil
import subprocess
import sys
import tomllib
from pathlib import Path

import pytest

import monitor

ROOT = Path(__file__).resolve().parents[1]
LINT_IMPORTS = Path(sys.executable).parent / "lint-imports"
CONFIG = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))["tool"]["importlinter"]
PACKAGES = CONFIG["root_packages"]


def _lint_imports(tree: Path) -> subprocess.CompletedProcess[str]:
    """``lint-imports`` run in ``tree``, which it reads (not the installed product)."""
    env = {key: value for key, value in os.environ.items() if key != "PYTHONPATH"}
    return subprocess.run(
        [str(LINT_IMPORTS), "--no-cache"],
        cwd=tree,
        env=env,
        capture_output=True,
        text=True,
        check=False,
        timeout=120,
    )


@pytest.fixture
def tree(tmp_path: Path) -> Path:
    """A copy of the packages' Python sources and of pyproject.toml."""
    for package in PACKAGES:
        shutil.copytree(
            ROOT / package,
            tmp_path / package,
            ignore=lambda folder, names: (
                [name for name in names if not name.endswith(".py") and not (Path(folder) / name).is_dir()]
                + ["__pycache__"]
            ),
        )
    shutil.copy(ROOT / "pyproject.toml", tmp_path)
    return tmp_path


def test_the_tree_keeps_its_layers() -> None:
    out = _lint_imports(ROOT)
    assert out.returncode == 0, out.stdout[out.stdout.find("Broken contracts") :] or out.stderr


def test_an_upward_import_breaks_the_layers(tree: Path) -> None:
    before = _lint_imports(tree)
    (tree / "monitor" / "model" / "upward.py").write_text(
        '"""A model module that reaches up to the use cases."""\n\nimport monitor.jobs  # noqa: F401\n'
    )
    after = _lint_imports(tree)
    assert after.returncode != 0
    assert "monitor.model is not allowed to import monitor.jobs" in after.stdout
    assert "monitor.model.upward -> monitor.jobs" in after.stdout
    assert "monitor.model.upward" not in before.stdout


def test_the_library_never_imports_the_service(tree: Path) -> None:
    (tree / "monitor" / "store" / "reaches.py").write_text("from api import app  # noqa: F401\n")
    out = _lint_imports(tree)
    assert out.returncode != 0
    assert "monitor.store.reaches -> api" in out.stdout


def test_an_import_circle_inside_a_package_is_refused(tree: Path) -> None:
    signal = tree / "monitor" / "signal"
    (signal / "circle_a.py").write_text("import monitor.signal.circle_b  # noqa: F401\n")
    (signal / "circle_b.py").write_text("import monitor.signal.circle_a  # noqa: F401\n")
    out = _lint_imports(tree)
    assert out.returncode != 0
    assert "No cycles are allowed in monitor.signal." in out.stdout


def test_every_package_of_the_library_has_a_layer() -> None:
    layered = {
        name.strip().strip("()")
        for contract in CONFIG["contracts"]
        if contract["type"] == "layers"
        for layer in contract["layers"]
        for name in layer.split("|")
    }
    children = {
        f"monitor.{path.stem if path.is_file() else path.name}"
        for path in (ROOT / "monitor").iterdir()
        if (path.suffix == ".py" and path.stem not in {"__init__", "__main__"})
        or (path / "__init__.py").is_file()
    }
    assert children - layered == set(), "place each new package of monitor in a layer (pyproject.toml)"


# ------------------------------------------------------------------------------------------ the face
def test_every_public_name_of_the_package_resolves() -> None:
    for name in monitor.__all__:
        assert getattr(monitor, name) is not None, name
        if name != "__version__":
            assert callable(getattr(monitor, name)), name
    assert sorted(dir(monitor)) == sorted(monitor.__all__)
    with pytest.raises(AttributeError, match="no_such_name"):
        monitor.no_such_name  # noqa: B018


def test_the_face_imports_its_entry_points_for_the_type_checkers_only() -> None:
    """The face loads nothing at import (start-up stays cheap); what it tells the type checkers is
    exactly what it loads on first use."""
    source = ast.parse((ROOT / "monitor" / "__init__.py").read_text(encoding="utf-8"))
    typed: dict[str, str] = {}
    for node in source.body:
        if isinstance(node, ast.If) and isinstance(node.test, ast.Name) and node.test.id == "TYPE_CHECKING":
            for statement in node.body:
                assert isinstance(statement, ast.ImportFrom) and statement.module is not None
                typed.update({alias.name: statement.module for alias in statement.names})
        elif isinstance(node, ast.Import | ast.ImportFrom):
            modules = [node.module] if isinstance(node, ast.ImportFrom) else [a.name for a in node.names]
            assert not any(str(m).startswith("monitor") for m in modules), ast.unparse(node)
    assert typed == monitor._ENTRY_POINTS
    assert set(monitor.__all__) == {*typed, "__version__"}


LOADED = "import sys, monitor; print(sorted(m for m in sys.modules if m.startswith('monitor.')))"


def test_importing_the_package_loads_no_entry_point() -> None:
    out = subprocess.run(
        [sys.executable, "-c", LOADED],
        cwd=ROOT,
        capture_output=True,
        text=True,
        check=True,
        timeout=60,
    )
    assert out.stdout.strip() == "[]"
