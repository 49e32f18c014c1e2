"""The diagnosis at the recording's own operating point: the load given, the load estimated, the reference.

A recording is diagnosed against the reference of its load (:mod:`monitor.diagnosis.operating_points`).
Its load is known two ways: stated (``--load``, an engine log's reading: uncertain by
:data:`~monitor.diagnosis.operating_points.LOAD_UNCERTAINTY`) and estimated from its crank-speed
orders (:mod:`monitor.diagnosis.load_estimate`).  The stated load, where there is one, is the load
the model and the reference are taken at: the estimate rests on the cylinders' strengths, which a
fault moves (a weak cylinder, and with few cylinders a misfire, reads as a lower load), so the
estimate is reported beside it and a disagreement beyond their joint uncertainty is noted, not
followed.  An estimate above the stated load by more than :data:`AGREE` of its own standard errors is
another matter: no fault makes the median cylinder fire more, so the engine fires more at its load
than the model does (its charge pressure does not follow the load as the engine file's law has it,
or the reading is low), and judged at the stated load the model's misfit widens the cylinders'
errors until a weak one passes (validation seeds 200051 and 200365: cylinders at 65 % and 69 % read
within 4 standard errors of the others, boost held at part load).  The model and the reference are
then taken at the estimate, at most :data:`AGREE` of the stated load's standard errors above it
(``load_used_from: "raised"``); the bearings' impacts are still judged over the stated load's
uncertainty.  Without a stated load, against several calibrated points whose speeds rise with their
loads (an engine on a propeller curve) the load is read from the recording's speed on theirs; against
several at one speed, or a single point, the estimate is used (the first pass at the middle point's
load, the second at the load found: judged at the baseline's load instead, a recording far from it
reads weak cylinders as healthy); without a baseline, rated (the estimate reported beside it).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import replace
from typing import Any

import numpy as np

from monitor.diagnosis.analysis import CyclePhase
from monitor.diagnosis.balance import Transfer
from monitor.diagnosis.bearings import SPEED_TOLERANCE
from monitor.diagnosis.diagnose import Diagnosis, diagnose
from monitor.diagnosis.load_estimate import LoadEstimate, estimate_load
from monitor.diagnosis.operating_points import LOAD_UNCERTAINTY, OperatingPoints, Reference
from monitor.io.recording import Recording
from monitor.model.engine import Engine

__all__ = ["AGREE", "diagnose_at_point", "load_from_speed"]

AGREE = 2.0  # a stated and an estimated load further apart than this many joint standard errors disagree


def diagnose_at_point(
    recording: Recording,
    engine: Engine,
    *,
    points: OperatingPoints | None = None,
    load: float | None = None,
    transfer: Transfer = "rigid",
    max_order: float = 24.0,
    cycle_phase: CyclePhase = None,
    exclude: tuple[str, ...] | list[str] = (),
    progress: Callable[[float], None] | None = None,
) -> Diagnosis:
    """Diagnose a recording against the reference at its load, with its load estimated and reported.

    Parameters
    ----------
    recording : Recording
    engine : Engine
    points : OperatingPoints, optional
        The calibrated points (a single-point baseline is one).
    load : float, optional
        The load stated [-] (uncertain by ``LOAD_UNCERTAINTY``); default: the estimate's.
    transfer : {"rigid", "shaft-line"}, optional
    max_order : float, optional
        [-]
    cycle_phase : float or "unknown", optional
    exclude : sequence of str, optional
    progress : callable, optional
        Told the fraction of the resampling done, from 0 to 1 [-].

    Returns
    -------
    Diagnosis
        Its ``operating_point`` says the load stated, estimated and used, and the reference.
    """

    Pass = tuple[Diagnosis, Reference | None]

    def run(at: float | None, within: tuple[float, float], earlier: Pass | None = None) -> Pass:
        """The diagnosis at a load against the reference there. The earlier pass's spectra are taken
        where its reference's baseline is this one (a single point's): they do not depend on the load."""
        reference = (
            points.reference_at(at if at is not None else _middle(points), within=within) if points else None
        )
        resampled = None
        if earlier is not None and earlier[1] is not None and reference is not None:
            resampled = earlier[0].spectra if earlier[1].baseline is reference.baseline else None
        diagnosis = diagnose(
            recording,
            engine,
            baseline=reference.baseline if reference is not None else None,
            load=at,
            transfer=transfer,
            max_order=max_order,
            cycle_phase=cycle_phase,
            exclude=exclude,
            progress=progress,
            resampled=resampled,
        )
        return diagnosis, reference

    # no load stated: the first pass is at the middle point's load, which diagnose takes from the
    # reference itself, so that it knows that no load was stated (a single cylinder then names no
    # weakness a lower load explains); a load read from the speed or estimated is told in a second pass
    first = load
    # the loads the recording may be at, for the impact reference: the stated load's uncertainty, else
    # any of the calibrated loads (the estimate from the crank-speed orders is not narrowed to: on many
    # cylinders the inertia torque dominates the orders it reads, and it can miss by half the range),
    # the load read from the speed's uncertainty where the points' speeds tell it (below)
    calibrated = points.loads if points is not None else [math.nan]
    within = (
        (load - LOAD_UNCERTAINTY, load + LOAD_UNCERTAINTY)
        if load is not None
        else (calibrated[0], calibrated[-1])
    )
    earlier = diagnosis, reference = run(first, within)
    estimate = _estimate(diagnosis, engine, points, transfer, max_order)
    used = "stated"
    if load is not None and estimate is not None and estimate.load > load + AGREE * estimate.standard_error:
        used = "raised"  # the engine fires more than the model at the stated load (module docstring)
        diagnosis, reference = run(min(estimate.load, load + AGREE * LOAD_UNCERTAINTY), within, earlier)
    by_speed = load_from_speed(diagnosis.speed_rpm, points) if load is None else None
    if load is None:
        used = "baseline" if points is not None else "rated"
        if by_speed is not None:
            used = "speed"
            # a propeller curve reads the load off the speed as well as an operator reads the log
            within = (by_speed - LOAD_UNCERTAINTY, by_speed + LOAD_UNCERTAINTY)
            diagnosis, reference = run(by_speed, within, earlier)  # the model and reference at its load
        elif estimate is not None and points is not None:
            used = "estimated"
            diagnosis, reference = run(estimate.load, within, earlier)  # the model and reference there
    notes = _load_notes(load, estimate, diagnosis.load, used, engine)
    if reference is not None and len(_calibrated(points)) > 1:
        notes.append(reference.note())
        notes.append(
            f"the bearings' impacts are judged against the engine's own high-frequency noise at its "
            f"loudest over the loads {max(min(within), 0.0):.2f} to {max(within):.2f} (the load's "
            "uncertainty), interpolated between the calibrated points"
        )
    point: dict[str, Any] = {
        "load_used": diagnosis.load,
        "load_used_from": used,
        "load_stated": load,
        "load_stated_standard_error": LOAD_UNCERTAINTY if load is not None else None,
        "load_estimated": estimate.load if estimate is not None else None,
        "load_estimated_standard_error": estimate.standard_error if estimate is not None else None,
        "calibrated_loads": points.loads if points is not None else [],
        "reference_between": [reference.lower, reference.upper] if reference is not None else None,
        "extrapolated": bool(reference.extrapolated) if reference is not None else False,
        "interpolation_uncertainty": reference.relative_uncertainty if reference is not None else 0.0,
    }
    return replace(diagnosis, notes=diagnosis.notes + notes, operating_point=point)


def _calibrated(points: OperatingPoints | None) -> tuple[Any, ...]:
    """The calibrated points (none without a baseline)."""
    return points.points if points is not None else ()


def _middle(points: OperatingPoints) -> float:
    return points.points[len(points.points) // 2].load


def _estimate(
    diagnosis: Diagnosis, engine: Engine, points: OperatingPoints | None, transfer: Transfer, max_order: float
) -> LoadEstimate | None:
    def reference(at: float) -> tuple[Any, float, str]:
        if points is None:
            return None, 1.0, "the model's strengths"
        return (
            points.reference_at(at).baseline.crank,
            points.mean_strength_at(at),
            "the calibrated points' strengths",
        )

    return estimate_load(
        diagnosis.spectra, engine, transfer=transfer, max_order=max_order, reference=reference
    )


def load_from_speed(speed_rpm: float, points: OperatingPoints | None) -> float | None:
    """The load the calibrated points' speeds give at the recording's speed, where they tell it.

    Points whose speeds rise with the load by more than the bearings' speed tolerance are an engine
    whose speed follows its load (a fixed-pitch propeller): the recording's mean speed reads its load
    off them, linearly between two points, the nearest point's beyond them.

    Parameters
    ----------
    speed_rpm : float
        The recording's mean speed [rpm].
    points : OperatingPoints or None

    Returns
    -------
    float or None
        [-]; None for fewer than two points, or points whose speeds do not rise with their loads
        by more than the tolerance (a generator's, at one speed).
    """
    if points is None or len(points.points) < 2 or not math.isfinite(speed_rpm):
        return None
    speeds = np.array([p.speed_rpm for p in points.points])
    if not (np.all(np.diff(speeds) > 0) and speeds[-1] > (1 + SPEED_TOLERANCE) * speeds[0]):
        return None
    return float(np.interp(speed_rpm, speeds, points.loads))


def _load_notes(
    stated: float | None, estimate: LoadEstimate | None, used: float, source: str, engine: Engine
) -> list[str]:
    """The loads stated, estimated and used, and a disagreement between the first two."""
    notes = []
    if estimate is not None:
        notes.append(
            f"load estimated from the crank-speed orders: {estimate.load:.2f} +- "
            f"{estimate.standard_error:.2f} (against {estimate.reference})"
        )
        if estimate.other_matches:
            others = ", ".join(f"{other:.2f}" for other in estimate.other_matches)
            notes.append(
                f"the cylinders' strengths also match the reference at load {others}: the lowest match "
                "is taken, its standard error spanning the others"
            )
    if stated is not None and estimate is not None:
        joint = math.hypot(LOAD_UNCERTAINTY, estimate.standard_error)
        if abs(stated - estimate.load) > AGREE * joint:
            notes.append(
                f"the load stated ({stated:.2f} +- {LOAD_UNCERTAINTY:.2f}) and the load estimated "
                f"({estimate.load:.2f} +- {estimate.standard_error:.2f}) disagree beyond their "
                "uncertainties: check the load reading"
                + (
                    "; a weak cylinder also reads as a lower load. The stated load is used"
                    if source == "stated"
                    else ""
                )
            )
    if source == "raised":
        law = engine.combustion.charge_pressure_law if engine.combustion is not None else "turbocharged"
        notes.append(
            f"the cylinders fire more than the model does at the load stated ({stated:.2f}): the model "
            f"and the reference are taken at {used:.2f}, the load estimated (at most {AGREE:g} of the "
            f"stated load's standard errors above it); the engine's charge pressure may not follow the "
            f"load as the engine file's law ('{law}') has it, or the load reading is low"
        )
    if source == "estimated":
        notes.append(f"no load stated: the estimated load {used:.2f} is used")
    if source == "speed":
        notes.append(
            f"no load stated: the load {used:.2f} is read from the recording's speed on the calibrated "
            "points' speeds (the engine's speed follows its load, as on a propeller curve)"
        )
    return notes
