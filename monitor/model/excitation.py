"""The cylinders' torque orders that excite the shaft line: what the torsion models take from the model.

Each cylinder's torque (gas and inertia of its moving parts) at an operating
point, as order coefficients with phases relative to TDC of cylinder 1, from
:func:`monitor.model.predicted.predict_orders`: over a range of speeds for the
forced responses (:func:`cylinder_torque_orders`), and cylinder 1's gas torque
alone at one speed for the variable-inertia crank (:func:`gas_torque_orders`).
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from monitor.errors import ModelError
from monitor.model.crankshaft import EngineModel
from monitor.model.engine import Engine
from monitor.model.predicted import predict_orders
from monitor.types import ComplexArray, FloatArray

__all__ = ["cylinder_torque_orders", "gas_torque_orders"]


def cylinder_torque_orders(
    engine: Engine,
    speeds: npt.ArrayLike,
    *,
    load: float | str = "propeller",
    max_order: float = 12,
) -> tuple[FloatArray, FloatArray, ComplexArray]:
    """Each cylinder's torque orders (gas and inertia, with phases) at every speed of a range.

    Parameters
    ----------
    engine : Engine
        With a gas-force model.
    speeds : array_like
        Crank speeds, > 0 [rad/s].
    load : float or "propeller"
        Fraction of rated IMEP, or "propeller" for the propeller law
        (IMEP proportional to speed squared, rated at rated speed, at most 1.1) [-].
    max_order : float, optional
        Highest order [-].

    Returns
    -------
    speeds : ndarray, shape (n_speeds,)
        [rad/s].
    orders : ndarray, shape (n_orders,)
        Orders without order 0 [-].
    torque : ndarray, shape (n_speeds, n_cylinders, n_orders)
        Complex torque orders [N m], phases relative to TDC of cylinder 1.
    """
    w = np.asarray(speeds, dtype=np.float64)
    if w.ndim != 1 or w.size == 0 or np.any(~np.isfinite(w)) or np.any(w <= 0):
        raise ModelError("speeds: expected a non-empty 1-D array of positive crank speeds [rad/s]")
    if load != "propeller" and not isinstance(load, int | float):
        raise ModelError(f"load = {load!r}: expected a fraction of rated IMEP or 'propeller'")
    model = EngineModel(engine)
    results = []
    for speed in w:
        point_load = min(1.1, (speed / engine.rated_speed) ** 2) if load == "propeller" else float(load)
        results.append(predict_orders(model, crank_speed=float(speed), load=point_load, max_order=max_order))
    torque = np.stack([r.cylinder_torque[:, 1:] for r in results])
    return w, results[0].orders[1:], torque


def gas_torque_orders(
    engine: Engine, crank_speed: float, *, load: float = 1.0, max_order: float = 12
) -> tuple[FloatArray, ComplexArray]:
    """Cylinder 1's gas-torque orders at one speed; its own angle is the engine's crank angle.

    Parameters
    ----------
    engine : Engine
        With a gas-force model.
    crank_speed : float
        [rad/s].
    load : float, optional
        Fraction of rated IMEP [-].
    max_order : float, optional
        Highest order [-].

    Returns
    -------
    orders : ndarray, shape (n_orders,)
        Orders without order 0 [-].
    torque : ndarray, complex, shape (n_orders,)
        [N m], phases relative to cylinder 1's TDC.
    """
    result = predict_orders(EngineModel(engine), crank_speed=crank_speed, load=load, max_order=max_order)
    return result.orders[1:], result.cylinder_gas_torque[0, 1:]
