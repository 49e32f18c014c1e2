"""The crank's speed orders driven by a torque, as one rigid body, exactly (no small-fluctuation expansion).

The diagnosis predicts the crank-speed orders it compares with the measured ones from the model's
torque orders (:mod:`monitor.diagnosis.diagnose`); the energy equation
``1/2 J omega^2 = E0 + integral T dtheta`` is solved on the cycle for the mean speed measured.
"""

from __future__ import annotations

import math

import numpy as np

from monitor.fourier import order_coefficients
from monitor.types import ComplexArray, FloatArray

__all__ = ["predicted_speed"]


def predicted_speed(
    torque: ComplexArray,
    orders: FloatArray,
    inertia: float | ComplexArray,
    mean_speed: float,
    cycle_revolutions: int,
) -> ComplexArray:
    """Speed orders of a rigid body driven by a torque, exactly: ``omega = sqrt(c + 2 E / J)``.

    ``E`` is the torque's integral over the angle (order by order ``T_k / (i k)``) and ``c``
    is chosen so that the mean speed over the cycle is ``mean_speed``; with an inertia per order,
    ``E / J`` is formed order by order.

    Parameters
    ----------
    torque : ndarray, complex, shape (n_orders,)
        [N m] (order 0 ignored: the load takes the mean).
    orders : ndarray
    inertia : float or ndarray, complex, shape (n_orders,)
        The body's, or the inertia each order meets (order 0's unused) [kg m^2].
    mean_speed : float
        [rad/s]
    cycle_revolutions : int

    Returns
    -------
    ndarray, complex, shape (n_orders,)
        [rad/s], order 0 the mean speed.
    """
    highest = float(orders[-1])
    points = 2 ** math.ceil(math.log2(max(64, 8 * highest * cycle_revolutions)))
    theta = np.arange(points) * (2 * math.pi * cycle_revolutions / points)
    energy_orders = np.zeros(orders.size, dtype=np.complex128)
    met = np.broadcast_to(np.asarray(inertia), orders.shape)
    energy_orders[1:] = torque[1:] / (1j * orders[1:]) / met[1:]
    energy = np.real(np.exp(1j * np.multiply.outer(theta, orders)) @ energy_orders)  # E / J
    c = mean_speed**2
    for _ in range(50):  # Newton on the mean speed
        omega = np.sqrt(np.maximum(c + 2 * energy, 1e-12 * mean_speed**2))
        miss = float(omega.mean()) - mean_speed
        c -= miss / float(np.mean(0.5 / omega))
        if abs(miss) < 1e-13 * mean_speed:
            break
    omega = np.sqrt(np.maximum(c + 2 * energy, 1e-12 * mean_speed**2))
    out = order_coefficients(omega, cycle_revolutions=cycle_revolutions, max_order=highest).coefficients
    return np.asarray(out[: orders.size])
