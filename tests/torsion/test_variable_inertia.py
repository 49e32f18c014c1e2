"""Variable-inertia crank (paper 002): Floquet stability, Table 1, responses, hard cases."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.integrate import solve_ivp
from scipy.signal import hilbert

from monitor.errors import ModelError
from monitor.model.crankshaft import EngineModel
from monitor.model.engine import load_engine
from monitor.model.predicted import predict_orders
from monitor.torsion.floquet import monodromy
from monitor.torsion.shaft_line import shaft_line_of
from monitor.torsion.stability import boundary_error, instability_ranges, stability_chart
from monitor.torsion.time_response import harmonic_content, simulate
from monitor.torsion.variable_inertia import (
    HarmonicExcitation,
    VariableInertiaCrank,
    crank_of_engine,
    gas_excitation,
)


def _reference_monodromy(eps: float, r: float, zeta: float = 0.0) -> np.ndarray:
    """Monodromy of eq. 6 in (gamma, gamma') by DOP853 at rtol 1e-13: an independent route."""

    def rhs(t: float, y: np.ndarray) -> np.ndarray:
        g, gp = y[:2], y[2:]
        j = 1 - eps * math.cos(2 * t)
        gpp = (
            -2 * eps * math.sin(2 * t) * gp - (1 / r**2 + 2 * eps * math.cos(2 * t)) * g - 2 * zeta / r * gp
        ) / j
        return np.concatenate([gp, gpp])

    sol = solve_ivp(rhs, (0, math.pi), [1, 0, 0, 1], method="DOP853", rtol=1e-13, atol=1e-15)
    return sol.y[:, -1].reshape(2, 2)


GREGORY = {  # paper 002 Table 1, Gregory's analysis: (r ~ 1/2 range), (r ~ 1 range)
    0.34: ((0.512, 0.516), (0.966, 1.168)),
    0.236: ((0.506, 0.508), (0.967, 1.09)),
}


@pytest.mark.parametrize("eps", sorted(GREGORY))
def test_table_1_instability_ranges_match_gregory(eps: float) -> None:
    """002 Table 1: both instability ranges, every boundary within 0.006 of Gregory's analysis.

    The method's own error (boundary bisected to 1e-10, trace to 1e-11) is
    far below the table's differences (the largest here is about 0.0045).
    """
    ranges = instability_ranges(eps, 0.45, 1.3)
    assert len(ranges) == 2
    for ours, theirs in zip(ranges, GREGORY[eps], strict=True):
        assert abs(ours[0] - theirs[0]) < 0.006 and abs(ours[1] - theirs[1]) < 0.006, (ours, theirs)


@pytest.mark.parametrize(("eps", "r"), [(0.34, 0.3), (0.34, 0.514), (0.236, 1.05), (0.6, 0.8), (0.1, 2.5)])
def test_magnus_monodromy_matches_an_ode_reference(eps: float, r: float) -> None:
    """Trace and the invariant trace/2 of the (gamma, J gamma') map against DOP853 in (gamma, gamma')."""
    ours = monodromy(eps, r, tolerance=1e-11)
    ref = _reference_monodromy(eps, r)
    assert float(ours.trace) == pytest.approx(np.trace(ref), abs=1e-9)  # the trace is coordinate-free
    assert float(ours.determinant) == pytest.approx(1.0, abs=1e-12)


@given(eps=st.floats(0.0, 0.95), r=st.floats(0.15, 3.0))
@settings(max_examples=40)
def test_undamped_monodromy_is_area_preserving(eps: float, r: float) -> None:
    """Hill equation: det = 1 (the multipliers are reciprocal), to round-off."""
    m = monodromy(eps, r, steps=256)
    assert float(m.determinant) == pytest.approx(1.0, abs=1e-12)


@pytest.mark.parametrize(("eps", "zeta"), [(0.0, 0.05), (0.34, 0.02), (0.8, 0.1)])
def test_damped_determinant_has_its_closed_form(eps: float, zeta: float) -> None:
    """Liouville: det = exp(int tr A) = exp(-(2 zeta / r) int_0^pi dtau / J)
    = exp(-2 zeta pi / (r sqrt(1 - eps^2)))."""
    r = 0.7
    m = monodromy(eps, r, zeta=zeta)
    assert float(m.determinant) == pytest.approx(
        math.exp(-2 * zeta * math.pi / (r * math.sqrt(1 - eps**2))), rel=1e-10
    )


def test_chart_and_long_simulations_agree_on_instability() -> None:
    """Points the chart calls unstable grow in a long direct integration (DOP853, not Magnus); stable ones
    stay bounded. Points within 0.05 of a boundary (in the Jury margin) are left out: a 60-revolution run
    cannot tell them apart."""
    chart = stability_chart(np.linspace(0.4, 1.3, 46), np.array([0.1, 0.236, 0.34, 0.5]))
    margin = 1.0 + 1.0 - np.abs(chart.trace)  # undamped: det = 1
    picks = []
    for wanted in (True, False):
        candidates = np.argwhere((chart.unstable == wanted) & (np.abs(margin) > 0.05))
        picks += [tuple(c) for c in candidates[np.linspace(0, len(candidates) - 1, 6).astype(int)]]
    for i, j in picks:
        crank = VariableInertiaCrank(float(chart.epsilon[i]), float(chart.r[j]))
        tau = np.linspace(0, 2 * math.pi * 60, 6001)
        try:
            out = simulate(crank, tau, integrator="DOP853", rtol=1e-9, atol=1e-12)
            grew = np.abs(out.gamma[-1000:]).max() > 50 * np.abs(out.gamma[:1000]).max()
        except ModelError:
            grew = True
        assert grew == bool(chart.unstable[i, j]), (chart.epsilon[i], chart.r[j])


def test_two_beats_per_revolution_at_low_speed_ratio() -> None:
    """002 Fig. 2-4: at r < 0.2 the response beats twice per revolution (envelope order 2)."""
    for eps, r in ((0.34, 1 / 12), (0.34, 1 / 10), (0.236, 1 / 12)):
        tau = np.linspace(0, 2 * math.pi * 64, 64 * 512, endpoint=False)
        out = simulate(VariableInertiaCrank(eps, r), tau)
        forced = simulate(VariableInertiaCrank(eps, r), tau, initial=(0.0, 0.0))  # the periodic forced part
        envelope = np.abs(hilbert(out.gamma - forced.gamma))
        spectrum = np.abs(np.fft.rfft(envelope - envelope.mean()))
        orders = np.fft.rfftfreq(tau.size, d=1 / 512)
        assert orders[np.argmax(spectrum)] == pytest.approx(2.0, abs=1 / 64)


def test_table_2_question_principal_order_and_sidebands() -> None:
    """002 Table 2 (r = 1/10, eps = 0.34): a principal order near 1/r with sidebands at +-2 and +-4.

    Independent route for the sideband amplitudes: the Floquet mode itself,
    exp(j nu tau) P(tau) with P of period pi, built from the fundamental
    solutions over one period and Fourier-analysed.  Its sideband ratios must
    match the spectrum of the long response (Hann window) within 3 %.
    """
    crank = VariableInertiaCrank(0.34, 0.1)
    content = harmonic_content(crank)
    nu = float(content["principal_order"])
    assert 10.0 < nu < 10.5
    amplitudes = content["amplitudes"]
    assert np.argmax(amplitudes) == 2  # the principal order dominates
    assert np.all(amplitudes[[0, 1, 3, 4]] > 0.02 * amplitudes[2])  # +-2 and +-4 are present

    def rhs(t: float, y: np.ndarray) -> np.ndarray:
        g, gp = y[:2], y[2:]
        j = 1 - 0.34 * math.cos(2 * t)
        return np.concatenate([gp, (-0.68 * math.sin(2 * t) * gp - (100 + 0.68 * math.cos(2 * t)) * g) / j])

    n = 512
    grid = np.linspace(0, math.pi, n + 1)
    sol = solve_ivp(rhs, (0, math.pi), [1, 0, 0, 1], method="DOP853", rtol=1e-12, atol=1e-14, t_eval=grid)
    fundamental = sol.y.reshape(2, 2, -1)  # (component, solution, time)
    values, vectors = np.linalg.eig(fundamental[:, :, -1])
    k = int(np.argmin(np.abs(np.angle(values) - math.remainder(nu * math.pi, 2 * math.pi))))
    mode = np.einsum("cst,s->t", fundamental[:1], vectors[:, k])[:-1]
    periodic = mode * np.exp(-1j * nu * grid[:-1])
    coefficients = np.fft.fft(periodic) / n  # component m at order nu + 2m
    floquet = np.abs(coefficients[[-2, -1, 0, 1, 2]])
    np.testing.assert_allclose(floquet / floquet[2], amplitudes / amplitudes[2], rtol=0.03)


def test_full_form_reduces_to_the_linear_one_at_small_amplitude() -> None:
    """Eq. 4 (full) and eq. 6 (linear) differ by terms of second order in gamma.

    The forced response (gamma = 0 at the start) is proportional to eps, and the
    neglected terms (eps gamma gamma'', eps gamma gamma', ...) are of order
    eps gamma^2 ~ eps^3: halving eps must divide the gap by about 8, while the
    response itself only halves.
    """
    tau = np.linspace(0, 2 * math.pi * 3, 3001)
    gaps, sizes = [], []
    for eps in (0.02, 0.01):
        crank = VariableInertiaCrank(eps, 0.3)
        options = dict(initial=(0.0, 0.0), integrator="DOP853", rtol=1e-13, atol=1e-16)
        full = simulate(crank, tau, form="full", **options)  # type: ignore[arg-type]
        linear = simulate(crank, tau, form="linear", **options)  # type: ignore[arg-type]
        gaps.append(np.abs(full.gamma - linear.gamma).max())
        sizes.append(np.abs(linear.gamma).max())
    assert sizes[0] / sizes[1] == pytest.approx(2.0, rel=0.05)
    assert 6.0 < gaps[0] / gaps[1] < 10.0
    assert gaps[0] < 0.01 * sizes[0]


def test_constant_inertia_forced_response_has_the_textbook_amplitude() -> None:
    """eps = 0: a damped oscillator; steady amplitude q / sqrt((1/r^2 - k^2)^2 + (2 zeta k / r)^2)."""
    q, k, r, zeta = 0.01, 3.0, 0.5, 0.05
    crank = VariableInertiaCrank(0.0, r, zeta=zeta, excitation=HarmonicExcitation((k,), (q,), (0.3,)))
    tau = np.linspace(0, 2 * math.pi * 400, 400 * 64 + 1)
    out = simulate(crank, tau, initial=(0.0, 0.0))
    last = slice(-64 * 10 - 1, -1)  # the last ten revolutions, whole periods of order 3
    steady = abs(2 * np.mean(out.gamma[last] * np.exp(-1j * k * tau[last])))
    assert steady == pytest.approx(q / math.hypot(1 / r**2 - k**2, 2 * zeta * k / r), rel=1e-6)


def test_periodic_propagation_matches_direct_integration() -> None:
    crank = VariableInertiaCrank(
        0.34, 0.1, excitation=HarmonicExcitation((1.0, 3.0), (0.002, 0.001), (0.0, 1.0))
    )
    tau = np.linspace(0, 2 * math.pi * 30, 3001)
    a = simulate(crank, tau)
    b = simulate(crank, tau, integrator="DOP853", rtol=1e-12, atol=1e-14)
    np.testing.assert_allclose(a.gamma, b.gamma, atol=1e-8)


def test_from_physical_units() -> None:
    crank = VariableInertiaCrank.from_physical(
        rotating_inertia=300.0,
        reciprocating_mass=9200.0,
        crank_radius=1.33,
        stiffness=2.0e9,
        crank_speed=104 * math.pi / 30,
        damping=1.0e5,
    )
    half = 0.5 * 9200 * 1.33**2
    assert crank.epsilon == pytest.approx(half / (300 + half))
    assert crank.r == pytest.approx((104 * math.pi / 30) / math.sqrt(2.0e9 / (300 + half)))
    assert crank.zeta == pytest.approx(1.0e5 / (2 * (300 + half) * math.sqrt(2.0e9 / (300 + half))))


# ----------------------------------------------------------------------------------- hard cases
@pytest.mark.parametrize("eps", [0.99, 0.999])
def test_epsilon_near_one(eps: float) -> None:
    """The inertia coefficient 1 - eps cos 2tau dips to 1 - eps: the step count adapts, det stays 1,
    and the trace agrees with the independent ODE route."""
    m = monodromy(eps, 0.7)
    assert np.isfinite(m.trace) and float(m.determinant) == pytest.approx(1.0, abs=1e-10)
    assert float(m.trace) == pytest.approx(np.trace(_reference_monodromy(eps, 0.7)), abs=1e-7)


def test_speed_ratio_exactly_on_a_boundary() -> None:
    """At a boundary the multipliers are double: the point is reported on the boundary, and the
    response grows linearly (Jordan block), not exponentially."""
    (_, _), (r_low, _) = instability_ranges(0.34, 0.45, 1.3, tolerance=1e-10)
    m = monodromy(0.34, r_low, tolerance=1e-12)
    assert bool(m.on_boundary) and not bool(m.unstable)
    tau = np.linspace(0, 2 * math.pi * 200, 20001)
    crank = VariableInertiaCrank(0.34, r_low)
    free = simulate(crank, tau, initial=(1e-3, 0.0)).gamma - simulate(crank, tau, initial=(0.0, 0.0)).gamma
    early = np.abs(free[1800:2001]).max()
    late = np.abs(free[19800:]).max()
    assert 2 < late / early < 15  # linear growth over 20 -> 200 revolutions is a factor of about 10


def test_very_small_speed_ratio() -> None:
    """r = 0.01: a hundred oscillations per revolution. Floquet and the periodic response stay accurate."""
    m = monodromy(0.34, 0.01)
    assert float(m.trace) == pytest.approx(np.trace(_reference_monodromy(0.34, 0.01)), abs=1e-6)
    tau = np.linspace(0, 2 * math.pi * 5, 20001)
    out = simulate(VariableInertiaCrank(0.34, 0.01), tau, initial=(1e-3, 0.0))
    assert np.all(np.isfinite(out.gamma)) and np.abs(out.gamma).max() < 2e-3


def test_long_run_stays_bounded_where_stable() -> None:
    """10 000 revolutions at a stable point: no growth beyond what the first 100 revolutions show."""
    crank = VariableInertiaCrank(0.34, 0.1)
    tau = np.linspace(0, 2 * math.pi * 10000, 500001)
    out = simulate(crank, tau)
    first = np.abs(out.gamma[:5001]).max()
    assert np.abs(out.gamma).max() <= 1.01 * first


def test_unstable_long_run_is_refused_before_overflow() -> None:
    crank = VariableInertiaCrank(0.34, 1.0)
    with pytest.raises(ModelError, match=r"overflowed after \d+ periods: the motion is unstable"):
        simulate(crank, np.linspace(0, 2 * math.pi * 5000, 1001))


@pytest.mark.parametrize(
    ("eps", "r", "message"),
    [
        (1.0, 0.5, "expected 0 <= epsilon < 1"),
        (1.2, 0.5, "expected 0 <= epsilon < 1"),
        (-0.1, 0.5, "expected 0 <= epsilon < 1"),
        (float("nan"), 0.5, "expected 0 <= epsilon < 1"),
        (0.3, 0.0, "expected a positive speed ratio"),
        (0.3, -1.0, "expected a positive speed ratio"),
    ],
)
def test_out_of_range_parameters_are_refused(eps: float, r: float, message: str) -> None:
    with pytest.raises(ModelError, match=message):
        VariableInertiaCrank(eps, r)
    with pytest.raises(ModelError, match=message):
        monodromy(eps, r)


def test_equivalent_crank_of_an_engine() -> None:
    """epsilon from one throw's inertias, r from a shaft-line mode (paper 002 eq. 5 in engine terms)."""

    e = load_engine("man-b-w-7k98mc")
    crank = crank_of_engine(e, e.rated_speed, mode=2)
    half = 0.5 * e.reciprocating_mass * e.crank_radius**2
    rotating = e.shaft_line.throw_inertia_kgm2 + e.rotating_rod_mass * e.crank_radius**2  # type: ignore[union-attr]
    assert crank.epsilon == pytest.approx(half / (rotating + half))
    assert crank.r == pytest.approx(e.rated_speed / shaft_line_of(e).modes().frequencies[1])
    with pytest.raises(ModelError, match=r"has modes 1\.\."):
        crank_of_engine(e, e.rated_speed, mode=99)


def test_gas_excitation_of_an_engine_drives_the_equivalent_crank() -> None:
    """The gas-torque orders in the crank's own angle (review finding: a cylinder's phase relative to
    cylinder 1 was put against the crank's own inertia variation). Every cylinder's torque, taken back
    to its own angle (times exp(+j k phi_c)), is the excitation; a constant-inertia crank (eps = 0) then
    responds at each order with the textbook amplitude."""

    e = load_engine("man-b-w-7k98mc")
    w = e.rated_speed
    excitation = gas_excitation(e, w, load=0.8, max_order=6)
    r2 = e.crank_radius**2
    j0 = e.shaft_line.throw_inertia_kgm2 + e.rotating_rod_mass * r2 + 0.5 * e.reciprocating_mass * r2  # type: ignore[union-attr]
    result = predict_orders(EngineModel(e), crank_speed=w, load=0.8, max_order=6)
    ours = np.array(excitation.amplitudes) * np.exp(1j * np.array(excitation.phases)) * w**2 * j0
    for c in range(e.cylinders):
        own_angle = result.cylinder_gas_torque[c, 1:] * np.exp(1j * result.orders[1:] * e.firing_angles[c])
        np.testing.assert_allclose(own_angle, ours, rtol=1e-9, atol=1e-9 * np.abs(ours).max())
    r, zeta = 0.35, 0.05
    crank = VariableInertiaCrank(0.0, r, zeta=zeta, excitation=excitation)
    tau = np.linspace(0, 2 * math.pi * 300, 300 * 64 + 1)
    out = simulate(crank, tau, initial=(0.0, 0.0))
    last = slice(-64 * 10 - 1, -1)
    for k, q in zip(excitation.orders, excitation.amplitudes, strict=True):
        steady = abs(2 * np.mean(out.gamma[last] * np.exp(-1j * k * tau[last])))
        assert steady == pytest.approx(q / math.hypot(1 / r**2 - k**2, 2 * zeta * k / r), rel=1e-5)


# ------------------------------------------------------------------- range search and step count
def _brute_force_ranges(eps: float, low: float, high: float, count: int) -> list[tuple[float, float]]:
    """Unstable runs of a uniform scan (public monodromy, 256 steps): the reference of the range search.

    Independent of the search's scan, golden section and bisection; a run's ends are within one
    scan spacing of the true boundaries (plus the 256-step Magnus error, below 1e-9 here).
    """
    r = np.linspace(low, high, count)
    unstable = monodromy(eps, r, steps=256).stability_margin < 0
    runs, start = [], None
    for i, flag in enumerate(unstable):
        if flag and start is None:
            start = i
        if start is not None and (not flag or i == count - 1):
            runs.append((float(r[start]), float(r[i - 1 if not flag else i])))
            start = None
    return runs


@pytest.mark.parametrize(
    ("eps", "low", "high"),
    [(0.1, 0.49, 0.51), (0.001, 0.99, 1.01), (0.34, 0.32, 0.36)],
    ids=["eps 0.1 near 1/2", "eps 0.001 near 1", "eps 0.34 near 1/3"],
)
def test_narrow_ranges_near_one_over_k_are_found(eps: float, low: float, high: float) -> None:
    """The narrow ranges that a uniform 400-point scan of r 0.3..1.5 missed: a brute-force scan with a
    spacing of 1e-6 around r = 1/k finds one range there, and the search over the whole window reports
    it with both boundaries within two spacings plus the search's tolerance (1e-6). At the middle of the
    range an independent integrator (DOP853 on the (gamma, gamma') form) gives |trace| > 2."""
    spacing = 1e-6
    brute = _brute_force_ranges(eps, low, high, round((high - low) / spacing) + 1)
    assert len(brute) == 1 and brute[0][1] - brute[0][0] > 1e-5  # the claim: a range wider than 1e-5
    found = [x for x in instability_ranges(eps, 0.3, 1.5) if x[1] > low and x[0] < high]
    assert len(found) == 1
    (a, b), (ref_a, ref_b) = found[0], brute[0]
    assert abs(a - ref_a) < 2 * spacing + 1e-6 and abs(b - ref_b) < 2 * spacing + 1e-6, (found, brute)
    assert abs(np.trace(_reference_monodromy(eps, 0.5 * (a + b)))) > 2.0


@given(eps=st.floats(0.0, 0.9), low=st.floats(0.25, 0.8), span=st.floats(0.05, 1.0))
@settings(max_examples=15, deadline=None)
def test_reported_ranges_are_unstable_and_complete(eps: float, low: float, span: float) -> None:
    """Invariants of the range search, checked by independent evaluations:
    - ranges are increasing, disjoint, of positive width and inside the window;
    - every range holds a point unstable at 1024 steps per period (margin < 0) within the
      tolerance (1e-6) of its ends: its middle where it is wider than twice the tolerance, else
      one of 2001 points spread over it and the tolerance either side (a range narrower than the
      tolerance, e.g. near r = 1/4, is only placed to within the tolerance);
    - every point of a scan with a spacing of 1e-3 that is unstable at 1024 steps by more than
      1e-9 in margin (clear of round-off and of the boundaries' 1e-6 tolerance) lies in a range."""
    high, tolerance = low + span, 1e-6
    ranges = instability_ranges(eps, low, high, tolerance=tolerance)
    flat = [x for pair in ranges for x in pair]
    assert flat == sorted(flat) and all(b > a for a, b in ranges)
    assert all(low <= a and b <= high for a, b in ranges)
    for a, b in ranges:
        if b - a > 2 * tolerance:
            points = np.array([0.5 * (a + b)])
        else:
            points = np.linspace(max(low, a - tolerance), min(high, b + tolerance), 2001)
        assert np.any(monodromy(eps, points, steps=1024).stability_margin < 0), (a, b)
    scan = np.linspace(low, high, max(2, round(span / 1e-3)))
    clearly = scan[monodromy(eps, scan, steps=1024).stability_margin < -1e-9]
    for r in clearly:
        assert any(a - 1e-6 <= r <= b + 1e-6 for a, b in ranges), (r, ranges)


@pytest.mark.parametrize("eps", [0.15, 0.55, 0.85])
def test_boundary_error_relation_bounds_the_measured_error(eps: float) -> None:
    """The step-count relation (BOUNDARY_ERROR, measured by the benchmark at other inertia ratios and
    over r 0.1..3) bounds the error of every boundary in r 0.3..1.5 bisected with 32 steps, against
    1024 steps (whose own error, by the same relation, is 1024^4 / 32^4 = 10^6 times smaller)."""

    located = instability_ranges(eps, 0.3, 1.5, steps=256, tolerance=1e-9)
    bounds = np.array([x for pair in located for x in pair])
    bounds = bounds[(bounds > 0.3) & (bounds < 1.5)]
    assert bounds.size
    gaps = np.abs(bounds[:, None] - bounds[None, :]) + np.diag(np.full(bounds.size, np.inf))
    half = np.minimum(1e-4, 0.45 * gaps.min(axis=1))  # a bracket holds one boundary only

    def bisect(steps: int) -> np.ndarray:
        lo, hi = bounds - half, bounds + half
        lo_unstable = monodromy(eps, lo, steps=steps).stability_margin < 0
        assert np.all(lo_unstable != (monodromy(eps, hi, steps=steps).stability_margin < 0))
        for _ in range(32):
            mid = 0.5 * (lo + hi)
            same = (monodromy(eps, mid, steps=steps).stability_margin < 0) == lo_unstable
            lo, hi = np.where(same, mid, lo), np.where(same, hi, mid)
        return 0.5 * (lo + hi)

    error = np.abs(bisect(32) - bisect(1024))
    assert float(error.max()) <= boundary_error(32, epsilon_max=eps)


def test_chart_step_count_follows_the_tolerance_and_reports_progress() -> None:
    """A tighter boundary tolerance takes more steps (a quarter power: 16x tighter, about 2x steps); the
    chart's traces are those of the monodromy at its step count; progress reports rise to the rows."""
    r, eps = np.linspace(0.3, 1.5, 40), np.linspace(0.0, 0.6, 90)
    reports: list[float] = []
    chart = stability_chart(r, eps, tolerance=1e-6, progress=reports.append)
    assert reports == sorted(reports) and reports[-1] == eps.size and len(reports) > 1
    coarse = stability_chart(r, eps, tolerance=16e-6)
    assert 1.8 < chart.steps / coarse.steps < 2.2
    assert chart.boundary_error <= 0.5e-6
    direct = monodromy(eps[:, None], r[None, :], steps=chart.steps)
    np.testing.assert_allclose(chart.trace, direct.trace, rtol=1e-12, atol=1e-12)


@pytest.mark.parametrize("tolerance", [0.0, -1e-6, float("nan"), float("inf")])
def test_bad_boundary_tolerance_is_refused(tolerance: float) -> None:
    with pytest.raises(ModelError, match="expected a positive, finite boundary accuracy"):
        stability_chart([0.5, 1.0], [0.1, 0.2], tolerance=tolerance)
    with pytest.raises(ModelError, match="expected a positive, finite boundary accuracy"):
        instability_ranges(0.3, 0.5, 1.0, tolerance=tolerance)


def test_unmeasured_inertia_ratio_asks_for_a_step_count() -> None:
    with pytest.raises(ModelError, match=r"measured up to epsilon 0\.95 only; give the Magnus steps"):
        stability_chart([0.5, 1.0], [0.1, 0.99])
    chart = stability_chart([0.5, 1.0], [0.1, 0.99], steps=256)
    assert chart.steps == 256 and math.isnan(chart.boundary_error)
