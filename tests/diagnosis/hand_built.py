"""A diagnosis built by hand, for rules that read only its findings, status and notes."""

from __future__ import annotations

from typing import cast

from monitor.diagnosis.diagnose import Diagnosis
from monitor.diagnosis.findings import Finding
from monitor.signal.measure import SpectrumResult


def hand_built(status: str, findings: list[Finding], notes: list[str]) -> Diagnosis:
    """A 6L32 at 750 rpm and full load with these findings, status and notes, and no spectra."""
    return Diagnosis(
        engine_id="6L32",
        speed_rpm=750.0,
        load=1.0,
        status=status,
        findings=findings,
        balance=None,
        comparisons=[],
        bearings=[],
        velocity={},
        zone_boundaries_mm_s=(1.4, 2.8, 4.5),
        notes=notes,
        spectra=cast(SpectrumResult, None),  # the rules under test read no spectra
    )
