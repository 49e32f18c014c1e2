"""When the cylinders' differences are known too poorly to call a recording healthy.

A recording without findings is healthy only when every cylinder's contrast error is below
``RESOLVED`` (25 %): above it a cylinder missing whole, a departure of 1, would be fewer than
``SIGNIFICANCE`` (4) errors from the others and go unnamed. Cylinders that fire together are judged
as one member's reading, ``n`` times the group's departure and errors (``shares.one_of``), so the
check reads a group's error the same way.
"""

from __future__ import annotations

import dataclasses
import importlib
from types import SimpleNamespace
from typing import Any, cast

import numpy as np
import pytest

from monitor.diagnosis.diagnose import RESOLVED, _unresolved
from monitor.diagnosis.findings import SIGNIFICANCE, cylinder_findings
from tests.diagnosis.test_rule_limits import _balance

# the module, which the package's function of the same name hides
diagnose = importlib.import_module("monitor.diagnosis.diagnose")
NAMES = ["A1", "A2", "A3", "A4", "B1", "B2", "B3", "B4"]


def _v8(contrast: float, relative: list[float] | None = None) -> Any:
    """A V8 balance whose A1 and B1 fire together, every cylinder's contrast error ``contrast``."""
    shares = relative or [1.0] * 8
    return dataclasses.replace(
        _balance([1.0] * 8, shares, contrast, contrast),
        names=NAMES,
        banks=["A"] * 4 + ["B"] * 4,
        together=[(0, 4)],
        orders=np.array([0.5, 1.0, 1.5, 2.0]),
    )


def _reasons(balance: Any, monkeypatch: pytest.MonkeyPatch) -> list[str]:
    """``_unresolved`` on this balance alone: a steady run, no pattern doubt, no pair named."""
    monkeypatch.setattr(diagnose, "unsteady_speeds", lambda _map: None)
    monkeypatch.setattr(diagnose, "missing_firing_doubt", lambda _balance: None)
    monkeypatch.setattr(diagnose, "firing_together", lambda _engine, _order: "")
    analysis = SimpleNamespace(
        spectra=SimpleNamespace(reference=SimpleNamespace(angle_map=None)), balance=balance
    )
    return _unresolved(cast(Any, analysis), cast(Any, SimpleNamespace(cylinders=8)))


def test_the_limit_lets_no_cylinder_missing_whole_pass() -> None:
    assert RESOLVED * SIGNIFICANCE == pytest.approx(1.0)


def test_a_group_s_contrast_error_is_read_as_one_member_s() -> None:
    member = _v8(0.05).member_contrast_error()
    assert member[0] == member[4] == pytest.approx(0.10, rel=1e-12)
    assert member[[1, 2, 3, 5, 6, 7]] == pytest.approx(np.full(6, 0.05), rel=1e-12)


@pytest.mark.parametrize(
    ("contrast", "uncertain"),
    [
        (0.124, None),  # the pair's member known to 24.8 %: resolved
        (0.126, "25 %"),  # to 25.2 %: a missing member would be under 4 of its errors
        (0.2, "40 %"),
    ],
)
def test_a_pair_uncertain_as_one_member_is_not_called_healthy(
    contrast: float, uncertain: str | None, monkeypatch: pytest.MonkeyPatch
) -> None:
    reasons = _reasons(_v8(contrast), monkeypatch)
    if uncertain is None:
        assert reasons == []
    else:
        assert reasons == [
            f"the cylinders' differences are uncertain by up to {uncertain} (one standard error): "
            "too little to call them healthy"
        ]


def test_a_member_missing_whole_is_named_or_the_run_is_inconclusive(monkeypatch: pytest.MonkeyPatch) -> None:
    """The two rules meet: for every pair error, a pair at 50 % of the others (one member dead, the
    other as the reference) is either a finding or a reason not to call the run healthy."""
    for contrast in np.linspace(0.05, 0.3, 26):
        balance = _v8(float(contrast), [0.5, 1.0, 1.0, 1.0, 0.5, 1.0, 1.0, 1.0])
        named = [f for f in cylinder_findings(balance) if f.kind == "cylinder"]
        assert named or _reasons(balance, monkeypatch), contrast
