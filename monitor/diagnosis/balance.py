"""Cylinder balance: each cylinder's strength from the crank-speed orders, by least squares.

Below the crankshaft's first torsional mode the engine side turns as one
rigid body of inertia ``J`` (:func:`monitor.torsion.shaft_line.engine_side_inertia`):
``1/2 J omega^2 = E0 + integral (T - T_mean) dtheta``, so the torque orders
follow from the measured speed without a small-fluctuation approximation,
``T_k = i k (J / 2) (omega^2)_k``, with ``omega^2`` formed from the measured
speed orders over the cycle.  With ``transfer="shaft-line"`` the speed orders
at the tooth wheel are compared instead, each throw's torque passed through
the shaft line's receptance at ``k Omega`` (any speed, resonances included).

Each cylinder's torque is ``inertia + fixed + s_c combustion``
(:func:`monitor.model_orders.cylinder_parts`), phased by its firing angle, so
every low order is linear in the strengths ``s``:

    y_k - sum_c H_ck (inertia + fixed)_ck = sum_c s_c H_ck combustion_ck

The orders ``0 < k <= n_cylinders / R`` (two-stroke 1..n, four-stroke
0.5..n/2) are stacked, real and imaginary parts apart, and weighted by their
standard errors from the spread over the averaged blocks.  Orders that are
multiples of the firing frequency see every cylinder in phase (they fix the
mean strength), the others resolve the differences.  The covariance is the
weighted problem's, scaled by the reduced chi-square when the residual is
larger than the block spread explains (model error).  The condition number of
the column-normalised problem says whether the cylinders can be told apart.

Each cylinder is reported against the mean of the cylinders that fire alike
(within :data:`ALIKE` of the median strength), itself excluded, so one or two
faulty cylinders move neither the reference nor the healthy cylinders'
shares: a misfiring cylinder is near 0 %, a cylinder 30 % weak near 70 %, the
others near 100 %.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal

import numpy as np

from monitor.engine import Engine
from monitor.errors import ModelError
from monitor.model_orders import CylinderParts
from monitor.orders import order_coefficients
from monitor.signal.angle_domain import OrderSpectrum
from monitor.types import ComplexArray, FloatArray

__all__ = ["CylinderBalance", "Transfer", "cylinder_balance", "measured_torque"]

Transfer = Literal["rigid", "shaft-line"]

ALIKE = 0.15  # cylinders within this fraction of the median strength form the reference [-]
# the model's relative uncertainty of the engine's torque at each order at nominal strengths, where no
# baseline measured it: engine files differ from engines (masses and inertia by up to 10 %, combustion
# timing by a few degrees, the load by 10 %), so the firing harmonics, where every cylinder adds, are
# known to about this; the orders where healthy cylinders cancel are not affected by a gap that all
# cylinders share
MODEL_UNCERTAINTY = 0.10
# above this condition number of the column-normalised problem two cylinders cannot be told apart
SEPARABLE_CONDITION = 1e3


@dataclass(frozen=True)
class CylinderBalance:
    """Each cylinder's estimated strength and its share against the others.

    Attributes
    ----------
    strength : ndarray, shape (n_cylinders,)
        Estimated strength (1 = as the model at the given load; 0 = motored) [-].
    strength_covariance : ndarray, shape (n_cylinders, n_cylinders)
    relative : ndarray, shape (n_cylinders,)
        Strength over the mean of the cylinders that fire alike, itself excluded [-].
    relative_error : ndarray, shape (n_cylinders,)
        Standard error of ``relative`` [-].
    contrast_error : ndarray, shape (n_cylinders,)
        Standard error of ``relative - 1`` as a contrast against the others: what the cylinders'
        differences are known to, without the uncertainty of their common level (a model gap at the
        firing harmonics moves every cylinder alike) [-].
    model_uncertainty : float
        The model's relative uncertainty at the orders where the cylinders add up [-].
    orders : ndarray
        The orders used [-].
    measured, predicted : ndarray, complex
        The left-hand side ``y_k`` measured and as fitted, at those orders
        (torque [N m] for the rigid body, speed [rad/s] for the shaft line).
    standard_error : ndarray
        Of ``measured`` [same unit].
    unit : str
    condition : float
        Condition number of the column-normalised least-squares problem [-].
    chi2_reduced : float
        Weighted residual over its degrees of freedom (1 when the block spread explains it) [-].
    separable : bool
        Whether the condition number allows naming a single cylinder.
    strength_meaning : str
        What a strength of 1 means ("heat release" or "gas force" of the model).
    transfer : str
        "rigid" or "shaft-line".
    inertia : float
        The rigid body's inertia, for the rigid transfer [kg m^2].
    """

    strength: FloatArray
    strength_covariance: FloatArray
    relative: FloatArray
    relative_error: FloatArray
    contrast_error: FloatArray
    model_uncertainty: float
    orders: FloatArray
    measured: ComplexArray
    predicted: ComplexArray
    standard_error: FloatArray
    unit: str
    condition: float
    chi2_reduced: float
    separable: bool
    strength_meaning: str
    transfer: str
    inertia: float

    @property
    def strength_error(self) -> FloatArray:
        """Standard error of each strength [-]."""
        return np.sqrt(np.maximum(np.diag(self.strength_covariance), 0.0))


def measured_torque(
    speed: OrderSpectrum, inertia: float, cycle_revolutions: int
) -> tuple[ComplexArray, FloatArray]:
    """Torque orders of a rigid body from its measured speed orders: ``i k (J / 2) (omega^2)_k``.

    Parameters
    ----------
    speed : OrderSpectrum
        Crank-speed orders (order 0 the mean speed) [rad/s].
    inertia : float
        The rigid body's inertia [kg m^2].
    cycle_revolutions : int

    Returns
    -------
    torque : ndarray, complex, shape (n_orders,)
        [N m] at ``speed.orders`` (order 0 set to 0).
    standard_error : ndarray, shape (n_orders,)
        To first order in the fluctuation, ``k J Omega`` times the speed's standard error [N m].
    """
    orders = speed.orders
    mean = float(np.real(speed.amplitude[0]))
    # omega over one cycle from its orders, squared, back to orders (exact for the rigid body)
    highest = float(orders[-1])
    points = 2 ** math.ceil(math.log2(max(64, 8 * highest * cycle_revolutions)))
    theta = np.arange(points) * (2 * math.pi * cycle_revolutions / points)
    fluctuation = speed.amplitude.copy()
    fluctuation[0] = mean
    omega = np.real(np.exp(1j * np.multiply.outer(theta, orders)) @ fluctuation)
    squared = order_coefficients(omega**2, cycle_revolutions=cycle_revolutions, max_order=highest)
    torque = 1j * orders * (inertia / 2) * squared.coefficients[: orders.size]
    torque[0] = 0.0
    return torque, orders * inertia * mean * speed.standard_error


def _shaft_line_receptance(engine: Engine, orders: FloatArray, crank_speed: float) -> ComplexArray:
    """Speed at the tooth wheel per unit torque at each throw, per order: shape (n_cylinders, n_orders)."""
    from monitor.torsion.shaft_line import shaft_line_of

    if engine.shaft_line is None:
        raise ModelError(f"transfer 'shaft-line' needs the [shaft_line] of engine {engine.id!r}")
    line = shaft_line_of(engine)
    probe = line.index(engine.shaft_line.tooth_wheel or line.node_names[0])
    throws = [line.index(f"cylinder {c}") for c in range(1, engine.cylinders + 1)]
    out = np.zeros((engine.cylinders, orders.size), dtype=np.complex128)
    for j, k in enumerate(orders):
        for i, node in enumerate(throws):
            unit = np.zeros(len(line.nodes))
            unit[node] = 1.0
            angle = line.harmonic_response(float(k * crank_speed), unit)[0][probe]
            out[i, j] = 1j * k * crank_speed * angle
    return out


def cylinder_balance(
    speed: OrderSpectrum,
    engine: Engine,
    parts: CylinderParts,
    *,
    transfer: Transfer = "rigid",
    highest_order: float | None = None,
    model_uncertainty: float = MODEL_UNCERTAINTY,
) -> CylinderBalance:
    """Estimate each cylinder's strength from the crank-speed orders (see the module docstring).

    Parameters
    ----------
    speed : OrderSpectrum
        The recording's crank-speed orders [rad/s].
    engine : Engine
    parts : CylinderParts
        The model's cylinder parts at the recording's mean speed and load.
    transfer : {"rigid", "shaft-line"}, optional
    highest_order : float, optional
        Highest order used; default ``n_cylinders / R`` [-].
    model_uncertainty : float, optional
        The model's relative uncertainty: each order's weight carries ``model_uncertainty`` times the
        engine's predicted value at nominal strengths beside the measurement's standard error [-].

    Returns
    -------
    CylinderBalance

    Raises
    ------
    ModelError
        Without gas forces in the model, with too few resolvable orders, or a transfer the
        engine description cannot give.
    """
    from monitor.torsion.shaft_line import engine_side_inertia

    n = engine.cylinders
    R = engine.cycle_revolutions
    if not parts.strength:
        raise ModelError("the model has no gas forces: cylinder strengths cannot be estimated")
    top = highest_order if highest_order is not None else n / R
    use = (speed.orders > 1e-9) & (speed.orders <= top + 1e-9)
    orders = speed.orders[use]
    if 2 * orders.size < n:
        raise ModelError(
            f"the crank speed resolves {orders.size} orders up to {top:g}: too few for {n} cylinders "
            "(a tooth wheel with more teeth, or longer blocks, resolve more)"
        )
    index = [int(np.argmin(np.abs(parts.orders - k))) for k in orders]
    if np.max(np.abs(parts.orders[index] - orders)) > 1e-9:
        raise ModelError("the model's orders do not cover the measured ones: raise its max_order")
    rotation = np.exp(-1j * np.multiply.outer(engine.firing_angles, orders))  # (n_cyl, n_orders)
    known = (parts.inertia[0, index] + parts.fixed[0, index])[None, :] * rotation
    combustion = parts.combustion[0, index][None, :] * rotation
    inertia = 0.0
    if transfer == "rigid":
        inertia = engine_side_inertia(engine)
        y_all, se_all = measured_torque(speed, inertia, R)
        y, se, unit = y_all[use], se_all[use], "N m"
        H = np.ones((n, orders.size), dtype=np.complex128)
    elif transfer == "shaft-line":
        y, se, unit = speed.amplitude[use], speed.standard_error[use], "rad/s"
        H = _shaft_line_receptance(engine, orders, parts.crank_speed)
    else:
        raise ModelError(f"transfer = {transfer!r}: expected 'rigid' or 'shaft-line'")
    rhs = y - (H * known).sum(axis=0)
    design = (H * combustion).T  # (n_orders, n_cyl)
    # weights: the block spread, with a floor of 1e-6 of the largest order (the arithmetic's resolution);
    # se is the complex standard error (E |noise|^2 = se^2): the real and imaginary parts have se / sqrt 2
    # the model's own uncertainty: a share of the engine's predicted value at nominal strengths, large
    # at the firing harmonics (every cylinder adds) and nil where healthy cylinders cancel (a gap all
    # cylinders share cancels there too)
    nominal = (H * (known + combustion)).sum(axis=0)
    floor = 1e-6 * float(np.abs(y).max()) + 1e-300
    if np.any(np.linalg.norm(np.abs(design), axis=0) == 0):
        raise ModelError("a cylinder's combustion does not reach the orders used: strengths not identifiable")
    strength = np.ones(n)
    for _ in range(3):
        # a cylinder that fires unlike the model's (a misfire, a weak one) has a torque the model knows to
        # the same share, and that part of the gap is its own: it adds where the cylinders do not cancel
        unlike = np.sqrt((np.abs((strength - 1.0)[:, None] * H * combustion) ** 2).sum(axis=0))
        spread = np.sqrt(
            se**2 + (model_uncertainty * np.abs(nominal)) ** 2 + (model_uncertainty * unlike) ** 2
        )
        sigma = np.maximum(spread, floor) / math.sqrt(2.0)
        a = np.vstack([design.real, design.imag]) / np.concatenate([sigma, sigma])[:, None]
        b = np.concatenate([rhs.real, rhs.imag]) / np.concatenate([sigma, sigma])
        norms = np.linalg.norm(a, axis=0)
        scaled = a / norms
        strength_scaled, *_ = np.linalg.lstsq(scaled, b, rcond=None)
        strength = strength_scaled / norms
    # whether the orders tell the cylinders apart is the measurement's geometry (the firing order, the
    # orders resolved), judged with the measurement's own weights: the model's uncertainty weakens only
    # the cylinders' common level, which no single cylinder's finding rests on
    own = np.maximum(se, 1e-6 * float(np.abs(y).max()) + 1e-300) / math.sqrt(2.0)
    geometry = np.vstack([design.real, design.imag]) / np.concatenate([own, own])[:, None]
    singular = np.linalg.svd(geometry / np.linalg.norm(geometry, axis=0), compute_uv=False)
    condition = float(singular[0] / singular[-1]) if singular[-1] > 0 else math.inf
    residual = scaled @ strength_scaled - b
    dof = a.shape[0] - n
    chi2 = float(residual @ residual / dof) if dof > 0 else 1.0
    inverse = np.linalg.pinv(scaled.T @ scaled)
    covariance = inverse / np.outer(norms, norms) * max(chi2, 1.0)
    relative, relative_error, contrast_error = _relative(strength, covariance)
    predicted = (H * (known + strength[:, None] * combustion)).sum(axis=0)
    return CylinderBalance(
        strength=strength,
        strength_covariance=covariance,
        relative=relative,
        relative_error=relative_error,
        contrast_error=contrast_error,
        model_uncertainty=float(model_uncertainty),
        orders=orders,
        measured=y,
        predicted=predicted,
        standard_error=se,
        unit=unit,
        condition=condition,
        chi2_reduced=chi2,
        separable=condition <= SEPARABLE_CONDITION,
        strength_meaning=parts.strength,
        transfer=transfer,
        inertia=inertia,
    )


def _relative(strength: FloatArray, covariance: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Each strength over the mean of the cylinders that fire alike, itself excluded, with its errors.

    Those that fire alike are within :data:`ALIKE` of the median strength, so one or two faulty
    cylinders do not move the reference. Two errors, first order in the covariance: of the ratio
    itself, and of the contrast ``(s_c - reference) / reference`` with the reference's level held
    (a change of every strength alike moves it by nothing): whether the cylinder differs from the
    others.
    """
    n = strength.size
    if n < 2:
        error = np.sqrt(np.maximum(np.diag(covariance), 0.0))
        return np.ones(1), error, error
    median = float(np.median(strength))
    alike = np.abs(strength - median) <= ALIKE * abs(median)
    relative = np.empty(n)
    error = np.empty(n)
    contrast = np.empty(n)
    for c in range(n):
        group = alike.copy()
        group[c] = False
        if not group.any():
            group = np.ones(n, dtype=bool)
            group[c] = False
        m = int(group.sum())
        reference = float(strength[group].mean())
        gradient = np.where(group, -strength[c] / (reference**2 * m), 0.0)
        gradient[c] = 1.0 / reference
        relative[c] = strength[c] / reference
        error[c] = math.sqrt(max(float(gradient @ covariance @ gradient), 0.0))
        difference = np.where(group, -1.0 / (reference * m), 0.0)
        difference[c] = 1.0 / reference
        contrast[c] = math.sqrt(max(float(difference @ covariance @ difference), 0.0))
    return relative, error, contrast
