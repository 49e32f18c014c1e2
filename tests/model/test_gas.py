"""Cylinder pressure: the parametric cycle against an ODE route, IMEP calibration, measured traces."""

from __future__ import annotations

import csv
import dataclasses
import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from monitor.errors import ModelError
from monitor.model.articulated import ArticulatedRod
from monitor.model.engine import load_engine
from monitor.model.gas import ParametricCycle, gas_force, indicated_mean_effective_pressure, resample_trace
from monitor.model.kinematics import piston_displacement
from tests.conftest import shared_path


def _slave_cycle() -> ParametricCycle:
    """The 6L32's cycle on the volume of an articulated rod's slave (knuckle pin a quarter of the rod
    from the crank pin, V of 45 degrees): a longer stroke and a TDC away from the bank angle."""
    master = ParametricCycle.of(load_engine("medium-speed-6l32"))
    length = master.crank_radius / master.rod_ratio
    rod = ArticulatedRod(
        master.crank_radius, length, length / 4, math.radians(45.0), 0.75 * length, math.radians(45.0)
    )
    tdc = rod.stroke().tdc_angle
    return dataclasses.replace(master, displacement=lambda theta: rod.slave_displacement(theta + tdc))


@pytest.fixture(params=["man-b-w-7k98mc", "medium-speed-6l32", "kluczyk-1cyl-4stroke", "articulated slave"])
def cycle(request: pytest.FixtureRequest) -> ParametricCycle:
    if request.param == "articulated slave":
        return _slave_cycle()
    return ParametricCycle.of(load_engine(request.param))


def test_a_displacement_given_as_the_slider_cranks_is_the_default_volume() -> None:
    """The displacement hook with the slider-crank's own displacement gives the same volume (to
    round-off), and an articulated slave's, longer in stroke, a higher compression ratio on the same
    clearance volume."""
    master = ParametricCycle.of(load_engine("medium-speed-6l32"))
    same = dataclasses.replace(
        master, displacement=lambda theta: piston_displacement(theta, master.crank_radius, master.rod_ratio)
    )
    grid = np.linspace(0.0, 4 * math.pi, 721)
    np.testing.assert_allclose(same.volume(grid), master.volume(grid), rtol=1e-14)
    slave = _slave_cycle()
    clearance = float(master.volume(0.0))
    assert float(slave.volume(0.0)) == pytest.approx(clearance, rel=1e-12)  # at its own TDC
    ratio = float(slave.volume(grid).max()) / clearance
    assert ratio > master.combustion.compression_ratio


def test_closed_cycle_matches_first_law_ode(cycle: ParametricCycle) -> None:
    """The closed form p V^n = p0 V0^n + (n-1) Q int V^(n-1) dx_b against the ODE solved by LSODA-free RK.

    dp/dtheta = -n p V'/V + (n - 1) Q x_b'/V, integrated with solve_ivp (DOP853,
    rtol 1e-11) from inlet closing to exhaust opening, V' by central differences
    of the exact volume (step 1e-6 rad).
    """
    c = cycle.combustion
    load = 0.8
    q_tot = cycle.heat_release(load)
    p_ic = cycle.charge_pressure(load)
    ic, soc, eo = (
        math.radians(v) for v in (c.inlet_closing_deg, c.combustion_start_deg, c.exhaust_opening_deg)
    )

    def rhs(theta: float, p: np.ndarray) -> np.ndarray:
        h = 1e-6
        v = float(cycle.volume(theta))
        dv = float(cycle.volume(theta + h) - cycle.volume(theta - h)) / (2 * h)
        n = c.polytropic_compression if theta < soc else c.polytropic_expansion
        burn = float(cycle._burn_rate(np.array([theta]))[0]) if theta >= soc else 0.0
        return np.array([-n * p[0] * dv / v + (n - 1) * q_tot * burn / v])

    checkpoints = np.linspace(ic + 0.01, eo - 0.01, 25)
    first = solve_ivp(rhs, (ic, soc), [p_ic], method="DOP853", rtol=1e-11, atol=1e-3, dense_output=True)
    second = solve_ivp(
        rhs,
        (soc, eo),
        [first.y[0, -1]],
        method="DOP853",
        rtol=1e-11,
        atol=1e-3,
        dense_output=True,
        max_step=0.01,
    )
    reference = np.where(checkpoints < soc, first.sol(checkpoints)[0], second.sol(checkpoints)[0])
    ours = cycle.pressure(checkpoints, load)
    np.testing.assert_allclose(ours, reference, rtol=2e-7)


def test_imep_equals_load_times_rated(cycle: ParametricCycle) -> None:
    """Calibration: IMEP from an independent fine grid (0.05 deg) is load x rated IMEP within 0.05 %."""
    grid = np.linspace(0, 2 * np.pi * cycle.cycle_revolutions, 7200 * cycle.cycle_revolutions, endpoint=False)
    volume = cycle.volume(grid)
    for load in (0.25, 0.5, 1.0):
        imep = indicated_mean_effective_pressure(cycle.pressure(grid, load), volume)
        assert imep == pytest.approx(load * cycle.combustion.rated_imep_bar * 1e5, rel=5e-4)


def test_pressure_is_continuous_and_periodic(cycle: ParametricCycle) -> None:
    period = 2 * np.pi * cycle.cycle_revolutions
    grid = np.linspace(0, period, 200_001)
    p = cycle.pressure(grid, 1.0)
    assert p[0] == pytest.approx(p[-1], rel=1e-12)
    jumps = np.abs(np.diff(p)) / p.max()
    assert jumps.max() < 2e-3  # largest step between points 0.0018 deg apart (steepest rise)
    assert np.all(p > 0)


def test_peak_pressure_rises_with_load() -> None:
    cycle = ParametricCycle.of(load_engine("man-b-w-7k98mc"))
    grid = np.linspace(0, 2 * np.pi, 3600, endpoint=False)
    peaks = [cycle.pressure(grid, load).max() for load in (0.0, 0.25, 0.5, 0.75, 1.0)]
    assert np.all(np.diff(peaks) > 0)
    assert 120e5 < peaks[-1] < 180e5  # a K98-class engine: about 140-150 bar at rated load


def test_load_out_of_range_is_refused() -> None:
    cycle = ParametricCycle.of(load_engine("man-b-w-7k98mc"))
    for load in (-0.1, 1.5, float("nan")):
        with pytest.raises(ModelError, match=r"expected 0 <= load <= 1\.1"):
            cycle.pressure(np.zeros(3), load)


def test_gas_force_sign_and_scale() -> None:
    force = gas_force([1.013e5, 2.013e5], 0.5, 1.013e5)
    np.testing.assert_allclose(force, [0.0, 0.5e5])


def test_resampled_trace_reproduces_a_known_cycle() -> None:
    """A trace sampled irregularly (0.5-1.5 deg apart) resamples within 0.3 % of peak, without overshoot."""
    cycle = ParametricCycle.of(load_engine("medium-speed-6l32"))
    rng = np.random.default_rng(7)
    steps = np.radians(rng.uniform(0.5, 1.5, 1000))
    angles = np.cumsum(steps)
    angles = angles[angles < 4 * np.pi]
    trace = cycle.pressure(angles, 1.0)
    fine = np.linspace(0, 4 * np.pi, 14400, endpoint=False)
    resampled = resample_trace(angles, trace, fine, cycle_revolutions=2)
    truth = cycle.pressure(fine, 1.0)
    assert np.max(np.abs(resampled - truth)) < 3e-3 * truth.max()
    assert resampled.max() <= trace.max() * (1 + 1e-12)
    np.testing.assert_allclose(resample_trace(angles, trace, angles, cycle_revolutions=2), trace, rtol=1e-12)


def test_trace_with_a_gap_is_refused() -> None:
    angles = np.radians(np.concatenate([np.arange(0, 200, 5.0), np.arange(260, 360, 5.0)]))
    with pytest.raises(ModelError, match=r"leaves 65.0 deg uncovered after 195.0 deg"):
        resample_trace(angles, np.ones_like(angles), [0.0], cycle_revolutions=1)


def test_real_digitised_trace_of_a_six_cylinder_diesel() -> None:
    """openTorsion's digitised diesel pressure curve (../shared/external/opentorsion, MIT).

    Firing TDC at 360 deg of its 0-720 deg axis; the curve peaks at 15.2 (the
    source normalises by that). The monotone resampling must keep the peak
    value and place it at the digitised peak's angle.
    """
    path = shared_path("external", "opentorsion", "pressure_data.csv")
    with path.open() as handle:
        rows = [tuple(float(v) for v in row[0].split(";")) for row in csv.reader(handle) if row]
    angle_deg = np.array([r[0] for r in rows]) - 360.0
    value = np.array([r[1] for r in rows])
    fine = np.radians(np.arange(-360.0, 360.0, 0.1))
    out = resample_trace(np.radians(angle_deg), value, fine, cycle_revolutions=2, max_gap=math.radians(130))
    assert value.max() * (1 - 1e-4) <= out.max() <= value.max()  # no overshoot at the peak
    own = resample_trace(
        np.radians(angle_deg), value, np.radians(angle_deg), cycle_revolutions=2, max_gap=math.radians(130)
    )
    np.testing.assert_allclose(own[1:-1], value[1:-1], rtol=1e-12)
    # its first and last points are the same angle (0 and 720 deg) with different values: averaged
    assert own[0] == own[-1] == pytest.approx(0.5 * (value[0] + value[-1]), rel=1e-12)
    assert math.degrees(fine[np.argmax(out)]) == pytest.approx(angle_deg[np.argmax(value)], abs=0.1)
    assert np.all(out >= value.min() - 1e-12)
