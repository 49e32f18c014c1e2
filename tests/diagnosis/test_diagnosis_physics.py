"""Diagnosis physics by independent routes: block scatter, cylinder parts, rigid-body speed and
torque, cylinder balance, rms velocity and zones, load reversals, high-frequency power."""

from __future__ import annotations

import functools
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.integrate import quad

from monitor.diagnosis.balance import cylinder_balance, measured_torque
from monitor.diagnosis.rigid_speed import predicted_speed
from monitor.diagnosis.zones import velocity_rms, zone_of
from monitor.errors import ModelError, SignalError
from monitor.fourier import order_coefficients
from monitor.io.recording import Channel
from monitor.model.crankshaft import EngineModel
from monitor.model.engine import Engine, load_engine
from monitor.model.inertia import engine_side_inertia
from monitor.model.predicted import (
    CylinderParts,
    combine_cylinders,
    cylinder_parts,
    load_reversals,
    predict_orders,
)
from monitor.signal.anglemap import AngleMap
from monitor.signal.grid import AngleDomainSignal
from monitor.signal.impact import HIGH_FREQUENCY_BINS_PER_REVOLUTION, impact_band
from monitor.signal.resample import to_angle_domain
from monitor.signal.spectrum import OrderSpectrum, order_spectrum

TWO_STROKE, FOUR_STROKE = "man-b-w-7k98mc", "medium-speed-6l32"
# operating points: the 7K98MC at 104 rpm, the 6L32 at 750 rpm (their rated speeds), part load
SPEED = {TWO_STROKE: 104 * math.pi / 30, FOUR_STROKE: 750 * math.pi / 30}
LOAD = {TWO_STROKE: 0.9, FOUR_STROKE: 0.75}


@functools.cache
def _engine(name: str) -> Engine:
    return load_engine(name)


@functools.cache
def _model(name: str) -> EngineModel:
    return EngineModel(_engine(name), gas="parametric")


@functools.cache
def _parts(name: str, load: float | None = None) -> CylinderParts:
    return cylinder_parts(_model(name), crank_speed=SPEED[name], load=LOAD[name] if load is None else load)


def _peak_scaled_rfft(blocks: np.ndarray) -> np.ndarray:
    """Peak order amplitudes of each row, written out: 2 X_k / N, order 0 and Nyquist X_k / N."""
    n = blocks.shape[-1]
    spectrum = np.fft.rfft(blocks, axis=-1) / n
    spectrum[..., 1 : (n + 1) // 2] *= 2.0
    return spectrum


def _speed_spectrum(orders: np.ndarray, amplitude: np.ndarray, standard_error: float = 0.0) -> OrderSpectrum:
    """An order spectrum of the crank speed with a given complex mean and standard error (50 blocks)."""
    blocks = 50
    zeros = np.zeros(orders.size)
    scatter = np.full(orders.size, standard_error * math.sqrt(blocks))
    return OrderSpectrum(orders, amplitude, zeros, zeros, scatter, blocks, 1)


def _synthesize(coefficients: np.ndarray, orders: np.ndarray, theta: np.ndarray) -> np.ndarray:
    """q(theta) = Re sum_k Q_k exp(i k theta), the convention of monitor.fourier, term by term."""
    return np.real(np.exp(1j * np.multiply.outer(theta, orders)) @ coefficients)


# --- 1. block scatter and standard error --------------------------------------------------------


def test_scatter_is_the_rms_complex_distance_over_more_blocks_than_one_chunk(
    rng: np.random.Generator,
) -> None:
    """Blocks built from known complex amplitudes Z[b, k] = mean_k + jitter: ``scatter`` equals
    sqrt(sum_b |Z - mean Z|^2 / (B - 1)) over those Z (no FFT on this side) within 1e-12 relative,
    and ``standard_error`` is scatter / sqrt(B); 10 001 blocks, three chunks of the Chan combination.

    Tolerance: the FFT returns Z to a few ulps of the samples' size (about 10), the scatter is
    about 1, so agreement is near 1e-15; the statistic itself is within 5 % of the jitter's rms
    (the relative spread of a variance estimate from 2 x 10 001 normal components is 0.7 %).
    """
    blocks, n, top = 10_001, 32, 12
    orders = np.arange(top + 1)
    mean = np.concatenate([[4.0], 3.0 * np.exp(1j * np.linspace(0.3, 2.9, top))])
    jitter_rms = np.linspace(0.2, 1.5, top + 1)
    noise = (
        rng.standard_normal((blocks, top + 1)) + 1j * rng.standard_normal((blocks, top + 1))
    ) / math.sqrt(2)
    z = mean + jitter_rms * noise
    z[:, 0] = z[:, 0].real  # order 0 of a real signal is real
    theta = 2 * np.pi * np.arange(n) / n
    values = np.real(z @ np.exp(1j * np.multiply.outer(orders, theta)))
    spectrum = order_spectrum(AngleDomainSignal(values, 0, n, 1, None, "given"), max_order=top)
    direct = np.sqrt(np.sum(np.abs(z - z.mean(axis=0)) ** 2, axis=0) / (blocks - 1))
    assert spectrum.blocks == blocks
    np.testing.assert_allclose(spectrum.amplitude, z.mean(axis=0), rtol=1e-12)
    np.testing.assert_allclose(spectrum.scatter, direct, rtol=1e-12)
    np.testing.assert_allclose(spectrum.standard_error, direct / math.sqrt(blocks), rtol=1e-12)
    # order 0 has only the real half of the jitter
    np.testing.assert_allclose(spectrum.scatter[1:], jitter_rms[1:], rtol=0.05)
    assert spectrum.scatter[0] == pytest.approx(jitter_rms[0] / math.sqrt(2), rel=0.05)


def test_scatter_of_two_cycle_blocks_equals_numpy_on_the_blocks(rng: np.random.Generator) -> None:
    """Blocks of two cycles (half orders), 8 195 blocks: scatter equals numpy's two-pass statistic over
    the blocks' peak-scaled FFTs (written out here) within 1e-12 relative, Nyquist included.

    Tolerance: both sides subtract the mean before squaring; round-off is near 1e-15.
    """
    blocks, n = 8195, 16
    values = 0.7 * rng.standard_normal((2 * blocks, n)) + 2.0 * np.cos(2 * np.pi * 3 * np.arange(n) / n + 0.4)
    spectrum = order_spectrum(AngleDomainSignal(values, 0, n, 1, None, "given"), block_cycles=2)
    z = _peak_scaled_rfft(values.reshape(blocks, 2 * n))
    np.testing.assert_allclose(spectrum.orders, np.arange(n + 1) / 2)
    np.testing.assert_allclose(spectrum.scatter, np.std(z, axis=0, ddof=1), rtol=1e-12)
    np.testing.assert_allclose(
        spectrum.standard_error, np.std(z, axis=0, ddof=1) / math.sqrt(blocks), rtol=1e-12
    )


@settings(max_examples=40)
@given(
    seed=st.integers(0, 2**32 - 1),
    blocks=st.sampled_from([2, 37, 4100]),
    order=st.integers(1, 7),
    magnitude=st.floats(0.0, 1e3),
    phase=st.floats(-math.pi, math.pi),
    constant=st.floats(-1e3, 1e3),
)
def test_scatter_ignores_a_sinusoid_common_to_every_block(
    seed: int, blocks: int, order: int, magnitude: float, phase: float, constant: float
) -> None:
    """Adding the same sinusoid (and constant) to every block moves the mean amplitude by exactly that
    complex offset and leaves the scatter unchanged.

    Tolerance: the offset is up to 1e3 against a jitter near 1; the FFT's round-off on it is a few
    ulps of 1e3 per block, so 1e-12 x (1 + offset) absolute covers it, 1e-9 relative the rest.
    """
    n = 16
    values = np.random.default_rng(seed).standard_normal((blocks, n))
    theta = 2 * np.pi * np.arange(n) / n
    shifted = values + constant + magnitude * np.cos(order * theta + phase)
    before = order_spectrum(AngleDomainSignal(values, 0, n, 1, None, "given"))
    after = order_spectrum(AngleDomainSignal(shifted, 0, n, 1, None, "given"))
    size = 1.0 + magnitude + abs(constant)
    np.testing.assert_allclose(after.scatter, before.scatter, rtol=1e-9, atol=1e-12 * size)
    offset = np.zeros(n // 2 + 1, dtype=np.complex128)
    offset[0] = constant
    offset[order] = magnitude * np.exp(1j * phase)
    np.testing.assert_allclose(after.amplitude - before.amplitude, offset, rtol=0, atol=1e-12 * size)


# --- 2. combining the cylinders -----------------------------------------------------------------


@pytest.mark.parametrize("name", [TWO_STROKE, FOUR_STROKE])
def test_all_cylinders_at_strength_one_reproduce_predict_orders(name: str) -> None:
    """Strength 1 everywhere is the model as it is: engine torque and main-bearing forces equal
    :func:`predict_orders` (the whole gas force at once) within 1e-12 of the largest.

    Tolerance: the parts are differences of crank-train evaluations at 1 rad/s; round-off is
    near 1e-16 of the largest coefficient.
    """
    engine = _engine(name)
    whole = predict_orders(_model(name), crank_speed=SPEED[name], load=LOAD[name])
    combined = combine_cylinders(_parts(name), engine, np.ones(engine.cylinders))
    np.testing.assert_allclose(combined.orders, whole.orders)
    torque_scale = np.abs(whole.engine_torque).max()
    np.testing.assert_allclose(combined.engine_torque, whole.engine_torque, rtol=0, atol=1e-12 * torque_scale)
    np.testing.assert_allclose(
        combined.cylinder_torque, whole.cylinder_torque, rtol=0, atol=1e-12 * torque_scale
    )
    force_scale = np.abs(whole.bearing_force).max()
    np.testing.assert_allclose(combined.bearing_force, whole.bearing_force, rtol=0, atol=1e-12 * force_scale)


@pytest.mark.parametrize("name", [TWO_STROKE, FOUR_STROKE])
def test_combined_orders_are_the_sum_of_the_parts_by_hand(name: str, rng: np.random.Generator) -> None:
    """Random strengths: each throw's torque and force, cylinder by cylinder and bearing by bearing in
    plain loops, is (inertia + fixed + s_c combustion) delayed by the firing angle; the engine's torque
    and bearing forces equal those sums within 1e-12 of the largest, and the result is affine in s.

    Tolerance: sums of a few products of the same numbers; round-off only.
    """
    engine, parts = _engine(name), _parts(name)
    strengths = rng.uniform(0.0, 1.2, engine.cylinders)
    combined = combine_cylinders(parts, engine, strengths)
    torque = np.zeros(parts.orders.size, dtype=np.complex128)
    throws = []
    for c in range(engine.cylinders):
        own = parts.inertia + parts.fixed + strengths[c] * parts.combustion
        delayed = own * np.exp(-1j * parts.orders * engine.firing_angles[c])
        torque += delayed[0]
        throws.append(delayed[1:3])
    bearing = np.zeros((engine.bearing_count, 2, parts.orders.size), dtype=np.complex128)
    for b in range(engine.bearing_count):
        for c in range(engine.cylinders):
            bearing[b] += engine.bearing_share[b, c] * throws[c]
    torque_scale, force_scale = np.abs(torque).max(), np.abs(bearing).max()
    np.testing.assert_allclose(combined.engine_torque, torque, rtol=0, atol=1e-12 * torque_scale)
    np.testing.assert_allclose(combined.bearing_force, bearing, rtol=0, atol=1e-12 * force_scale)
    # affine: s = 0 plus each cylinder's own increment
    base = combine_cylinders(parts, engine, np.zeros(engine.cylinders))
    total = base.engine_torque.copy()
    for c in range(engine.cylinders):
        alone = np.zeros(engine.cylinders)
        alone[c] = 1.0
        total += strengths[c] * (combine_cylinders(parts, engine, alone).engine_torque - base.engine_torque)
    np.testing.assert_allclose(combined.engine_torque, total, rtol=0, atol=1e-12 * torque_scale)


@pytest.mark.parametrize("name", [TWO_STROKE, FOUR_STROKE])
def test_each_cylinder_fires_its_firing_angle_after_cylinder_one(name: str) -> None:
    """The phasing's sign: synthesized over the cycle, cylinder c's combustion torque peaks at cylinder
    1's peak angle plus c's firing angle (a later crank angle), within one grid step (0.35 deg)."""
    engine, parts = _engine(name), _parts(name)
    cycle = 2 * math.pi * engine.cycle_revolutions
    theta = np.arange(1024 * engine.cycle_revolutions) * (2 * math.pi / 1024)
    step = theta[1]
    none = combine_cylinders(parts, engine, np.zeros(engine.cylinders)).cylinder_torque
    full = combine_cylinders(parts, engine, np.ones(engine.cylinders)).cylinder_torque
    own_peak = theta[np.argmax(_synthesize(parts.combustion[0], parts.orders, theta))]
    for c in range(engine.cylinders):
        peak = theta[np.argmax(_synthesize(full[c] - none[c], parts.orders, theta))]
        miss = math.remainder(peak - own_peak - engine.firing_angles[c], cycle)
        assert abs(miss) <= step * (1 + 1e-9), c


# --- 3. the motored cylinder's work ------------------------------------------------------------


@pytest.mark.parametrize("name", [TWO_STROKE, FOUR_STROKE])
def test_the_split_parts_carry_the_indicated_work(name: str) -> None:
    """Order 0 of a gas torque is its cycle's indicated work over the cycle angle, oint p dV / (2 pi R).
    Independent route: the parametric cycle's strokes integrated in closed form (polytropic compression
    p V^n_c = const from inlet closing to the start of combustion, p V^n_e = const from there to
    exhaust opening), the cosine blowdown by adaptive quadrature, the gas exchange at charge pressure,
    on a volume written out from the exact slider-crank geometry.

    - the fixed part (the motored cylinder, strength 0) has that motored work;
    - fixed plus combustion has the load's IMEP x V_d;
    - the motored cylinder's work nearly cancels: below 10 % of the gross compression work and of the
      combustion part's at rated load.

    Tolerances: 2e-5 relative for the first two; the model integrates on its 1024-point grid, exact
    for smooth periodic integrands but O(h^2) = (2 pi / 1024)^2 = 4e-5 at the slope jumps of the
    pressure (inlet closing, start of combustion), and it sets the heat release from a 2880-point
    central-difference IMEP.  10 % for the third: a motored cycle of this model is not work-free
    (after the start of combustion it expands with n_e < n_c, above its compression line, and it blows
    down above charge pressure: about 1 bar of IMEP), but for strength 0 to stand for a misfire its
    work must be a small remainder of the compression and expansion strokes that nearly cancel.
    """
    engine = _engine(name)
    c = engine.combustion
    assert c is not None
    radius, lam = engine.crank_radius, engine.rod_ratio
    area = math.pi * engine.geometry.bore_m**2 / 4
    swept = 2 * radius * area
    clearance = swept / (c.compression_ratio - 1)

    def volume(t: float) -> float:
        return clearance + area * radius * (
            (1 - math.cos(t)) + (1 - math.sqrt(1 - (lam * math.sin(t)) ** 2)) / lam
        )

    def volume_rate(t: float) -> float:
        s = math.sin(t)
        return area * radius * (s + lam * math.sin(2 * t) / (2 * math.sqrt(1 - (lam * s) ** 2)))

    ic, soc, eo, blowdown = (
        math.radians(v)
        for v in (c.inlet_closing_deg, c.combustion_start_deg, c.exhaust_opening_deg, c.blowdown_deg)
    )
    n_c, n_e = c.polytropic_compression, c.polytropic_expansion
    cycle = 2 * math.pi * engine.cycle_revolutions
    v_ic, v_soc, v_eo = volume(ic), volume(soc), volume(eo)
    expansion = (v_ic / v_soc) ** n_c * v_soc**n_e  # p V^n_e per unit charge pressure after soc
    compression_work = v_ic**n_c * (v_soc ** (1 - n_c) - v_ic ** (1 - n_c)) / (1 - n_c)
    expansion_work = expansion * (v_eo ** (1 - n_e) - v_soc ** (1 - n_e)) / (1 - n_e)

    def blowdown_pressure(t: float) -> float:
        weight = 0.5 * (1 + math.cos(math.pi * (t - eo) / blowdown))
        return 1.0 + weight * (expansion * volume(t) ** -n_e - 1.0)

    blowdown_work, _ = quad(lambda t: blowdown_pressure(t) * volume_rate(t), eo, eo + blowdown, epsrel=1e-12)
    exchange_work = volume(ic + cycle) - volume(eo + blowdown)
    motored = compression_work + expansion_work + blowdown_work + exchange_work  # per unit charge pressure

    for load in (0.5, 1.0):
        parts = _parts(name, load)
        charge = (c.ambient_pressure_bar + load * (c.intake_pressure_bar - c.ambient_pressure_bar)) * 1e5
        fixed, combustion = parts.fixed[0, 0], parts.combustion[0, 0]
        assert abs(fixed.imag) < 1e-9 * abs(fixed.real) and abs(combustion.imag) < 1e-9 * abs(combustion.real)
        assert fixed.real == pytest.approx(charge * motored / cycle, rel=2e-5)
        imep = load * c.rated_imep_bar * 1e5
        assert fixed.real + combustion.real == pytest.approx(imep * swept / cycle, rel=2e-5)
        assert abs(parts.inertia[0, 0]) < 1e-9 * abs(combustion)  # moving masses do no net work
        if load == 1.0:
            assert abs(fixed.real) < 0.1 * charge * abs(compression_work) / cycle
            assert abs(fixed.real) < 0.1 * combustion.real


# --- 4. rigid body: speed from torque and back ---------------------------------------------------


def _torque_one_weak(name: str) -> np.ndarray:
    """The engine's torque orders with cylinder 3 misfiring (strength 0), the others as the model."""
    engine = _engine(name)
    strengths = np.ones(engine.cylinders)
    strengths[2] = 0.0
    return combine_cylinders(_parts(name), engine, strengths).engine_torque


@pytest.mark.parametrize("name", [TWO_STROKE, FOUR_STROKE])
def test_measured_torque_inverts_predicted_speed(name: str) -> None:
    """Cylinder 3 misfiring: torque -> predicted_speed -> an order spectrum -> measured_torque gives the
    torque orders back (k > 0) within 1e-6 of the largest, and the speed's mean over the cycle angle is
    the mean speed within 1e-12.

    Tolerance: both sides are exact for the rigid body, but the speed is cut at order 24 while the exact
    sqrt(c + 2 E / J) has every order; with fluctuations of a few per cent of the mean speed what is
    cut is orders of magnitude below 1e-6.
    """
    engine, parts = _engine(name), _parts(name)
    inertia, mean_speed, R = engine_side_inertia(engine), SPEED[name], engine.cycle_revolutions
    torque = _torque_one_weak(name)
    speed = predicted_speed(torque, parts.orders, inertia, mean_speed, R)
    theta = np.arange(4096) * (2 * math.pi * R / 4096)
    omega = _synthesize(speed, parts.orders, theta)
    assert omega.mean() == pytest.approx(mean_speed, rel=1e-12)
    assert np.ptp(omega) < 0.05 * mean_speed  # the premise of the tolerance
    recovered, _ = measured_torque(_speed_spectrum(parts.orders, speed), inertia, R)
    assert recovered[0] == 0
    np.testing.assert_allclose(recovered[1:], torque[1:], rtol=0, atol=1e-6 * np.abs(torque[1:]).max())


@pytest.mark.parametrize("name", [TWO_STROKE, FOUR_STROKE])
def test_predicted_speed_against_its_small_fluctuation_expansion(name: str) -> None:
    """With a fifth of the engine's inertia (3 to 10 % of speed fluctuation) and the angle integral
    of the torque u = 2 E / J with E_k = T_k / (i k):

    - first order, omega_k = T_k / (i k J Omega), is off by at most delta^2 / Omega;
    - second order, omega = Omega + u / (2 Omega) - (u^2 - <u^2>) / (8 Omega^3), by at most
      2 delta^3 / Omega^2;

    delta = max |u| / (2 Omega), the first-order fluctuation.  The bounds are the next term of
    sqrt(c + u) with the mean held, its order coefficients (peak) at most twice its maximum.
    """
    engine, parts = _engine(name), _parts(name)
    inertia, mean_speed, R = 0.2 * engine_side_inertia(engine), SPEED[name], engine.cycle_revolutions
    orders = parts.orders
    torque = _torque_one_weak(name)
    speed = predicted_speed(torque, orders, inertia, mean_speed, R)
    theta = np.arange(4096) * (2 * math.pi * R / 4096)
    energy = np.zeros(orders.size, dtype=np.complex128)
    energy[1:] = torque[1:] / (1j * orders[1:])
    u = 2 * _synthesize(energy, orders, theta) / inertia
    delta = np.abs(u).max() / (2 * mean_speed)
    assert 0.02 < delta / mean_speed < 0.15  # large enough for the orders to tell apart
    first = np.zeros_like(speed)
    first[0] = mean_speed
    first[1:] = torque[1:] / (1j * orders[1:] * inertia * mean_speed)
    assert np.abs(speed - first).max() <= delta**2 / mean_speed
    second = mean_speed + u / (2 * mean_speed) - (u**2 - np.mean(u**2)) / (8 * mean_speed**3)
    second_orders = _peak_scaled_rfft(second)[: orders.size]  # theta spans the cycle: bin j is order j / R
    assert np.abs(speed - second_orders).max() <= 2 * delta**3 / mean_speed**2
    assert np.abs(speed - first).max() > 5 * np.abs(speed - second_orders).max()  # second order matters


def test_measured_torque_standard_error_is_the_linear_response() -> None:
    """Perturbing the speed's order k by a small complex d moves the torque's order k by i k J Omega d,
    the standard error's factor k J Omega, to first order in the fluctuation.

    Tolerance: omega^2 gains 2 Omega d from the mean speed and conj(d) W_2k from the speed's order 2k,
    a relative |W_2k| / (2 Omega); bounded here by |W_2k| / Omega, plus 1e-5 for the step's own square.
    """
    name = TWO_STROKE
    engine, parts = _engine(name), _parts(name)
    inertia, mean_speed = engine_side_inertia(engine), SPEED[name]
    speed = predicted_speed(_torque_one_weak(name), parts.orders, inertia, mean_speed, 1)
    base, _ = measured_torque(_speed_spectrum(parts.orders, speed), inertia, 1)
    for k in (1, 3, 7):
        for d in (1e-5, 1e-5j):
            moved = speed.copy()
            moved[k] += d
            torque, error = measured_torque(
                _speed_spectrum(parts.orders, moved, standard_error=1.0), inertia, 1
            )
            change = (torque[k] - base[k]) / d
            bound = abs(speed[2 * k]) / mean_speed + 1e-5
            assert abs(change / (1j * k * inertia * mean_speed) - 1) <= bound
            assert error[k] == pytest.approx(k * inertia * mean_speed, rel=1e-12)


@settings(max_examples=40, deadline=None)
@given(
    cycle_revolutions=st.sampled_from([1, 2]),
    top=st.integers(2, 120),
    seed=st.integers(0, 2**32 - 1),
)
def test_measured_torque_squares_the_speed_as_the_term_by_term_sum(
    cycle_revolutions: int, top: int, seed: int
) -> None:
    """``(omega^2)_k`` from one inverse FFT equals the term-by-term synthesis of omega on the same grid,
    squared and analysed, for any speed spectrum on the orders' grid (a mean and fluctuations of up to
    a tenth of it).

    Tolerance: both are sums of the same ``points`` products in another order, each term within a few
    ulps; 1e-10 of the largest torque order bounds the rounding of a few thousand terms."""
    rng = np.random.default_rng(seed)
    orders = np.arange(top + 1) / cycle_revolutions
    amplitude = 0.1 * (rng.standard_normal(orders.size) + 1j * rng.standard_normal(orders.size)) / orders.size
    amplitude[0] = 1.0
    inertia = 2.5
    torque, _ = measured_torque(_speed_spectrum(orders, amplitude), inertia, cycle_revolutions)
    points = 2 ** math.ceil(math.log2(max(64, 8 * orders[-1] * cycle_revolutions)))
    theta = np.arange(points) * (2 * math.pi * cycle_revolutions / points)
    squared = order_coefficients(
        _synthesize(amplitude, orders, theta) ** 2, cycle_revolutions=cycle_revolutions, max_order=orders[-1]
    )
    expected = 1j * orders * (inertia / 2) * squared.coefficients[: orders.size]
    expected[0] = 0.0
    assert np.abs(torque - expected).max() <= 1e-10 * np.abs(expected).max()


def test_measured_torque_refuses_orders_off_the_cycles_grid() -> None:
    """Orders that are not multiples of ``1 / cycle_revolutions`` are no cycle's orders: refused."""
    orders = np.array([0.0, 0.5, 1.0])
    with pytest.raises(ModelError, match=r"expected non-negative multiples of 1 for a 1-revolution cycle"):
        measured_torque(_speed_spectrum(orders, np.array([1.0, 0.1, 0.1])), 2.5, 1)


# --- 5. cylinder balance with known strengths ---------------------------------------------------


@pytest.mark.parametrize("name", [TWO_STROKE, FOUR_STROKE])
def test_cylinder_balance_finds_a_weak_cylinder_in_noise(name: str, rng: np.random.Generator) -> None:
    """Cylinder 3 at 40 %: the speed from the exact rigid body plus complex normal noise of a stated
    standard error (1e-4 rad/s, about 1 % of the firing order's amplitude) at every order; every
    estimated strength within 4 of its standard errors of the truth, the weak cylinder's share within 4
    of its errors of 0.4, and the contrasts' errors small enough that this says something (< 0.05:
    the 3 % each healthy cylinder fires unlike the others, balance.IMBALANCE, sets their floor; the
    strengths' own errors carry the model's 10 % uncertainty of their common level too).

    Noise: E |n|^2 = se^2, half in each of the real and imaginary parts, as the standard error of a
    complex mean over blocks is defined (``scatter / sqrt(blocks)``).
    """
    engine, parts = _engine(name), _parts(name)
    inertia, mean_speed, R = engine_side_inertia(engine), SPEED[name], engine.cycle_revolutions
    truth = np.ones(engine.cylinders)
    truth[2] = 0.4
    torque = combine_cylinders(parts, engine, truth).engine_torque
    speed = predicted_speed(torque, parts.orders, inertia, mean_speed, R)
    se = 1e-4
    noise = se * (rng.standard_normal(speed.size) + 1j * rng.standard_normal(speed.size)) / math.sqrt(2)
    noise[0] = noise[0].real
    balance = cylinder_balance(_speed_spectrum(parts.orders, speed + noise, se), engine, parts)
    np.testing.assert_allclose(balance.orders, np.arange(1, engine.cylinders + 1) / R)  # 0 < k <= n / R
    assert balance.separable
    assert np.all(balance.contrast_error < 0.05)
    assert np.all(np.abs(balance.strength - truth) <= 4 * balance.strength_error)
    assert abs(balance.relative[2] - 0.4) <= 4 * balance.relative_error[2]
    healthy = np.delete(np.arange(engine.cylinders), 2)
    assert np.all(np.abs(balance.relative[healthy] - 1.0) <= 4 * balance.relative_error[healthy])


@settings(max_examples=30)
@given(strengths=st.lists(st.floats(0.0, 1.2), min_size=6, max_size=6))
def test_cylinder_balance_recovers_any_strengths_without_noise(strengths: list[float]) -> None:
    """The 6L32 (half orders 0.5..3), any strengths in [0, 1.2], no noise: recovered from the orders
    alone (no prior on their common level, ``level_uncertainty=0``) within 1e-6.

    Tolerance: the only error is the speed's cut at order 24 (below 1e-7 of the torque, see the round
    trip above), over a problem whose condition number is a few.
    """
    name = FOUR_STROKE
    engine, parts = _engine(name), _parts(name)
    inertia, R = engine_side_inertia(engine), engine.cycle_revolutions
    torque = combine_cylinders(parts, engine, strengths).engine_torque
    speed = predicted_speed(torque, parts.orders, inertia, SPEED[name], R)
    balance = cylinder_balance(_speed_spectrum(parts.orders, speed), engine, parts, level_uncertainty=0.0)
    np.testing.assert_allclose(balance.strength, strengths, rtol=0, atol=1e-6)


def test_strength_errors_match_the_scatter_of_the_estimates(rng: np.random.Generator) -> None:
    """Calibration of ``strength_error``: over 200 noise draws of the 7K98MC's speed (complex normal,
    E |n|^2 = se^2), the estimates' standard deviation equals the reported error within 25 %
    (the spread of a standard deviation from 200 draws is 5 %). The measurement's part alone (no
    model uncertainty): the model's share is no scatter a noise draw can show, and with it the
    reported errors are larger (checked at the end); so are the contrasts' errors smaller than the
    strengths' (a common level drops out of a contrast)."""
    name = TWO_STROKE
    engine, parts = _engine(name), _parts(name)
    inertia, mean_speed = engine_side_inertia(engine), SPEED[name]
    truth = np.ones(engine.cylinders)
    truth[2] = 0.4
    speed = predicted_speed(
        combine_cylinders(parts, engine, truth).engine_torque, parts.orders, inertia, mean_speed, 1
    )
    se, draws = 1e-4, 200
    estimates, reported = [], []
    for _ in range(draws):
        noise = se * (rng.standard_normal(speed.size) + 1j * rng.standard_normal(speed.size)) / math.sqrt(2)
        noise[0] = 0.0
        balance = cylinder_balance(
            _speed_spectrum(parts.orders, speed + noise, se),
            engine,
            parts,
            model_uncertainty=0.0,
            timing_uncertainty=0.0,
            imbalance=0.0,
        )
        estimates.append(balance.strength)
        reported.append(balance.strength_error)
    ratio = np.mean(reported, axis=0) / np.std(estimates, axis=0, ddof=1)
    assert np.all((ratio > 0.8) & (ratio < 1.25)), ratio
    with_model = cylinder_balance(_speed_spectrum(parts.orders, speed, se), engine, parts)
    assert np.all(with_model.strength_error > 2 * np.mean(reported, axis=0))
    # near 1 a common level moves a ratio by nothing to first order; at 0.4 it does, a contrast not (the
    # weak cylinder's contrast keeps the model's share of its own torque change: 10 % of it)
    assert np.all(with_model.contrast_error <= with_model.relative_error * (1 + 1e-9))
    assert with_model.contrast_error[2] < 0.5 * with_model.relative_error[2]


# --- 6. rms velocity and zones ----------------------------------------------------------------------

FS = 5120.0


def _tone(kind: str, unit: str, frequency: float, amplitude: float, seconds: float = 40.0) -> Channel:
    t = np.arange(int(seconds * FS)) / FS
    data = (amplitude * np.sin(2 * np.pi * frequency * t + 0.3)).astype(np.float32)
    return Channel("mb3-vertical", kind, unit, data, FS, location="main bearing 3", direction="vertical")


@pytest.mark.parametrize("frequency", [13.7, 80.0, 900.0])
def test_rms_velocity_of_a_tone_in_the_band(frequency: float) -> None:
    """A sin(2 pi f t): as acceleration [m/s^2] its velocity is A / (2 pi f) / sqrt(2) x 1000 mm/s rms,
    as velocity [mm/s] A / sqrt(2); within 1 % (Hann leakage spreads the tone over a few bins whose
    1/f^2 weights differ by under 0.1 % at 13.7 Hz)."""
    amplitude = 5.0
    acceleration = velocity_rms(_tone("acceleration", "m/s^2", frequency, amplitude), (2.0, 1000.0))
    assert acceleration.value == pytest.approx(
        amplitude / (2 * math.pi * frequency) / math.sqrt(2) * 1e3, rel=0.01
    )
    assert acceleration.band_hz == (2.0, 1000.0)
    velocity = velocity_rms(_tone("velocity", "mm/s", frequency, amplitude), (2.0, 1000.0))
    assert velocity.value == pytest.approx(amplitude / math.sqrt(2), rel=0.01)


@pytest.mark.parametrize(("kind", "unit"), [("acceleration", "m/s^2"), ("velocity", "mm/s")])
@pytest.mark.parametrize("frequency", [1.0, 1500.0])
def test_a_tone_outside_the_band_is_left_out(kind: str, unit: str, frequency: float) -> None:
    """1 Hz below a 2-1000 Hz band, 1500 Hz above it: under 1 % of the tone's own rms velocity."""
    amplitude = 5.0
    own = amplitude / math.sqrt(2) * (1e3 / (2 * math.pi * frequency) if kind == "acceleration" else 1.0)
    value = velocity_rms(_tone(kind, unit, frequency, amplitude), (2.0, 1000.0)).value
    assert value < 0.01 * own


@pytest.mark.parametrize(
    ("kind", "unit", "to_si"),
    [("acceleration", "g", 9.80665), ("acceleration", "mm/s^2", 1e-3), ("velocity", "m/s", 1e3)],
)
def test_rms_velocity_honours_the_channel_unit(kind: str, unit: str, to_si: float) -> None:
    """The same 80 Hz motion in another accepted unit gives the same mm/s (or is refused)."""
    amplitude_si = 5.0  # m/s^2 or mm/s
    reference = velocity_rms(_tone(kind, "m/s^2" if kind == "acceleration" else "mm/s", 80.0, amplitude_si))
    try:
        other = velocity_rms(_tone(kind, unit, 80.0, amplitude_si / to_si))
    except SignalError:
        return
    assert other.value == pytest.approx(reference.value, rel=1e-3)


@pytest.mark.parametrize(
    ("value", "zone"),
    [(0.0, "A"), (7.09, "A"), (7.1, "B"), (10.99, "B"), (11.0, "C"), (17.99, "C"), (18.0, "D"), (1e3, "D")],
)
def test_zones_at_and_between_the_boundaries(value: float, zone: str) -> None:
    """Below the first boundary A; a boundary itself belongs to the zone above it; D at or above the third."""
    assert zone_of(value, (7.1, 11.0, 18.0)) == zone


# --- 7. load reversals ------------------------------------------------------------------------------


def _force(orders: np.ndarray, x: dict[float, complex], y: dict[float, complex]) -> np.ndarray:
    force = np.zeros((2, orders.size), dtype=np.complex128)
    for row, terms in enumerate((x, y)):
        for k, value in terms.items():
            force[row, int(np.argmin(np.abs(orders - k)))] = value
    return force


def _angle_error(found: np.ndarray, expected: list[float], cycle: float) -> float:
    assert found.size == len(expected), found
    return max(
        abs(math.remainder(f - e, cycle)) for f, e in zip(np.sort(found), sorted(expected), strict=True)
    )


@given(ratio=st.floats(0.05, 0.95), phase=st.floats(-math.pi, math.pi))
def test_a_pulsating_load_turns_opposite_its_peak(ratio: float, phase: float) -> None:
    """x = 0, y = F0 + F1 cos(theta - phi), F1 < F0: the load's magnitude is least at phi + pi, found
    within one grid step (2 pi / 4096)."""
    orders = np.arange(13.0)
    force = _force(orders, {}, {0: 1e5, 1: ratio * 1e5 * np.exp(-1j * phase)})
    found = load_reversals(force, orders, 1)
    assert _angle_error(found, [phase + math.pi], 2 * math.pi) <= 2 * math.pi / 4096


def test_load_reversals_of_known_forces() -> None:
    """Magnitudes known in closed form, minima within one grid step:

    - a rotating force on a constant one, x = F1 sin, y = F0 + F1 cos (|F|^2 = F0^2 + F1^2 + 2 F0 F1 cos):
      pi, also for F1 > F0;
    - y = F0 + F1 cos(2 theta): pi / 2 and 3 pi / 2;
    - y = F0 + F1 cos(theta), F1 > F0 (the load passes through zero): +-arccos(-F0 / F1);
    - a four-stroke, y = F0 + F1 cos(theta / 2) over 4 pi: 2 pi.
    """
    step = 2 * math.pi / 4096
    orders = np.arange(13.0)
    for f1 in (0.4, 2.5):
        force = _force(orders, {1: -1j * f1}, {0: 1.0, 1: f1})
        assert _angle_error(load_reversals(force, orders, 1), [math.pi], 2 * math.pi) <= step
    force = _force(orders, {}, {0: 1.0, 2: 0.5})
    assert _angle_error(load_reversals(force, orders, 1), [math.pi / 2, 3 * math.pi / 2], 2 * math.pi) <= step
    zero = math.acos(-1.0 / 1.7)
    force = _force(orders, {}, {0: 1.0, 1: 1.7})
    assert _angle_error(load_reversals(force, orders, 1), [zero, 2 * math.pi - zero], 2 * math.pi) <= step
    half = np.arange(25.0) / 2
    force = _force(half, {}, {0: 1.0, 0.5: 0.6})
    assert _angle_error(load_reversals(force, half, 2), [2 * math.pi], 4 * math.pi) <= step


# --- 8. high-frequency power over the cycle -------------------------------------------------------


def _band_power_variance(taps: np.ndarray, n: int) -> float:
    """Variance [sigma^4] of the mean of n consecutive squares of unit white noise through the FIR ``taps``.

    y = h * x has autocovariance r(l) = sum_i h_i h_(i+l); for normal y, cov(y_i^2, y_j^2) =
    2 r(i - j)^2, so the mean's variance is 2 / n^2 sum over |l| < n of (n - |l|) r(l)^2.
    """
    r = np.correlate(taps, taps, mode="full")[taps.size - 1 :][:n]
    weights = n - np.arange(r.size)
    return float(2.0 / n**2 * (n * r[0] ** 2 + 2 * np.sum(weights[1:] * r[1:] ** 2)))


def test_high_frequency_power_of_white_noise_and_of_bursts(rng: np.random.Generator) -> None:
    """Constant speed (10 rev/s, a keyphasor), 81 920 Hz, 512 bins per cycle (the profile's own
    resolution at this speed, so the grid's bins are its bins) of 16 samples each, 20 s of white noise
    of rms sigma, plus a 4 kHz burst (48 samples, Hann envelope, 5 sigma) a quarter into bin 17 of
    every cycle:

    - the pass band is 1-10 kHz, and the band-pass passes (10.25 - 0.75) / 40.96 of white noise's
      power, an ideal filter's between its transitions' centres, within 2 % (a transition's power
      is not symmetric about its centre);
    - the profile equals a plain numpy evaluation of its definition (the samples band-passed by
      ``np.convolve`` with the same taps, each bin's samples from the grid time up to the next, mean
      square, mean over the cycles) within 1e-9;
    - the noise bins' mean is sigma^2 sum(h^2) within 5 standard deviations of the estimate (the
      variance of a bin's power from the filter's autocovariance, over the cycles and bins averaged),
      and ``std`` is the single-cycle spread within 3 %;
    - the burst's bin holds the noise's power plus the burst's own band-passed power within 5 standard
      deviations of their cross term (the noise's band-passed samples times the burst's, averaged over
      the cycles), and stands out.
    """
    fs, revolution_rate, m, sigma, seconds = 81920.0, 10.0, HIGH_FREQUENCY_BINS_PER_REVOLUTION, 0.5, 20.0
    n = int(seconds * fs)
    noise = sigma * rng.standard_normal(n)
    start = 0.0123 + 0.5 / fs  # grid times half-way between samples: whole bins of 16 samples
    pulses = start + np.arange(int((seconds - 0.05) * revolution_rate)) / revolution_rate
    angle_map = AngleMap.from_keyphasor(pulses, pulse_angle=0.0)
    burst_bin = 17
    burst = np.zeros(n)
    j = np.arange(48)
    pattern = 5 * sigma * np.hanning(48) * np.sin(2 * math.pi * 4000.0 * j / fs)
    for cycle in range(pulses.size):
        first = round((start + (cycle + (burst_bin + 0.25) / m) / revolution_rate) * fs)
        if first + pattern.size < n:
            burst[first : first + pattern.size] = pattern
    signal = noise + burst
    resampled = to_angle_domain(signal, fs, angle_map, samples_per_cycle=m, high_frequency=True)
    profile = resampled.high_frequency
    assert profile is not None and profile.cycles == resampled.values.shape[0]
    assert profile.mean.size == m and profile.band_hz == (1000.0, 10000.0)
    assert profile.speed_rpm == pytest.approx(600.0, rel=1e-9)
    taps = impact_band(fs)[0].taps
    gain = float(np.sum(taps**2))
    assert gain == pytest.approx(2 * 9500.0 / fs, rel=0.02)

    # the definition, evaluated plainly
    y = np.convolve(signal, taps, mode="same")
    b = np.convolve(burst, taps, mode="same")
    samples = fs / (revolution_rate * m)
    assert samples == 16
    total, burst_power, count = np.zeros(m), np.zeros(m), np.zeros(m)
    for cycle in range(profile.cycles):
        for i in range(m):
            if cycle == profile.cycles - 1 and i == m - 1:
                continue  # the last grid point has no next one: its bin is open
            t0 = start + (resampled.first_cycle + cycle + i / m) / revolution_rate
            j0 = math.ceil(t0 * fs)
            j1 = math.ceil((t0 + 1 / (revolution_rate * m)) * fs)
            assert j1 - j0 == samples
            total[i] += np.mean(y[j0:j1] ** 2)
            burst_power[i] += np.mean(b[j0:j1] ** 2)
            count[i] += 1
    np.testing.assert_allclose(profile.mean, total / count, rtol=1e-9)

    loud = np.flatnonzero(burst_power / count > 1e-3 * sigma**2 * gain)
    assert set(loud) >= {burst_bin, burst_bin + 1, burst_bin + 2}
    quiet = np.setdiff1d(np.arange(m), loud)
    single = sigma**2 * math.sqrt(_band_power_variance(taps, 16))
    # neighbouring bins share the filter's memory: their means are not independent, 2 x the spread
    spread = single / math.sqrt(profile.cycles * quiet.size)
    assert profile.mean[quiet].mean() == pytest.approx(sigma**2 * gain, abs=2 * 5 * spread)
    assert profile.std[quiet].mean() == pytest.approx(single, rel=0.03)
    expected = profile.mean[quiet].mean() + burst_power[burst_bin] / count[burst_bin]
    # the cross term 2/16 sum_j n_j b_j of one cycle: variance (2/16)^2 sum_jk b_j b_k sigma^2 r(j - k)
    t0 = start + (resampled.first_cycle + 1 + burst_bin / m) / revolution_rate
    own = b[math.ceil(t0 * fs) : math.ceil(t0 * fs) + 16]
    r = np.correlate(taps, taps, mode="full")[taps.size - 1 :][:16]
    covariance = sigma**2 * r[np.abs(np.subtract.outer(np.arange(16), np.arange(16)))]
    cross = (2 / 16) * math.sqrt(own @ covariance @ own / profile.cycles)
    assert profile.mean[burst_bin] == pytest.approx(expected, abs=5 * cross)
    assert profile.mean[burst_bin] > 1.5 * profile.mean[quiet].max()


def test_high_frequency_power_on_a_grid_finer_than_the_samples(rng: np.random.Generator) -> None:
    """128 bins per cycle at about 97 samples per cycle (1 kHz, 10.3 rev/s): many bins hold no sample in
    a cycle, the others one or two.  At 1 kHz the band is 125-500 Hz (its lower edge an eighth of the
    sampling rate), a high-pass whose transition is centred at 93.75 Hz: it passes (500 - 93.75) / 500
    of white noise's power within 2 %; averaged over the
    cycles in which a bin has samples, the bins' mean is that power within 3 % (its spread from
    250 000 squares is under 0.5 %)."""
    fs, revolution_rate, m, seconds = 1000.0, 10.3, 128, 250.0
    signal = rng.standard_normal(int(seconds * fs))
    pulses = 0.01 + np.arange(int((seconds - 0.2) * revolution_rate)) / revolution_rate
    resampled = to_angle_domain(
        signal, fs, AngleMap.from_keyphasor(pulses), samples_per_cycle=m, high_frequency=True
    )
    assert resampled.high_frequency is not None
    assert resampled.high_frequency.band_hz == (125.0, 500.0)
    gain = float(np.sum(impact_band(fs)[0].taps ** 2))
    assert gain == pytest.approx((500 - 93.75) / 500, rel=0.02)
    assert resampled.high_frequency.mean.mean() == pytest.approx(gain, rel=0.03)


def test_a_slow_engines_profile_has_bins_of_half_a_millisecond(rng: np.random.Generator) -> None:
    """At 1 rev/s (60 rpm) 512 bins per revolution would last 2 ms each, longer than a knock's ring:
    the profile has 2048 (0.49 ms each, a power of two), and coarsening it by 4 gives the mean of each
    four bins with their spreads added as independent."""
    fs, revolution_rate, seconds = 10240.0, 1.0, 12.0
    signal = rng.standard_normal(int(seconds * fs))
    pulses = 0.01 + np.arange(int((seconds - 0.2) * revolution_rate)) / revolution_rate
    profile = to_angle_domain(
        signal, fs, AngleMap.from_keyphasor(pulses), samples_per_cycle=256, high_frequency=True
    ).high_frequency
    assert profile is not None and profile.mean.size == 2048
    coarse = profile.coarsened(512)
    np.testing.assert_allclose(coarse.mean, profile.mean.reshape(512, 4).mean(axis=1), rtol=1e-12)
    np.testing.assert_allclose(coarse.std, np.sqrt((profile.std.reshape(512, 4) ** 2).sum(axis=1)) / 4)
    with pytest.raises(SignalError, match="cannot be coarsened to 3"):
        profile.coarsened(3)
