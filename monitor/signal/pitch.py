"""A tooth wheel's (or an encoder's) own pitch errors: estimated from a recording, and corrected.

No wheel is perfect, and a sensor's field bends near a wheel's gap: a tooth
that sits ``e_i`` from its nominal angle shifts its edge by ``e_i`` in every
revolution.  So does a speed fluctuation synchronous with the revolution (the
engine's integer orders), and in one recording at steady speed the two cannot
be told apart where they share an order.  :func:`estimate_pitch_errors`
separates them where the physics allows: the engine's part is smooth in
angle and made of the orders it excites, what is left is the wheel's.  By
default only the teeth beside the gap are corrected, and only where their
error stands out of what the engine could put there; a healthy baseline can
teach every tooth, its firing harmonics left to the engine
(:func:`monitor.signal.reference.learn_pitch_errors`); a run whose speed changes (a
motored run-up, a coast-down with the fuel cut) teaches every tooth at every
order (:func:`learn_pitch_over_speed`), because the wheel's errors do not
change with speed and the gas forces' share does.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, replace
from typing import Literal

import numpy as np
import numpy.typing as npt
from scipy.interpolate import CubicSpline
from scipy.ndimage import median_filter

from monitor.errors import SignalError
from monitor.signal.toothwheel import ToothWheelDecoding
from monitor.types import FloatArray

__all__ = [
    "PitchCorrection",
    "correct_pitch",
    "estimate_pitch_errors",
    "learn_pitch_over_speed",
    "speed_range",
    "tooth_places",
    "tooth_spacing_errors",
]

#: The least standard error stated for an order learned over speed, as a share of the pitch: the
#: first-order speed law's own error (on a simulated 60-2 run-up with 0.2 us timing jitter the learned
#: orders were off by up to 2.6e-4 deg, 0.44 of it, and ten times their scatter alone;
#: tests/signal/test_pitch_over_speed.py) [-].
RESOLUTION = 1e-4


@dataclass(frozen=True)
class PitchCorrection:
    """The wheel's own tooth-position errors, as applied to a decoding.

    Attributes
    ----------
    errors : ndarray, shape (teeth - missing,)
        Where each tooth after the gap really is minus where a perfect wheel has it, mean zero [rad].
    kept_orders : tuple of int
        The integer orders of what repeats every revolution that were left to the engine (not taken
        as the wheel's).
    revolutions : int
        Revolutions the estimate averaged.
    source : str
        "recording" (estimated from the recording itself), "baseline" (learned earlier on a steady
        healthy recording) or "run-up" (learned earlier on a run whose speed changed).
    scope : str
        "gap" (the gap's neighbours corrected) or "all" (every tooth).
    standard_error : float
        rms over the teeth of each error's standard error, where the method gives one [rad]; NaN
        otherwise.
    order_errors : ndarray or None
        The standard error of the errors' whole orders ``1, 2, ...`` (the rms of the complex
        amplitude's error, peak) [rad], where the method gives them; None otherwise.
    speeds : tuple of float
        The slowest and fastest revolution's mean speed it was learned over [rad/s]; empty where not
        known (a baseline stored before it was kept).
    """

    errors: FloatArray
    kept_orders: tuple[int, ...]
    revolutions: int
    source: str = "recording"
    scope: str = "gap"
    standard_error: float = math.nan
    order_errors: FloatArray | None = None
    speeds: tuple[float, ...] = ()

    @property
    def rms(self) -> float:
        """rms of the corrections [rad]."""
        return float(np.sqrt(np.mean(self.errors**2)))

    @property
    def largest(self) -> float:
        """Largest correction in magnitude [rad]."""
        return float(np.max(np.abs(self.errors)))


def _per_revolution(decoding: ToothWheelDecoding) -> int:
    """The teeth a revolution holds (a pattern's extra ones included)."""
    return decoding.pattern.teeth if decoding.pattern is not None else decoding.teeth - decoding.missing


def speed_range(decoding: ToothWheelDecoding) -> tuple[float, float]:
    """The slowest and fastest complete revolution's mean speed (both the mean without one).

    Parameters
    ----------
    decoding : ToothWheelDecoding

    Returns
    -------
    tuple of float
        [rad/s].
    """
    starts = _complete(decoding, np.flatnonzero(decoding.tooth_index == 0))
    per_rev = _per_revolution(decoding)
    if starts.size == 0:
        speed = (decoding.angles[-1] - decoding.angles[0]) / (decoding.times[-1] - decoding.times[0])
        return float(speed), float(speed)
    speed = 2 * math.pi / (decoding.times[starts + per_rev] - decoding.times[starts])
    return float(speed.min()), float(speed.max())


def _complete(decoding: ToothWheelDecoding, starts: npt.NDArray[np.int64]) -> npt.NDArray[np.int64]:
    """Those first teeth after the gap whose revolution holds every tooth (the next gap's edge follows)."""
    per_rev = _per_revolution(decoding)
    starts = starts[starts + per_rev < decoding.times.size]
    return starts[decoding.tooth_index[starts + per_rev] == 0]


def _mean_places(decoding: ToothWheelDecoding) -> tuple[FloatArray, FloatArray, FloatArray, int]:
    """Each tooth's mean place over the complete revolutions less where the decoding puts it, the
    standard error of that mean, where the decoding puts it [rad], and the revolutions averaged.

    Each tooth's place is its share of its revolution's time; where the decoding puts it is nominal,
    or nominal plus the errors of a correction already applied (whose residual this then gives).
    """
    per_rev = _per_revolution(decoding)
    starts = _complete(decoding, np.flatnonzero(decoding.tooth_index == 0))
    if starts.size < 4:
        raise SignalError(
            f"tooth-pitch errors need at least four complete revolutions; the recording has {starts.size}"
        )
    window = decoding.times[starts[:, None] + np.arange(per_rev + 1)]
    shares = (window[:, :-1] - window[:, :1]) / (window[:, -1:] - window[:, :1])
    placed = decoding.angles[starts[0] + np.arange(per_rev)] - decoding.angles[starts[0]]
    deviation = 2 * math.pi * shares.mean(axis=0) - placed
    scatter = 2 * math.pi * shares.std(axis=0, ddof=1) / math.sqrt(starts.size)
    return deviation, scatter, placed, int(starts.size)


def _one_gap(decoding: ToothWheelDecoding) -> None:
    """Refuse a wheel of several gaps: the errors are estimated against one gap's evenly spaced teeth."""
    if decoding.pattern is not None:
        raise SignalError(
            f"tooth-pitch errors are estimated on wheels of one gap; this one is {decoding.pattern.name}"
        )


def estimate_pitch_errors(
    decoding: ToothWheelDecoding,
    *,
    kept_orders: npt.ArrayLike | None = None,
    gap_neighbours: int = 1,
    scope: Literal["gap", "all"] = "gap",
) -> PitchCorrection:
    """The wheel's tooth-position errors, separated from the engine's own speed fluctuation.

    Parameters
    ----------
    decoding : ToothWheelDecoding
        With at least four complete revolutions.
    kept_orders : array_like of int, optional
        Integer orders of the revolution-synchronous deviation that belong to the engine and are not
        corrected. Default: 1 to ``teeth // 6`` (1 to 10 on a 60-2 wheel) [-].
    gap_neighbours : int, optional
        Teeth on each side of the gap left out of the fit of the engine's orders: the gap bends
        the sensor's field there, so their errors are larger and not smooth [-].
    scope : {"gap", "all"}, optional
        Which teeth are corrected: only the gap's neighbours whose error stands out (the default:
        the error is large and systematic on real wheels), or every
        tooth (the wheel's errors in orders above the kept ones are then removed too, and with them
        any of the engine's integer orders there: use it where the physics says the engine has
        none, or on a baseline whose correction is stored).

    Returns
    -------
    PitchCorrection

    Raises
    ------
    SignalError
        With fewer than four complete revolutions, or more kept orders than the teeth can fit.

    Notes
    -----
    A tooth ``i`` that sits ``e_i`` away from its nominal angle ``2 pi i / teeth`` shifts its edge by
    ``e_i`` in every revolution; a speed fluctuation synchronous with the revolution (the engine's
    integer orders) shifts it too. Each tooth's angle is measured as its share of its revolution's
    time, averaged over the complete revolutions: ``d_i``. The engine's part of ``d_i`` is smooth
    in angle and made of the orders it excites, so ``d_i`` is fitted by least squares with a mean and
    the ``kept_orders`` (cosine and sine) over the teeth away from the gap; what the fit leaves,
    ``e_i = d_i - fit_i``, on every tooth including the gap's neighbours, is the wheel's error. The
    part of the wheel's errors that lies in the kept orders cannot be told from the engine in one
    recording at steady speed; it stays in the speed orders. Half orders of a four-stroke are not
    revolution-synchronous and average out.

    With ``scope="gap"`` a gap tooth is corrected only when its error exceeds what the engine could
    put there unseen: the largest residual ``r`` of the fit on the other teeth (their own errors,
    the engine's orders beyond the kept ones) times ``1 + g``, ``g`` the fit's gain across the gap
    (the L1 norm of that tooth's row of ``B_gap pinv(B_inner)``), and 3 standard errors of its mean
    position over the revolutions, and a hundredth of a pitch. A perfect wheel then gets no
    correction however strong the engine's high orders are; the real wheel's 1.8 and 0.8 deg stand
    far above the bound (about 0.5 deg there).
    """
    _one_gap(decoding)
    per_rev = decoding.teeth - decoding.missing
    orders = (
        np.arange(1, decoding.teeth // 6 + 1)
        if kept_orders is None
        else np.unique(np.asarray(kept_orders, dtype=np.int64))
    )
    # a tooth's estimate within 3 standard errors of its mean place (timing noise, cycle-to-cycle
    # variation) is not told from zero and not applied beside the gap
    deviation, scatter, nominal, revolutions = _mean_places(decoding)
    inner = np.arange(gap_neighbours, per_rev - gap_neighbours)
    if 1 + 2 * orders.size >= inner.size:
        raise SignalError(
            f"{orders.size} kept orders need more than the {inner.size} teeth away from the gap to fit"
        )
    errors = np.zeros(per_rev)
    for _ in range(4):
        # the engine's part is a function of where each tooth really is: evaluated there, so that a
        # large error (0.3 pitch beside the gap) does not leave the speed fluctuation's slope times
        # that error in the estimate; three passes converge to round-off
        position = nominal + errors
        basis = np.column_stack(
            [np.ones(per_rev)]
            + [np.cos(k * position) for k in orders]
            + [np.sin(k * position) for k in orders]
        )
        coefficients, *_ = np.linalg.lstsq(basis[inner], (deviation - errors)[inner], rcond=None)
        errors = deviation - basis @ coefficients
        if scope == "gap":
            errors[inner] = 0.0
    if scope == "gap":
        # what the fit leaves on the other teeth (their own pitch errors, the engine's orders beyond the
        # kept ones) may be as large at a gap tooth, and the fit carries it there amplified by its
        # extrapolation across the gap (the L1 norm of the gap tooth's row of basis_gap pinv(basis_inner)):
        # a gap tooth's estimate within that worst case is not told from the engine, nor within 3 of its
        # standard errors over the revolutions, nor below a hundredth of a pitch (nothing a wheel needs)
        residual = float(np.max(np.abs((deviation - basis @ coefficients)[inner])))
        gain = np.abs(basis @ np.linalg.pinv(basis[inner])).sum(axis=1)
        floor = np.maximum.reduce(
            [(1.0 + gain) * residual, 3.0 * scatter, np.full(per_rev, 0.01 * decoding.pitch)]
        )
        errors[np.abs(errors) < floor] = 0.0
    else:
        errors = errors - errors.mean()
    return PitchCorrection(
        errors, tuple(int(k) for k in orders), revolutions, scope=scope, speeds=speed_range(decoding)
    )


def learn_pitch_over_speed(
    decoding: ToothWheelDecoding,
    *,
    speed_independent: Callable[[FloatArray], FloatArray] | None = None,
    lowest_speed_share: float = 0.25,
    min_speed_ratio: float = 1.25,
) -> PitchCorrection:
    """Every tooth's error at every order, from a run whose mean speed changes (run-up, coast-down).

    Parameters
    ----------
    decoding : ToothWheelDecoding
        A run whose mean speed changes by ``min_speed_ratio`` or more, with the engine's torque from
        the gas forces the same at every speed: motored (no fuel), a coast-down with the fuel cut,
        or a run-up at a fixed fuel setting.
    speed_independent : callable, optional
        The engine's angle fluctuation that does not change with speed (the reciprocating parts'
        inertia torque over the rotating inertia, :func:`monitor.model.predicted.inertia_angle_fluctuation`)
        at crank angles [rad] -> [rad]. Without it the inertia's orders stay in the errors.
    lowest_speed_share : float, optional
        Revolutions slower than this share of the fastest one are left out: there the gas forces
        shake the crank too much for the expansion below [-].
    min_speed_ratio : float, optional
        Fastest over slowest revolution used, at least [-].

    Returns
    -------
    PitchCorrection
        ``scope="all"``, no order kept, ``source="run-up"``, with its standard error.

    Raises
    ------
    SignalError
        With fewer than eight complete revolutions, or a speed that changes too little.

    Notes
    -----
    A tooth ``k`` really at ``theta_k + e_k`` is reached when the crank's angle is there. Write the
    crank's angle as a smooth trend ``Phi(t)`` (a cubic spline through the times the first tooth
    after the gap comes round) plus the fluctuation ``f`` that repeats with the engine's cycle; the
    tooth then comes ``y_k = Phi(t_k) - theta_k = e_k - f(theta_k)`` (plus a constant) ahead of the
    trend. For a rigid crank, ``J Omega^2 df/dtheta^2 = T(theta)`` to first order: the gas torque
    (the same at every speed) gives ``f`` in ``1 / Omega^2``, the reciprocating parts' inertia torque
    (proportional to ``Omega^2``) a part that does not change with speed, as the wheel's errors do
    not. So each tooth's ``y`` over the revolutions ``j`` is fitted by least squares with
    ``1, x_j`` (``x_j = (Omega_max / Omega_j)^2``) or ``1, x_j, x_j^2`` (the square takes the next
    term of ``sqrt(1 + u)``), and the same times ``(-1)^j`` (a four-stroke's half orders, which
    alternate from one revolution to the next), each revolution weighted by the inverse of its timing
    noise (from a first, unweighted fit); its value at ``x = 0`` is ``e_k - f_inertia(theta_k)``.
    Adding back the model's ``f_inertia`` (or nothing) and removing the mean gives ``e``. A load that
    grows with speed (a propeller) puts gas forces in the speed-independent part: learn on a motored
    run or a coast-down then.

    Of the two polynomials the one whose value at ``x = 0`` has the smaller standard error is taken.
    A wide run-up (speed ratio 3) needs the square: the line misses the curvature, its residuals say
    so. A short fuel cut does not: the real 4GB10 rig's (1960 to 1535 rpm, eleven revolutions) puts
    ``x`` between 1 and 1.63, where the square's extrapolation to 0 multiplies the noise by 17, the
    line's by 2.1 (standard errors 1.9 and 0.22 deg per tooth). Each whole order's standard error is
    returned too: the compression's low orders follow ``x`` least well, so the first orders of a
    fuel cut are learned least well (0.11 deg at order 1, 0.01 deg from order 3 on, on that run).
    """
    _one_gap(decoding)
    per_rev = decoding.teeth - decoding.missing
    knots = np.flatnonzero(decoding.tooth_index == 0)
    if knots.size < 10:
        raise SignalError(
            f"learning tooth-pitch errors over speed needs at least ten revolutions; the run has {knots.size}"
        )
    trend = CubicSpline(decoding.angles[knots], decoding.times[knots])
    slope = trend.derivative()
    # complete revolutions, the first and last left out (the spline's ends)
    starts = _complete(decoding, knots[1:-2])
    window = starts[:, None] + np.arange(per_rev)
    angles, times = decoding.angles[window], decoding.times[window]
    ahead = (times - trend(angles)) / slope(angles)  # y_k per revolution [rad]
    speed = 2 * math.pi / (decoding.times[starts + per_rev] - decoding.times[starts])
    used = speed >= lowest_speed_share * speed.max()
    if used.sum() < 8:
        raise SignalError(
            f"learning tooth-pitch errors over speed needs eight complete revolutions above "
            f"{lowest_speed_share:.0%} of the top speed; the run has {int(used.sum())}"
        )
    speed, ahead, angles = speed[used], ahead[used], angles[used]
    ratio = float(speed.max() / speed.min())
    if ratio < min_speed_ratio:
        raise SignalError(
            f"learning tooth-pitch errors over speed needs a run whose speed changes by a factor of "
            f"{min_speed_ratio:g} or more (a run-up or a coast-down); this one spans "
            f"{speed.min() * 30 / math.pi:.1f} to {speed.max() * 30 / math.pi:.1f} rpm"
        )
    x = (speed.max() / speed) ** 2
    parity = np.where(np.arange(starts.size)[used] % 2 == 0, 1.0, -1.0)
    fits = [
        fit for degree in (1, 2) if (fit := _fit_over_speed(ahead, angles[0], x, parity, degree)) is not None
    ]
    if not fits:
        raise SignalError("the run's revolutions do not separate speed-dependent from fixed errors")
    intercept, standard_error, order_errors = min(fits, key=lambda fit: fit[1])
    order_errors = np.maximum(order_errors, RESOLUTION * decoding.pitch)
    if speed_independent is not None:
        intercept = intercept + np.asarray(
            speed_independent(np.mod(angles[0], 2 * math.pi)), dtype=np.float64
        )
    return PitchCorrection(
        intercept - intercept.mean(),
        (),
        int(x.size),
        source="run-up",
        scope="all",
        standard_error=standard_error,
        order_errors=order_errors,
        speeds=(float(speed.min()), float(speed.max())),
    )


def _fit_over_speed(
    ahead: FloatArray, angles: FloatArray, x: FloatArray, parity: FloatArray, degree: int
) -> tuple[FloatArray, float, FloatArray] | None:
    """Each tooth's lead fitted in ``x`` to ``degree`` (and the same times the revolutions' parity),
    its value at ``x = 0`` with the rms standard error over the teeth [rad] and that of each whole
    order of it, ``1`` to half the teeth [rad]; None when the revolutions cannot determine it.

    The standard errors come from the residuals, order by order: where the engine's fluctuation is
    not the polynomial in ``x`` the fit assumes (the compression's own low orders), its residuals
    there are larger, and so is the error of the extrapolation to ``x = 0``.
    """
    powers = np.column_stack([x**n for n in range(degree + 1)])
    design = np.hstack([powers, parity[:, None] * powers])
    if np.linalg.matrix_rank(design) < design.shape[1] or x.size <= design.shape[1]:
        return None
    # timing noise is not the same at every speed (a VR sensor's slope grows with the square of the
    # speed): a first fit's residuals give each revolution's noise, smoothed over its neighbours, and the
    # second fit weighs each revolution by its inverse
    coefficients = np.linalg.lstsq(design, ahead, rcond=None)[0]
    noise = np.mean((ahead - design @ coefficients) ** 2, axis=1)
    noise = median_filter(noise, size=9, mode="nearest")
    weight = 1.0 / np.maximum(noise, 1e-6 * float(np.median(noise)) + 1e-300)
    root = np.sqrt(weight)[:, None]
    coefficients = np.linalg.lstsq(design * root, ahead * root, rcond=None)[0]
    residual = (ahead - design @ coefficients) * root
    dof = x.size - design.shape[1]
    spread = np.linalg.inv((design * root).T @ (design * root))[0, 0]
    variance = (residual**2).sum(axis=0) / dof
    teeth = angles.size
    whole = np.arange(1, teeth // 2 + 1)
    # each revolution's residual at each whole order (peak amplitude, complex): their scatter over the
    # revolutions is that order's, and the intercept's is it times the extrapolation's ``spread``
    per_order = residual @ np.exp(-1j * np.outer(angles, whole)) * (2 / teeth)
    order_errors = np.sqrt((np.abs(per_order) ** 2).sum(axis=0) / dof * spread)
    # the revolution's first tooth is where the trend is pinned: its error is fixed by the mean
    return (
        np.asarray(coefficients[0], dtype=np.float64),
        float(np.sqrt(np.mean(variance * spread))),
        np.asarray(order_errors, dtype=np.float64),
    )


def correct_pitch(decoding: ToothWheelDecoding, correction: PitchCorrection) -> ToothWheelDecoding:
    """The decoding with each tooth at its measured place on the wheel (nominal plus its error).

    Parameters
    ----------
    decoding : ToothWheelDecoding
    correction : PitchCorrection
        For the same wheel (``teeth - missing`` errors).

    Returns
    -------
    ToothWheelDecoding

    Raises
    ------
    SignalError
        If the correction is for another wheel, or would put a tooth at or beyond its neighbour.
    """
    per_rev = decoding.teeth - decoding.missing
    if correction.errors.shape != (per_rev,):
        raise SignalError(
            f"tooth-pitch correction for {correction.errors.size} teeth: this wheel has {per_rev} "
            f"({decoding.teeth}-{decoding.missing})"
        )
    if correction.largest >= 0.5 * decoding.pitch:
        raise SignalError(
            f"tooth-pitch correction of {math.degrees(correction.largest):.3g} deg is half a tooth pitch "
            "or more: the wheel or its decoding is not what the channel states"
        )
    angles = decoding.angles + correction.errors[decoding.tooth_index]
    return replace(decoding, angles=angles)


def tooth_places(decoding: ToothWheelDecoding) -> FloatArray:
    """Where the decoding puts each tooth of a revolution, from the first after the gap [rad].

    Parameters
    ----------
    decoding : ToothWheelDecoding
        With at least four complete revolutions.

    Returns
    -------
    ndarray, shape (teeth in a revolution,)
        Nominal (the pattern's places), plus the errors of a correction already applied [rad].
    """
    return _mean_places(decoding)[2]


def tooth_spacing_errors(decoding: ToothWheelDecoding) -> FloatArray:
    """Angular position error of each tooth, averaged over the complete revolutions, nothing kept.

    Parameters
    ----------
    decoding : ToothWheelDecoding
        With at least four complete revolutions.

    Returns
    -------
    ndarray, shape (teeth - missing,)
        Measured minus nominal angle of each tooth after the gap, mean removed [rad].

    Notes
    -----
    :func:`estimate_pitch_errors` with no order left to the engine: every speed fluctuation
    synchronous with the revolution is taken as the wheel's, so it is for a run whose fluctuation
    is small (a coast-down, a steady run of a heavy shaft line).
    """
    deviation = _mean_places(decoding)[0]
    return deviation - deviation.mean()
