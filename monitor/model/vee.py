"""A V engine's free forces and moments: each cylinder's forces turned into the engine's frame and summed.

A V engine's cylinders stand on two banks whose axes lean from the vertical by their bank angles
(bank A at ``-g/2``, bank B at ``+g/2`` for a V of ``g``). Each cylinder moves as the slider-crank of
:mod:`monitor.model.kinematics` about its own axis (side-by-side or fork-and-blade rods; an articulated
slave's own motion is :mod:`monitor.model.articulated`'s): its forces, across (``x``) and along
(``y``) its own axis, are one cylinder's orders delayed by the crank angle at which it reaches its own
TDC. In the engine's frame (``y`` vertical towards the heads' middle, ``x`` across, towards where the
crank pin goes just after it passes the vertical) a cylinder whose axis leans by ``p`` from the
vertical towards ``+x`` has its ``y`` along ``(sin p, cos p)`` and its ``x`` along ``(cos p, -sin p)``,
so its force is

    F_engine = F_x (cos p, -sin p) + F_y (sin p, cos p),

and, the crank turning from the vertical, it reaches its TDC at crank angle ``p`` plus its throw's
angle (and, on a four-stroke, the revolution of its firing). These linear maps act on the order
coefficients as they act on the forces in time. The free forces are their sum; the free moments, as
:mod:`monitor.model.predicted` gives an in-line engine's, each force times its cylinder's distance
along the shaft from the engine's middle (``vertical``: of the vertical forces, ``horizontal``: of
the horizontal ones).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from monitor.errors import ModelError
from monitor.model.banks import to_engine_frame
from monitor.model.crankshaft import phase_shift
from monitor.types import ComplexArray, FloatArray

__all__ = ["VeeFree", "vee_free_forces"]


@dataclass(frozen=True)
class VeeFree:
    """A V engine's free forces and moments, order by order.

    Attributes
    ----------
    orders : ndarray
        [-].
    force : ndarray, complex, shape (2, n_orders)
        Horizontal (``x``) and vertical (``y``) free force [N].
    moment : ndarray, complex, shape (2, n_orders)
        Of the vertical forces, and of the horizontal ones, about the engine's middle [N m].
    """

    orders: FloatArray
    force: ComplexArray
    moment: ComplexArray


def vee_free_forces(
    cylinder: npt.ArrayLike,
    orders: npt.ArrayLike,
    *,
    tdc_angles: npt.ArrayLike,
    axis_angles: npt.ArrayLike,
    positions: npt.ArrayLike,
) -> VeeFree:
    """Sum one cylinder's forces over a V engine's cylinders (module docstring).

    Parameters
    ----------
    cylinder : array_like, complex, shape (2, n_orders)
        One cylinder's force across (``x``) and along (``y``) its own axis, at its own crank angle
        from its TDC [N] (:func:`monitor.model.predicted.predict_orders`'s per cylinder, undelayed).
    orders : array_like, shape (n_orders,)
        [-].
    tdc_angles : array_like, shape (n_cylinders,)
        The crank angle at which each cylinder reaches its TDC (its firing TDC on a four-stroke),
        from the vertical [rad].
    axis_angles : array_like, shape (n_cylinders,)
        Each cylinder's axis from the vertical, towards ``+x`` [rad].
    positions : array_like, shape (n_cylinders,)
        Each cylinder's place along the shaft [m].

    Returns
    -------
    VeeFree

    Raises
    ------
    ModelError
        For arrays of other shapes, or non-finite angles and positions.
    """
    force = np.asarray(cylinder, dtype=np.complex128)
    k = np.asarray(orders, dtype=np.float64)
    tdc, axis, place = (np.asarray(a, dtype=np.float64) for a in (tdc_angles, axis_angles, positions))
    if force.shape != (2, k.size) or not (tdc.ndim == 1 and tdc.shape == axis.shape == place.shape):
        raise ModelError(
            f"V engine forces: one cylinder's shape {force.shape} for {k.size} orders, {tdc.shape} TDC "
            f"angles, {axis.shape} axes, {place.shape} positions: expected (2, orders) and one of each "
            "per cylinder"
        )
    if not (np.all(np.isfinite(tdc)) and np.all(np.isfinite(axis)) and np.all(np.isfinite(place))):
        raise ModelError("V engine forces: expected finite TDC angles, axis angles and positions")
    delayed = phase_shift(force, k, tdc)  # (n_cyl, 2, n_orders), each in its own frame
    turned = to_engine_frame(delayed, axis)
    horizontal, vertical = turned[:, 0, :], turned[:, 1, :]
    lever = (place - place.mean())[:, None]
    return VeeFree(
        orders=k,
        force=np.stack([horizontal.sum(axis=0), vertical.sum(axis=0)]),
        moment=np.stack([(lever * vertical).sum(axis=0), (lever * horizontal).sum(axis=0)]),
    )
