"""The crank speed's and the crank's angular vibration's order spectra, from an angle map.

The speed is the angle map's derivative on a crank-angle grid of its own whole
cycles, at least twice as fine as the pulses (a 60-2 wheel: 128 points a
revolution), whatever the grid of the other channels: the map interpolates
between the pulses, so nothing above half the pulse rate is in it to alias.
An encoder of hundreds of pulses would need thousands of points a cycle: the
grid is capped at ``_SPEED_GRID_CAP`` and the speed taken as its mean over each
grid step, whose sinc is undone order by order.  The angular vibration is the
crank's angle lead over a uniform rotation at each cycle's own mean speed (see
:mod:`monitor.signal.measure`).

A speed that drifts (an engine accelerating or slowing after a load step, a run-up) is no periodic
function of the cycle: taken as one, each cycle jumps back at its end by the drift across it, a
sawtooth whose orders fall as ``1 / k``. The rigid crank train's torque ``T = (J / 2) d(omega^2)/dtheta``
turns it into ``2 T_net`` at every torque order, ``T_net`` the net torque that drives the drift: on a
propeller engine's load step as large as a cylinder's whole contribution. Each cycle's speed is taken
less a ramp of zero mean that rises across it by the drift, read from its neighbours' mean speeds
(their difference over two cycles, one-sided at the ends): what is periodic in the cycle is left, to the
drift's own curvature within a cycle (tests/signal/test_crank_speed_drift.py). On a steady run the
neighbours differ by the cycles' own scatter, which is no more periodic than the drift; where single
cycles' work scatters by several per cent (the real 4GB10's one cylinder) the standard errors of the
half orders about double (docs/load-response.md), and the half orders' agreement with the cylinder
pressure's prediction improves. A line through five cycles widened them by about half instead, but
missed the fast part of a slow engine's load step: weak cylinders at 80 % on the validation
population's load steps were named 14 and 15 times of 18 instead of 16 (make bench-diagnosis, both
ways).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from monitor.errors import SignalError
from monitor.signal.anglemap import AngleMap
from monitor.signal.grid import AngleGrid, angle_grid
from monitor.signal.spectrum import OrderSpectrum, OrderSpectrumStream
from monitor.types import FloatArray

__all__ = ["crank_speed_spectra"]

_SPEED_GRID_CAP = 2048  # most crank-speed grid points a cycle
_PART_CYCLES = 4096  # cycles transformed at a time


def crank_speed_spectra(
    angle_map: AngleMap,
    pulses_per_revolution: int,
    *,
    cycle_revolutions: int,
    block_cycles: int,
    max_order: float,
    known: Sequence[AngleGrid] = (),
) -> tuple[OrderSpectrum, OrderSpectrum] | None:
    """The crank speed's order spectrum [rad/s] and the angular vibration's [rad].

    Parameters
    ----------
    angle_map : AngleMap
    pulses_per_revolution : int
        Pulses the map is built from per revolution: it resolves speed orders below half of it.
    cycle_revolutions : int
        1 or 2.
    block_cycles : int
        Cycles per averaged block.
    max_order : float
        Highest order reported [-].
    known : sequence of AngleGrid, optional
        Grids of the same map already computed (their times are reused where they fit).

    Returns
    -------
    (OrderSpectrum, OrderSpectrum) or None
        None when the map covers less than one whole cycle.

    Raises
    ------
    SignalError
        When the map covers fewer cycles than a block.
    """
    # crank speed: the angle map's derivative on a grid of its own whole cycles. The map holds orders
    # below pulses / 2 per revolution: a grid of at least 2 R pulses per cycle (a power of two) has
    # its Nyquist order above them, whatever max_order and the channels' grid are
    m = 2 ** math.ceil(math.log2(max(16, 2 * cycle_revolutions * pulses_per_revolution)))
    # an encoder of hundreds of pulses would need thousands of points a cycle: the grid is capped,
    # and the speed taken as its mean over each grid step (below) so that nothing aliases
    stepped = m > _SPEED_GRID_CAP
    m = min(m, _SPEED_GRID_CAP)
    try:
        grid = angle_grid(
            angle_map,
            float(angle_map.times[0]),
            float(angle_map.times[-1]),
            samples_per_cycle=m,
            cycle_revolutions=cycle_revolutions,
            known=list(known),
        )
    except SignalError:
        return None
    if block_cycles > grid.cycles:
        raise SignalError(
            f"block_cycles = {block_cycles!r}: expected 1..{grid.cycles} (cycles in the crank speed)"
        )
    step = 2 * math.pi * cycle_revolutions / m  # crank angle between grid points [rad]
    if stepped:
        # the mean over each step, step / (time across it): the slowness averaged over the step in
        # angle, exactly; its orders come back scaled by sinc(k step / 2), delayed by half a step
        end = angle_map.time_at(np.array([(grid.first_cycle + grid.cycles) * step * m]))
        speed = (step / np.diff(np.concatenate([grid.times, end]))).reshape(grid.cycles, m)
    else:
        speed = angle_map.speed_at(grid.times).reshape(grid.cycles, m)
    # the map holds pulses_per_revolution samples of the speed per revolution: orders from
    # half of that up are not in it (a keyphasor gives the mean speed only)
    resolvable = max(min(max_order, 0.5 * pulses_per_revolution - 1e-9), 0.0)
    speed_stream, g_stream = (
        OrderSpectrumStream(m, cycle_revolutions, block_cycles=block_cycles, max_order=resolvable)
        for _ in range(2)
    )
    # angular vibration: lead = integral over the cycle of g = 1 - Omega_c / omega, Omega_c the
    # cycle's mean speed (g has zero mean over it); integrated order by order, g_k / (i k). Both
    # spectra are fed a part of the cycles at a time (no hour-long temporaries)
    speed = _without_drift(speed)
    for c0 in range(0, grid.cycles, _PART_CYCLES):
        part = speed[c0 : c0 + _PART_CYCLES]
        speed_stream.add(part)
        slowness = 1.0 / part
        g_stream.add(1.0 - slowness / slowness.mean(axis=1, keepdims=True))

    def unstepped(spectrum: OrderSpectrum) -> OrderSpectrum:
        if not stepped:
            return spectrum
        x = 0.5 * spectrum.orders * step
        gain = np.ones(x.size)
        gain[1:] = x[1:] / np.sin(x[1:])  # 1 / sinc: the steps' mean undone, order by order
        return OrderSpectrum(
            spectrum.orders,
            spectrum.amplitude * gain * np.exp(-1j * x),
            spectrum.magnitude_mean * gain,
            spectrum.magnitude_std * gain,
            spectrum.scatter * gain,
            spectrum.blocks,
            spectrum.block_cycles,
        )

    g = unstepped(g_stream.result())
    factor = np.zeros(g.orders.size)
    factor[1:] = 1.0 / g.orders[1:]
    lead = OrderSpectrum(
        g.orders,
        -1j * factor * g.amplitude,
        factor * g.magnitude_mean,
        factor * g.magnitude_std,
        factor * g.scatter,
        g.blocks,
        g.block_cycles,
    )
    return unstepped(speed_stream.result()), lead


def _without_drift(speed: FloatArray) -> FloatArray:
    """Each cycle's speed less the drift across it (module docstring).

    Parameters
    ----------
    speed : ndarray, shape (cycles, m)
        The speed on each whole cycle's grid [rad/s].

    Returns
    -------
    ndarray, shape (cycles, m)
        Each cycle less a ramp of zero mean over its grid, rising by the difference of its neighbours'
        mean speeds over two cycles (one-sided at the first and the last); unchanged for one cycle.
    """
    cycles, m = speed.shape
    if cycles < 2:
        return speed
    rise = np.gradient(speed.mean(axis=1))  # the drift across each cycle [rad/s]
    return speed - np.multiply.outer(rise, np.arange(m) / m - 0.5 + 0.5 / m)
