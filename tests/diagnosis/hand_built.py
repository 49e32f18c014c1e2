"""A diagnosis and a calibrated point built by hand, for rules that read only what they hold."""

from __future__ import annotations

from typing import cast

import numpy as np

from monitor.diagnosis import Baseline, SensorBaseline
from monitor.diagnosis.diagnose import Diagnosis
from monitor.diagnosis.findings import Finding
from monitor.signal.impact import HighFrequencyPower
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


def one_sensor_point(
    load: float,
    *,
    transfer: complex = 1.0,
    error: float = 0.1,
    rms: float = 1.0,
    high_frequency: HighFrequencyPower | None = None,
    sample_rate: float = 1000.0,
) -> Baseline:
    """A point calibrated at ``load`` on a 750 rpm engine: one sensor on main bearing 1 with one order."""
    sensor = SensorBaseline(
        channel="mb1",
        kind="acceleration",
        unit="m/s^2",
        bearing=1,
        direction="vertical",
        sample_rate=sample_rate,
        orders=np.array([1.0]),
        transfer=np.array([complex(transfer)]),
        transfer_error=np.array([error]),
        high_frequency=high_frequency,
        velocity_rms=rms,
    )
    return Baseline("e", 750.0, load, [1.0, 1.0], 64, {"mb1": sensor}, f"at {load}")
