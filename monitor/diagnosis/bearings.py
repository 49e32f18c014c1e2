"""Main bearings: accelerometer orders against the calibrated model, and impact content.

Orders.  A sensor on main bearing ``b`` measures ``X_k = H_k F_k``: the force
of the crankshaft on the bearing (:func:`monitor.model.predicted.combine_cylinders`,
``y`` for a vertical sensor, ``x`` for a horizontal one) through the
structure's transfer ``H_k``.  ``H_k`` is calibrated per sensor and order on
a healthy baseline recording of the same engine, ``H_k = X_k / F_k`` at the
baseline's own speed, load and cylinder strengths; a later recording's
prediction is ``H_k F_k`` at its own.  The transfer holds at the baseline's
frequencies ``k Omega``: a recording more than :data:`SPEED_TOLERANCE` away
in speed is not compared order by order (the report says so).  Orders whose
prediction is small against the block spread, or against the channel's
largest order, carry no evidence and are left out.

Impacts.  Wear opens the clearance: where the bearing's load turns
(:func:`monitor.model.predicted.load_reversals`) the journal crosses it and
knocks.  The high-frequency power profile of each sensor
(:class:`monitor.signal.impact.HighFrequencyPower`, 1-10 kHz) is
searched in crank-angle windows from :data:`WINDOW_BEFORE_DEG` before each
reversal to :data:`WINDOW_AFTER_DEG` after it (the knock rings down after the
turn) for the knock span that stands out most against the baseline's power in
the same bins: a span lasts :data:`KNOCK_SPAN_S` at the recording's speed (a
knock rings the structure for a time set by its damping, not by the crank
angle).  At another speed and load than the baseline's, the baseline's profile
is first carried to the recording's point
(:func:`monitor.diagnosis.impact_reference.reference_profile`).  Without a baseline the
reference is the median of the recording's own profile (weaker, judged more
strictly by :mod:`monitor.diagnosis.diagnose`).
A sensor hears its neighbours' bearings too, so the windows of the bearing it
sits on and of the bearings next to it are scored, and the worst is named.
Away from the speed the baseline's reference was measured at (by more than
:data:`REPEATING_SPEED_TOLERANCE`, or a reference made from points at other
speeds), a span's significance is the smaller of its excess in the whole power
and in the part that varies from cycle to cycle
(:attr:`HighFrequencyPower.varying`, each against its own reference): two of
the engine's own events that ring one resonance add in phase at one speed and
cancel at another, so the part that repeats every cycle is not known there,
while a knock, a little earlier or later each cycle, stands out in the varying
part. At the reference's own speed the repeating part is known, and a knock
that repeats as exactly as the engine's events is still heard in the whole
power.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from statistics import NormalDist

import numpy as np

from monitor.signal.impact import HighFrequencyPower
from monitor.signal.spectrum import OrderSpectrum
from monitor.types import ComplexArray, FloatArray

__all__ = [
    "AWAY_SHARE",
    "AWAY_SIGNIFICANCE",
    "REPEATING_SPEED_TOLERANCE",
    "SPEED_TOLERANCE",
    "WINDOW_AFTER_DEG",
    "WINDOW_BEFORE_DEG",
    "ImpactScore",
    "OrderDeviation",
    "away_note",
    "impact_score",
    "order_deviations",
    "repeats_at",
    "span_score",
    "varying_note",
]

SPEED_TOLERANCE = 0.05  # largest relative speed difference at which a calibrated transfer is used [-]
WINDOW_BEFORE_DEG = 20.0  # crank angle before a load reversal in its impact window [deg]
WINDOW_AFTER_DEG = 30.0  # and after it [deg]
KNOCK_SPAN_S = 1.5e-3  # time over which a knock's ringing is summed: most of a 1-10 kHz ring's energy [s]
KNOCK_SPAN_DEG = 2.0  # the span in crank angle for a profile whose speed is not known [deg]
FAMILY_FALSE_ALARM = 1e-4  # chance that noise alone lifts one span of a bearing's windows to significance [-]
RELEVANT_FRACTION = 0.02  # orders predicted below this fraction of the channel's largest carry no evidence
RELEVANT_SIGMAS = 10.0  # nor those predicted below this many standard errors
#: Largest relative speed difference at which the reference's repeating high-frequency part holds [-]:
#: two rings that overlap for up to RING_S (10 ms) at the band's lowest 1 kHz are up to 10 periods
#: apart, and a speed 1 % away moves one against the other by a tenth of a period.
REPEATING_SPEED_TOLERANCE = 0.01
#: The share of a sensor's spans clear of the windows it is scored for whose excess
#: :attr:`ImpactScore.away` gives [-]: a worn bearing's knocks lift a few spans of the cycle (some
#: outside the windows, where the engine's reversals differ from the model's), the engine's own noise at
#: a load and speed its baseline does not know lifts spans all round it.
AWAY_SHARE = 0.05
#: A span away from the windows counts as lifted where it stands this many standard errors out [-].
AWAY_SIGNIFICANCE = 4.0


@dataclass(frozen=True)
class OrderDeviation:
    """Measured against predicted orders of one vibration channel.

    Attributes
    ----------
    orders : ndarray
        The orders compared [-].
    measured, predicted : ndarray, complex
        [the channel's unit].
    deviation : ndarray
        ``|measured - predicted| / |predicted|`` [-].
    deviation_error : ndarray
        Its standard error, from the blocks' spread of both recordings [-].
    """

    orders: FloatArray
    measured: ComplexArray
    predicted: ComplexArray
    deviation: FloatArray
    deviation_error: FloatArray


def order_deviations(
    spectrum: OrderSpectrum,
    force: ComplexArray,
    force_orders: FloatArray,
    transfer: ComplexArray,
    transfer_error: FloatArray,
    transfer_orders: FloatArray,
    force_error: FloatArray | None = None,
) -> OrderDeviation:
    """Compare a channel's orders with ``H_k F_k`` (see the module docstring).

    Parameters
    ----------
    spectrum : OrderSpectrum
        The recording's channel.
    force : ndarray, complex
        The bearing force component at the recording's operating point [N].
    force_orders : ndarray
    transfer, transfer_error : ndarray
        Calibrated ``H_k`` and its standard error [unit / N].
    transfer_orders : ndarray
    force_error : ndarray, optional
        Standard error of ``force`` (from the estimated cylinder strengths) [N].

    Returns
    -------
    OrderDeviation
        The orders 0 < k that all three cover and that carry evidence.
    """
    keep = []
    for position, k in enumerate(spectrum.orders):
        if k <= 1e-9:
            continue
        at_f = int(np.argmin(np.abs(force_orders - k)))
        at_h = int(np.argmin(np.abs(transfer_orders - k)))
        if abs(force_orders[at_f] - k) < 1e-9 and abs(transfer_orders[at_h] - k) < 1e-9:
            keep.append((position, at_f, at_h))
    if not keep:
        empty = np.zeros(0)
        return OrderDeviation(empty, empty.astype(complex), empty.astype(complex), empty, empty)
    j, i_f, i_h = (np.array(v) for v in zip(*keep, strict=True))
    measured = spectrum.amplitude[j]
    predicted = transfer[i_h] * force[i_f]
    error = np.hypot(spectrum.standard_error[j], transfer_error[i_h] * np.abs(force[i_f]))
    if force_error is not None:
        error = np.hypot(error, np.abs(transfer[i_h]) * force_error[i_f])
    size = np.abs(predicted)
    relevant = (size >= RELEVANT_FRACTION * size.max()) & (size >= RELEVANT_SIGMAS * error)
    size = np.where(size > 0, size, 1.0)
    return OrderDeviation(
        orders=spectrum.orders[j][relevant],
        measured=measured[relevant],
        predicted=predicted[relevant],
        deviation=(np.abs(measured - predicted) / size)[relevant],
        deviation_error=(error / size)[relevant],
    )


@dataclass(frozen=True)
class ImpactScore:
    """Impact content in a bearing's load-reversal windows, against a reference.

    Attributes
    ----------
    bearing : int
        The bearing whose windows were scored.
    score : float
        High-frequency power of the knock span that stands out most in the windows, over the
        reference's in the same bins [-] (1 = as the reference).
    score_error : float
        Standard error [-].
    reference : str
        "baseline" or "own median".
    reversal_angles_deg : list of float
        The load reversals' cycle angles [deg].
    significance : float
        The span's excess power over the reference in standard errors [-].
    significance_needed : float
        The excess that one span in all the windows reaches by chance with probability
        :data:`FAMILY_FALSE_ALARM` [-] (one-sided normal quantile, Sidak-corrected for the spans tested).
    angle_deg : float
        Cycle angle of that span's centre [deg].
    elsewhere : float
        The same span's power over its reference on the other bearing sensors, the highest (NaN
        without others; :func:`span_score`): a knock of this bearing is heard loudest on its own
        sensor, a change of the engine's own noise (combustion moved by a misfire) on all alike [-].
    away : float
        The excess over the reference that :data:`AWAY_SHARE` of the sensor's spans clear of the
        windows of every bearing it is scored for reach, a span counted only where its whole power
        stands :data:`AWAY_SIGNIFICANCE` standard errors out (1 where fewer do; NaN where none is clear):
        a knock is heard where a load reverses, the engine's own noise at a point its baseline does
        not know all round the cycle [-].
    """

    bearing: int
    score: float
    score_error: float
    reference: str
    reversal_angles_deg: list[float]
    significance: float = math.nan
    significance_needed: float = math.nan
    angle_deg: float = math.nan
    elsewhere: float = math.nan
    away: float = math.nan


def window_bins(reversals: FloatArray, bins: int, cycle_revolutions: int) -> FloatArray:
    """Boolean mask over a profile's bins: those in any reversal's window."""
    cycle = 2 * math.pi * cycle_revolutions
    start = np.arange(bins) * (cycle / bins)
    centre = start + 0.5 * cycle / bins
    mask = np.zeros(bins, dtype=bool)
    before, after = math.radians(WINDOW_BEFORE_DEG), math.radians(WINDOW_AFTER_DEG)
    for r in reversals:
        offset = (centre - r + before) % cycle  # 0 at the window's start
        mask |= offset <= before + after
    return mask


def _span_sums(values: FloatArray, span: int) -> FloatArray:
    """Circular sums of ``span`` consecutive bins, centred on each bin (the cycle closes on itself)."""
    if span <= 1:
        return np.asarray(values, dtype=np.float64)
    low = span // 2
    padded = np.concatenate([values[-low:] if low else values[:0], values, values[: span - 1 - low]])
    cumulative = np.concatenate([[0.0], np.cumsum(padded)])
    return np.asarray(cumulative[span:] - cumulative[:-span])


def _span_bins(profile: HighFrequencyPower, cycle_revolutions: int) -> int:
    """Bins of a profile in one knock span (:data:`KNOCK_SPAN_S` at its speed), at least one."""
    span_deg = 6.0 * profile.speed_rpm * KNOCK_SPAN_S if profile.speed_rpm > 0 else KNOCK_SPAN_DEG
    return max(1, round(span_deg / (360.0 * cycle_revolutions / profile.mean.size)))


def _reference(
    profile: HighFrequencyPower, baseline: HighFrequencyPower | None
) -> tuple[FloatArray, FloatArray]:
    """Each bin's reference power and the variance of its mean: the baseline's, else the profile's median."""
    if baseline is not None:
        return baseline.mean, baseline.std**2 / max(baseline.cycles, 1)
    bins = profile.mean.size
    median_variance = float(np.median(profile.std)) ** 2 / max(profile.cycles * bins, 1)
    return np.full(bins, float(np.median(profile.mean))), np.full(bins, median_variance)


def repeats_at(profile: HighFrequencyPower, reference: HighFrequencyPower) -> bool:
    """Whether the reference's part that repeats every cycle holds at the profile's speed: every speed
    it was measured at within :data:`REPEATING_SPEED_TOLERANCE` of the profile's (True where a speed
    is not known).

    Parameters
    ----------
    profile : HighFrequencyPower
        The recording's.
    reference : HighFrequencyPower
        The baseline's, or one made from several calibrated points (its ``speed_span``).

    Returns
    -------
    bool
    """
    speed = profile.speed_rpm
    ends = reference.speed_span()
    if not all(math.isfinite(s) and s > 0 for s in (speed, *ends)):
        return True
    return all(abs(end / speed - 1.0) <= REPEATING_SPEED_TOLERANCE for end in ends)


def varying_note(profile: HighFrequencyPower, reference: HighFrequencyPower | None) -> str | None:
    """What the diagnosis says where a knock must stand out in the power's varying part too: the
    reference holds one and its repeating part does not hold at the profile's speed (:func:`repeats_at`).

    Parameters
    ----------
    profile : HighFrequencyPower
        The recording's.
    reference : HighFrequencyPower or None
        The one its impacts are judged against.

    Returns
    -------
    str or None
        The note, with the speeds [rpm] the reference was measured at and the recording's; None where
        the whole power alone decides.
    """
    if reference is None or reference.varying is None or repeats_at(profile, reference):
        return None
    low, high = reference.speed_span()
    said = f"{low:.0f} rpm" if round(low) == round(high) else f"{low:.0f} to {high:.0f} rpm"
    return (
        "the bearings' impacts are judged also on the part of the high-frequency power that varies from "
        f"cycle to cycle: the reference was measured at {said}, the recording runs at "
        f"{profile.speed_rpm:.0f} rpm, where the engine's own rings may add otherwise"
    )


def away_note(channel: str, scores: list[ImpactScore], limit: float) -> str | None:
    """What the diagnosis says of a sensor whose spans away from the windows reach ``limit`` (the
    warning's) over its reference: the reference does not describe the engine's own noise there.

    Parameters
    ----------
    channel : str
    scores : list of ImpactScore
        The sensor's, one per bearing scored.
    limit : float
        [-]

    Returns
    -------
    str or None
    """
    away = max((s.away for s in scores if math.isfinite(s.away)), default=math.nan)
    if not away >= limit:
        return None
    return (
        f"{channel}: {100 * AWAY_SHARE:.0f} % of the cycle away from the load-reversal windows reads "
        f"{away:.1f} x the reference (the engine's own noise at a load or speed the baseline does not "
        "know): a knock is named only where it stands out well beyond that (calibrate at this point)"
    )


def _span_significance(
    profile: HighFrequencyPower, baseline: HighFrequencyPower | None, span: int
) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
    """Each span's power, its reference's, the standard error of their difference, and how many of
    those the first stands above the second (spans centred on each bin)."""
    variance = profile.std**2 / max(profile.cycles, 1)
    reference, reference_variance = _reference(profile, baseline)
    measured = _span_sums(profile.mean, span)
    expected = np.maximum(_span_sums(reference, span), 1e-300)
    error = np.sqrt(np.maximum(_span_sums(variance + reference_variance, span), 1e-300))
    return measured, expected, error, (measured - expected) / error


def impact_score(
    profile: HighFrequencyPower,
    reversals: FloatArray,
    bearing: int,
    cycle_revolutions: int,
    baseline: HighFrequencyPower | None = None,
    heard: FloatArray | None = None,
) -> ImpactScore:
    """Score a bearing's reversal windows in a sensor's high-frequency profile (module docstring).

    Parameters
    ----------
    profile : HighFrequencyPower
    reversals : ndarray
        The bearing's load reversals, cycle angles [rad].
    bearing : int
    cycle_revolutions : int
    baseline : HighFrequencyPower, optional
        The same sensor's profile on the healthy baseline (same bins and sampling rate).
    heard : ndarray, optional
        The load reversals of every bearing the sensor is scored for [rad]: the spans
        :attr:`ImpactScore.away` reads are clear of all their windows (a worn neighbour's knocks are
        none of this bearing's engine noise); default: ``reversals``.

    Returns
    -------
    ImpactScore
    """
    bins = profile.mean.size
    mask = window_bins(reversals, bins, cycle_revolutions)
    cycle_deg = 360.0 * cycle_revolutions
    span = _span_bins(profile, cycle_revolutions)
    how = "baseline" if baseline is not None else "own median"
    measured, expected, error, z = _span_significance(profile, baseline, span)
    # how far the reference falls short of the engine's noise away from every window: in the whole power
    windows = mask if heard is None else np.logical_or(mask, window_bins(heard, bins, cycle_revolutions))
    away = _away(measured / expected, z, windows, span)
    varying = profile.varying_part()
    theirs = baseline.varying_part() if baseline is not None else None
    if (
        baseline is not None
        and varying is not None
        and theirs is not None
        and not repeats_at(profile, baseline)
    ):
        # the engine's own rings repeat; how they add is not known at this speed (module docstring)
        z = np.minimum(z, _span_significance(varying, theirs, span)[3])
    z = np.where(mask, z, -np.inf)
    peak = int(np.argmax(z))
    tested = max(1.0, float(mask.sum()) / span)  # about independent spans in the windows
    needed = NormalDist().inv_cdf((1.0 - FAMILY_FALSE_ALARM) ** (1.0 / tested))
    return ImpactScore(
        bearing,
        float(measured[peak] / expected[peak]),
        float(error[peak] / expected[peak]),
        how,
        np.degrees(reversals).round(2).tolist(),
        float(z[peak]),
        float(needed),
        round((peak + 0.5) * cycle_deg / bins, 2),
        away=away,
    )


def _away(ratio: FloatArray, z: FloatArray, windows: FloatArray, span: int) -> float:
    """:attr:`ImpactScore.away` from every span's power over its reference, its significance, the
    windows' bins, and the span's bins (a span is clear where no bin of it lies in a window)."""
    clear = _span_sums(windows.astype(np.float64), 2 * span + 1) == 0.0
    if not clear.any():
        return math.nan
    lifted = np.where(z >= AWAY_SIGNIFICANCE, ratio, 1.0)[clear]
    return float(np.quantile(lifted, 1.0 - AWAY_SHARE))


def span_score(
    profile: HighFrequencyPower,
    angle_deg: float,
    cycle_revolutions: int,
    baseline: HighFrequencyPower | None = None,
) -> float:
    """A sensor's high-frequency power in the knock span centred at a cycle angle, over its reference.

    Parameters
    ----------
    profile : HighFrequencyPower
    angle_deg : float
        Cycle angle [deg].
    cycle_revolutions : int
    baseline : HighFrequencyPower, optional
        The same sensor's baseline profile; without one, the profile's own median is the reference.

    Returns
    -------
    float
        The span's power over the reference's in the same bins (those of :func:`impact_score`) [-].
    """
    bins = profile.mean.size
    span = _span_bins(profile, cycle_revolutions)
    centre = math.floor(angle_deg / (360.0 * cycle_revolutions / bins)) % bins
    reference, _ = _reference(profile, baseline)
    measured = _span_sums(profile.mean, span)[centre]
    expected = max(float(_span_sums(reference, span)[centre]), 1e-300)
    return float(measured / expected)
