"""The crank-speed orders of an engine whose speed drifts (accelerating or slowing) are its periodic torque's.

Independent route: a rigid crank train of inertia ``J`` driven by a periodic torque plus a constant net
torque ``T_net`` (the engine accelerating after a load step) has, exactly,

    omega^2(theta) = Omega_0^2 + (2 / J) [sum_k (A_k / k) (sin(k theta + phi_k) - sin phi_k) + T_net theta]

so the time at each angle is ``integral dtheta / omega``, integrated here by Simpson's rule on a fine grid
(not by the product). A tooth wheel's pulses at those times give the angle map; the torque orders the
cylinder balance forms from the measured speed orders (``i k (J / 2) (omega^2)_k``) must be the periodic
torque's ``A_k exp(i phi_k)`` whatever ``T_net``. Each cycle's speed, taken as a periodic function of the
cycle, jumps by the drift across it: uncorrected, that sawtooth adds ``2 T_net`` to every torque order.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import cumulative_simpson

from monitor.diagnosis.balance import measured_torque
from monitor.signal.anglemap import AngleMap
from monitor.signal.crank_speed import crank_speed_spectra

INERTIA = 135.0  # [kg m^2]
OMEGA_0 = 60.0  # the speed at the first pulse [rad/s]
TORQUE = {0.5: 3.0e3, 1.5: 2.0e3, 3.0: 6.0e3}  # the periodic torque's orders: amplitude [N m]
PHASE = {0.5: 0.4, 1.5: -1.1, 3.0: 2.0}  # and phase [rad]
TEETH = 60  # pulses a revolution (an encoder-like wheel, no gap) [-]
CYCLES = 12  # four-stroke cycles recorded [-]


def _angle_map(net_torque: float) -> AngleMap:
    """Pulse times of the rigid crank train under the periodic torque plus ``net_torque`` [N m]."""
    fine = np.linspace(0.0, CYCLES * 4 * math.pi, CYCLES * 2 * TEETH * 64 + 1)
    periodic = sum((a / k) * (np.sin(k * fine + PHASE[k]) - math.sin(PHASE[k])) for k, a in TORQUE.items())
    omega = np.sqrt(OMEGA_0**2 + (2.0 / INERTIA) * (periodic + net_torque * fine))
    times = cumulative_simpson(1.0 / omega, x=fine, initial=0.0)
    return AngleMap(times=times[::64], angles=fine[::64])


def _torque_orders(net_torque: float) -> tuple[np.ndarray, np.ndarray, float]:
    """The torque orders formed from the measured speed orders: (orders, torque [N m], speed change [-])."""
    angle_map = _angle_map(net_torque)
    result = crank_speed_spectra(angle_map, TEETH, cycle_revolutions=2, block_cycles=1, max_order=6.0)
    assert result is not None
    speed, _ = result
    torque, _ = measured_torque(speed, INERTIA, 2)
    drift = float(angle_map.speed_at(angle_map.times[-1:])[0] / OMEGA_0 - 1.0)
    return speed.orders, torque, drift


@pytest.mark.parametrize("net_share", [0.0, 0.15, -0.11])
def test_an_accelerating_or_slowing_engine_shows_its_periodic_torque(net_share: float) -> None:
    net = net_share * TORQUE[3.0]
    orders, torque, drift = _torque_orders(net)
    if net_share:
        # the speed drifts by a quarter over the recording, as across a propeller engine's load step
        assert 0.2 < abs(drift) < 0.3
    expected = np.zeros(orders.size, dtype=complex)
    for k, a in TORQUE.items():
        expected[np.isclose(orders, k)] = a * np.exp(1j * PHASE[k])
    # what is left: the speed orders averaged over cycles at speeds a quarter apart, squared at their mean
    # speed (off by the cycles' relative speed variance, 0.6 % here), the drift's curvature within a cycle
    # (a ramp in omega^2 is a slightly bent one in omega) and the map's interpolation between 60 pulses a
    # revolution: within 1 % of the largest order; uncorrected, every order is off by 2 T_net, 30 % of it
    tolerance = 0.01 * max(TORQUE.values())
    error = np.abs(torque[1:] - expected[1:])
    assert error.max() < tolerance, (orders[1:][error >= tolerance], error.max())
