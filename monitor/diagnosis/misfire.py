"""A missing firing impulse: each cylinder's deficit by its pattern in the crank-speed orders.

The cylinder balance (:mod:`monitor.diagnosis.balance`) fits every cylinder's strength against the
model's torque at the stated load.  Where the model's level is wrong (a charge pressure that does
not fall with load as the engine file assumes, a load stated 10 % off) its fit is poor, the
covariance is scaled by the reduced chi-square, and a dead cylinder's contrast with the others can
sink below significance.  This test asks a narrower question that the model's level cannot
answer for it: does one cylinder lack its share of the firing impulse?

The orders and their parts
--------------------------
At each order ``k`` used by the balance, the measured left-hand side ``y_k`` (torque for the rigid
body, speed for the shaft line) is the sum over the cylinders of the moving masses' torque
``I``, the gas force's fixed part ``X`` (compression and charge pressure) and each cylinder's
combustion ``s_c D_ck``, where ``D_ck = f_k H_ck G_k exp(-i k phi_c)`` is cylinder ``c``'s
combustion at nominal strength as it reaches ``y`` (cylinder 1's combustion order ``G_k``, the
firing angle ``phi_c``, the transfer ``H`` and a baseline's factor ``f``;
:attr:`CylinderBalance.columns`).  Let the healthy cylinders fire at a common level ``L`` and
cylinder ``c`` lack ``a`` of it (``s_c = L - a``); then

    y_k - I_k = beta X_k + L C_k - a D_ck,        C_k = sum_j D_jk,

with ``beta`` a free scale of the fixed gas part.  At the orders that are not multiples of the
firing frequency (``k`` not a multiple of ``n / R``) an evenly firing engine's cylinders cancel:
``C_k``, ``X_k`` and (rigid) ``I_k`` vanish, and what is left, ``-a D_ck``, is the missing impulse's
pattern across those orders, whatever the model's level, the load stated or the charge-pressure
law: those set the level of ``G_k`` and the fixed part, not the pattern's phases, which are the
firing angles.  One amplitude ``a`` per cylinder is fitted; a healthy engine's are all near 0.

What share ``a`` is of a healthy cylinder's impulse needs the healthy level ``L``, which only the
firing harmonics (the orders where every cylinder adds) carry.  There the model's fixed gas part
is the part most in doubt (its charge-pressure law), so its scale ``beta`` is left free: the
firing harmonic's one complex value fixes ``beta`` and ``L`` together.  This works because the
moving masses' torque and the torque of a pressure symmetric about top dead centre (the
compression) are odd functions of the crank angle, pure sines about firing TDC, while the heat
release is late and gives the combustion's orders a cosine part: ``L`` is read from the part of
the firing harmonic that neither the masses nor the compression can make.  The share the cylinder
fires, ``r = 1 - a / L``, is then the model's level cancelled out twice: ``a`` and ``L`` are both in
the model's units.  Where the compression and the combustion are nearly parallel at the firing
harmonic (a four-cylinder four-stroke's second order, which the masses dominate, or a
six-cylinder four-stroke's third) ``L`` is loose; it is weighed with the model's level at the stated
load, 1 to :data:`~monitor.diagnosis.balance.LEVEL_UNCERTAINTY` (what the balance assumes of the
cylinders' common level), by their inverse variances, so the firing harmonic decides wherever it
can.  The balance's own level (the others' mean strength) is not a second reading: it is the same
firing harmonic read with ``beta`` held at 1, so where the charge-pressure law is not the engine's
its strengths take up the compression's misfit.  On the validation simulator a motored cylinder at
47 % load with its boost held read 51 % of the others by the balance, whose strengths were 2.4 times
the model's, while its deficit, 1.18 of the model's cylinder, said that the engine fired about as
the model does (seed 200239).

A missing impulse explains most of what the cancelling orders carry: the share of their weighted
power the fitted pattern leaves unexplained tells a misfire from a disturbance of another shape
(a transfer that is not the engine's, a torsional resonance) that a single amplitude would
otherwise read as a deficit.

Errors
------
Each order's standard error is the block spread's (the measurement), with the healthy cylinders'
own differences (:data:`~monitor.diagnosis.balance.IMBALANCE` of each cylinder's combustion), the
masses' uncertainty on the inertia torque (:data:`~monitor.diagnosis.balance.INERTIA_SHARE`) and
the combustion's shape uncertainty (the model's :data:`~monitor.diagnosis.balance.MODEL_UNCERTAINTY`
and the timing's :data:`~monitor.diagnosis.balance.TIMING_UNCERTAINTY` times the order, or
:data:`~monitor.diagnosis.balance.CALIBRATED_UNCERTAINTY` where a baseline calibrated the order)
on the fitted combustion, re-weighted at the fit, or on the model's at the stated load where that
is larger: a fit that reads the level near nothing must not thereby make the model's firing
harmonic exact (seed 200225 of the validation population, a twelve-cylinder four-stroke at 41 %
load calibrated at 80 %, read its level as -0.09 +- 0.06 with its compression scale at -1.8, both
impossible, once the shape's error had shrunk with the level it weighed).  The covariance is the
weighted problem's and
is never scaled by a misfit: a model that does not describe the engine widens the balance's
errors, but the pattern's amplitude is measured against the measurement's own spread.

The cylinder whose deficit is most significant (``a / sigma_a`` largest) is the candidate; the
rule (:func:`monitor.diagnosis.findings.missing_firing_findings`) reports it when its deficit
stands :data:`~monitor.diagnosis.findings.SIGNIFICANCE` standard errors above nothing, its pattern
explains at least :data:`~monitor.diagnosis.findings.PATTERN_EXPLAINED` of the cancelling orders,
and it lacks most of its impulse (``r`` below the alarm limit).  docs/diagnosis.md gives its rates
on the validation simulator's engines away from the baseline's load
(``python -m benchmarks.misfire_loads``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from monitor.diagnosis.balance import (
    CALIBRATED_UNCERTAINTY,
    IMBALANCE,
    INERTIA_SHARE,
    LEVEL_UNCERTAINTY,
    MODEL_UNCERTAINTY,
    TIMING_UNCERTAINTY,
    CylinderBalance,
)
from monitor.types import ComplexArray, FloatArray

__all__ = ["MissingFiring", "missing_firing"]

ITERATIONS = 3  # the weights re-evaluated at the fit this many times (the shape term depends on it)


@dataclass(frozen=True)
class MissingFiring:
    """Each cylinder's missing firing impulse, and the share of the others' it fires.

    Attributes
    ----------
    deficit : ndarray, shape (n_cylinders,)
        ``a``: the combustion the cylinder lacks against the others, in the model's units [-].
    deficit_error : ndarray, shape (n_cylinders,)
        Its standard error (the measurement's spread, never scaled by a misfit) [-].
    level : ndarray, shape (n_cylinders,)
        ``L``: the healthy cylinders' level, from the firing harmonics with the cylinder's
        deficit and a free compression scale, weighed with the model's level at the stated
        load (1) by their errors [-].
    level_error : ndarray, shape (n_cylinders,)
        Its standard error [-].
    share : ndarray, shape (n_cylinders,)
        ``1 - a / L``: the share of the others' firing impulse the cylinder fires [-].
    share_error : ndarray, shape (n_cylinders,)
        Its standard error, first order in the fit's covariance [-].
    compression : ndarray, shape (n_cylinders,)
        ``beta``: the fixed gas part's scale the fit found [-].
    explained : ndarray, shape (n_cylinders,)
        The share of the weighted power at the cancelling orders that the cylinder's pattern
        explains (1: all of it; a missing impulse explains most, a disturbance of another shape
        little) [-].
    orders : ndarray
        The orders used [-].
    cancelling : ndarray of bool
        Which of them are not firing harmonics (where the pattern is seen).
    """

    deficit: FloatArray
    deficit_error: FloatArray
    level: FloatArray
    level_error: FloatArray
    share: FloatArray
    share_error: FloatArray
    compression: FloatArray
    explained: FloatArray
    orders: FloatArray
    cancelling: np.ndarray

    @property
    def significance(self) -> FloatArray:
        """Each cylinder's deficit over its standard error [-]."""
        return np.asarray(self.deficit / np.maximum(self.deficit_error, 1e-300), dtype=np.float64)

    @property
    def candidate(self) -> int:
        """The cylinder (index) whose deficit is the most significant."""
        return int(np.argmax(self.significance))


def missing_firing(
    balance: CylinderBalance,
    *,
    imbalance: float = IMBALANCE,
    inertia_share: float = INERTIA_SHARE,
    model_uncertainty: float = MODEL_UNCERTAINTY,
    timing_uncertainty: float = TIMING_UNCERTAINTY,
    level_uncertainty: float = LEVEL_UNCERTAINTY,
) -> MissingFiring | None:
    """Each cylinder's missing firing impulse by its pattern (see the module docstring).

    Parameters
    ----------
    balance : CylinderBalance
        A balance of two or more cylinders with its parts (:attr:`CylinderBalance.columns`).
    imbalance : float, optional
        Each healthy cylinder's own share of its combustion [-].
    inertia_share : float, optional
        The moving masses' torque's relative uncertainty [-].
    model_uncertainty : float, optional
        The combustion's relative uncertainty at an order no baseline calibrated [-].
    timing_uncertainty : float, optional
        The combustion timing's uncertainty [rad].
    level_uncertainty : float, optional
        The healthy cylinders' level is the model's at the stated load (1) to this standard error,
        beside the firing harmonics [-].

    Returns
    -------
    MissingFiring or None
        None for a single cylinder, a balance without its parts, too few orders for the three
        unknowns, or no order where the cylinders cancel or add.

    Notes
    -----
    For each cylinder ``c`` the model ``y - I = beta X + L C - a D_c`` is fitted by weighted least
    squares, real and imaginary parts apart, each order's weight ``1 / sigma_k^2`` with

        sigma_k^2 = se_k^2 + w_k^2 + (imbalance |D_k|)^2 + (inertia_share |I_k|)^2
                    + (u_k max(|L C_k - a D_ck|, |C_k|))^2,

    ``|D_k|`` the root sum of squares of the cylinders' columns, ``w_k`` the tooth wheel's pitch
    errors left in the map (the balance's ``wheel_error``) and ``u_k`` the combustion's shape
    uncertainty (``hypot(model_uncertainty, k timing_uncertainty)``, or the calibrated one), on the
    fitted combustion or the model's at the stated load (``C_k``, every cylinder at strength 1),
    whichever is larger.
    """
    columns = balance.columns
    if columns.ndim != 2 or columns.shape[1] < 2 or columns.shape[0] != balance.orders.size:
        return None
    if balance.inertia_part.size != balance.orders.size or balance.gas_part.size != balance.orders.size:
        return None
    n_orders, n = columns.shape
    if 2 * n_orders < 3 + 1:
        return None
    together = columns.sum(axis=1)
    spread = np.sqrt((np.abs(columns) ** 2).sum(axis=1))
    cancelling = np.abs(together) < 0.5 * spread
    if cancelling.all() or not cancelling.any():
        return None
    calibrated = balance.calibrated if balance.calibrated.size == n_orders else np.zeros(n_orders, dtype=bool)
    shape = np.where(
        calibrated,
        CALIBRATED_UNCERTAINTY,
        np.hypot(model_uncertainty, np.minimum(balance.orders * timing_uncertainty, 1.0)),
    )
    masses = inertia_share * np.abs(balance.inertia_part)
    wheel = balance.wheel_error if balance.wheel_error.size == n_orders else np.zeros(n_orders)
    fixed_error = np.sqrt(balance.standard_error**2 + wheel**2 + (imbalance * spread) ** 2 + masses**2)
    rhs = balance.measured - balance.inertia_part
    out = np.zeros((7, n))
    for c in range(n):
        design = np.stack([balance.gas_part, together, -columns[:, c]], axis=1)
        out[:, c] = _fit(design, rhs, fixed_error, shape, cancelling)
    deficit, deficit_error, read, read_error, covariance, compression, explained = out
    level, level_error, weight = _level(read, read_error, level_uncertainty)
    covariance = weight * covariance  # the deficit's covariance with the level, the pattern's share
    safe = np.where(np.abs(level) > 0, level, math.nan)
    share = 1.0 - deficit / safe
    # first order: d share / d a = -1 / L, d share / d L = a / L^2
    share_error = np.sqrt(
        np.maximum(
            (deficit_error / safe) ** 2
            + (deficit * level_error / safe**2) ** 2
            - 2 * deficit * covariance / safe**3,
            0.0,
        )
    )
    return MissingFiring(
        deficit=deficit,
        deficit_error=deficit_error,
        level=level,
        level_error=level_error,
        share=share,
        share_error=share_error,
        compression=compression,
        explained=explained,
        orders=balance.orders.copy(),
        cancelling=cancelling,
    )


def _level(
    read: FloatArray, read_error: FloatArray, uncertainty: float
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Each cylinder's healthy level: the firing harmonic's, weighed with the model's at the stated load
    (1, to ``uncertainty``) by their inverse variances; with the weight of the former [-]."""
    if not uncertainty > 0:
        return read, read_error, np.ones(read.size)
    prior = uncertainty**2
    seen = np.isfinite(read) & np.isfinite(read_error)
    variance = np.where(seen, read_error, 0.0) ** 2
    weight = np.where(seen, prior / (prior + variance), 0.0)
    level = np.where(seen, weight * np.where(seen, read, 0.0) + (1 - weight), 1.0)
    error = np.where(seen, np.sqrt(variance * prior / (variance + prior)), uncertainty)
    return level, error, weight


def _fit(
    design: ComplexArray,
    rhs: ComplexArray,
    fixed_error: FloatArray,
    shape: FloatArray,
    cancelling: np.ndarray,
) -> FloatArray:
    """One cylinder's fit: its deficit and error, the level and error, their covariance, beta, and the
    share of the cancelling orders' weighted power its pattern explains."""
    theta = np.array([1.0, 1.0, 0.0])
    covariance = np.zeros((3, 3))
    floor = 1e-9 * float(np.abs(rhs).max(initial=0.0)) + 1e-300
    for _ in range(ITERATIONS):
        # the shape's error on the fitted combustion, or on the model's at the stated load where that is
        # larger: a level read near nothing must not make the model's firing harmonic exact
        burning = np.maximum(np.abs(theta[1] * design[:, 1] + theta[2] * design[:, 2]), np.abs(design[:, 1]))
        sigma = np.maximum(np.hypot(fixed_error, shape * burning), floor) / math.sqrt(2.0)
        weights = np.concatenate([sigma, sigma])
        a = np.vstack([design.real, design.imag]) / weights[:, None]
        b = np.concatenate([rhs.real, rhs.imag]) / weights
        norms = np.linalg.norm(a, axis=0)
        norms = np.where(norms > 0, norms, 1.0)
        scaled, *_ = np.linalg.lstsq(a / norms, b, rcond=None)
        theta = scaled / norms
        covariance = np.linalg.pinv((a / norms).T @ (a / norms)) / np.outer(norms, norms)
    residual = (rhs - design @ theta)[cancelling] / sigma[cancelling]
    power = float(np.sum(np.abs(rhs[cancelling] / sigma[cancelling]) ** 2))
    explained = 1.0 - float(np.sum(np.abs(residual) ** 2)) / power if power > 0 else 0.0
    return np.array(
        [
            theta[2],
            math.sqrt(max(covariance[2, 2], 0.0)),
            theta[1],
            math.sqrt(max(covariance[1, 1], 0.0)),
            covariance[1, 2],
            theta[0],
            explained,
        ]
    )
