"""Slider-crank kinematics against independent routes.

Independent routes used here:
- mpmath at 50 digits, differentiating the displacement formula (000 eq. 2-3)
  numerically, so the analytic derivatives are checked against nothing but
  the geometry;
- the two-term approximation's closed form (000 eq. 5, 7, 9);
- paper 000's published comparison for the 7K98MC (lambda = 0.413, 104 rpm);
- property tests (hypothesis) for symmetry, bounds and hard cases.
"""

from __future__ import annotations

import math

import mpmath
import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from monitor.errors import ModelError
from monitor.model import kinematics as kin

mpmath.mp.dps = 50

R_7K98 = 2.66 / 2  # crank radius of the 7K98MC [m] (stroke 2660 mm)
LAMBDA_7K98 = 0.413  # paper 000
OMEGA_7K98 = 104 * math.pi / 30  # 104 rpm [rad/s]


def _x_mp(alpha: mpmath.mpf, radius: float, lam: float) -> mpmath.mpf:
    """Piston displacement from the geometry alone (000 eq. 2, 3), in mpmath."""
    rod = mpmath.mpf(radius) / mpmath.mpf(lam) if lam else None
    if rod is None:
        return mpmath.mpf(radius) * (1 - mpmath.cos(alpha))
    sin_beta = mpmath.mpf(lam) * mpmath.sin(alpha)
    return mpmath.mpf(radius) * (1 - mpmath.cos(alpha)) + rod * (1 - mpmath.sqrt(1 - sin_beta**2))


def _reference(alpha: float, radius: float, lam: float) -> tuple[float, float, float]:
    a = mpmath.mpf(alpha)
    return tuple(float(mpmath.diff(lambda t: _x_mp(t, radius, lam), a, n)) for n in (0, 1, 2))


ANGLES = [0.0, 0.1, 0.7, 1.2, math.pi / 2, 2.0, 3.0, math.pi, 4.0, 5.5, 1e-9, math.pi / 2 + 1e-7]


@pytest.mark.parametrize("lam", [0.0, 0.25, LAMBDA_7K98, 0.8, 0.99, 0.999999])
def test_displacement_and_derivatives_match_mpmath(lam: float) -> None:
    """x, dx/da, d2x/da2 agree with 50-digit numerical derivatives of eq. 2-3.

    Tolerance: 1e-13 relative to the natural scale of each quantity, which is
    R for x and dx, and R / c^3 for d2x where c = cos(beta) (the second
    derivative is a difference of terms of that size; the rounding of the
    input angle alone perturbs it by about eps / c^3 relative).
    """
    for alpha in ANGLES:
        x, dx, d2x = kin.piston_x_derivatives(np.array([alpha]), R_7K98, lam)
        rx, rdx, rd2x = _reference(alpha, R_7K98, lam)
        c = float(kin.cos_rod_angle(alpha, lam))
        assert abs(x[0] - rx) <= 1e-13 * R_7K98, (alpha, lam)
        assert abs(dx[0] - rdx) <= 1e-13 * R_7K98 / c, (alpha, lam)
        assert abs(d2x[0] - rd2x) <= 1e-13 * R_7K98 / c**3, (alpha, lam, d2x[0], rd2x)


def test_lambda_near_one_at_ninety_degrees_is_finite_and_accurate() -> None:
    """lambda = 0.999999 at exactly 90 deg: cos(beta) = sqrt(1 - lambda^2) ~ 1.4e-3.

    The direct form 1 - lambda^2 sin^2(a) loses about 6 digits here; the
    rewritten form keeps full relative precision (checked at 1e-14).
    """
    lam = 0.999999
    alpha = math.pi / 2
    c = float(kin.cos_rod_angle(alpha, lam))
    exact_c = float(mpmath.sqrt(1 - mpmath.mpf(lam) ** 2 * mpmath.sin(mpmath.mpf(alpha)) ** 2))
    assert c == pytest.approx(exact_c, rel=1e-14)
    x, dx, d2x = kin.piston_x_derivatives(alpha, 1.0, lam)
    rx, rdx, rd2x = _reference(alpha, 1.0, lam)
    assert np.isfinite([x, dx, d2x]).all()
    assert x == pytest.approx(rx, rel=1e-13)
    assert dx == pytest.approx(rdx, rel=1e-13)
    assert d2x == pytest.approx(rd2x, rel=1e-10)


def test_approximation_is_second_order_in_lambda() -> None:
    """The two-term forms differ from the exact ones by O(lambda^3) in acceleration.

    The x and acceleration errors divided by lambda^3 (x: lambda^3 / 8 sin^4 a
    leading term) tend to a finite limit as lambda -> 0.
    """
    alpha = np.linspace(0, 2 * np.pi, 721)
    ratios = []
    for lam in (1e-2, 5e-3, 2.5e-3):
        exact = kin.piston_x_derivatives(alpha, 1.0, lam)
        approx = kin.piston_x_derivatives_approx(alpha, 1.0, lam)
        ratios.append(np.max(np.abs(exact[0] - approx[0])) / lam**3)
    assert ratios[0] == pytest.approx(1 / 8, rel=0.02)
    assert ratios[2] == pytest.approx(1 / 8, rel=0.005)


def test_paper_000_approximation_error_for_7k98mc() -> None:
    """Paper 000 (section 3, Fig. 6-7): exact vs approximate acceleration, 7K98MC at 104 rpm.

    The paper states an absolute error over 5 m/s^2, about 3 % of the peak,
    peak acceleration up to 200 m/s^2 (read from Fig. 6: about 220). We find
    the largest difference at 90 deg: R omega^2 lambda (1/sqrt(1-lambda^2) - 1).
    """
    alpha = np.linspace(0, 2 * np.pi, 3601)
    exact = kin.piston_acceleration(alpha, OMEGA_7K98, R_7K98, LAMBDA_7K98)
    approx = kin.piston_acceleration_approx(alpha, OMEGA_7K98, R_7K98, LAMBDA_7K98)
    diff = np.max(np.abs(exact - approx))
    peak = np.max(np.abs(exact))
    closed_form = R_7K98 * OMEGA_7K98**2 * LAMBDA_7K98 * (1 / math.sqrt(1 - LAMBDA_7K98**2) - 1)
    assert diff > 5.0
    assert diff == pytest.approx(closed_form, rel=1e-6)
    assert 0.025 < diff / peak < 0.035
    assert 200 < peak < 230


def test_varying_speed_acceleration_matches_time_derivative() -> None:
    """With alpha(t) = w0 t + e t^2 / 2 the piston acceleration is d2x/dt2 (mpmath route)."""
    w0, eps, lam, radius = 12.0, 35.0, 0.45, 0.3
    for t in (0.0, 0.05, 0.13, 0.31):
        angle = w0 * t + 0.5 * eps * t * t
        speed = w0 + eps * t
        ours = kin.piston_acceleration(angle, speed, radius, lam, crank_acceleration=eps)
        ref = mpmath.diff(
            lambda tt: _x_mp(w0 * tt + mpmath.mpf(eps) * tt * tt / 2, radius, lam), mpmath.mpf(t), 2
        )
        assert float(ours) == pytest.approx(float(ref), rel=1e-12, abs=1e-12)
        vel = kin.piston_velocity(angle, speed, radius, lam)
        ref_v = mpmath.diff(
            lambda tt: _x_mp(w0 * tt + mpmath.mpf(eps) * tt * tt / 2, radius, lam), mpmath.mpf(t), 1
        )
        assert float(vel) == pytest.approx(float(ref_v), rel=1e-12, abs=1e-12)


@pytest.mark.parametrize("lam", [0.1, 0.413, 0.9, 0.999999])
def test_rod_angle_derivatives_match_mpmath(lam: float) -> None:
    """beta = asin(lambda sin a); its derivatives against 50-digit numerical ones."""
    for alpha in ANGLES:
        beta, d1, d2 = kin.rod_angle_derivatives(alpha, lam)
        ref = [
            float(mpmath.diff(lambda t: mpmath.asin(lam * mpmath.sin(t)), mpmath.mpf(alpha), n))
            for n in (0, 1, 2)
        ]
        c = float(kin.cos_rod_angle(alpha, lam))
        assert beta == pytest.approx(ref[0], abs=1e-15)
        assert d1 == pytest.approx(ref[1], abs=1e-14 / c)
        assert d2 == pytest.approx(ref[2], abs=1e-13 / c**3)


def test_rod_cg_acceleration_matches_paper_003_vector_form() -> None:
    """Paper 003 eq. 2-5: r_cg = r2 e^{i th2} + r_d e^{i th3}, differentiated twice.

    We rebuild that vector in mpmath (crank pin plus the rod vector from the
    crank pin to the centre of gravity), differentiate it in time under a
    varying crank speed, and compare with the affine end-point route.
    """
    radius, lam, k = 0.5, 0.3, 0.35  # k: CG distance from the piston pin / rod length
    rod = radius / lam
    w0, eps = 9.0, -20.0

    def cg(t: mpmath.mpf) -> tuple[mpmath.mpf, mpmath.mpf]:
        a = w0 * t + mpmath.mpf(eps) * t * t / 2
        pin = (radius * mpmath.sin(a), radius * mpmath.cos(a))
        beta = mpmath.asin(lam * mpmath.sin(a))
        r_d = (1 - k) * rod  # from the crank pin to the centre of gravity, up the rod
        return pin[0] - r_d * mpmath.sin(beta), pin[1] + r_d * mpmath.cos(beta)

    for t in (0.0, 0.1, 0.27):
        angle, speed = w0 * t + 0.5 * eps * t * t, w0 + eps * t
        ax, ay = kin.rod_cg_acceleration(angle, speed, radius, lam, k, crank_acceleration=eps)
        ref_x = mpmath.diff(lambda tt: cg(tt)[0], mpmath.mpf(t), 2)
        ref_y = mpmath.diff(lambda tt: cg(tt)[1], mpmath.mpf(t), 2)
        assert float(ax) == pytest.approx(float(ref_x), rel=1e-12, abs=1e-11)
        assert float(ay) == pytest.approx(float(ref_y), rel=1e-12, abs=1e-11)


finite_angles = st.floats(min_value=-1e4, max_value=1e4, allow_nan=False)
rod_ratios = st.floats(min_value=0.0, max_value=0.999999999, exclude_max=False)


@given(alpha=finite_angles, lam=rod_ratios)
def test_properties_bounds_and_symmetry(alpha: float, lam: float) -> None:
    """For every lambda in [0, 1): x in [0, 2R]; x, d2x even and dx odd in alpha; all finite."""
    x, dx, d2x = kin.piston_x_derivatives(np.array([alpha, -alpha]), 1.0, lam)
    assert np.all(np.isfinite(np.concatenate([x, dx, d2x])))
    assert np.all((x >= 0) & (x <= 2.0 + 1e-15))
    assert x[0] == x[1]
    assert dx[0] == -dx[1]
    assert d2x[0] == d2x[1]


@given(lam=rod_ratios, omega=st.floats(min_value=0.0, max_value=kin.MAX_CRANK_SPEED))
def test_properties_speed_scaling(lam: float, omega: float) -> None:
    """Acceleration scales as omega^2 (speed near zero and very high speeds stay finite)."""
    alpha = np.linspace(0, 2 * np.pi, 7)
    a = kin.piston_acceleration(alpha, omega, 1.0, lam)
    assert np.all(np.isfinite(a))
    base = kin.piston_x_derivatives(alpha, 1.0, lam)[2]
    # below the normal range (omega^2 < 2e-308) IEEE subnormals keep fewer digits
    np.testing.assert_allclose(a, base * omega**2, rtol=1e-15, atol=np.finfo(float).tiny)


@pytest.mark.parametrize("lam", [1.0, 1.2, -0.1, float("nan"), float("inf")])
def test_rod_ratio_out_of_range_is_refused(lam: float) -> None:
    with pytest.raises(ModelError, match=r"rod_ratio = .*expected 0 <= rod_ratio < 1"):
        kin.piston_displacement(0.3, 1.0, lam)


def test_nan_angle_is_refused_with_its_position() -> None:
    with pytest.raises(ModelError, match=r"crank_angle has 1 non-finite value.*index 2"):
        kin.piston_acceleration([0.0, 1.0, float("nan")], 10.0, 1.0, 0.3)


@pytest.mark.parametrize("omega", [float("nan"), float("inf"), 1e6, -1e200])
def test_absurd_speed_is_refused(omega: float) -> None:
    with pytest.raises(ModelError, match="crank_speed"):
        kin.piston_acceleration([0.0], omega, 1.0, 0.3)


def test_empty_input_gives_empty_output() -> None:
    for function in (kin.piston_displacement, kin.piston_displacement_approx):
        assert function(np.array([]), 1.0, 0.3).shape == (0,)
    assert kin.piston_acceleration(np.array([]), 10.0, 1.0, 0.3).shape == (0,)
    assert kin.rod_angle(np.empty((0, 3)), 0.3).shape == (0, 3)


def test_output_rank_follows_input_rank() -> None:
    assert np.ndim(kin.piston_displacement(0.4, 1.0, 0.3)) == 0
    assert kin.piston_acceleration(np.zeros((2, 5)), 3.0, 1.0, 0.3).shape == (2, 5)
