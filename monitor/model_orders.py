"""Predicted orders at an operating point: the model side of every comparison.

For an engine and an operating point (crank speed, load) this gives the
complex order coefficients, with phases relative to TDC of cylinder 1 (see
:mod:`monitor.orders` for the convention), of

- the inertia force of each cylinder's moving parts (piston, rod, throw
  unbalance), across (x) and along (y) the cylinder axis [N];
- the torque of each cylinder, its gas part, and the engine's total [N m];
- the force on each main bearing, x and y [N];
- the engine's free forces [N] and free moments [N m] (about the middle of
  the engine; ``vertical`` is the moment of the y forces, ``horizontal`` of
  the x forces, lever arm towards higher cylinder numbers).

Everything that does not depend on the operating point (kinematics, the
pressure basis) is evaluated once in :class:`~monitor.crankshaft.EngineModel`;
:func:`predict_orders` then costs one batched FFT and a few small products.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from monitor.crankshaft import EngineModel, phase_shift
from monitor.errors import ModelError
from monitor.orders import order_coefficients
from monitor.types import ComplexArray, FloatArray

__all__ = ["ModelOrders", "predict_orders"]


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
        Components x, y [N].
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
    rows = np.stack(
        [
            forces.inertia_force_x + unb_x,
            forces.inertia_force_y + unb_y,
            forces.torque,
            gas_torque,
            forces.pin_force_x + unb_x,
            forces.pin_force_y + unb_y,
        ]
    )
    oc = order_coefficients(rows, cycle_revolutions=model.cycle_revolutions, max_order=max_order)
    per_cylinder = phase_shift(oc.coefficients, oc.orders, engine.firing_angles)  # (n_cyl, 6, n_orders)
    inertia = per_cylinder[:, 0:2, :]
    torque = per_cylinder[:, 2, :]
    throw = per_cylinder[:, 4:6, :]
    bearing = np.einsum("bc,cko->bko", engine.bearing_share, throw)
    lever = engine.cylinder_positions - engine.cylinder_positions.mean()
    free_force = inertia.sum(axis=0)
    free_moment = np.stack(
        [
            np.einsum("c,co->o", lever, inertia[:, 1, :]),
            np.einsum("c,co->o", lever, inertia[:, 0, :]),
        ]
    )
    alias = {name: float(oc.aliasing_error[i].max()) for i, name in enumerate(_ROWS)}
    trunc = {name: float(oc.truncation_error[i]) for i, name in enumerate(_ROWS)}
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
