"""The systematic uncertainty a wheel's unlearned pitch errors put in the integer crank-speed orders.

A tooth that sits ``e_j`` from its nominal angle shifts its edge the same way every revolution: the
angle map is off by ``-e(theta)`` and the speed by ``-Omega de/dtheta``, at the integer orders only
(the errors repeat once a revolution; a four-stroke's half orders do not see them). Where the errors
were not learned (every tooth but those beside the gap, unless a baseline or a run-up taught them),
one steady recording cannot tell them from the engine's own integer orders: they are a systematic
error of those orders, not a scatter that averaging removes.

Its size. With independent errors of standard deviation ``sigma`` on ``T`` teeth, the order ``k``
of the angle error, ``E_k = (2 / T) sum_j e_j exp(-i k theta_j)`` (peak amplitude), is a complex
Gaussian with ``E|E_k|^2 = 4 sigma^2 / T``: its magnitude exceeds ``c 2 sigma / sqrt(T)`` with
probability ``exp(-c^2)``: 1.8 % beyond ``c = 2``. The angle map adds a little beyond the teeth's own
errors (the gap's missing teeth are interpolated from neighbours whose errors they carry, the gap
teeth's correction is itself fitted): on a 60-2 wheel the errors came out 1.07 to 1.21 times the
scale, order by order, with ``sigma`` estimated (tests/signal/test_pitch_systematic.py, 200 wheels,
and 200 two-gap 36-2-1 wheels).
A real wheel's errors are not quite independent: the 4GB10 rig's 60-2 wheel, learned tooth by tooth
on one steady run and applied to another, puts its order 16 at 2.3 to 2.8 times the scale
(tests/signal/test_pitch_from_a_fuel_cut.py). The stated bound is :data:`COVERAGE` ``= 3`` times the
scale, ``2 c sigma / sqrt(T)`` on the angular vibration [rad], ``Omega k`` times it on the speed
[rad/s]: for independent errors beyond it with a probability of ``exp(-(3 / 1.2)^2)``, about 0.2 %
per order (the test: 95 % of the cases or more at every order, with margin).

``sigma`` itself is read off the recording (:func:`pitch_scatter`): each tooth's mean position over
the revolutions, less where the decoding puts it (nominal, or nominal plus a correction already
applied: the gap's corrected neighbours count for what is left of their errors), less a
least-squares series of the orders up to a quarter of the teeth (the engine's integer orders, smooth
in angle), leaves the errors' orders above it; white across the wheel, their variance over the
residual's degrees of freedom is ``sigma^2``. What the engine puts above that quarter is counted as
the wheel's: the bound errs large, never small.

Where the errors were learned on a run whose speed changed (a run-up, a coast-down, a fuel cut), what
is left is the learning's own error, order by order (:attr:`PitchCorrection.order_errors`, the
rms of each order's complex error): :func:`learned_bound` states ``COVERAGE`` times it, the same
coverage. A short fuel cut learns its first orders worst; the bound says by how much.
"""

from __future__ import annotations

import math

import numpy as np

from monitor.errors import SignalError
from monitor.signal.pitch import PitchCorrection, tooth_places, tooth_spacing_errors
from monitor.signal.toothwheel import ToothWheelDecoding
from monitor.types import FloatArray

__all__ = ["COVERAGE", "learned_bound", "pitch_scatter", "systematic_bound"]

COVERAGE = 3.0  # the bound's multiple of the angle error's rms scale 2 sigma / sqrt(T), per order [-]


def pitch_scatter(decoding: ToothWheelDecoding) -> float:
    """The standard deviation of the wheel's tooth-position errors, from the recording (module docstring).

    Parameters
    ----------
    decoding : ToothWheelDecoding
        Any wheel (one gap, several, an extra tooth), after whatever correction was applied, with four
        complete revolutions.

    Returns
    -------
    float
        ``sigma`` [rad].

    Raises
    ------
    SignalError
        For fewer than four complete revolutions, or too few teeth to leave a residual above a
        quarter of them.
    """
    errors = tooth_spacing_errors(decoding)  # every tooth's mean position, less where it is put [rad]
    teeth = errors.size
    highest = teeth // 4
    angles = tooth_places(decoding)
    k = np.arange(1, highest + 1)
    design = np.hstack([np.ones((teeth, 1)), np.cos(np.outer(angles, k)), np.sin(np.outer(angles, k))])
    freedom = teeth - design.shape[1]
    if freedom < 8:
        raise SignalError(f"a wheel of {teeth} teeth leaves {freedom} to read its pitch errors: expected 8")
    fitted, *_ = np.linalg.lstsq(design, errors, rcond=None)
    residual = errors - design @ fitted
    return float(math.sqrt(float(residual @ residual) / freedom))


def systematic_bound(
    orders: FloatArray,
    sigma: float,
    teeth: int,
    *,
    mean_speed: float | None = None,
    only: tuple[int, ...] | None = None,
) -> FloatArray:
    """The bound on each order's systematic error from pitch errors of scatter ``sigma`` (module docstring).

    Parameters
    ----------
    orders : ndarray
        The orders listed [-].
    sigma : float
        The tooth-position errors' standard deviation [rad] (0: all learned).
    teeth : int
        The teeth present on the wheel [-].
    mean_speed : float, optional
        For the speed's orders, the mean speed [rad/s]; without it, the angle's [rad].
    only : tuple of int, optional
        The whole orders the errors are left in (a baseline's correction left them in its kept
        orders); default: every whole order.

    Returns
    -------
    ndarray
        0 at order 0 and at orders that are not whole; ``COVERAGE 2 sigma / sqrt(T)`` at the whole
        orders, times ``mean_speed k`` for the speed [rad or rad/s].
    """
    whole = (orders > 0) & np.isclose(orders, np.round(orders))
    if only is not None:
        whole &= np.isin(np.round(orders), only)
    scale = COVERAGE * 2 * sigma / math.sqrt(teeth)
    bound = np.where(whole, scale, 0.0)
    if mean_speed is not None:
        bound = bound * mean_speed * orders
    return np.asarray(bound, dtype=np.float64)


def learned_bound(
    orders: FloatArray, correction: PitchCorrection, *, mean_speed: float | None = None
) -> FloatArray:
    """The bound on each order's error left by a correction learned with per-order standard errors.

    Parameters
    ----------
    orders : ndarray
        The orders listed [-].
    correction : PitchCorrection
        The correction applied; without ``order_errors`` (learned on a steady recording) it adds
        nothing.
    mean_speed : float, optional
        For the speed's orders, the mean speed [rad/s]; without it, the angle's [rad].

    Returns
    -------
    ndarray
        ``COVERAGE`` times the correction's standard error at each whole order it gives, times
        ``mean_speed k`` for the speed; 0 elsewhere [rad or rad/s].
    """
    bound = np.zeros(orders.shape, dtype=np.float64)
    errors = correction.order_errors
    if errors is None:
        return bound
    whole = np.round(orders).astype(np.int64)
    given = (orders > 0) & np.isclose(orders, whole) & (whole <= errors.size)
    bound[given] = COVERAGE * errors[whole[given] - 1]
    if mean_speed is not None:
        bound = bound * mean_speed * orders
    return bound
