"""A V engine's free forces and moments, against closed-form balance results and a direct numerical sum.

The cylinders here carry a reciprocating mass only (the balance textbooks' "unbalanced reciprocating
forces"), so the results are the classical ones, derived again in each test's docstring:

- 90 deg V-twin on one crank pin: a primary force of constant size ``m r w^2`` that turns with the
  crank (balanceable by a counterweight), and a secondary force ``sqrt(2) lambda m r w^2``, horizontal;
- 90 deg V8 with a cross-plane crank: no primary or secondary force, no secondary moment, and a primary
  moment of constant size ``sqrt(10) m r w^2 a`` that turns with the crank (``a`` the throws' spacing).

And for any V, the product's sum against a direct one: each piston pin's place in the engine's frame
from the geometry alone, its acceleration by spectral differentiation at a steady speed, the masses'
forces summed, their orders taken.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from monitor.errors import ModelError
from monitor.fourier import cycle_grid, order_coefficients
from monitor.model.kinematics import piston_x_derivatives
from monitor.model.vee import vee_free_forces

MASS, RADIUS, RATIO, SPEED = 50.0, 0.1, 0.25, 100.0  # [kg], [m], [-], [rad/s]
PRIMARY = MASS * RADIUS * SPEED**2  # m r w^2 [N]
GRID = 4096
ORDERS = np.arange(0.0, 9.0)


def _one_cylinder() -> np.ndarray:
    """One cylinder's reciprocating force on the engine, across and along its axis, at its own crank
    angle from TDC: ``m w^2 x''`` along it (x the piston's travel from TDC towards the crank)."""
    angle = cycle_grid(GRID, 1)
    _, _, second = piston_x_derivatives(angle, RADIUS, RATIO)
    rows = np.stack([np.zeros(GRID), MASS * SPEED**2 * second])
    return np.asarray(order_coefficients(rows, max_order=ORDERS[-1]).coefficients)


def _direct(tdc: np.ndarray, axis: np.ndarray, place: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The free force and moment summed directly: each piston pin at ``R cos t + sqrt(L^2 - R^2 sin^2 t)``
    along its axis (``t`` its crank angle from its TDC), accelerated twice by FFT, times ``-m``."""
    angle = cycle_grid(GRID, 1)
    rod = RADIUS / RATIO
    wave = np.fft.rfftfreq(GRID, d=1.0 / GRID)
    force = np.zeros((2, GRID))
    moment = np.zeros((2, GRID))
    for t0, p, z in zip(tdc, axis, place - place.mean(), strict=True):
        t = angle - t0
        height = RADIUS * np.cos(t) + np.sqrt(rod**2 - (RADIUS * np.sin(t)) ** 2)
        curvature = np.fft.irfft(-(wave**2) * np.fft.rfft(height), n=GRID)  # d2/dangle2
        pull = -MASS * SPEED**2 * curvature  # along the axis, on the engine
        xy = np.stack([pull * math.sin(p), pull * math.cos(p)])
        force += xy
        moment += z * xy[::-1]  # of the vertical forces, then of the horizontal ones
    coefficients = order_coefficients(np.concatenate([force, moment]), max_order=ORDERS[-1]).coefficients
    return coefficients[:2], coefficients[2:]


def _at(values: np.ndarray, order: float) -> np.ndarray:
    return values[..., int(np.argmin(np.abs(ORDERS - order)))]


def test_a_90_deg_v_twin_has_a_turning_primary_and_a_horizontal_secondary() -> None:
    """The cylinders at -45 and +45 deg on one pin reach TDC at crank angles -45 and +45 deg. Their
    primary forces ``m r w^2 cos(a -+ 45)`` along ``(-+sin 45, cos 45)`` add to ``m r w^2 (sin a,
    cos a)``: constant in size, turning with the crank. Their secondaries ``lambda m r w^2 cos(2a -+ 90)
    = -+lambda m r w^2 sin 2a`` cancel vertically and add horizontally to ``sqrt(2) lambda m r w^2
    sin 2a``. Tolerance: 1e-9 of the primary (the grid's aliasing is far below)."""
    half = math.radians(45.0)
    free = vee_free_forces(
        _one_cylinder(), ORDERS, tdc_angles=[-half, half], axis_angles=[-half, half], positions=[0.0, 0.0]
    )
    horizontal, vertical = _at(free.force, 1.0)
    assert abs(horizontal) == pytest.approx(PRIMARY, rel=1e-9)
    assert abs(vertical) == pytest.approx(PRIMARY, rel=1e-9)
    assert (
        abs(horizontal - 1j * vertical) < 1e-9 * PRIMARY or abs(horizontal + 1j * vertical) < 1e-9 * PRIMARY
    )
    horizontal2, vertical2 = _at(free.force, 2.0)
    assert abs(vertical2) < 1e-9 * PRIMARY
    # the exact slider-crank's second order is lambda (1 + lambda^2 / 4 + ...) of the primary
    assert abs(horizontal2) == pytest.approx(math.sqrt(2) * RATIO * PRIMARY, rel=0.02)


def test_a_90_deg_cross_plane_v8_has_only_a_turning_primary_moment_of_root_10() -> None:
    """Throws at 0, 90, 270 and 180 deg, a apart along the shaft, each with a cylinder of each bank:
    each throw's primary pair turns as the V-twin's, at the throw's angle, so the primary forces
    sum as ``exp(-i theta)`` over the throws, 1 - i + i - 1 = 0, and the moments as ``z exp(-i theta)``
    = -1.5 + 0.5 i + 0.5 i - 1.5 = -3 + i times a: of size sqrt(10) a m r w^2. The secondaries go as
    ``exp(-2 i theta)`` = 1, -1, -1, 1: no force, and no moment (-1.5 + 0.5 - 0.5 + 1.5 = 0)."""
    spacing = 0.5
    throws = np.radians([0.0, 90.0, 270.0, 180.0])
    half = math.radians(45.0)
    axes = np.array([-half, half] * 4)
    tdc = np.repeat(throws, 2) + axes
    place = np.repeat(spacing * np.arange(4.0), 2)
    free = vee_free_forces(_one_cylinder(), ORDERS, tdc_angles=tdc, axis_angles=axes, positions=place)
    for order in (1.0, 2.0):
        assert np.all(np.abs(_at(free.force, order)) < 1e-9 * PRIMARY)
    assert np.all(np.abs(_at(free.moment, 2.0)) < 1e-9 * PRIMARY * spacing)
    about_vertical_forces, about_horizontal_forces = _at(free.moment, 1.0)
    assert abs(about_vertical_forces) == pytest.approx(math.sqrt(10) * PRIMARY * spacing, rel=1e-9)
    assert abs(about_horizontal_forces) == pytest.approx(math.sqrt(10) * PRIMARY * spacing, rel=1e-9)


@settings(max_examples=40, deadline=None)
@given(
    bank=st.floats(math.radians(30.0), math.radians(120.0)),
    throws=st.lists(st.floats(0.0, 2 * math.pi), min_size=1, max_size=8),
)
def test_any_v_agrees_with_the_direct_sum(bank: float, throws: list[float]) -> None:
    """Any bank angle from 30 to 120 deg, any throws (angles, one cylinder of each bank on each, 0.4 m
    apart): the product's forces and moments at orders 0 to 8 agree with the direct sum to 1e-9 of
    the primary (the spectral derivative of the smooth place is exact to round-off on this grid)."""
    axes = np.array([-bank / 2, bank / 2] * len(throws))
    tdc = np.repeat(throws, 2) + axes
    place = np.repeat(0.4 * np.arange(len(throws), dtype=float), 2)
    free = vee_free_forces(_one_cylinder(), ORDERS, tdc_angles=tdc, axis_angles=axes, positions=place)
    force, moment = _direct(tdc, axes, place)
    np.testing.assert_allclose(free.force, force, rtol=0, atol=1e-9 * PRIMARY)
    np.testing.assert_allclose(free.moment, moment, rtol=0, atol=1e-9 * PRIMARY)


def test_shapes_that_do_not_fit_are_refused() -> None:
    with pytest.raises(ModelError, match=r"expected \(2, orders\) and one of each per cylinder"):
        vee_free_forces(_one_cylinder(), ORDERS, tdc_angles=[0.0], axis_angles=[0.0, 1.0], positions=[0.0])
    with pytest.raises(ModelError, match="finite"):
        vee_free_forces(_one_cylinder(), ORDERS, tdc_angles=[math.nan], axis_angles=[0.0], positions=[0.0])
