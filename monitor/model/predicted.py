"""Predicted orders at an operating point: the model side of every comparison.

For an engine and an operating point (crank speed, load) this gives the
complex order coefficients, with phases relative to TDC of cylinder 1 (see
:mod:`monitor.fourier` for the convention), of

- the inertia force of each cylinder's moving parts (piston, rod, throw
  unbalance), across (x) and along (y) the cylinder axis [N];
- the torque of each cylinder, its gas part, and the engine's total [N m];
- the force on each main bearing, x and y [N];
- the engine's free forces [N] and free moments [N m] (about the middle of
  the engine; ``vertical`` is the moment of the y forces, ``horizontal`` of
  the x forces, lever arm towards higher cylinder numbers).

Everything that does not depend on the operating point (kinematics, the
pressure basis) is evaluated once in :class:`~monitor.model.crankshaft.EngineModel`;
:func:`predict_orders` then costs one batched FFT and a few small products.

Cylinder strengths.  The diagnosis estimates how strongly each cylinder
fires, so it needs each cylinder's torque and throw force split by what a
fault changes (:func:`cylinder_parts`).  The gas force ``(p - p_ambient) A``
is affine in the pressure, and the crank train's forces are linear in the
gas force at a given speed, so every quantity of cylinder ``c`` is

    inertia(Omega) + fixed + s_c combustion

with ``s_c`` the cylinder's strength (1 = as the model).  With the
parametric cycle, ``combustion`` is the heat-release part of the pressure and
``fixed`` the compression of the charge less the ambient pressure (a
misfiring cylinder, ``s_c = 0``, is motored); with a measured trace, the
whole gas force is ``combustion``.  :func:`combine_cylinders` phases the
parts by the firing angles and sums them into the engine's torque and the
main-bearing forces.  The bearing load's reversals (:func:`load_reversals`),
where a worn bearing's journal crosses its clearance, come from the same
forces.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from monitor.errors import ModelError
from monitor.fourier import order_coefficients
from monitor.model.banks import slave_cylinders, to_engine_frame
from monitor.model.crankshaft import EngineModel
from monitor.model.engine import Engine
from monitor.model.forces import crank_train_forces
from monitor.model.gas import gas_force
from monitor.model.inertia import engine_side_inertia
from monitor.types import ComplexArray, FloatArray

__all__ = [
    "CombinedOrders",
    "CylinderParts",
    "ModelOrders",
    "combine_cylinders",
    "cylinder_parts",
    "inertia_angle_fluctuation",
    "load_reversals",
    "predict_orders",
]


@dataclass(frozen=True)
class ModelOrders:
    """Predicted order coefficients at one operating point (complex, peak, SI).

    Attributes
    ----------
    engine_id : str
    crank_speed : float
        [rad/s].
    load : float
        Fraction of rated IMEP [-].
    orders : ndarray, shape (n_orders,)
        0, then steps of 1 (two-stroke) or 0.5 (four-stroke) [-].
    cylinder_inertia_force : ndarray, shape (n_cylinders, 2, n_orders)
        Components x, y in the engine's frame (a V engine's cylinders turned by their banks' lean,
        :func:`monitor.model.banks.to_engine_frame`) [N].
    cylinder_torque, cylinder_gas_torque : ndarray, shape (n_cylinders, n_orders)
        [N m].
    engine_torque : ndarray, shape (n_orders,)
        [N m].
    bearing_force : ndarray, shape (n_bearings, 2, n_orders)
        Force of the crankshaft on each main bearing, x and y [N].
    free_force : ndarray, shape (2, n_orders)
        x, y [N].
    free_moment : ndarray, shape (2, n_orders)
        Moment of the y forces ("vertical") and of the x forces ("horizontal") [N m].
    aliasing_error : dict[str, float]
        Largest estimated grid error of any coefficient, per quantity, in its unit.
    truncation_error : dict[str, float]
        Bound on the sup-norm error of the truncated series of one cylinder's
        quantity (engine sums can be up to n_cylinders times this), in its unit.
    grid_size : int
        Samples per cycle.
    rod_model, kinematics, gas : str
        Model choices.
    """

    engine_id: str
    crank_speed: float
    load: float
    orders: FloatArray
    cylinder_inertia_force: ComplexArray
    cylinder_torque: ComplexArray
    cylinder_gas_torque: ComplexArray
    engine_torque: ComplexArray
    bearing_force: ComplexArray
    free_force: ComplexArray
    free_moment: ComplexArray
    aliasing_error: dict[str, float]
    truncation_error: dict[str, float]
    grid_size: int
    rod_model: str
    kinematics: str
    gas: str

    @property
    def speed_rpm(self) -> float:
        """Crank speed [rpm]."""
        return self.crank_speed * 30 / math.pi


_ROWS = ("inertia_x", "inertia_y", "torque", "gas_torque", "throw_x", "throw_y")


def predict_orders(
    model: EngineModel, *, crank_speed: float, load: float, max_order: float = 24
) -> ModelOrders:
    """Order coefficients of the engine's forces and torques at an operating point.

    Parameters
    ----------
    model : EngineModel
        The engine's model, set up once.
    crank_speed : float
        Mean crank speed, > 0 [rad/s].
    load : float
        Fraction of rated IMEP, 0..1.1 [-].
    max_order : float, optional
        Highest order reported [-].

    Returns
    -------
    ModelOrders

    Raises
    ------
    ModelError
        If the speed is not positive and finite, or the grid cannot resolve ``max_order``.
    """
    if not (math.isfinite(crank_speed) and crank_speed > 0):
        raise ModelError(f"crank_speed = {crank_speed!r}: expected a positive speed [rad/s]")
    engine = model.engine
    forces = model.cylinder_forces(crank_speed, load)
    unb_x, unb_y = model.unbalance_force(crank_speed)
    kin = model.kinematics
    gas_torque = (
        forces.gas_force * engine.crank_radius * np.sin(kin.crank_angle + kin.beta) / np.cos(kin.beta)
    )
    unbalance = np.stack([unb_x, unb_y, 0 * unb_x, 0 * unb_x, unb_x, unb_y])
    rows = np.stack(
        [
            forces.inertia_force_x,
            forces.inertia_force_y,
            forces.torque,
            gas_torque,
            forces.pin_force_x,
            forces.pin_force_y,
        ]
    )
    kinds = [rows + unbalance]  # a slider-crank cylinder's (a master's), then a slave's
    if model.articulated:
        slave_gas = gas_force(model.slave_pressure(load), engine.piston_area, model.ambient_pressure)
        kinds.append(model.slave_rows(crank_speed, slave_gas, model.gravity) + unbalance)
    oc = order_coefficients(np.stack(kinds), cycle_revolutions=model.cycle_revolutions, max_order=max_order)
    kind = slave_cylinders(engine.cylinders, engine.vee).astype(int)
    rotation = np.exp(-1j * np.multiply.outer(engine.firing_angles, oc.orders))
    per_cylinder = oc.coefficients[kind] * rotation[:, None, :]  # (n_cyl, 6, n_orders)
    inertia = to_engine_frame(per_cylinder[:, 0:2, :], engine.cylinder_axes)
    torque = per_cylinder[:, 2, :]
    throw = to_engine_frame(per_cylinder[:, 4:6, :], engine.cylinder_axes)
    bearing = np.einsum("bc,cko->bko", engine.bearing_share, throw)
    lever = engine.cylinder_positions - engine.cylinder_positions.mean()
    free_force = inertia.sum(axis=0)
    free_moment = np.stack(
        [
            np.einsum("c,co->o", lever, inertia[:, 1, :]),
            np.einsum("c,co->o", lever, inertia[:, 0, :]),
        ]
    )
    alias = {name: float(oc.aliasing_error[:, i].max()) for i, name in enumerate(_ROWS)}
    trunc = {name: float(oc.truncation_error[:, i].max()) for i, name in enumerate(_ROWS)}
    return ModelOrders(
        engine_id=engine.id,
        crank_speed=float(crank_speed),
        load=float(load),
        orders=oc.orders,
        cylinder_inertia_force=inertia,
        cylinder_torque=torque,
        cylinder_gas_torque=per_cylinder[:, 3, :],
        engine_torque=torque.sum(axis=0),
        bearing_force=bearing,
        free_force=free_force,
        free_moment=free_moment,
        aliasing_error=alias,
        truncation_error=trunc,
        grid_size=oc.grid_size,
        rod_model=model.rod_model,
        kinematics=kin.model,
        gas=model.gas,
    )


@dataclass(frozen=True)
class CylinderParts:
    """Cylinder 1's (and a slave's) torque and throw force at an operating point by source (complex, peak).

    Rows of each array: torque [N m], throw force x [N], throw force y [N] (the rod's
    force on the crank pin plus the throw's unbalance, as in :func:`predict_orders`).

    Attributes
    ----------
    orders : ndarray, shape (n_orders,)
    inertia : ndarray, shape (3, n_orders)
        Moving masses and weights at the crank speed.
    fixed : ndarray, shape (3, n_orders)
        The part of the gas force that a cylinder's strength does not scale.
    combustion : ndarray, shape (3, n_orders)
        The part it scales.
    strength : str
        What a strength of 1 means: "heat release" (parametric cycle) or
        "gas force" (measured trace); "" without gas forces.
    crank_speed, load : float
        [rad/s], fraction of rated IMEP [-].
    slave : ndarray or None, shape (3, 3, n_orders)
        An articulated rod's slave cylinder's inertia, fixed and combustion parts, rows as above in
        its own axes, from its nominal firing TDC (:meth:`EngineModel.slave_rows`); None without.
    slaves : ndarray of bool or None, shape (n_cylinders,)
        Which cylinders are slaves; None without articulated rods.
    """

    orders: FloatArray
    inertia: ComplexArray
    fixed: ComplexArray
    combustion: ComplexArray
    strength: str
    crank_speed: float
    load: float
    slave: ComplexArray | None = None
    slaves: npt.NDArray[np.bool_] | None = None

    def per_cylinder(self, cylinders: int) -> tuple[ComplexArray, ComplexArray, ComplexArray]:
        """Each cylinder's inertia, fixed and combustion parts, before its firing angle's delay.

        Parameters
        ----------
        cylinders : int

        Returns
        -------
        inertia, fixed, combustion : ndarray, complex, shape (cylinders, 3, n_orders)
        """
        parts = np.stack([self.inertia, self.fixed, self.combustion])  # (3 parts, 3 rows, n_orders)
        each = np.repeat(parts[None], cylinders, axis=0)
        if self.slave is not None and self.slaves is not None:
            each[self.slaves] = self.slave
        return each[:, 0], each[:, 1], each[:, 2]


def cylinder_parts(
    model: EngineModel, *, crank_speed: float, load: float, max_order: float = 24
) -> CylinderParts:
    """Cylinder 1's torque and throw-force orders split into inertia, fixed gas and combustion parts.

    Parameters
    ----------
    model : EngineModel
    crank_speed : float
        Mean crank speed, > 0 [rad/s].
    load : float
        Fraction of rated IMEP, 0..1.1 [-].
    max_order : float, optional
        Highest order [-].

    Returns
    -------
    CylinderParts

    Raises
    ------
    ModelError
        For a speed or load out of range.
    """
    if not (math.isfinite(crank_speed) and crank_speed > 0):
        raise ModelError(f"crank_speed = {crank_speed!r}: expected a positive speed [rad/s]")
    if not 0.0 <= load <= 1.1:
        raise ModelError(f"load = {load!r}: expected 0 <= load <= 1.1 (fraction of rated IMEP)")
    engine = model.engine
    area, ambient = engine.piston_area, model._ambient

    def rows(force: FloatArray | float, speed: float, gravity: float) -> FloatArray:
        f = crank_train_forces(
            model.kinematics,
            model.train,
            crank_speed=speed,
            gas_force=force,
            rod_model=model.rod_model,
            gravity=gravity,
        )
        return np.stack([f.torque, f.pin_force_x, f.pin_force_y])

    zero = np.zeros_like(model.crank_angle)
    unb_x, unb_y = model.unbalance_force(crank_speed)
    unbalance = np.stack([zero, unb_x, unb_y])
    inertia = rows(0.0, crank_speed, model.gravity) + unbalance
    # the forces are affine in the gas force: its part is the difference to no gas force (at a
    # speed of 1 rad/s and no weights, where the rest is small; the difference is exact either way)
    empty = rows(0.0, 1.0, 0.0)
    if model.gas == "parametric":
        assert model._cycle is not None and model._setup.gas_basis is not None
        basis_charge, basis_heat = model._setup.gas_basis
        charge = model._cycle.charge_pressure(load) * basis_charge
        heat = model._cycle.heat_release(load) * basis_heat
        fixed = rows(gas_force(charge, area, ambient), 1.0, 0.0) - empty
        combustion = rows(heat * area, 1.0, 0.0) - empty
        strength = "heat release"
    elif model.gas == "measured":
        fixed = np.zeros_like(inertia)
        combustion = rows(gas_force(model.cylinder_pressure(load), area, ambient), 1.0, 0.0) - empty
        strength = "gas force"
    else:
        fixed = combustion = np.zeros_like(inertia)
        strength = ""
    kinds = [np.stack([inertia, fixed, combustion])]
    if model.articulated:
        kinds.append(_slave_parts(model, crank_speed, load, unbalance))
    oc = order_coefficients(np.stack(kinds), cycle_revolutions=model.cycle_revolutions, max_order=max_order)
    return CylinderParts(
        orders=oc.orders,
        inertia=oc.coefficients[0, 0],
        fixed=oc.coefficients[0, 1],
        combustion=oc.coefficients[0, 2],
        strength=strength,
        crank_speed=float(crank_speed),
        load=float(load),
        slave=oc.coefficients[1] if model.articulated else None,
        slaves=slave_cylinders(engine.cylinders, engine.vee) if model.articulated else None,
    )


def _slave_parts(model: EngineModel, crank_speed: float, load: float, unbalance: FloatArray) -> FloatArray:
    """A slave cylinder's inertia, fixed gas and combustion parts over the grid, as
    :func:`cylinder_parts` splits a slider-crank cylinder's (shape (3, 3, grid))."""
    area, ambient = model.engine.piston_area, model.ambient_pressure

    def rows(force: FloatArray | float, speed: float, gravity: float) -> FloatArray:
        return model.slave_rows(speed, force, gravity)[[2, 4, 5]]  # torque, pin force x and y

    inertia = rows(0.0, crank_speed, model.gravity) + unbalance
    empty = rows(0.0, 1.0, 0.0)
    slave = model._slave
    assert slave is not None
    if slave.gas_basis is not None:
        assert model._cycle is not None
        basis_charge, basis_heat = slave.gas_basis
        charge = model._cycle.charge_pressure(load) * basis_charge
        heat = model._cycle.heat_release(load) * basis_heat  # a master's fuel (EngineModel.slave_pressure)
        fixed = rows(gas_force(charge, area, ambient), 1.0, 0.0) - empty
        combustion = rows(heat * area, 1.0, 0.0) - empty
    elif model.gas == "measured":
        fixed = np.zeros_like(inertia)
        combustion = rows(gas_force(model.slave_pressure(load), area, ambient), 1.0, 0.0) - empty
    else:
        fixed = combustion = np.zeros_like(inertia)
    return np.stack([inertia, fixed, combustion])


@dataclass(frozen=True)
class CombinedOrders:
    """The engine's orders for given cylinder strengths (complex, peak, SI).

    Attributes
    ----------
    orders : ndarray, shape (n_orders,)
    cylinder_torque : ndarray, shape (n_cylinders, n_orders)
        Each throw's torque, phased by its firing angle [N m].
    engine_torque : ndarray, shape (n_orders,)
        [N m].
    bearing_force : ndarray, shape (n_bearings, 2, n_orders)
        Force of the crankshaft on each main bearing, x and y [N].
    """

    orders: FloatArray
    cylinder_torque: ComplexArray
    engine_torque: ComplexArray
    bearing_force: ComplexArray


def combine_cylinders(parts: CylinderParts, engine: Engine, strengths: npt.ArrayLike) -> CombinedOrders:
    """Sum the cylinders' parts, each with its strength and firing angle.

    Parameters
    ----------
    parts : CylinderParts
    engine : Engine
    strengths : array_like, shape (n_cylinders,)
        Each cylinder's strength (1 = as the model, 0 = motored) [-].

    Returns
    -------
    CombinedOrders
    """
    s = np.asarray(strengths, dtype=np.float64)
    if s.shape != (engine.cylinders,):
        raise ModelError(f"strengths have shape {s.shape}: expected one per cylinder ({engine.cylinders})")
    inertia, fixed, combustion = parts.per_cylinder(engine.cylinders)  # (n_cyl, 3, n_orders) each
    per_cylinder = inertia + fixed + s[:, None, None] * combustion
    rotation = np.exp(-1j * np.multiply.outer(engine.firing_angles, parts.orders))
    phased = per_cylinder * rotation[:, None, :]  # (n_cyl, 3, n_orders)
    throw = to_engine_frame(phased[:, 1:3, :], engine.cylinder_axes)
    bearing = np.einsum("bc,cko->bko", engine.bearing_share, throw)
    torque = phased[:, 0, :]
    return CombinedOrders(parts.orders, torque, torque.sum(axis=0), bearing)


def load_reversals(
    force: ComplexArray, orders: FloatArray, cycle_revolutions: int, *, points: int = 4096
) -> FloatArray:
    """Cycle angles where a bearing's load turns: local minima of its magnitude below the cycle mean.

    There the journal crosses its clearance; a worn bearing knocks.

    Parameters
    ----------
    force : ndarray, shape (2, n_orders)
        The bearing force's x and y orders [N].
    orders : ndarray, shape (n_orders,)
    cycle_revolutions : int
    points : int, optional
        Grid points per revolution on which the minima are found.

    Returns
    -------
    ndarray
        Cycle angles [rad], ascending (the global minimum alone if no local one lies below the mean).
    """
    n = points * cycle_revolutions
    grid = np.arange(n) * (2 * math.pi / points)
    # Re sum_k F_k exp(i k theta) on the grid by one inverse real FFT: order k is harmonic k R of the cycle
    harmonic = np.rint(np.asarray(orders) * cycle_revolutions).astype(np.int64)
    if harmonic.max(initial=0) >= n // 2:
        raise ModelError(
            f"load_reversals: orders up to {orders[-1]:g} need more than {points} points per revolution"
        )
    spectrum = np.zeros((2, n // 2 + 1), dtype=np.complex128)
    for row in range(2):  # orders are distinct harmonics; add.at keeps repeated ones summed all the same
        np.add.at(spectrum[row], harmonic, force[row] * (n / 2))
    spectrum[:, 0] = np.real(spectrum[:, 0]) * 2  # order 0 enters once, not as half of a pair
    x, y = np.fft.irfft(spectrum, n, axis=-1)
    magnitude = np.hypot(x, y)
    low = (magnitude < np.roll(magnitude, 1)) & (magnitude <= np.roll(magnitude, -1))
    low &= magnitude < magnitude.mean()
    return np.asarray(grid[low] if low.any() else grid[[int(np.argmin(magnitude))]])


def inertia_angle_fluctuation(
    engine: Engine, *, max_order: int = 36
) -> Callable[[npt.ArrayLike], FloatArray]:
    """The crank's angle fluctuation driven by the reciprocating parts' inertia: the same at every speed.

    Parameters
    ----------
    engine : Engine
        With its ``[shaft_line]`` (the rotating inertia the torque drives).
    max_order : int, optional
        Highest order kept [-].

    Returns
    -------
    callable
        ``f(theta)``: how far the crank runs ahead of uniform rotation at crank angle ``theta``
        (from TDC of cylinder 1) [rad] -> [rad], mean zero.

    Raises
    ------
    ModelError
        If the engine has no ``[shaft_line]``.

    Notes
    -----
    For a rigid engine side of inertia ``J`` (:func:`monitor.model.inertia.engine_side_inertia`)
    turning at ``Omega (1 + delta)``, ``J Omega^2 d delta / d theta = T(theta)`` to first order, and
    the angle ahead of uniform rotation obeys ``df / d theta = delta``; so order ``k`` of the
    torque gives ``f_k = -T_k / (J Omega^2 k^2)``. The inertia torque (every cylinder's moving
    parts, phased by its firing angle) is ``Omega^2`` times a shape fixed by the kinematics, so
    ``f`` does not depend on speed; it is evaluated at the rated speed, without the weights (whose
    torque does not scale with ``Omega^2``), and repeats every revolution.
    """
    inertia = engine_side_inertia(engine)
    omega = engine.operation.rated_speed_rpm * math.pi / 30
    model = EngineModel(engine, gas="none", gravity=0.0, grid_size=max(256, 8 * max_order))
    parts = cylinder_parts(model, crank_speed=omega, load=0.0, max_order=max_order)
    torque = combine_cylinders(parts, engine, np.zeros(engine.cylinders)).engine_torque
    orders = parts.orders
    keep = (orders > 0) & (orders == np.rint(orders))  # each throw's inertia repeats every revolution
    coefficients = -torque[keep] / (inertia * omega**2 * orders[keep] ** 2)
    kept_orders = orders[keep]

    def fluctuation(theta: npt.ArrayLike) -> FloatArray:
        phase = np.exp(1j * np.multiply.outer(np.asarray(theta, dtype=np.float64), kept_orders))
        return np.asarray(np.real(phase @ coefficients), dtype=np.float64)

    return fluctuation
