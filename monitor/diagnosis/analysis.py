"""The analysis the calibration and the diagnosis both start from.

The recording's order spectra and high-frequency profiles (with the tooth-pitch correction and the
cycle phase), the model's cylinder parts at the recording's own mean speed and the load stated,
the cylinder balance from the crank-speed orders (:mod:`monitor.diagnosis.balance`), and the
engine's orders and main-bearing forces combined with the strengths it estimates
(:func:`analyse`); which vibration channels sit on which main bearing (:func:`bearing_sensors`), and
why the bearings are not judged when none does (:func:`bearings_unjudged`).
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Literal, TypeAlias

import numpy as np

from monitor.diagnosis.balance import CrankCalibration, CylinderBalance, Transfer, cylinder_balance
from monitor.diagnosis.shares import fire_together
from monitor.errors import DiagnosisError, ModelError
from monitor.io.recording import Channel, Recording
from monitor.model.banks import to_engine_frame
from monitor.model.crankshaft import EngineModel
from monitor.model.engine import Engine
from monitor.model.inertia import engine_side_inertia
from monitor.model.predicted import CombinedOrders, CylinderParts, combine_cylinders, cylinder_parts
from monitor.signal.measure import SPEED_CHANNEL, SpectrumResult, spectra
from monitor.signal.pitch import PitchCorrection
from monitor.signal.spectrum import OrderSpectrum
from monitor.types import FloatArray

__all__ = [
    "Analysis",
    "CyclePhase",
    "analyse",
    "bearing_sensors",
    "bearings_unjudged",
    "engine_orders",
    "firing_together",
    "phase_partners",
    "vibration_channels",
]

# reduced chi-square of the cylinder balance above which the notes say it fits poorly (the strengths'
# errors are widened by it); above diagnose.MISFIT no cylinder is named
POOR_FIT = 4.0
#: An order where the cylinders' firing phasors add up to more than this share of their number is a
#: firing harmonic of the engine (:func:`engine_orders`): 0 on an even engine between its harmonics,
#: 0.13 at a 55 deg V12's order 3, the least a bank angle of the class makes; firing angles rounded to
#: a tenth of a degree leave at most 0.02 at order 12 (k times 0.1 deg in radians) [-].
ADD_UP = 0.05


def _bearing_of(channel: Channel) -> int | None:
    words = channel.location.lower().split()
    if len(words) == 3 and words[:2] == ["main", "bearing"] and words[2].isdigit():
        return int(words[2])
    return None


def vibration_channels(recording: Recording) -> list[Channel]:
    """The recording's acceleration and velocity channels (not event channels).

    Parameters
    ----------
    recording : Recording

    Returns
    -------
    list of Channel
    """
    return [c for c in recording.channels if c.kind in ("acceleration", "velocity") and not c.is_events]


def bearing_sensors(recording: Recording, engine: Engine) -> list[tuple[Channel, int]]:
    """The vibration channels on a main bearing ('main bearing N', vertical or horizontal).

    Parameters
    ----------
    recording : Recording
    engine : Engine
        Its bearing count bounds N.

    Returns
    -------
    list of (Channel, int)
        Each channel with its bearing's number (from 1).
    """
    out = []
    for channel in vibration_channels(recording):
        b = _bearing_of(channel)
        if (
            b is not None
            and channel.direction in ("vertical", "horizontal")
            and 1 <= b <= engine.bearing_count
        ):
            out.append((channel, b))
    return out


def bearings_unjudged(recording: Recording, judged: list[tuple[Channel, int]], engine: Engine) -> str:
    """Why the main bearings are not judged, or "" when a sensor on one is left to judge them.

    Parameters
    ----------
    recording : Recording
        As given, before faulty or excluded channels were left out.
    judged : list of (Channel, int)
        The bearing sensors left to judge (:func:`bearing_sensors` of the screened recording).
    engine : Engine

    Returns
    -------
    str
        The reason, to follow "main bearings not judged: ".
    """
    if judged:
        return ""
    if bearing_sensors(recording, engine):
        return "its main-bearing vibration channels were left out (faulty, or excluded)"
    return (
        "the recording has no main-bearing vibration channel (acceleration or velocity at 'main "
        "bearing N', vertical or horizontal): the status speaks for the cylinders and the crank speed only"
    )


@dataclass(frozen=True)
class Analysis:
    """What :func:`analyse` found: the spectra, the balance, the model at nominal and found strengths."""

    spectra: SpectrumResult
    balance: CylinderBalance | None
    combined: CombinedOrders
    nominal: CombinedOrders
    load: float
    notes: list[str]
    inertia: float
    force_error: FloatArray  # (n_bearings, 2, n_orders): of combined.bearing_force, from the strengths [N]
    parts: CylinderParts
    partners: list[int | None] | None = None  # four-stroke phase unknown: each cylinder's 360 deg partner


def _force_error(parts: CylinderParts, engine: Engine, covariance: FloatArray | None) -> FloatArray:
    """Standard error of each bearing force order that the strengths' covariance gives [N].

    ``dF_bk / ds_c = share_bc R_c combustion_ck exp(-i k phi_c)``, cylinder ``c``'s combustion part (a
    slave's its own) turned by ``R_c`` from its own axes into the engine's, as
    :func:`~monitor.model.predicted.combine_cylinders` turns it; ``E |dF|^2 = g^H C g``.
    """
    n_orders = parts.orders.size
    if covariance is None:
        return np.zeros((engine.bearing_count, 2, n_orders))
    rotation = np.exp(-1j * np.multiply.outer(engine.firing_angles, parts.orders))  # (n_cyl, n_orders)
    combustion = parts.per_cylinder(engine.cylinders)[2]  # (n_cyl, 3, n_orders)
    throw = to_engine_frame(rotation[:, None, :] * combustion[:, 1:3, :], engine.cylinder_axes)
    g = engine.bearing_share[:, :, None, None] * throw[None]  # (n_bearings, n_cyl, 2, n_orders)
    variance = np.einsum("bcko,cd,bdko->bko", g, covariance, np.conj(g)).real
    return np.asarray(np.sqrt(np.maximum(variance, 0.0)))


CyclePhase: TypeAlias = float | Literal["unknown"] | None


def _phase_known(recording: Recording) -> bool:
    """True if the recording itself tells the four-stroke cycle phase (a cam or a cylinder-1 pressure)."""
    return (
        recording.cycle_phase_deg is not None
        or bool(recording.of_kind("cam"))
        or any(int(c.fields.get("cylinder", 0)) == 1 for c in recording.of_kind("pressure"))
    )


def analyse(
    recording: Recording,
    engine: Engine,
    *,
    load: float,
    transfer: Transfer,
    max_order: float,
    cycle_phase: CyclePhase = None,
    pitch: PitchCorrection | None = None,
    crank: CrankCalibration | None = None,
    progress: Callable[[float], None] | None = None,
    resampled: SpectrumResult | None = None,
) -> Analysis:
    """The recording's spectra, its cylinder balance and the model combined with the strengths found.

    Parameters
    ----------
    recording : Recording
    engine : Engine
    load : float
        The load it ran at, fraction of rated IMEP [-].
    transfer : {"rigid", "shaft-line"}
        From the torque to the crank speed.
    max_order : float
        Highest order analysed [-].
    cycle_phase : float or "unknown", optional
        Four-stroke: the shift that puts cylinder 1's firing TDC at cycle angle 0 [rad], or
        "unknown" (analysed with 0, each cylinder's 360 deg partner kept).
    pitch : PitchCorrection, optional
        A learned tooth-pitch correction (default: estimated on the recording).
    crank : CrankCalibration, optional
        A baseline's calibration of the crank-speed model.
    progress : callable, optional
        Told the fraction of the resampling done, from 0 to 1 [-].
    resampled : SpectrumResult, optional
        The recording's spectra with these channels, cycle phase and pitch correction, made already (at
        another load: they do not depend on it); taken as they are. Default: resampled here.

    Returns
    -------
    Analysis

    Raises
    ------
    DiagnosisError
        For a recording of another engine than its description.
    """
    if recording.engine_id and recording.engine_id != engine.id:
        raise DiagnosisError(
            f"the recording is of engine {recording.engine_id!r}, the description given is {engine.id!r}"
        )
    R = engine.cycle_revolutions
    ambiguous = R == 2 and cycle_phase == "unknown" and not _phase_known(recording)
    phase: float | None = None
    if R == 2 and isinstance(cycle_phase, float | int):
        phase = float(cycle_phase)
    elif ambiguous:
        phase = 0.0
    result = resampled
    if result is None:
        result = spectra(
            recording,
            cycle_revolutions=R,
            max_order=max_order,
            high_frequency=True,
            cycle_phase=phase,
            pitch_correction="estimate" if pitch is None else pitch,
            kept_orders=engine_orders(engine, recording),
            progress=progress,
        )
    model = EngineModel(engine, gas="auto")
    parts = cylinder_parts(model, crank_speed=result.mean_speed, load=load, max_order=max_order)
    notes: list[str] = list(result.reference.notes)
    if recording.truncated:
        notes.append("the file was cut short: diagnosed up to its last whole chunk")
    correction = result.reference.pitch_correction
    if correction is not None and correction.largest > math.radians(0.05):
        notes.append(
            f"{result.reference.source}: tooth-pitch errors corrected ({correction.scope} teeth, from the "
            f"{correction.source}): largest {math.degrees(correction.largest):.2f} deg"
        )
    balance, strengths = _balance(result, engine, parts, transfer, crank, notes)
    covariance = balance.strength_covariance if balance is not None and balance.separable else None
    inertia = _rigid_inertia(engine, notes) if transfer == "rigid" else 0.0
    if ambiguous:
        notes.append(
            "the cycle phase is unknown (no cam or cylinder-1 pressure channel, --cycle-phase unknown): "
            "each cylinder named may be the one that fires 360 deg from it"
        )
    return Analysis(
        spectra=result,
        balance=balance,
        combined=combine_cylinders(parts, engine, strengths),
        nominal=combine_cylinders(parts, engine, np.ones(engine.cylinders)),
        load=load,
        notes=notes,
        inertia=inertia,
        force_error=_force_error(parts, engine, covariance),
        parts=parts,
        partners=phase_partners(engine) if ambiguous else None,
    )


def _balance(
    result: SpectrumResult,
    engine: Engine,
    parts: CylinderParts,
    transfer: Transfer,
    crank: CrankCalibration | None,
    notes: list[str],
) -> tuple[CylinderBalance | None, FloatArray]:
    """The cylinder balance from the crank-speed orders, and the strengths the model is combined with.

    Notes what was not done, or how well it fits, onto ``notes``.
    """
    balance = None
    strengths = np.ones(engine.cylinders)
    speed = result.spectra.get(SPEED_CHANNEL)
    if speed is None or speed.orders.size < 2:
        notes.append(
            "cylinder balance not done: the angle reference gives no crank-speed orders "
            f"({result.reference.pulses_per_revolution} pulse(s) per revolution; a tooth wheel gives them)"
        )
    else:
        try:
            usable = crank if crank is not None and crank.transfer == transfer else None
            balance = cylinder_balance(speed, engine, parts, transfer=transfer, calibration=usable)
            if usable is not None and balance.calibrated.any():
                orders = ", ".join(f"{k:g}" for k in balance.orders[balance.calibrated])
                notes.append(f"the crank-speed model is calibrated on the baseline at orders {orders}")
        except ModelError as error:
            notes.append(f"cylinder balance not done: {error}")
        else:
            if balance.chi2_reduced > POOR_FIT:
                other = "shaft-line" if transfer == "rigid" else "rigid"
                notes.append(
                    f"the {transfer} crank-speed model fits the measured orders poorly (reduced chi-square "
                    f"{balance.chi2_reduced:.3g}; the strengths' errors are widened by it): near a torsional "
                    f"resonance try the {other} transfer"
                )
            said = _unlearned_orders(speed, balance)
            notes.extend([said] if said else [])
            if balance.separable:
                strengths = balance.strength
            else:
                notes.append(
                    f"the crank-speed orders cannot tell the cylinders apart (condition number "
                    f"{balance.condition:.3g}): no cylinder is named"
                )
    return balance, strengths


def _unlearned_orders(speed: OrderSpectrum, balance: CylinderBalance) -> str | None:
    """A note where the balance leans on whole orders that the wheel's unlearned pitch errors can move
    by more than their standard error (:mod:`monitor.signal.pitch_uncertainty`); None where none does.

    An order the baseline calibrated is left out: the same wheel's errors are in the baseline's.
    """
    if speed.systematic is None:
        return None
    used = np.isin(speed.orders, balance.orders[~balance.calibrated])
    over = used & (speed.systematic > np.maximum(speed.standard_error, 1e-300))
    if not over.any():
        return None
    ratio = float(np.max(speed.systematic[over] / np.maximum(speed.standard_error[over], 1e-300)))
    orders = ", ".join(f"{k:g}" for k in speed.orders[over])
    return (
        f"the cylinder balance uses crank-speed orders {orders}, which the wheel's unlearned tooth-pitch "
        f"errors can move by more than their standard error (up to {ratio:.0f} times; spectrum's "
        "'systematic'): the strengths there lean on what a run-up or coast-down calibration of the wheel "
        "would clean (calibrate --pitch-from)"
    )


def _rigid_inertia(engine: Engine, notes: list[str]) -> float:
    """The rigid engine side's inertia, or 0 (noted) when the engine description lacks it [kg m^2]."""
    try:
        return engine_side_inertia(engine)
    except ModelError as error:
        notes.append(f"crank speed not predicted: {error}")
        return 0.0


def engine_orders(engine: Engine, recording: Recording, *, firing_only: bool = False) -> list[int] | None:
    """Integer orders of the crank speed the engine excites: the low ones and the firing harmonics.

    Left to the engine by the tooth-pitch estimate: orders 1 to a sixth of the wheel's pulses (any
    of which a cylinder that fires unlike the others excites; not with ``firing_only``, for a
    healthy baseline), and every integer order below 0.4 of them at which cylinders firing alike
    add up (where the gas and inertia torques are): ``|sum_c exp(-i k phi_c)|`` not nothing, over
    the firing angles ``phi_c``. On an evenly firing engine these are the multiples of the firing
    frequency (cylinders / revolutions per cycle); on an uneven one (a V whose bank angle is not
    the even interval) more: a 60 deg V16 fires each bank every 90 deg and so excites order 4 as
    well as 8.

    Parameters
    ----------
    engine : Engine
    recording : Recording
        Its first tooth-wheel or encoder channel gives the pulses per revolution.
    firing_only : bool, optional
        Only the firing harmonics (for a healthy baseline).

    Returns
    -------
    list of int or None
        None without a tooth wheel or encoder.
    """
    wheels = recording.of_kind("tooth") or recording.of_kind("encoder")
    if not wheels:
        return None
    fields = wheels[0].fields
    pulses = int(fields["teeth"]) if wheels[0].kind == "tooth" else int(fields["pulses_per_revolution"])
    candidates = np.arange(1, int(0.4 * pulses) + 1)
    alike = np.abs(np.exp(-1j * np.multiply.outer(candidates, engine.firing_angles)).sum(axis=1))
    harmonics = {int(k) for k in candidates[alike > ADD_UP * engine.cylinders]}
    low = set() if firing_only else set(range(1, pulses // 6 + 1))
    return sorted(low | harmonics)


def phase_partners(engine: Engine) -> list[int | None]:
    """For each cylinder, the one that fires 360 deg after it (0-based), or None if no cylinder does.

    Parameters
    ----------
    engine : Engine
        A four-stroke engine.

    Returns
    -------
    list of int or None
    """
    angles = np.mod(engine.firing_angles, 4 * math.pi)
    partners: list[int | None] = []
    for c in range(engine.cylinders):
        target = np.mod(angles[c] + 2 * math.pi, 4 * math.pi)
        distance = np.abs(np.angle(np.exp(1j * (angles - target) / 2)))  # on the 720 deg cycle
        match = int(np.argmin(distance))
        partners.append(match if distance[match] < math.radians(1.0) else None)
    return partners


def firing_together(engine: Engine, highest_order: float) -> str:
    """A reason's clause naming the cylinders that fire too nearly together for the crank-speed orders
    up to ``highest_order`` to tell them apart ("" if none do).

    Two cylinders ``d`` apart in their firing angles (on the cycle) differ at order ``k`` by the phase
    ``k d``: under :data:`~monitor.diagnosis.shares.TOGETHER` at the highest order, their differences
    from each other are hardly seen. A V engine whose bank angle is, or is near, a multiple of its
    banks' firing interval (a 90 deg V16 firing each bank every 90 deg) fires its cylinders in such
    pairs; the cylinder balance judges each pair as one (:mod:`monitor.diagnosis.shares`).

    Parameters
    ----------
    engine : Engine
    highest_order : float
        The highest crank-speed order the balance used [-].

    Returns
    -------
    str
    """
    cycle = 2 * math.pi * engine.cycle_revolutions
    angles = np.mod(engine.firing_angles, cycle)
    names = engine.cylinder_names
    pairs = []
    for group in fire_together(engine.firing_angles, engine.cycle_revolutions, highest_order):
        for a, b in itertools.pairwise(group):
            apart = abs(float(angles[a] - angles[b]))
            pairs.append(f"{names[a]} and {names[b]} ({math.degrees(min(apart, cycle - apart)):.1f} deg)")
    if not pairs:
        return ""
    return (
        f"; cylinders that fire too nearly together for the crank-speed orders up to {highest_order:g} "
        f"to tell apart: {', '.join(pairs)}"
    )
