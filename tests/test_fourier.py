"""Order coefficients: conventions, exact-kinematics orders against an mpmath route."""

from __future__ import annotations

import math

import mpmath
import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from monitor.errors import ModelError
from monitor.fourier import cycle_grid, order_coefficients, order_coefficients_of, synthesize
from monitor.model import kinematics as kin

LAMBDA = 0.413


def test_convention_amplitude_and_phase() -> None:
    """q = q0 + |Q_k| cos(k a + arg Q_k): a known signal gives back its amplitudes and phases."""
    alpha = cycle_grid(64)
    q = 2.0 + 3.0 * np.cos(alpha + 0.4) + 0.5 * np.cos(5 * alpha - 1.1)
    oc = order_coefficients(q, max_order=8)
    assert oc.coefficients[0] == pytest.approx(2.0)
    assert oc.amplitude[1] == pytest.approx(3.0) and oc.phase[1] == pytest.approx(0.4)
    assert oc.amplitude[5] == pytest.approx(0.5) and oc.phase[5] == pytest.approx(-1.1)
    np.testing.assert_allclose(np.delete(oc.amplitude, [0, 1, 5]), 0.0, atol=1e-14)
    np.testing.assert_allclose(synthesize(oc, alpha), q, atol=1e-13)


def test_four_stroke_cycle_has_half_orders() -> None:
    alpha = cycle_grid(128, cycle_revolutions=2)
    q = np.cos(0.5 * alpha + 0.2) + np.cos(1.5 * alpha)
    oc = order_coefficients(q, cycle_revolutions=2, max_order=3)
    np.testing.assert_allclose(oc.orders, np.arange(0, 3.01, 0.5))
    assert oc.amplitude[1] == pytest.approx(1.0) and oc.phase[1] == pytest.approx(0.2)
    assert oc.amplitude[3] == pytest.approx(1.0)


def _mp_order(k: int, lam: float) -> complex:
    """Order k of d2x/da2 (R = 1) by 40-digit quadrature of the geometric definition."""
    mpmath.mp.dps = 40

    def d2x(t: mpmath.mpf) -> mpmath.mpf:
        return mpmath.diff(
            lambda u: (1 - mpmath.cos(u)) + (1 - mpmath.sqrt(1 - (lam * mpmath.sin(u)) ** 2)) / lam, t, 2
        )

    # Even function of alpha: the coefficient is real. Use the closed-form
    # second derivative inside quad for speed, but cross-check it once against diff.
    def d2x_closed(t: mpmath.mpf) -> mpmath.mpf:
        s, c = mpmath.sin(t), mpmath.cos(t)
        cb = mpmath.sqrt(1 - (lam * s) ** 2)
        return c + lam * mpmath.cos(2 * t) / cb + lam**3 * mpmath.sin(2 * t) ** 2 / (4 * cb**3)

    assert abs(d2x(mpmath.mpf("0.7")) - d2x_closed(mpmath.mpf("0.7"))) < mpmath.mpf(10) ** -15
    value = mpmath.quad(lambda t: d2x_closed(t) * mpmath.cos(k * t), [0, mpmath.pi / 2, mpmath.pi])
    return complex(2 * value / mpmath.pi)


def test_exact_acceleration_orders_match_mpmath_quadrature() -> None:
    """7K98MC at 104 rpm: orders 1, 2, 4, 6, 8 of the exact piston acceleration within
    1e-9 m/s^2 of an independent route.

    Independent route: 40-digit Gauss quadrature of paper 000 eq. 10 (whose
    closed form is itself checked against mpmath.diff of eq. 2-3), times R omega^2.
    """
    radius, omega = 1.33, 104 * math.pi / 30
    oc = order_coefficients_of(
        lambda a: kin.piston_acceleration(a, omega, radius, LAMBDA), max_order=12, tolerance=1e-14
    )
    for k in (1, 2, 4, 6, 8):
        ref = _mp_order(k, LAMBDA) * radius * omega**2
        assert abs(oc.coefficients[k] - ref) < 1e-9, k
    oc = order_coefficients_of(
        lambda a: kin.piston_x_derivatives(a, 1.0, LAMBDA)[2], max_order=12, tolerance=1e-14
    )
    assert abs(oc.coefficients[4]) > 1e-3  # order 4 present (about 0.4 % of R omega^2)
    assert abs(oc.coefficients[6]) > 1e-5
    assert abs(oc.coefficients[8]) > 1e-7
    # odd orders above 1 vanish: the function is symmetric about 90 deg up to the cos a term
    np.testing.assert_allclose(np.abs(oc.coefficients[3::2]), 0.0, atol=1e-14)
    assert float(np.max(oc.aliasing_error)) < 1e-13


def test_approximate_acceleration_has_only_orders_one_and_two() -> None:
    oc = order_coefficients(kin.piston_x_derivatives_approx(cycle_grid(256), 1.0, LAMBDA)[2])
    assert oc.coefficients[1] == pytest.approx(1.0)
    assert oc.coefficients[2] == pytest.approx(LAMBDA)
    np.testing.assert_allclose(np.abs(oc.coefficients[3:]), 0.0, atol=1e-14)


def test_truncation_error_bounds_the_reconstruction() -> None:
    """Keeping orders up to K reproduces the function within the reported truncation error."""
    alpha = cycle_grid(512)
    q = kin.piston_x_derivatives(alpha, 1.0, 0.9)[2]
    for k in (4, 8, 16):
        oc = order_coefficients(q, max_order=k)
        err = np.max(np.abs(synthesize(oc, alpha) - q))
        assert err <= oc.truncation_error * (1 + 1e-12) + 1e-14
        assert err >= 0.2 * oc.truncation_error  # the bound is not vacuous


def test_tolerance_not_reached_is_an_error() -> None:
    with pytest.raises(ModelError, match="did not reach tolerance"):
        order_coefficients_of(lambda a: np.abs(np.sin(a)), max_order=4, tolerance=1e-15, max_grid_size=4096)


@pytest.mark.parametrize(
    ("samples", "message"),
    [
        (np.array([]), "expected at least 4"),
        (np.ones(7), "even number"),
        (np.array([1.0, np.nan, 0.0, 1.0]), "NaN or Inf"),
    ],
)
def test_bad_samples_are_refused(samples: np.ndarray, message: str) -> None:
    with pytest.raises(ModelError, match=message):
        order_coefficients(samples)


def test_max_order_beyond_grid_is_refused() -> None:
    with pytest.raises(ModelError, match="resolves orders up to 3"):
        order_coefficients(np.ones(16), max_order=5)
    with pytest.raises(ModelError, match=r"multiple of 0\.5"):
        order_coefficients(np.ones(16), cycle_revolutions=2, max_order=1.25)


@given(
    amplitude=st.floats(0.0, 1e6),
    phase=st.floats(-math.pi + 1e-6, math.pi - 1e-6),
    order=st.integers(1, 30),
)
def test_round_trip_single_order(amplitude: float, phase: float, order: int) -> None:
    alpha = cycle_grid(128)
    oc = order_coefficients(amplitude * np.cos(order * alpha + phase))
    assert oc.amplitude[order] == pytest.approx(amplitude, rel=1e-12, abs=1e-9)
    if amplitude > 1e-6:
        assert math.remainder(oc.phase[order] - phase, 2 * math.pi) == pytest.approx(0.0, abs=1e-9)
