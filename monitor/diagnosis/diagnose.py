"""The diagnosis of a recording: measured orders against the model, findings with severity.

Steps (DESIGN.md, "Diagnosis: the sums behind it"):

1. Order spectra of every vibration channel and of the crank speed, with the
   crank-angle profile of each vibration channel's high-frequency power, in
   one pass (:func:`monitor.signal.measure.spectra`).
2. Cylinder balance from the crank-speed orders (:mod:`monitor.diagnosis.balance`):
   each cylinder's strength with its standard error.
3. The model at the recording's own mean speed and load, with the estimated
   strengths: the crank-speed orders (rigid body or shaft line) and the
   main-bearing forces; through the baseline's calibrated transfers, each
   bearing sensor's orders (:mod:`monitor.diagnosis.bearings`).
4. Impact content in each bearing's load-reversal windows; the overall rms
   velocity of each vibration channel against its zones (:mod:`monitor.diagnosis.zones`).
5. Findings (:mod:`monitor.diagnosis.findings`, where the rules and their
   thresholds are): a deviation beyond its engineering threshold and
   statistically significant is a finding, with the evidence behind it and a
   confidence.  A recording without findings is healthy only when the checks
   could be made (a steady run, the cylinders resolved); otherwise it is
   inconclusive (:data:`STEADY`, :data:`RESOLVED`, :data:`MISFIT`).

Steps 1 and 2, and the model combined with the strengths, are the analysis the calibration of a
baseline shares (:mod:`monitor.diagnosis.analysis`, :mod:`monitor.diagnosis.calibration`).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from monitor.diagnosis.analysis import (
    Analysis,
    CyclePhase,
    analyse,
    bearing_sensors,
    bearings_unjudged,
    firing_together,
    vibration_channels,
)
from monitor.diagnosis.balance import CylinderBalance, Transfer
from monitor.diagnosis.baseline import Baseline, SensorBaseline
from monitor.diagnosis.bearings import (
    SPEED_TOLERANCE,
    OrderDeviation,
    away_note,
    impact_score,
    order_deviations,
    varying_note,
)
from monitor.diagnosis.elsewhere import with_elsewhere
from monitor.diagnosis.findings import (
    IMPACT_WARNING,
    BearingResult,
    Finding,
    bearing_findings,
    confidence_beyond,
    cylinder_findings,
    missing_firing_doubt,
    missing_firing_findings,
    sensor_finding,
    worse,
)
from monitor.diagnosis.impact_reference import engine_level, reference_profile
from monitor.diagnosis.rigid_speed import predicted_speed
from monitor.diagnosis.sensors import SensorFault, level_faults, screen_sensors, without
from monitor.diagnosis.single_cylinder import single_cylinder_verdict
from monitor.diagnosis.zones import (
    DEFAULT_BAND_HZ,
    DEFAULT_BOUNDARIES_MM_S,
    VelocityRms,
    limits_named,
    velocity_rms,
    zone_of,
)
from monitor.errors import SignalError
from monitor.io.recording import Channel, Recording
from monitor.model.engine import Engine
from monitor.model.inertia import engine_side_inertia_at
from monitor.model.predicted import (
    combine_cylinders,
    load_reversals,
)
from monitor.signal.anglemap import AngleMap
from monitor.signal.impact import HighFrequencyPower
from monitor.signal.measure import SPEED_CHANNEL, SpectrumResult
from monitor.torsion.shaft_line import tooth_wheel_receptance
from monitor.types import ComplexArray, FloatArray

__all__ = [
    "ANALYSIS_VERSION",
    "BearingResult",
    "ChannelComparison",
    "Diagnosis",
    "Finding",
    "diagnose",
    "unsteady_speeds",
]

ANALYSIS_VERSION = "1"
# the model's uncertainty of the change in a bearing force that the cylinders' estimated strengths make
# against the baseline's (a changed gas force's high orders are known to tens of per cent) [-]
CHANGE_UNCERTAINTY = 0.5
# revolutions' speeds of a relative standard deviation above this are no steady run: the model at their mean
STEADY = 0.10  # speed misses their mean inertia forces (as the speed squared) by its square, 1 % or more [-]
RESOLVED = 0.25  # a cylinder balance whose strengths' errors exceed this (relative) names nothing [-]
MISFIT = 25.0  # reduced chi-square of the cylinder balance above which no cylinder is named (inconclusive)


@dataclass(frozen=True)
class ChannelComparison:
    """Measured against predicted orders of one channel.

    Attributes
    ----------
    channel : str
    unit : str
    orders : ndarray
    measured, predicted : ndarray, complex
    standard_error : ndarray
        Of ``measured``, from the spread over the averaged blocks (and the calibration).
    basis : str
        What the prediction rests on.
    """

    channel: str
    unit: str
    orders: FloatArray
    measured: ComplexArray
    predicted: ComplexArray
    standard_error: FloatArray
    basis: str

    @property
    def deviation(self) -> FloatArray:
        """``|measured - predicted|`` over the channel's largest predicted order [-]."""
        largest = float(np.abs(self.predicted).max()) if self.predicted.size else 0.0
        return np.asarray(np.abs(self.measured - self.predicted) / (largest if largest > 0 else 1.0))


@dataclass(frozen=True)
class Diagnosis:
    """A recording's diagnosis.

    Attributes
    ----------
    engine_id : str
    speed_rpm : float
        Mean crank speed [rpm].
    load : float
        Load the model was evaluated at [-].
    status : str
        "healthy", "warning" or "alarm": the worst finding; "inconclusive" when there is none but
        the checks could not all be made (the notes say why).
    findings : list of Finding
    balance : CylinderBalance or None
    comparisons : list of ChannelComparison
    bearings : list of BearingResult
    velocity : dict of str to (VelocityRms, zone)
    zone_boundaries_mm_s : tuple of float
    notes : list of str
        What was not done, and why.
    spectra : SpectrumResult
    baseline : str
        The baseline's source, or "".
    bearings_not_judged : str
        Why the main bearings were not judged (no sensor on one), or "" when they were.
    operating_point : dict
        The loads stated, estimated and used and the reference's calibrated points
        (:func:`monitor.diagnosis.at_point.diagnose_at_point`); empty from :func:`diagnose` alone.
    """

    engine_id: str
    speed_rpm: float
    load: float
    status: str
    findings: list[Finding]
    balance: CylinderBalance | None
    comparisons: list[ChannelComparison]
    bearings: list[BearingResult]
    velocity: dict[str, tuple[VelocityRms, str]]
    zone_boundaries_mm_s: tuple[float, float, float]
    notes: list[str]
    spectra: SpectrumResult = field(repr=False)
    baseline: str = ""
    bearings_not_judged: str = ""
    operating_point: dict[str, Any] = field(default_factory=dict)


# ------------------------------------------------------------------------------------------ model
def _speed_comparison(analysis: Analysis, engine: Engine, transfer: Transfer) -> ChannelComparison | None:
    speed = analysis.spectra.spectra.get(SPEED_CHANNEL)
    if speed is None or speed.orders.size < 2:
        return None
    orders = speed.orders
    nominal = analysis.nominal
    index = [int(np.argmin(np.abs(nominal.orders - k))) for k in orders]
    if transfer == "rigid":
        if analysis.inertia <= 0:
            return None
        mean = float(speed.amplitude[0].real)
        met = np.full(orders.size, analysis.inertia, dtype=np.complex128)
        met[1:] = engine_side_inertia_at(engine, orders[1:] * mean)
        predicted = predicted_speed(nominal.engine_torque[index], orders, met, mean, engine.cycle_revolutions)
        basis = (
            f"healthy model, rigid engine side (J = {analysis.inertia:.4g} kg m^2) and the driven end "
            "through its shafts"
        )
    else:
        receptance = tooth_wheel_receptance(engine, orders[1:], float(speed.amplitude[0].real))
        predicted = np.concatenate(
            [[speed.amplitude[0]], (receptance * nominal.cylinder_torque[:, index[1:]]).sum(axis=0)]
        )
        basis = "healthy model, shaft-line receptance at the tooth wheel"
    # the speed spline follows orders up to about a sixth of the pulses per revolution (pipeline tests)
    keep = (orders > 1e-9) & (orders <= analysis.spectra.reference.pulses_per_revolution / 6 + 1e-9)
    return ChannelComparison(
        SPEED_CHANNEL,
        "rad/s",
        orders[keep],
        speed.amplitude[keep],
        predicted[keep],
        speed.standard_error[keep],
        basis,
    )


def unsteady_speeds(angle_map: AngleMap) -> FloatArray | None:
    """Each whole revolution's mean speed [rpm] when they spread beyond :data:`STEADY`, else None.

    Parameters
    ----------
    angle_map : AngleMap
        The recording's.

    Returns
    -------
    ndarray or None
        [rpm]; None for a steady run (relative standard deviation :data:`STEADY` or less) or fewer
        than two whole revolutions: the model at the mean speed then stands for every revolution.
    """
    cycle = 2 * math.pi
    first, last = math.ceil(angle_map.angles[0] / cycle), math.floor(angle_map.angles[-1] / cycle)
    if last - first < 2:
        return None
    times = angle_map.time_at(cycle * np.arange(first, last + 1, dtype=np.float64))
    rpm = np.asarray((cycle / np.diff(times)) * 30 / math.pi)
    return rpm if float(np.std(rpm) / np.mean(rpm)) > STEADY else None


def _unresolved(analysis: Analysis, engine: Engine) -> list[str]:
    """Why a recording without findings cannot be called healthy (empty if it can)."""
    reasons = []
    angle_map = analysis.spectra.reference.angle_map
    if (rpm := unsteady_speeds(angle_map)) is not None:
        spread = float(np.std(rpm) / np.mean(rpm))
        reasons.append(
            f"the speed was not steady ({rpm.min():.1f} to {rpm.max():.1f} rpm over the revolutions, "
            f"{100 * spread:.0f} % rms); the diagnosis compares the revolutions with the model at their "
            "mean speed, whose inertia forces (as the speed squared) miss theirs by "
            f"{100 * spread**2:.0f} %"
        )
    if engine.cylinders > 1:
        balance = analysis.balance
        together = firing_together(engine, float(balance.orders.max())) if balance is not None else ""
        if balance is None:
            reasons.append("the cylinders were not compared (see the notes)")
        elif not balance.separable or balance.chi2_reduced > MISFIT:
            reasons.append("the crank-speed orders do not resolve the cylinders (see the notes)" + together)
        elif (worst := float(np.max(balance.member_contrast_error()))) > RESOLVED:
            # read as the findings read them: a group that fires together as one member's, so that a
            # member missing whole (1) is never within SIGNIFICANCE of its errors and called healthy
            uncertain = f"the cylinders' differences are uncertain by up to {100 * worst:.0f} %"
            reasons.append(uncertain + " (one standard error): too little to call them healthy" + together)
        if balance is not None and (doubt := missing_firing_doubt(balance)) is not None:
            reasons.append(doubt)
    elif analysis.balance is None and engine.combustion is not None:
        reasons.append("the cylinder was not judged (see the notes)")
    return reasons


def diagnose(
    recording: Recording,
    engine: Engine,
    *,
    baseline: Baseline | None = None,
    load: float | None = None,
    transfer: Transfer = "rigid",
    max_order: float = 24.0,
    cycle_phase: CyclePhase = None,
    exclude: tuple[str, ...] | list[str] = (),
    progress: Callable[[float], None] | None = None,
    resampled: SpectrumResult | None = None,
) -> Diagnosis:
    """Diagnose a recording against the engine's model (see the module docstring).

    Parameters
    ----------
    recording : Recording
    engine : Engine
    baseline : Baseline, optional
        A healthy recording's calibration: without it, the bearing sensors' orders are
        not compared and impacts are judged against the recording's own profile.
    load : float, optional
        The load it ran at [-]; default: the baseline's, else rated (1).
    transfer : {"rigid", "shaft-line"}, optional
        From the torque to the crank speed.
    max_order : float, optional
        Highest order analysed [-].
    cycle_phase : float or "unknown", optional
        Four-stroke, for a recording without a cam or cylinder-1 pressure channel: the shift (0 or
        2 pi) that puts cylinder 1's firing TDC at cycle angle 0 [rad], or "unknown": diagnosed
        with 0, and each cylinder named together with the one firing 360 deg from it.
    exclude : sequence of str, optional
        Channels left out of the diagnosis.
    progress : callable, optional
        Told the fraction of the resampling done, from 0 to 1 [-].
    resampled : SpectrumResult, optional
        Its spectra from its diagnosis against the same baseline and options at another load (they do
        not depend on it): taken as they are. Default: resampled here.

    Returns
    -------
    Diagnosis
        Vibration channels found clipped, dead or implausibly scaled are findings on the sensor
        and left out of the rest (:mod:`monitor.diagnosis.sensors`).

    Raises
    ------
    DiagnosisError
        For a recording of another engine than its description or baseline, or a channel
        layout the baseline lacks.
    SignalError
        Without a usable angle reference.
    """
    recording_before = recording
    limits = engine.vibration_limits
    boundaries = limits.zone_boundaries_mm_s if limits is not None else DEFAULT_BOUNDARIES_MM_S
    band = limits.band_hz if limits is not None else DEFAULT_BAND_HZ
    recording, sensor_faults, screen_notes, rms, unrated = _screen(recording, baseline, band, exclude)
    if baseline is not None:
        baseline.check_layout(recording, engine)
    stated, load = load, load if load is not None else (baseline.load if baseline is not None else 1.0)
    analysis = analyse(
        recording,
        engine,
        load=load,
        transfer=transfer,
        max_order=max_order,
        cycle_phase=cycle_phase,
        pitch=baseline.pitch_for(recording) if baseline is not None else None,
        crank=baseline.crank if baseline is not None else None,
        progress=progress,
        resampled=resampled,
    )
    result = analysis.spectra
    notes = screen_notes + list(analysis.notes) + unrated
    speed_rpm = result.mean_speed * 30 / math.pi
    comparisons = [c for c in [_speed_comparison(analysis, engine, transfer)] if c is not None]
    # the transfers: the baseline's, else those given in the engine file
    transfers = baseline if baseline is not None else Baseline.from_engine(engine)
    usable = transfers is not None and abs(speed_rpm / transfers.speed_rpm - 1.0) <= SPEED_TOLERANCE
    sensors = bearing_sensors(recording, engine)
    unjudged = bearings_unjudged(recording_before, sensors, engine)
    notes += _transfer_notes(
        transfers, usable, speed_rpm, with_baseline=baseline is not None, unjudged=unjudged
    )
    level = _engine_level(baseline, sensors, result.high_frequency)
    judged = [_bearing_result(c, b, analysis, engine, transfers, usable, notes, level) for c, b in sensors]
    comparisons += [comparison for _, comparison in judged if comparison is not None]
    bearings = with_elsewhere([one for one, _ in judged], result.high_frequency, engine, baseline, level)
    findings: list[Finding] = [sensor_finding(f, recording_before) for f in sensor_faults]
    undecided: list[str] = []
    findings += _cylinder_findings(analysis, engine, baseline, stated, notes, undecided)
    findings += bearing_findings(
        bearings,
        with_baseline=baseline is not None,
        cylinders_changed=any(f.kind == "cylinder" for f in findings),
    )
    velocity, zone_findings = _zones(recording, rms, boundaries, stated=limits is not None)
    findings += zone_findings
    status = _status(findings, analysis, engine, notes, undecided)
    order = {"alarm": 0, "warning": 1}
    findings.sort(key=lambda f: (order[f.severity], -f.confidence, f.subject))
    return Diagnosis(
        engine_id=engine.id,
        speed_rpm=speed_rpm,
        load=load,
        status=status,
        findings=findings,
        balance=analysis.balance,
        comparisons=comparisons,
        bearings=bearings,
        velocity=velocity,
        zone_boundaries_mm_s=tuple(boundaries),  # type: ignore[arg-type]
        notes=notes,
        spectra=result,
        baseline=baseline.source if baseline is not None else "",
        bearings_not_judged=unjudged,
    )


def _screen(
    recording: Recording,
    baseline: Baseline | None,
    band: tuple[float, float],
    exclude: tuple[str, ...] | list[str],
) -> tuple[Recording, list[SensorFault], list[str], dict[str, VelocityRms], list[str]]:
    """Faulty sensors found and left out, with the vibration channels' rms velocities.

    Returns the recording without them, the faults, the screening's notes, the rms velocities and
    a note for each channel without one. A sensor whose level is implausible against its
    baseline's is a fault too (:func:`monitor.diagnosis.sensors.level_faults`).
    """
    recording, faults, notes = screen_sensors(recording, exclude=exclude)
    rms, unrated = _velocities(recording, band)
    if baseline is not None:
        scaled = level_faults(
            {name: s.velocity_rms for name, s in baseline.sensors.items()},
            {name: v.value for name, v in rms.items()},
        )
        faults += scaled
        recording = without(recording, [f.channel for f in scaled])
    return recording, faults, notes, rms, unrated


def _status(
    findings: list[Finding], analysis: Analysis, engine: Engine, notes: list[str], undecided: list[str]
) -> str:
    """The worst finding's severity; "inconclusive" (reasons noted) if none and the checks were not made."""
    status = "healthy"
    for f in findings:
        status = worse(f.severity, status)
    # no finding is "healthy" only if the checks were made: the cylinders resolved (where an engine has
    # several and a gas model) and the speed steady; otherwise the recording is inconclusive
    if status == "healthy":
        reasons = undecided + _unresolved(analysis, engine)
        if reasons:
            status = "inconclusive"
            notes += [f"inconclusive: {reason}" for reason in reasons]
    return status


def _velocities(recording: Recording, band: tuple[float, float]) -> tuple[dict[str, VelocityRms], list[str]]:
    """Each vibration channel's rms velocity over the band, and a note for each that has none."""
    rms: dict[str, VelocityRms] = {}
    unrated = []
    for channel in vibration_channels(recording):
        try:
            rms[channel.name] = velocity_rms(channel, band)
        except SignalError as error:
            unrated.append(f"rms velocity not rated: {error}")
    return rms, unrated


def _transfer_notes(
    transfers: Baseline | None, usable: bool, speed_rpm: float, *, with_baseline: bool, unjudged: str
) -> list[str]:
    """What the sensors' transfers leave undone: bearing orders not compared, impacts judged how.

    Without a bearing sensor to judge (``unjudged`` says why), only that the bearings were not judged.
    """
    if unjudged:
        return [f"main bearings not judged: {unjudged}"]
    notes = []
    if transfers is not None and not usable:
        notes.append(
            f"bearing orders not compared: {transfers.source or 'the baseline'} holds at "
            f"{transfers.speed_rpm:.1f} rpm, this recording ran at {speed_rpm:.1f} rpm (more than "
            f"{100 * SPEED_TOLERANCE:g} % apart; calibrate at a comparable speed)"
        )
    if transfers is None:
        notes.append(
            "no baseline and no sensor transfers in the engine file: bearing orders not compared; "
            "impacts judged against the recording's own median (a warning at 10 times, where the "
            "bearing's own sensor hears it loudest)"
        )
    elif not with_baseline:
        notes.append(
            "no baseline: impacts judged against the recording's own median (a warning at 10 times, "
            "where the bearing's own sensor hears it loudest)"
        )
    return notes


def _engine_level(
    baseline: Baseline | None, sensors: list[tuple[Channel, int]], profiles: dict[str, HighFrequencyPower]
) -> float:
    """The engine's high-frequency level over its baseline's, from the bearing sensors' profiles [-]."""
    known = {name: s.high_frequency for name, s in baseline.sensors.items()} if baseline is not None else {}
    return engine_level((known.get(c.name), profiles[c.name]) for c, _ in sensors if c.name in profiles)


def _bearing_result(
    channel: Channel,
    b: int,
    analysis: Analysis,
    engine: Engine,
    transfers: Baseline | None,
    usable: bool,
    notes: list[str],
    level: float,
) -> tuple[BearingResult, ChannelComparison | None]:
    """One bearing sensor's orders against the calibrated model (where usable) and its impacts."""
    result = analysis.spectra
    calibration = transfers.sensors.get(channel.name) if transfers is not None else None
    if calibration is not None and (calibration.bearing, calibration.direction) != (b, channel.direction):
        notes.append(
            f"{channel.name}: the engine file's transfer is for main bearing {calibration.bearing} "
            f"{calibration.direction}, the channel is on main bearing {b} {channel.direction}: not used"
        )
        calibration = None
    deviation = comparison = None
    if calibration is not None and transfers is not None and usable:
        deviation, comparison = _order_comparison(channel, b, analysis, engine, calibration, transfers)
    impacts = []
    profile = result.high_frequency.get(channel.name)
    if profile is not None:
        R = engine.cycle_revolutions
        known = calibration.high_frequency if calibration is not None else None
        matched = reference_profile(known, profile, R, level)
        notes += matched.notes(channel.name)
        if (note := varying_note(profile, matched.reference)) is not None and note not in notes:
            notes.append(note)
        force, orders = analysis.combined.bearing_force, analysis.combined.orders
        near = [n for n in (b - 1, b, b + 1) if 1 <= n <= engine.bearing_count]
        heard = {n: load_reversals(force[n - 1], orders, R) for n in near}
        every = np.concatenate(list(heard.values()))
        for n, reversals in heard.items():
            impacts.append(impact_score(matched.profile, reversals, n, R, matched.reference, heard=every))
        if (note := away_note(channel.name, impacts, IMPACT_WARNING)) is not None:
            notes.append(note)
    return BearingResult(channel.name, b, deviation, impacts), comparison


def _order_comparison(
    channel: Channel,
    b: int,
    analysis: Analysis,
    engine: Engine,
    calibration: SensorBaseline,
    transfers: Baseline,
) -> tuple[OrderDeviation, ChannelComparison]:
    """A bearing sensor's orders against the model's bearing force through its calibrated transfer."""
    spectrum = analysis.spectra.spectra[channel.name]
    component = 1 if channel.direction == "vertical" else 0
    force = analysis.combined.bearing_force[b - 1, component]
    # what the cylinders' strengths change against the baseline's is the model's to explain, and
    # it explains a changed gas force's high orders to tens of per cent only: that share of the
    # change is uncertain, so an order that a misfire moves is no bearing finding
    calibrated = np.asarray(transfers.strengths, dtype=np.float64)
    if calibrated.shape != (engine.cylinders,):
        calibrated = np.ones(engine.cylinders)
    before = combine_cylinders(analysis.parts, engine, calibrated).bearing_force[b - 1, component]
    force_error = np.hypot(
        analysis.force_error[b - 1, component], CHANGE_UNCERTAINTY * np.abs(force - before)
    )
    deviation = order_deviations(
        spectrum,
        force,
        analysis.combined.orders,
        calibration.transfer,
        calibration.transfer_error,
        calibration.orders,
        force_error,
    )
    k = spectrum.orders
    index = np.array([int(np.argmin(np.abs(calibration.orders - v))) for v in k])
    f_index = np.array([int(np.argmin(np.abs(analysis.combined.orders - v))) for v in k])
    covered = (k > 1e-9) & (np.abs(calibration.orders[index] - k) < 1e-9)
    covered &= np.abs(analysis.combined.orders[f_index] - k) < 1e-9
    h, f = calibration.transfer[index[covered]], force[f_index[covered]]
    comparison = ChannelComparison(
        channel.name,
        channel.unit,
        k[covered],
        spectrum.amplitude[covered],
        h * f,
        np.sqrt(
            spectrum.standard_error[covered] ** 2
            + (calibration.transfer_error[index[covered]] * np.abs(f)) ** 2
            + (np.abs(h) * force_error[f_index[covered]]) ** 2
        ),
        f"bearing {b} force through the transfer of {transfers.source or 'the baseline'}",
    )
    return deviation, comparison


def _cylinder_findings(
    analysis: Analysis,
    engine: Engine,
    baseline: Baseline | None,
    load: float | None,
    notes: list[str],
    undecided: list[str],
) -> list[Finding]:
    """The cylinders' findings from the balance, where it fits the model (else none: inconclusive).

    ``load`` is the load stated (None: none, the baseline's or rated assumed); a single cylinder's
    verdict weighs it (:func:`~monitor.diagnosis.single_cylinder.single_cylinder_verdict`).
    """
    balance = analysis.balance
    # a balance the model does not describe even within its uncertainty names no cylinder: inconclusive
    fits = balance is not None and balance.chi2_reduced <= MISFIT
    if balance is not None and fits and balance.separable and engine.cylinders > 1:
        return cylinder_findings(balance, analysis.partners)
    if balance is not None and balance.separable and engine.cylinders > 1:  # a misfire is never hidden
        return missing_firing_findings(balance, analysis.partners)
    if balance is not None and fits and engine.cylinders == 1:
        return single_cylinder_verdict(balance, baseline, load, notes, undecided)
    return []


def _zones(
    recording: Recording, rms: dict[str, VelocityRms], boundaries: tuple[float, float, float], stated: bool
) -> tuple[dict[str, tuple[VelocityRms, str]], list[Finding]]:
    """Each vibration channel's rms velocity with its zone; a finding for each in zone C or D."""
    velocity = {}
    findings = []
    for channel in vibration_channels(recording):
        if (v := rms.get(channel.name)) is None:
            continue
        zone = zone_of(v.value, boundaries)
        velocity[channel.name] = (v, zone)
        if zone in ("C", "D"):
            limit = boundaries[1] if zone == "C" else boundaries[2]
            findings.append(
                Finding(
                    kind="vibration zone",
                    subject=channel.name,
                    severity="warning" if zone == "C" else "alarm",
                    summary=(
                        f"{channel.name} ({channel.location or 'location not given'}): {v.value:.2f} "
                        f"mm/s rms over {v.band_hz[0]:g}-{v.band_hz[1]:g} Hz, zone {zone} "
                        f"(boundary {limit:g} mm/s; {limits_named(boundaries, stated=stated)})"
                    ),
                    confidence=confidence_beyond((v.value - limit) / max(v.error, 1e-12)),
                    evidence=[
                        {
                            "quantity": "rms velocity",
                            "channel": channel.name,
                            "measured": v.value,
                            "standard_error": v.error,
                            "threshold": limit,
                            "unit": "mm/s",
                        }
                    ],
                )
            )
    return velocity, findings
