"""Diagnosis: measured orders against the engine's model; cylinders and main bearings named.

See :mod:`monitor.diagnosis.diagnose` for the steps and thresholds,
:mod:`monitor.diagnosis.analysis` for the analysis the calibration and the diagnosis share,
:mod:`monitor.diagnosis.calibration` for the baseline's calibration,
:mod:`monitor.diagnosis.balance` for the cylinder balance,
:mod:`monitor.diagnosis.bearings` for the bearing indicators,
:mod:`monitor.diagnosis.zones` for the vibration zones and
:mod:`monitor.diagnosis.baseline` for the stored calibration,
:mod:`monitor.diagnosis.operating_points` for a baseline over several loads and
:mod:`monitor.diagnosis.load_estimate` and :mod:`monitor.diagnosis.at_point` for the load estimated
and the diagnosis at the recording's own load, :mod:`monitor.diagnosis.misfire` for the misfire
pattern, :mod:`monitor.diagnosis.segments` for recordings that cross operating points and
:mod:`monitor.diagnosis.rigid_speed` for the crank's speed orders driven by a torque.
"""

from monitor.diagnosis.balance import CylinderBalance, cylinder_balance
from monitor.diagnosis.baseline import Baseline, SensorBaseline
from monitor.diagnosis.calibration import calibrate
from monitor.diagnosis.diagnose import (
    ANALYSIS_VERSION,
    BearingResult,
    ChannelComparison,
    Diagnosis,
    Finding,
    diagnose,
)
from monitor.diagnosis.rigid_speed import predicted_speed

__all__ = [
    "ANALYSIS_VERSION",
    "Baseline",
    "BearingResult",
    "ChannelComparison",
    "CylinderBalance",
    "Diagnosis",
    "Finding",
    "SensorBaseline",
    "calibrate",
    "cylinder_balance",
    "diagnose",
    "predicted_speed",
]
