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
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Literal, TypeAlias

import numpy as np

from monitor.diagnosis.balance import CrankCalibration, CylinderBalance, Transfer, cylinder_balance
from monitor.diagnosis.baseline import Baseline, SensorBaseline
from monitor.diagnosis.bearings import (
    SPEED_TOLERANCE,
    impact_score,
    order_deviations,
)
from monitor.diagnosis.findings import (
    BearingResult,
    Finding,
    bearing_findings,
    confidence_beyond,
    cylinder_findings,
    reference_profile,
    sensor_finding,
    single_cylinder_findings,
    with_elsewhere,
    worse,
)
from monitor.diagnosis.sensors import level_faults, screen_sensors, without
from monitor.diagnosis.zones import (
    DEFAULT_BAND_HZ,
    DEFAULT_BOUNDARIES_MM_S,
    VelocityRms,
    velocity_rms,
    zone_of,
)
from monitor.errors import DiagnosisError, ModelError, SignalError
from monitor.fourier import order_coefficients
from monitor.io.recording import Channel, Recording
from monitor.model.crankshaft import EngineModel
from monitor.model.engine import Engine
from monitor.model.predicted import (
    CombinedOrders,
    CylinderParts,
    combine_cylinders,
    cylinder_parts,
    inertia_angle_fluctuation,
    load_reversals,
)
from monitor.signal.measure import SPEED_CHANNEL, SpectrumResult, spectra
from monitor.signal.pitch import PitchCorrection
from monitor.signal.reference import learn_pitch_errors, learn_pitch_errors_over_speed
from monitor.types import ComplexArray, FloatArray

__all__ = [
    "ANALYSIS_VERSION",
    "BearingResult",
    "ChannelComparison",
    "Diagnosis",
    "Finding",
    "calibrate",
    "diagnose",
    "predicted_speed",
]

ANALYSIS_VERSION = "1"
# the model's uncertainty of the change in a bearing force that the cylinders' estimated strengths make
# against the baseline's (a changed gas force's high orders are known to tens of per cent) [-]
CHANGE_UNCERTAINTY = 0.5
STEADY = 0.10  # revolutions' mean speeds further apart than this (max / min - 1) are not a steady run [-]
RESOLVED = 0.25  # a cylinder balance whose strengths' errors exceed this (relative) names nothing [-]
MISFIT = 25.0  # reduced chi-square of the cylinder balance above which no cylinder is named (inconclusive)
POOR_FIT = 4.0  # and above which the notes say it fits poorly (the strengths' errors are widened by it)


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


# ------------------------------------------------------------------------------------------ model
def predicted_speed(
    torque: ComplexArray,
    orders: FloatArray,
    inertia: float | ComplexArray,
    mean_speed: float,
    cycle_revolutions: int,
) -> ComplexArray:
    """Speed orders of a rigid body driven by a torque, exactly: ``omega = sqrt(c + 2 E / J)``.

    ``E`` is the torque's integral over the angle (order by order ``T_k / (i k)``) and ``c``
    is chosen so that the mean speed over the cycle is ``mean_speed``; with an inertia per order,
    ``E / J`` is formed order by order.

    Parameters
    ----------
    torque : ndarray, complex, shape (n_orders,)
        [N m] (order 0 ignored: the load takes the mean).
    orders : ndarray
    inertia : float or ndarray, complex, shape (n_orders,)
        The body's, or the inertia each order meets (order 0's unused) [kg m^2].
    mean_speed : float
        [rad/s]
    cycle_revolutions : int

    Returns
    -------
    ndarray, complex, shape (n_orders,)
        [rad/s], order 0 the mean speed.
    """
    highest = float(orders[-1])
    points = 2 ** math.ceil(math.log2(max(64, 8 * highest * cycle_revolutions)))
    theta = np.arange(points) * (2 * math.pi * cycle_revolutions / points)
    energy_orders = np.zeros(orders.size, dtype=np.complex128)
    met = np.broadcast_to(np.asarray(inertia), orders.shape)
    energy_orders[1:] = torque[1:] / (1j * orders[1:]) / met[1:]
    energy = np.real(np.exp(1j * np.multiply.outer(theta, orders)) @ energy_orders)  # E / J
    c = mean_speed**2
    for _ in range(50):  # Newton on the mean speed
        omega = np.sqrt(np.maximum(c + 2 * energy, 1e-12 * mean_speed**2))
        miss = float(omega.mean()) - mean_speed
        c -= miss / float(np.mean(0.5 / omega))
        if abs(miss) < 1e-13 * mean_speed:
            break
    omega = np.sqrt(np.maximum(c + 2 * energy, 1e-12 * mean_speed**2))
    out = order_coefficients(omega, cycle_revolutions=cycle_revolutions, max_order=highest).coefficients
    return np.asarray(out[: orders.size])


def _bearing_of(channel: Channel) -> int | None:
    words = channel.location.lower().split()
    if len(words) == 3 and words[:2] == ["main", "bearing"] and words[2].isdigit():
        return int(words[2])
    return None


def _vibration_channels(recording: Recording) -> list[Channel]:
    return [c for c in recording.channels if c.kind in ("acceleration", "velocity") and not c.is_events]


def _bearing_sensors(recording: Recording, engine: Engine) -> list[tuple[Channel, int]]:
    out = []
    for channel in _vibration_channels(recording):
        b = _bearing_of(channel)
        if (
            b is not None
            and channel.direction in ("vertical", "horizontal")
            and 1 <= b <= engine.bearing_count
        ):
            out.append((channel, b))
    return out


@dataclass(frozen=True)
class _Analysis:
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

    ``dF_bk / ds_c = share_bc combustion_k exp(-i k phi_c)``; ``E |dF|^2 = g^H C g``.
    """
    n_orders = parts.orders.size
    if covariance is None:
        return np.zeros((engine.bearing_count, 2, n_orders))
    rotation = np.exp(-1j * np.multiply.outer(engine.firing_angles, parts.orders))  # (n_cyl, n_orders)
    g = engine.bearing_share[:, :, None, None] * (
        rotation[None, :, None, :] * parts.combustion[None, None, 1:3, :]
    )  # (n_b, n_cyl, 2, n_orders)
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


def _analyse(
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
) -> _Analysis:
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
    result = spectra(
        recording,
        cycle_revolutions=R,
        max_order=max_order,
        high_frequency=True,
        cycle_phase=phase,
        pitch_correction="estimate" if pitch is None else pitch,
        kept_orders=_engine_orders(engine, recording),
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
            if balance.separable:
                strengths = balance.strength
            else:
                notes.append(
                    f"the crank-speed orders cannot tell the cylinders apart (condition number "
                    f"{balance.condition:.3g}): no cylinder is named"
                )
    covariance = balance.strength_covariance if balance is not None and balance.separable else None
    inertia = 0.0
    if transfer == "rigid":
        from monitor.torsion.shaft_line import engine_side_inertia

        try:
            inertia = engine_side_inertia(engine)
        except ModelError as error:
            notes.append(f"crank speed not predicted: {error}")
    if ambiguous:
        notes.append(
            "the cycle phase is unknown (no cam or cylinder-1 pressure channel, --cycle-phase unknown): "
            "each cylinder named may be the one that fires 360 deg from it"
        )
    return _Analysis(
        spectra=result,
        balance=balance,
        combined=combine_cylinders(parts, engine, strengths),
        nominal=combine_cylinders(parts, engine, np.ones(engine.cylinders)),
        load=load,
        notes=notes,
        inertia=inertia,
        force_error=_force_error(parts, engine, covariance),
        parts=parts,
        partners=_phase_partners(engine) if ambiguous else None,
    )


def _engine_orders(engine: Engine, recording: Recording, *, firing_only: bool = False) -> list[int] | None:
    """Integer orders of the crank speed the engine excites: the low ones and the firing harmonics.

    Left to the engine by the tooth-pitch estimate: orders 1 to a sixth of the wheel's pulses (any
    of which a cylinder that fires unlike the others excites; not with ``firing_only``, for a
    healthy baseline), and every integer multiple of the firing frequency (cylinders / revolutions
    per cycle) below 0.4 of them (where the gas and inertia torques of cylinders firing alike are).
    """
    wheels = recording.of_kind("tooth") or recording.of_kind("encoder")
    if not wheels:
        return None
    fields = wheels[0].fields
    pulses = int(fields["teeth"]) if wheels[0].kind == "tooth" else int(fields["pulses_per_revolution"])
    firing = engine.cylinders / engine.cycle_revolutions
    harmonics = {round(m * firing) for m in range(1, 64) if float(m * firing).is_integer()}
    low = set() if firing_only else set(range(1, pulses // 6 + 1))
    return sorted(low | {k for k in harmonics if k <= 0.4 * pulses})


def _baseline_pitch(recording: Recording, baseline: Baseline | None) -> PitchCorrection | None:
    """The baseline's learned pitch errors, if they belong to this recording's angle-reference wheel."""
    if baseline is None or baseline.pitch is None:
        return None
    names = {c.name: c for c in recording.channels}
    channel = names.get(baseline.pitch_channel)
    if channel is None or channel.kind not in ("tooth", "encoder"):
        return None
    present = (
        int(channel.fields["teeth"]) - int(channel.fields["missing_teeth"])
        if channel.kind == "tooth"
        else int(channel.fields["pulses_per_revolution"])
    )
    return baseline.pitch if baseline.pitch.errors.size == present else None


def _phase_partners(engine: Engine) -> list[int | None]:
    """For each cylinder, the one that fires 360 deg after it (0-based), or None if no cylinder does."""
    angles = np.mod(engine.firing_angles, 4 * math.pi)
    partners: list[int | None] = []
    for c in range(engine.cylinders):
        target = np.mod(angles[c] + 2 * math.pi, 4 * math.pi)
        distance = np.abs(np.angle(np.exp(1j * (angles - target) / 2)))  # on the 720 deg cycle
        match = int(np.argmin(distance))
        partners.append(match if distance[match] < math.radians(1.0) else None)
    return partners


def _speed_comparison(analysis: _Analysis, engine: Engine, transfer: Transfer) -> ChannelComparison | None:
    speed = analysis.spectra.spectra.get(SPEED_CHANNEL)
    if speed is None or speed.orders.size < 2:
        return None
    orders = speed.orders
    nominal = analysis.nominal
    index = [int(np.argmin(np.abs(nominal.orders - k))) for k in orders]
    if transfer == "rigid":
        if analysis.inertia <= 0:
            return None
        from monitor.torsion.shaft_line import engine_side_inertia_at

        mean = float(speed.amplitude[0].real)
        met = np.full(orders.size, analysis.inertia, dtype=np.complex128)
        met[1:] = engine_side_inertia_at(engine, orders[1:] * mean)
        predicted = predicted_speed(nominal.engine_torque[index], orders, met, mean, engine.cycle_revolutions)
        basis = (
            f"healthy model, rigid engine side (J = {analysis.inertia:.4g} kg m^2) and the driven end "
            "through its shafts"
        )
    else:
        from monitor.diagnosis.balance import _shaft_line_receptance

        receptance = _shaft_line_receptance(engine, orders[1:], float(speed.amplitude[0].real))
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


# ---------------------------------------------------------------------------------------- public
def calibrate(
    recording: Recording,
    engine: Engine,
    *,
    load: float = 1.0,
    transfer: Transfer = "rigid",
    max_order: float = 24.0,
    source: str = "",
    cycle_phase: float | None = None,
    pitch_from: Recording | None = None,
    exclude: tuple[str, ...] | list[str] = (),
    progress: Callable[[float], None] | None = None,
) -> Baseline:
    """Calibrate each bearing sensor's transfer on a healthy recording of the engine.

    Parameters
    ----------
    recording : Recording
        Healthy, at a steady speed.
    engine : Engine
    load : float, optional
        The load it ran at [-].
    transfer : {"rigid", "shaft-line"}, optional
        For the cylinder balance the calibration is made at.
    max_order : float, optional
        Highest order analysed [-].
    source : str, optional
        Name of the recording, kept in the baseline.
    cycle_phase : float, optional
        Four-stroke: the shift (0 or 2 pi) that puts cylinder 1's firing TDC at cycle angle 0, for a
        recording without a cam or cylinder-1 pressure channel [rad].
    pitch_from : Recording, optional
        A run of the same wheel whose speed changes (motored run-up, coast-down with the fuel
        cut): the wheel's pitch errors are learned on it at every order, firing harmonics included
        (:func:`monitor.signal.reference.learn_pitch_errors_over_speed`), instead of on ``recording`` with
        the firing harmonics left to the engine.
    exclude : sequence of str, optional
        Channels left out (not calibrated).
    progress : callable, optional
        Told the fraction of the resampling done, from 0 to 1 [-].

    Returns
    -------
    Baseline

    Raises
    ------
    DiagnosisError
        Without a vibration sensor on a main bearing, or with one that is clipped, dead or
        implausibly scaled (a baseline is the reference for later recordings: leave it out).
    """
    recording, bad, _ = screen_sensors(recording, exclude=exclude)
    if bad:
        raise DiagnosisError(
            "cannot calibrate on faulty sensors: "
            + "; ".join(f"{f.channel}: {f.fault}: {f.detail}" for f in bad)
            + ". Mend them, or leave them out with "
            + " ".join(f"--exclude-channel {f.channel}" for f in bad)
        )
    sensors = _bearing_sensors(recording, engine)
    if not sensors:
        raise DiagnosisError(
            "the recording has no acceleration or velocity channel on a main bearing (location "
            "'main bearing N', direction 'vertical' or 'horizontal'): nothing to calibrate"
        )
    # the wheel's pitch errors, learned here once for every later recording (and used here too)
    pitch: PitchCorrection | None
    if pitch_from is not None:
        inertia = inertia_angle_fluctuation(engine) if engine.shaft_line is not None else None
        pitch = learn_pitch_errors_over_speed(pitch_from, inertia)
    else:
        harmonics = _engine_orders(engine, recording, firing_only=True)
        pitch = learn_pitch_errors(recording, engine_orders=harmonics) if harmonics is not None else None
    analysis = _analyse(
        recording,
        engine,
        load=load,
        transfer=transfer,
        max_order=max_order,
        cycle_phase=cycle_phase,
        pitch=pitch,
        progress=progress,
    )
    if analysis.balance is not None and analysis.balance.separable and engine.cylinders > 1:
        faults = cylinder_findings(analysis.balance)
        if faults:
            raise DiagnosisError(
                "the recording is not healthy enough to calibrate on: "
                + "; ".join(f.summary for f in faults)
                + ". Calibrate on a recording of the engine in good order"
            )
    result = analysis.spectra
    out = {}
    for channel, b in sensors:
        spectrum = result.spectra[channel.name]
        component = 1 if channel.direction == "vertical" else 0
        force_orders = analysis.combined.orders
        index = [int(np.argmin(np.abs(force_orders - k))) for k in spectrum.orders]
        force = analysis.combined.bearing_force[b - 1, component, index]
        magnitude = np.abs(force)
        safe = np.where(magnitude > 0, force, 1.0)
        transfer_k = np.where(magnitude > 0, spectrum.amplitude / safe, 0.0)
        # H = X / F: the relative errors of X (block spread) and of F (the strengths') add
        relative = np.hypot(
            spectrum.standard_error
            / np.where(magnitude > 0, magnitude, 1.0)
            / np.maximum(np.abs(transfer_k), 1e-300),
            analysis.force_error[b - 1, component, index] / np.where(magnitude > 0, magnitude, 1.0),
        )
        error = np.where(magnitude > 0, relative * np.abs(transfer_k), 0.0)
        profile = result.high_frequency[channel.name]
        out[channel.name] = SensorBaseline(
            channel=channel.name,
            kind=channel.kind,
            unit=channel.unit,
            bearing=b,
            direction=channel.direction,
            sample_rate=float(channel.sample_rate or 0.0),
            orders=spectrum.orders,
            transfer=np.asarray(transfer_k, dtype=np.complex128),
            transfer_error=np.asarray(error, dtype=np.float64),
            high_frequency=profile,
            velocity_rms=_velocity_or_nan(channel),
        )
    balance = analysis.balance
    used = balance is not None and balance.separable  # the strengths the bearing forces were predicted with
    strengths = balance.strength.tolist() if balance is not None and used else [1.0] * engine.cylinders
    return Baseline(
        engine_id=engine.id,
        speed_rpm=result.mean_speed * 30 / math.pi,
        load=load,
        strengths=[float(s) for s in strengths],
        samples_per_cycle=int(profile.mean.size),
        sensors=out,
        source=source,
        pitch=result.reference.pitch_correction,
        pitch_channel=result.reference.source if result.reference.pitch_correction is not None else "",
        crank=balance.calibration() if balance is not None else None,
    )


def _velocity_or_nan(channel: Channel) -> float:
    try:
        return velocity_rms(channel).value
    except SignalError:  # a channel in volts: no rms velocity
        return math.nan


def _check_baseline(recording: Recording, engine: Engine, baseline: Baseline) -> None:
    if baseline.engine_id != engine.id:
        raise DiagnosisError(
            f"the baseline is of engine {baseline.engine_id!r}, the recording of {engine.id!r}: "
            "calibrate a baseline of this engine"
        )
    missing = []
    for channel, b in _bearing_sensors(recording, engine):
        known = baseline.sensors.get(channel.name)
        if known is None:
            missing.append(f"{channel.name!r} (not in the baseline)")
        elif (known.bearing, known.direction, known.unit, known.sample_rate) != (
            b,
            channel.direction,
            channel.unit,
            float(channel.sample_rate or 0.0),
        ):
            missing.append(
                f"{channel.name!r} (baseline: main bearing {known.bearing} {known.direction}, {known.unit}, "
                f"{known.sample_rate:g} Hz; recording: main bearing {b} {channel.direction}, {channel.unit}, "
                f"{float(channel.sample_rate or 0):g} Hz)"
            )
    if missing:
        raise DiagnosisError(
            f"the baseline {baseline.source or ''} lacks the recording's channel layout: "
            + ", ".join(missing)
            + f"; baseline channels: {', '.join(sorted(baseline.sensors)) or 'none'}"
        )


def _unresolved(analysis: _Analysis, engine: Engine) -> list[str]:
    """Why a recording without findings cannot be called healthy (empty if it can)."""
    reasons = []
    angle_map = analysis.spectra.reference.angle_map
    cycle = 2 * math.pi
    first, last = math.ceil(angle_map.angles[0] / cycle), math.floor(angle_map.angles[-1] / cycle)
    if last - first >= 2:
        times = angle_map.time_at(cycle * np.arange(first, last + 1, dtype=np.float64))
        per_revolution = cycle / np.diff(times)
        spread = float(per_revolution.max() / per_revolution.min() - 1.0)
        if spread > STEADY:
            rpm = per_revolution * 30 / math.pi
            reasons.append(
                f"the speed was not steady ({rpm.min():.1f} to {rpm.max():.1f} rpm over the revolutions); "
                "the diagnosis compares a steady run with the model at its mean speed"
            )
    if engine.cylinders > 1:
        balance = analysis.balance
        if balance is None:
            reasons.append("the cylinders were not compared (see the notes)")
        elif not balance.separable or balance.chi2_reduced > MISFIT:
            reasons.append("the crank-speed orders do not resolve the cylinders (see the notes)")
        elif (worst := float(np.max(balance.contrast_error))) > RESOLVED:
            reasons.append(
                f"the cylinders' differences are uncertain by up to {100 * worst:.0f} % (one standard "
                "error): too little to call them healthy"
            )
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
    recording, sensor_faults, screen_notes = screen_sensors(recording, exclude=exclude)
    limits = engine.vibration_limits
    boundaries = limits.zone_boundaries_mm_s if limits is not None else DEFAULT_BOUNDARIES_MM_S
    band = limits.band_hz if limits is not None else DEFAULT_BAND_HZ
    rms: dict[str, VelocityRms] = {}
    unrated = []
    for channel in _vibration_channels(recording):
        try:
            rms[channel.name] = velocity_rms(channel, band)
        except SignalError as error:
            unrated.append(f"rms velocity not rated: {error}")
    if baseline is not None:
        scaled = level_faults(
            {name: s.velocity_rms for name, s in baseline.sensors.items()},
            {name: v.value for name, v in rms.items()},
        )
        sensor_faults += scaled
        recording = without(recording, [f.channel for f in scaled])
    if baseline is not None:
        _check_baseline(recording, engine, baseline)
    if load is None:
        load = baseline.load if baseline is not None else 1.0
    analysis = _analyse(
        recording,
        engine,
        load=load,
        transfer=transfer,
        max_order=max_order,
        cycle_phase=cycle_phase,
        pitch=_baseline_pitch(recording, baseline),
        crank=baseline.crank if baseline is not None else None,
        progress=progress,
    )
    result = analysis.spectra
    notes = screen_notes + list(analysis.notes) + unrated
    R = engine.cycle_revolutions
    speed_rpm = result.mean_speed * 30 / math.pi
    comparisons = []
    speed_comparison = _speed_comparison(analysis, engine, transfer)
    if speed_comparison is not None:
        comparisons.append(speed_comparison)
    # the transfers: the baseline's, else those given in the engine file
    transfers = baseline if baseline is not None else Baseline.from_engine(engine)
    usable = transfers is not None and abs(speed_rpm / transfers.speed_rpm - 1.0) <= SPEED_TOLERANCE
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
    elif baseline is None:
        notes.append(
            "no baseline: impacts judged against the recording's own median (a warning at 10 times, "
            "where the bearing's own sensor hears it loudest)"
        )
    bearings = []
    for channel, b in _bearing_sensors(recording, engine):
        spectrum = result.spectra[channel.name]
        component = 1 if channel.direction == "vertical" else 0
        calibration = transfers.sensors.get(channel.name) if transfers is not None else None
        if calibration is not None and (calibration.bearing, calibration.direction) != (b, channel.direction):
            notes.append(
                f"{channel.name}: the engine file's transfer is for main bearing {calibration.bearing} "
                f"{calibration.direction}, the channel is on main bearing {b} {channel.direction}: not used"
            )
            calibration = None
        deviation = None
        if calibration is not None and transfers is not None and usable:
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
            comparisons.append(
                ChannelComparison(
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
            )
        impacts = []
        profile = result.high_frequency.get(channel.name)
        if profile is not None:
            for neighbour in (b - 1, b, b + 1):
                if not 1 <= neighbour <= engine.bearing_count:
                    continue
                reversals = load_reversals(
                    analysis.combined.bearing_force[neighbour - 1], analysis.combined.orders, R
                )
                own, reference = reference_profile(calibration, profile)
                impacts.append(impact_score(own, reversals, neighbour, R, reference))
        bearings.append(BearingResult(channel.name, b, deviation, impacts))
    bearings = with_elsewhere(bearings, result.high_frequency, engine, baseline)
    velocity = {}
    findings: list[Finding] = [sensor_finding(f, recording_before) for f in sensor_faults]
    # a balance the model does not describe even within its uncertainty names no cylinder: inconclusive
    fits = analysis.balance is not None and analysis.balance.chi2_reduced <= MISFIT
    if analysis.balance is not None and fits and analysis.balance.separable and engine.cylinders > 1:
        findings += cylinder_findings(analysis.balance, analysis.partners)
    elif analysis.balance is not None and fits and engine.cylinders == 1:
        single = (
            # a calibrated model gives the strength against the baseline's directly
            (
                1.0
                if baseline.crank is not None and baseline.crank.orders.size
                else float(baseline.strengths[0])
            )
            if baseline is not None and len(baseline.strengths) == 1
            else None
        )
        findings += single_cylinder_findings(analysis.balance, load, single)
        notes.append(
            f"a single cylinder is judged against the load stated ({load:.2f}): state the load set "
            "(the fuel or the governor's setting), not the power delivered, or a weak cylinder reads as "
            "a lower load"
        )
    findings += bearing_findings(
        bearings,
        with_baseline=baseline is not None,
        cylinders_changed=any(f.kind == "cylinder" for f in findings),
    )
    for channel in _vibration_channels(recording):
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
                        f"(boundary {limit:g} mm/s)"
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
    status = "healthy"
    for f in findings:
        status = worse(f.severity, status)
    # no finding is "healthy" only if the checks were made: the cylinders resolved (where an engine has
    # several and a gas model) and the speed steady; otherwise the recording is inconclusive
    if status == "healthy":
        reasons = _unresolved(analysis, engine)
        if reasons:
            status = "inconclusive"
            notes += [f"inconclusive: {reason}" for reason in reasons]
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
    )
