"""Cylinder balance: each cylinder's strength from the crank-speed orders, by least squares.

Below the crankshaft's first torsional mode the engine side turns as one
rigid body of inertia ``J`` (:func:`monitor.model.inertia.engine_side_inertia`):
``1/2 J omega^2 = E0 + integral (T - T_mean) dtheta``, so the torque orders
follow from the measured speed without a small-fluctuation approximation,
``T_k = i k (J / 2) (omega^2)_k``, with ``omega^2`` formed from the measured
speed orders over the cycle.  With ``transfer="shaft-line"`` the speed orders
at the tooth wheel are compared instead, each throw's torque passed through
the shaft line's receptance at ``k Omega`` (any speed, resonances included).

Each cylinder's torque is ``inertia + fixed + s_c combustion``
(:func:`monitor.model.predicted.cylinder_parts`), phased by its firing angle, so
every low order is linear in the strengths ``s``:

    y_k - sum_c H_ck (inertia + fixed)_ck = sum_c s_c H_ck combustion_ck

The orders ``0 < k <= n_cylinders / R`` (two-stroke 1..n, four-stroke
0.5..n/2) are stacked, real and imaginary parts apart, and weighted by their
standard errors from the spread over the averaged blocks (and, at the whole orders no
baseline calibrated, the tooth wheel's pitch errors left in the map:
:mod:`monitor.signal.pitch_uncertainty`).  Orders that are
multiples of the firing frequency see every cylinder in phase (they fix the
mean strength), the others resolve the differences.  The covariance is the
weighted problem's, scaled by the reduced chi-square when the residual is
larger than the block spread explains (model error).  The condition number of
the column-normalised problem says whether the cylinders can be told apart.

Each cylinder is reported against the mean of the cylinders of its own bank
that fire alike, itself excluded, and cylinders that fire too nearly
together to be told apart are judged as one (:mod:`monitor.diagnosis.shares`),
so one or two faulty cylinders move neither the reference nor the healthy
cylinders' shares: a misfiring cylinder is near 0 %, a cylinder 30 % weak
near 70 %, the others near 100 %.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Literal

import numpy as np
import numpy.typing as npt

from monitor.diagnosis.shares import ALIKE, fire_together, relative_shares
from monitor.errors import ModelError
from monitor.fourier import order_coefficients
from monitor.model.engine import Engine
from monitor.model.inertia import engine_side_inertia, engine_side_inertia_at
from monitor.model.predicted import CylinderParts
from monitor.signal.pitch_uncertainty import COVERAGE
from monitor.signal.spectrum import OrderSpectrum
from monitor.torsion.shaft_line import tooth_wheel_receptance
from monitor.types import ComplexArray, FloatArray

__all__ = ["ALIKE", "CrankCalibration", "CylinderBalance", "Transfer", "cylinder_balance", "measured_torque"]

Transfer = Literal["rigid", "shaft-line"]

# the model's relative uncertainty of the engine's torque at each order at nominal strengths, where no
# baseline measured it: engine files differ from engines (masses and inertia by up to 10 %, combustion
# timing by a few degrees, the load by 10 %), so the firing harmonics, where every cylinder adds, are
# known to about this; the orders where healthy cylinders cancel are not affected by a gap that all
# cylinders share
MODEL_UNCERTAINTY = 0.10
# the combustion's timing in an engine file is known to a few degrees of crank angle (start and duration of
# the heat release fitted to the real, double law): a cylinder's combustion torque at order k is known in
# phase to k times this [rad], which grows past the level's uncertainty above the first few orders
TIMING_UNCERTAINTY = math.radians(3.0)
# healthy cylinders do not fire exactly alike (injection, wear, the cycles' scatter), and not alike from one
# run to the next: each cylinder's combustion torque carries this much that is its own [-]
IMBALANCE = 0.03
# what remains of it at an order a healthy baseline calibrated (CrankCalibration): the operating point
# drifts between the baseline and the recording (speed, load, the cycles' scatter)
CALIBRATED_UNCERTAINTY = 0.05
# orders whose predicted value at nominal strengths is below this share of the largest are not calibrated
# (where healthy cylinders cancel, the baseline's residual is the wheel's, taken by its pitch correction)
CALIBRATED_FRACTION = 0.1
SIGNIFICANT = 4.0  # standard errors a baseline's order must stand above nothing to be calibrated [-]
# the relative uncertainties a calibration shares a firing harmonic's gap by: the inertia torque is exact
# kinematics with masses known to about 10 %; a gas model's firing harmonics may be off by their own size
# (on the validation population's engines they were off by several times the model's, of either sign)
INERTIA_SHARE = 0.10
# the cylinders' mean strength is 1 (the model's combustion at the stated load) to about this [-]: the
# orders where the cylinders cancel give each cylinder's difference from the others in the model's units,
# and a share of the others needs their level, which a firing harmonic dominated by the inertia torque
# fixes poorly (the model's low-order combustion and the stated load are known to some 10 to 30 %)
LEVEL_UNCERTAINTY = 0.3
COMBUSTION_SHARE = 1.0
# above this condition number of the column-normalised problem two cylinders cannot be told apart
SEPARABLE_CONDITION = 1e3


@dataclass(frozen=True)
class CrankCalibration:
    """The crank-speed model calibrated on a healthy baseline, order by order.

    At the orders where the cylinders add up (the firing harmonics) the engine file's model is
    known only to its masses', inertias' and combustion's accuracy; the baseline measures the gap
    ``g_k = y_k - known_k - combustion_k`` between the measured left-hand side and the model's at
    nominal strengths.  The gap is shared between the model's two parts as their uncertainties
    are: the inertia and fixed torques (``known``, the masses known to :data:`INERTIA_SHARE`) and
    the combustion (a gas model's firing harmonics known to :data:`COMBUSTION_SHARE`), each part's
    share ``sigma_part^2 / (sigma_known^2 + sigma_combustion^2)`` (the least-squares split of one
    measured sum of two uncertain terms).  A later recording's model at those orders is
    ``inertia_factor x known + factor x combustion``, each part at its own speed and load: a
    recording slower than the baseline (a propeller slowed by a weak cylinder) keeps the inertia
    torque's change with the speed squared whichever part was off.

    Attributes
    ----------
    transfer : str
        "rigid" or "shaft-line": the left-hand side the factors belong to.
    orders : ndarray
        The orders calibrated [-].
    factor : ndarray, complex
        The combustion's factor ``1 + share_c g_k / combustion_k`` [-].
    factor_error : ndarray
        Standard error of ``factor`` (its share of the baseline's block spread) [-].
    inertia_factor : ndarray, complex
        The inertia and fixed torques' factor ``1 + share_known g_k / known_k`` [-].
    inertia_factor_error : ndarray
        Its standard error [-].
    """

    transfer: str
    orders: FloatArray
    factor: ComplexArray
    factor_error: FloatArray
    inertia_factor: ComplexArray
    inertia_factor_error: FloatArray


@dataclass(frozen=True)
class CylinderBalance:
    """Each cylinder's estimated strength and its share against the others.

    Attributes
    ----------
    strength : ndarray, shape (n_cylinders,)
        Estimated strength (1 = as the model at the given load; 0 = motored) [-].
    strength_covariance : ndarray, shape (n_cylinders, n_cylinders)
    relative : ndarray, shape (n_cylinders,)
        Strength over the mean of its bank's cylinders that fire alike, itself excluded [-].
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
    measured, predicted, nominal : ndarray, complex
        The left-hand side ``y_k`` measured, as fitted, and as the model gives it at nominal strengths
        (the calibration's factors applied), at those orders (torque [N m] for the rigid body, speed
        [rad/s] for the shaft line).
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
    calibrated : ndarray of bool
        Which of the orders a baseline's :class:`CrankCalibration` calibrated.
    known, combustion : ndarray, complex
        The model's inertia and fixed torques, and its combustion at nominal strengths, at those
        orders, uncalibrated (the parts a :class:`CrankCalibration` shares a gap between).
    columns : ndarray, complex, shape (n_orders, n_cylinders)
        Each cylinder's combustion at nominal strength as it reaches the left-hand side (the
        calibration's factors applied): the least-squares problem's design [same unit].
    inertia_part, gas_part : ndarray, complex
        The moving masses' torque and the gas force's fixed part (the compression and charge
        pressure), summed over the cylinders as they reach the left-hand side, the calibration's
        factors applied [same unit].
    wheel_error : ndarray
        The tooth wheel's pitch errors left in the map, their rms share of each order the weights
        carry beside ``standard_error`` (0 where a baseline calibrated the order) [same unit].
    names : list of str
        Each cylinder's name (:attr:`monitor.model.engine.Engine.cylinder_names`).
    banks : list of str
        Each cylinder's bank (:attr:`monitor.model.engine.Engine.cylinder_banks`; ``""`` in line).
    together : list of tuple of int
        Groups of cylinders (indices) that fire too nearly together to be told apart, each judged as
        one (:func:`monitor.diagnosis.shares.fire_together`).
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
    nominal: ComplexArray = field(default_factory=lambda: np.zeros(0, dtype=np.complex128))
    calibrated: npt.NDArray[np.bool_] = field(default_factory=lambda: np.zeros(0, dtype=bool))
    known: ComplexArray = field(default_factory=lambda: np.zeros(0, dtype=np.complex128))
    combustion: ComplexArray = field(default_factory=lambda: np.zeros(0, dtype=np.complex128))
    columns: ComplexArray = field(default_factory=lambda: np.zeros((0, 0), dtype=np.complex128))
    inertia_part: ComplexArray = field(default_factory=lambda: np.zeros(0, dtype=np.complex128))
    gas_part: ComplexArray = field(default_factory=lambda: np.zeros(0, dtype=np.complex128))
    wheel_error: FloatArray = field(default_factory=lambda: np.zeros(0))
    names: list[str] = field(default_factory=list)
    banks: list[str] = field(default_factory=list)
    together: list[tuple[int, ...]] = field(default_factory=list)

    def name(self, c: int) -> str:
        """Cylinder ``c``'s name (index; ``A3`` on a V engine), its number when no names were given."""
        return self.names[c] if c < len(self.names) else str(c + 1)

    def group(self, c: int) -> tuple[int, ...]:
        """The cylinders (indices) judged as one with cylinder ``c``: its group in :attr:`together`,
        else itself alone."""
        return next((g for g in self.together if c in g), (c,))

    def member_contrast_error(self) -> FloatArray:
        """Each cylinder's :attr:`contrast_error` as the findings read its share: a group's as one
        member's (:func:`monitor.diagnosis.shares.one_of`), ``n`` times the group's [-]."""
        size = np.array([len(self.group(c)) for c in range(self.contrast_error.size)], dtype=np.float64)
        return np.asarray(size * self.contrast_error, dtype=np.float64)

    def calibration(self) -> CrankCalibration:
        """This (healthy) balance's calibration of the model where the cylinders add up.

        Orders whose nominal value is below :data:`CALIBRATED_FRACTION` of the largest, or whose
        measured value is within :data:`SIGNIFICANT` standard errors of nothing, are left out.
        """
        size = np.abs(self.nominal)
        keep = (size >= CALIBRATED_FRACTION * float(size.max(initial=0.0))) & (size > 0)
        keep &= np.abs(self.measured) >= SIGNIFICANT * self.standard_error
        known, burning = self.known[keep], self.combustion[keep]
        gap = self.measured[keep] - known - burning
        spread_known = (INERTIA_SHARE * np.abs(known)) ** 2
        spread_burning = (COMBUSTION_SHARE * np.abs(burning)) ** 2
        share = spread_known / np.maximum(spread_known + spread_burning, 1e-300)  # the inertia's
        safe_known = np.where(np.abs(known) > 0, known, 1.0)
        safe_burning = np.where(np.abs(burning) > 0, burning, 1.0)
        se = self.standard_error[keep]
        return CrankCalibration(
            self.transfer,
            self.orders[keep].copy(),
            np.asarray(1 + (1 - share) * gap / safe_burning, dtype=np.complex128),
            np.asarray((1 - share) * se / np.abs(safe_burning), dtype=np.float64),
            np.asarray(1 + share * gap / safe_known, dtype=np.complex128),
            np.asarray(share * se / np.abs(safe_known), dtype=np.float64),
        )

    @property
    def strength_error(self) -> FloatArray:
        """Standard error of each strength [-]."""
        return np.sqrt(np.maximum(np.diag(self.strength_covariance), 0.0))


def measured_torque(
    speed: OrderSpectrum, inertia: float | ComplexArray, cycle_revolutions: int
) -> tuple[ComplexArray, FloatArray]:
    """Torque orders of a rigid body from its measured speed orders: ``i k (J / 2) (omega^2)_k``.

    Parameters
    ----------
    speed : OrderSpectrum
        Crank-speed orders (order 0 the mean speed) [rad/s].
    inertia : float or ndarray, complex, shape (n_orders,)
        The rigid body's inertia, or the inertia each order meets
        (:func:`monitor.model.inertia.engine_side_inertia_at`; order 0's unused) [kg m^2].
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
    bins = np.rint(orders * cycle_revolutions).astype(np.int64)
    if np.any(np.abs(orders * cycle_revolutions - bins) > 1e-9) or np.any(bins < 0):
        raise ModelError(
            f"crank-speed orders {orders.tolist()}: expected non-negative multiples of "
            f"{1 / cycle_revolutions:g} for a {cycle_revolutions}-revolution cycle"
        )
    fluctuation = speed.amplitude.copy()
    fluctuation[0] = mean
    # sum_k c_k exp(i k theta) on the cycle's grid theta_j = 2 pi R j / points is one inverse FFT
    spectrum = np.zeros(points, dtype=np.complex128)
    spectrum[bins] = fluctuation
    omega = np.real(np.fft.ifft(spectrum)) * points
    squared = order_coefficients(omega**2, cycle_revolutions=cycle_revolutions, max_order=highest)
    torque = 1j * orders * (np.asarray(inertia) / 2) * squared.coefficients[: orders.size]
    torque[0] = 0.0
    return torque, orders * np.abs(inertia) * mean * speed.standard_error


def cylinder_balance(
    speed: OrderSpectrum,
    engine: Engine,
    parts: CylinderParts,
    *,
    transfer: Transfer = "rigid",
    highest_order: float | None = None,
    model_uncertainty: float = MODEL_UNCERTAINTY,
    calibration: CrankCalibration | None = None,
    timing_uncertainty: float = TIMING_UNCERTAINTY,
    imbalance: float = IMBALANCE,
    level_uncertainty: float = LEVEL_UNCERTAINTY,
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
        The model's relative uncertainty: each order's weight carries it times the engine's value at
        nominal strengths beside the measurement's standard error [-].
    timing_uncertainty : float, optional
        The combustion timing's uncertainty [rad] (:data:`TIMING_UNCERTAINTY`).
    imbalance : float, optional
        Each healthy cylinder's own share of its combustion torque [-] (:data:`IMBALANCE`).
    level_uncertainty : float, optional
        Two or more cylinders: their mean strength is 1 (the model at the stated load) to this
        standard error, beside the orders (:data:`LEVEL_UNCERTAINTY`; 0: not) [-].
    calibration : CrankCalibration, optional
        A healthy baseline's calibration of the model (same transfer): at its orders the model's
        combustion times its factor (the inertia and fixed torques the model's at this speed), and
        the model's uncertainty :data:`CALIBRATED_UNCERTAINTY` beside the factor's own error.

    Returns
    -------
    CylinderBalance

    Raises
    ------
    ModelError
        Without gas forces in the model, with too few resolvable orders, or a transfer the
        engine description cannot give.
    """
    if not parts.strength:
        raise ModelError("the model has no gas forces: cylinder strengths cannot be estimated")
    use, orders, known, combustion, gas = _cylinder_orders(speed, engine, parts, highest_order)
    y, se, unit, H, inertia, wheel = _left_hand_side(speed, use, engine, parts, transfer)
    # the baseline's factor at each order it calibrated (1 elsewhere), and its relative error
    factor, factor_error, inertia_factor, inertia_factor_error, calibrated = _factors(
        calibration, transfer, orders
    )
    plain = (H * known).sum(axis=0)  # the inertia and fixed torques, at the recording's own speed
    fixed = inertia_factor * plain
    burning = (H * combustion).sum(axis=0)  # the model's combustion at nominal strengths, uncalibrated
    rhs = y - fixed
    design = (factor * H * combustion).T  # (n_orders, n_cyl)
    # the model's own uncertainty: a share of the engine's predicted value at nominal strengths, large at
    # the firing harmonics (every cylinder adds), nil where healthy cylinders (and a gap all share) cancel
    nominal = fixed + factor * burning
    # the combustion's timing: on every cylinder's combustion where no baseline calibrated the order
    timing = np.minimum(orders * timing_uncertainty, 1.0)
    if np.any(np.linalg.norm(np.abs(design), axis=0) == 0):
        raise ModelError("a cylinder's combustion does not reach the orders used: strengths not identifiable")
    together = fire_together(engine.firing_angles, engine.cycle_revolutions, float(orders.max()))
    spread = _Spread(
        se=se,
        model=np.where(calibrated, CALIBRATED_UNCERTAINTY, model_uncertainty) * np.abs(nominal),
        calibration=factor_error * np.abs(burning),
        inertia=inertia_factor_error * np.abs(plain),
        unlike_share=np.hypot(model_uncertainty, timing),
        timed=np.where(calibrated, 0.0, timing * np.abs((factor * H * combustion).sum(axis=0))),
        # the healthy cylinders' own differences, independent from cylinder to cylinder
        uneven=imbalance * np.sqrt((np.abs(factor * H * combustion) ** 2).sum(axis=0)),
        wheel=np.where(calibrated, 0.0, wheel),  # a calibrated order's factor holds the wheel's errors
        factor=factor,
        transfer=H,
        combustion=combustion,
        groups=together,
    )
    strength, covariance, chi2 = _fit(design, rhs, y, spread, level_uncertainty)
    shares = relative_shares(strength, covariance, engine.cylinder_banks, together)
    relative, relative_error, contrast_error = shares
    predicted = fixed + factor * (H * strength[:, None] * combustion).sum(axis=0)
    return CylinderBalance(
        names=engine.cylinder_names,
        banks=engine.cylinder_banks,
        together=together,
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
        condition=(condition := _condition(design, se, y)),
        chi2_reduced=chi2,
        separable=condition <= SEPARABLE_CONDITION,
        strength_meaning=parts.strength,
        transfer=transfer,
        inertia=inertia,
        nominal=nominal,
        calibrated=calibrated,
        known=plain,
        combustion=burning,
        columns=design,
        inertia_part=inertia_factor * (H * (known - gas)).sum(axis=0),
        gas_part=inertia_factor * (H * gas).sum(axis=0),
        wheel_error=spread.wheel,
    )


def _cylinder_orders(
    speed: OrderSpectrum, engine: Engine, parts: CylinderParts, highest_order: float | None
) -> tuple[npt.NDArray[np.bool_], FloatArray, ComplexArray, ComplexArray, ComplexArray]:
    """The orders used (mask and values) and each cylinder's known and combustion torques at them,
    with the gas force's fixed part of the known."""
    n = engine.cylinders
    R = engine.cycle_revolutions
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
    inertia, fixed, burning = (part[:, 0, index] for part in parts.per_cylinder(engine.cylinders))  # torques
    known = (inertia + fixed) * rotation
    combustion = burning * rotation
    gas = fixed * rotation
    return use, orders, known, combustion, gas


def _left_hand_side(
    speed: OrderSpectrum, use: npt.NDArray[np.bool_], engine: Engine, parts: CylinderParts, transfer: Transfer
) -> tuple[ComplexArray, FloatArray, str, ComplexArray, float, FloatArray]:
    """The measured left-hand side ``y`` at the orders used, its standard error and unit, the transfer
    ``H`` from each throw's torque to it, the rigid body's inertia (0 for the shaft line), and the
    wheel's unlearned pitch errors' rms share of each order in the same unit (0 where not known)."""
    orders = speed.orders[use]
    inertia = 0.0
    # the unlearned pitch errors' bound over its coverage: their rms scale at each order [rad/s]
    wheel = np.zeros(speed.orders.size) if speed.systematic is None else speed.systematic / COVERAGE
    if transfer == "rigid":
        inertia = engine_side_inertia(engine)
        # each order meets the engine side and, through its shafts, what the engine drives
        met = np.full(speed.orders.size, inertia, dtype=np.complex128)
        positive = speed.orders > 1e-9
        met[positive] = engine_side_inertia_at(engine, speed.orders[positive] * parts.crank_speed)
        y_all, se_all = measured_torque(speed, met, engine.cycle_revolutions)
        y, se, unit = y_all[use], se_all[use], "N m"
        # as the block spread goes to torque (to first order in the fluctuation)
        wheel_torque = speed.orders * np.abs(met) * float(np.real(speed.amplitude[0])) * wheel
        H = np.ones((engine.cylinders, orders.size), dtype=np.complex128)
        return y, se, unit, H, inertia, np.asarray(wheel_torque[use], dtype=np.float64)
    if transfer == "shaft-line":
        y, se, unit = speed.amplitude[use], speed.standard_error[use], "rad/s"
        H = tooth_wheel_receptance(engine, orders, parts.crank_speed)
        return y, se, unit, H, inertia, np.asarray(wheel[use], dtype=np.float64)
    raise ModelError(f"transfer = {transfer!r}: expected 'rigid' or 'shaft-line'")


def _factors(
    calibration: CrankCalibration | None, transfer: Transfer, orders: FloatArray
) -> tuple[ComplexArray, FloatArray, ComplexArray, FloatArray, npt.NDArray[np.bool_]]:
    """A baseline's factors at the orders it calibrated (1 elsewhere), their errors, and which it did."""
    factor = np.ones(orders.size, dtype=np.complex128)
    factor_error = np.zeros(orders.size)
    inertia_factor = np.ones(orders.size, dtype=np.complex128)
    inertia_factor_error = np.zeros(orders.size)
    calibrated = np.zeros(orders.size, dtype=bool)
    if calibration is not None:
        if calibration.transfer != transfer:
            raise ModelError(
                f"the crank calibration is for the {calibration.transfer} transfer, "
                f"the balance uses {transfer}"
            )
        for i, k in enumerate(orders):
            match = np.flatnonzero(np.abs(calibration.orders - k) < 1e-9)
            if match.size:
                factor[i] = calibration.factor[match[0]]
                factor_error[i] = calibration.factor_error[match[0]]
                inertia_factor[i] = calibration.inertia_factor[match[0]]
                inertia_factor_error[i] = calibration.inertia_factor_error[match[0]]
                calibrated[i] = True
    return factor, factor_error, inertia_factor, inertia_factor_error, calibrated


@dataclass(frozen=True)
class _Spread:
    """The terms of each order's uncertainty beside the measurement's (see :func:`cylinder_balance`)."""

    se: FloatArray  # the measurement's block spread
    model: FloatArray  # the model's uncertainty of the engine's value at nominal strengths
    calibration: FloatArray  # a baseline factor's error on the combustion
    inertia: FloatArray  # and on the inertia and fixed torques
    unlike_share: FloatArray  # the share of a cylinder's own deviation from the model that is uncertain
    timed: FloatArray  # the combustion's timing
    uneven: FloatArray  # the healthy cylinders' own differences
    wheel: FloatArray  # the tooth wheel's unlearned pitch errors (their rms scale)
    factor: ComplexArray
    transfer: ComplexArray
    combustion: ComplexArray
    groups: list[tuple[int, ...]] = field(default_factory=list)  # cylinders that fire together

    def at(self, strength: FloatArray) -> FloatArray:
        """Each order's standard error with the cylinders at these strengths."""
        # a cylinder that fires unlike the model's (a misfire, a weak one) has a torque the model knows to
        # the same share, and that part of the gap is its own: it adds where the cylinders do not cancel.
        # Cylinders that fire together depart as one: their departures add before the share is taken (the
        # orders fix only their sum; each member's own strength may be anything that keeps it)
        departing = (strength - 1.0)[:, None] * self.factor * self.transfer * self.combustion
        own = [departing[list(g)].sum(axis=0) for g in self.groups]
        alone = [departing[c] for c in range(strength.size) if not any(c in g for g in self.groups)]
        unlike = np.sqrt((np.abs(np.array(own + alone)) ** 2).sum(axis=0))
        return np.asarray(
            np.sqrt(
                self.se**2
                + self.model**2
                + self.calibration**2
                + self.inertia**2
                + (self.unlike_share * unlike) ** 2
                + self.timed**2
                + self.uneven**2
                + self.wheel**2
            )
        )


def _fit(
    design: ComplexArray, rhs: ComplexArray, y: ComplexArray, spread: _Spread, level_uncertainty: float
) -> tuple[FloatArray, FloatArray, float]:
    """The strengths by weighted least squares, re-weighted at the strengths found; their covariance
    (scaled by the reduced chi-square where it exceeds 1) and the reduced chi-square."""
    n = design.shape[1]
    # weights: the spread, with a floor of 1e-6 of the largest order (the arithmetic's resolution); it is
    # the complex standard error (E |noise|^2 = se^2): the real and imaginary parts have se / sqrt 2
    floor = 1e-6 * float(np.abs(y).max()) + 1e-300
    strength = np.ones(n)
    for _ in range(3):
        sigma = np.maximum(spread.at(strength), floor) / math.sqrt(2.0)
        a = np.vstack([design.real, design.imag]) / np.concatenate([sigma, sigma])[:, None]
        b = np.concatenate([rhs.real, rhs.imag]) / np.concatenate([sigma, sigma])
        if n > 1 and level_uncertainty > 0:
            # the cylinders' common level, as the model gives it at the stated load: weighs only where
            # the orders leave the level loose (a firing harmonic the inertia torque dominates)
            a = np.vstack([a, np.full((1, n), 1.0 / (n * level_uncertainty))])
            b = np.concatenate([b, [1.0 / level_uncertainty]])
        norms = np.linalg.norm(a, axis=0)
        scaled = a / norms
        strength_scaled, *_ = np.linalg.lstsq(scaled, b, rcond=None)
        strength = strength_scaled / norms
    residual = scaled @ strength_scaled - b
    dof = a.shape[0] - n
    chi2 = float(residual @ residual / dof) if dof > 0 else 1.0
    inverse = np.linalg.pinv(scaled.T @ scaled)
    covariance = inverse / np.outer(norms, norms) * max(chi2, 1.0)
    return strength, covariance, chi2


def _condition(design: ComplexArray, se: FloatArray, y: ComplexArray) -> float:
    """Condition number of the column-normalised problem with the measurement's own weights."""
    # whether the orders tell the cylinders apart is the measurement's geometry (the firing order, the
    # orders resolved), judged with the measurement's own weights: the model's uncertainty weakens only
    # the cylinders' common level, which no single cylinder's finding rests on
    own = np.maximum(se, 1e-6 * float(np.abs(y).max()) + 1e-300) / math.sqrt(2.0)
    geometry = np.vstack([design.real, design.imag]) / np.concatenate([own, own])[:, None]
    singular = np.linalg.svd(geometry / np.linalg.norm(geometry, axis=0), compute_uv=False)
    return float(singular[0] / singular[-1]) if singular[-1] > 0 else math.inf
