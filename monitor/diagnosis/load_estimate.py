"""The load a recording ran at, estimated from its crank-speed orders.

The cylinder balance (:mod:`monitor.diagnosis.balance`) fits each cylinder's strength against the
model at a load: a healthy engine diagnosed at its true load has the strengths of the reference
(1 against a model the baseline calibrated; the calibrated points' own strengths against the plain
model; 1 without a baseline).  Diagnosed at another load the model's gas torque is wrong and the
strengths move to make up the difference (more than in proportion: the compression's share of the
gas torque changes with the charge pressure).  The load estimated is the one at which the
cylinders' median strength equals the reference's: the balance is fitted on the recording's own
crank-speed orders at loads over the model's range, the mismatch bracketed and its root found by
the secant rule.  A mismatch may fall through zero more than once over the range: the reference
then switches between calibrated points whose crank-speed calibrations differ, or the compression's
and the combustion's torque nearly cancel at the orders fitted, and the strengths alone do not say
which root is the load.  The lowest is kept, and its standard error widened to half the distance to
the farthest other root, so that every root lies within two standard errors of the load reported:
on the validation population the lowest was right in cases 200246 and 310054 (not told their load:
leaving the load unestimated named a misfire weak and missed a weak cylinder) and far below the load
run in case 200472 (a healthy nine-cylinder two-stroke told its load, whose "check the load reading"
the widened error no longer raises; docs/diagnosis-validation.md).
A rise through zero is no match (the strengths would have to grow with the model's load): a mismatch
near zero at an end of the range, where its errors are largest, does not hide a fall.

The median, not the mean: one misfiring cylinder of six moves the mean by a sixth and the median
hardly at all, so a fault does not read as a lower load (its standard error is taken as
``sqrt(pi / 2)`` times the mean's, the median's of normal errors).  The estimate's uncertainty is
that of the median strength and of the reference's level (the calibration factors' errors, or the
model's uncertainty without a calibrated model), over the mismatch's slope in load.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from monitor.diagnosis.balance import CrankCalibration, CylinderBalance, Transfer, cylinder_balance
from monitor.errors import ModelError
from monitor.model.crankshaft import EngineModel
from monitor.model.engine import Engine
from monitor.model.predicted import cylinder_parts
from monitor.signal.measure import SPEED_CHANNEL, SpectrumResult

__all__ = ["LoadEstimate", "estimate_load"]

LOADS = np.linspace(0.1, 1.1, 11)  # where the mismatch is bracketed (the model's range) [-]
_MEDIAN_EFFICIENCY = math.sqrt(math.pi / 2)  # the median's standard error over the mean's (normal errors)


@dataclass(frozen=True)
class LoadEstimate:
    """A load estimated from the crank-speed orders.

    Attributes
    ----------
    load : float
        [-], fraction of rated.
    standard_error : float
        [-]
    reference : str
        What the cylinders' strengths were matched to.
    other_matches : tuple of float
        Loads above ``load`` where the mismatch also falls through zero [-], fraction of rated
        (``standard_error`` spans them).
    """

    load: float
    standard_error: float
    reference: str
    other_matches: tuple[float, ...] = ()


ReferenceAt = Callable[[float], tuple[CrankCalibration | None, float, str]]
"""For a load: the crank-speed calibration to fit with, the reference strength to match, and what it is."""


def estimate_load(
    spectra: SpectrumResult,
    engine: Engine,
    *,
    transfer: Transfer,
    max_order: float,
    reference: ReferenceAt,
) -> LoadEstimate | None:
    """The load at which the cylinders' median strength matches the reference's.

    Parameters
    ----------
    spectra : SpectrumResult
        The recording's (its crank speed's orders are fitted).
    engine : Engine
    transfer : {"rigid", "shaft-line"}
        From the torque to the crank speed.
    max_order : float
        Highest order of the model [-].
    reference : callable
        For a load [-]: the crank-speed calibration to fit with (or None), the strength a healthy
        engine at that load shows against it [-], and what that is (words).

    Returns
    -------
    LoadEstimate or None
        None without crank-speed orders, for a single cylinder (its strength is the load), or when
        no load in the model's range matches.
    """
    speed = spectra.spectra.get(SPEED_CHANNEL)
    if speed is None or speed.orders.size < 2 or engine.cylinders < 2 or engine.combustion is None:
        return None
    model = EngineModel(engine, gas="auto")

    def mismatch(load: float) -> tuple[float, float, str]:
        """Median strength less the reference's, its standard error, the reference's words."""
        parts = cylinder_parts(model, crank_speed=spectra.mean_speed, load=load, max_order=max_order)
        crank, strength, words = reference(load)
        usable = crank if crank is not None and crank.transfer == transfer else None
        balance = cylinder_balance(speed, engine, parts, transfer=transfer, calibration=usable)
        level = _reference_level(balance, usable)
        error = (
            _MEDIAN_EFFICIENCY
            * float(np.sqrt(np.mean(balance.strength_error**2)))
            / math.sqrt(balance.strength.size)
        )
        matched = 1.0 if usable is not None and balance.calibrated.any() else strength
        return float(np.median(balance.strength)) - matched, math.hypot(error, level), words

    try:  # a load the model or the balance cannot take leaves the load unestimated, never the diagnosis
        return _root(mismatch)
    except (ModelError, FloatingPointError, np.linalg.LinAlgError):
        return None


def _root(mismatch: Callable[[float], tuple[float, float, str]]) -> LoadEstimate | None:
    """The lowest load where the mismatch falls through zero, bracketed on :data:`LOADS`, by the secant
    rule; its standard error spans the other falls."""
    gaps = np.array([mismatch(float(load))[0] for load in LOADS])
    crossing = np.flatnonzero((gaps[:-1] > 0) & (gaps[1:] <= 0))
    if crossing.size == 0:
        return None  # no match in the model's range
    i = int(crossing[0])
    a, b, fa, fb = float(LOADS[i]), float(LOADS[i + 1]), float(gaps[i]), float(gaps[i + 1])
    for _ in range(4):  # the secant rule, kept inside the bracket (fa > 0 >= fb)
        c = b - fb * (b - a) / (fb - fa)
        fc = mismatch(c)[0]
        if abs(fc) < 1e-4:
            a, b, fa, fb = c, c, fc, fc
            break
        if fc > 0:
            a, fa = c, fc
        else:
            b, fb = c, fc
    load = a if a == b else a - fa * (b - a) / (fb - fa)
    below, above = max(load - 0.02, float(LOADS[0])), min(load + 0.02, float(LOADS[-1]))
    slope = (mismatch(above)[0] - mismatch(below)[0]) / (above - below)
    _, spread, words = mismatch(load)
    if not slope < 0:  # the strengths do not tell the load here
        return None
    # the other falls, linear in their brackets: they only widen the error
    others = tuple(
        float(LOADS[j] + gaps[j] * (LOADS[j + 1] - LOADS[j]) / (gaps[j] - gaps[j + 1])) for j in crossing[1:]
    )
    error = max([spread / -slope] + [(other - load) / 2 for other in others])
    return LoadEstimate(float(load), float(error), words, others)


def _reference_level(balance: CylinderBalance, calibration: CrankCalibration | None) -> float:
    """The reference strength's own uncertainty: the calibration's factors', else the model's level [-]."""
    if calibration is not None and balance.calibrated.any():
        return float(np.sqrt(np.mean(calibration.factor_error**2))) if calibration.factor_error.size else 0.0
    return float(balance.model_uncertainty)
