"""Tooth-pitch errors learned on a motored run-up, at every order, and the speed orders they give back.

At one steady speed a wheel's error that repeats every revolution cannot be told from the engine's
speed fluctuation at the same order; over a run-up it can, because the wheel's errors do not change
with speed and the gas forces' share does. The crank of these tests is written here, apart from
the product's model: a six-cylinder four-stroke turned by a constant torque from 150 to 750 rpm,
motored (each cylinder compresses and expands its air polytropically), its speed from the exact
energy balance ``J(theta) omega^2 / 2 = E(theta)`` with ``J(theta)`` from the slider-crank's
positions differentiated numerically (piston, connecting rod's mass and its moment of inertia).
The product learns from the tooth times alone, taking the reciprocating parts' share from its own
model of the engine (:func:`monitor.model.predicted.inertia_angle_fluctuation`).
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
from scipy.integrate import cumulative_trapezoid

from monitor.cli import main
from monitor.diagnosis import Baseline
from monitor.errors import SignalError
from monitor.io.hdf5 import write_hdf5
from monitor.io.recording import Channel, Recording
from monitor.model.engine import Engine, load_engine
from monitor.model.inertia import engine_side_inertia
from monitor.model.predicted import inertia_angle_fluctuation
from monitor.scene import load_scene, simulate
from monitor.signal.measure import spectra
from monitor.signal.pitch_uncertainty import COVERAGE
from monitor.signal.reference import learn_pitch_errors_over_speed
from tests.conftest import ROOT
from tests.signal.test_real_sensors import FS, _vr_voltage

TEETH, MISSING = 60, 2
PITCH = 2 * math.pi / TEETH


class _Crank:
    """A motored engine's crank mechanism, by its positions (written here, apart from the product)."""

    def __init__(self, engine: Engine) -> None:
        self.r, self.rod = engine.crank_radius, engine.rod_length
        self.masses = engine.masses
        self.area = math.pi * engine.geometry.bore_m**2 / 4
        assert engine.combustion is not None
        self.clearance = self.area * 2 * self.r / (engine.combustion.compression_ratio - 1)
        self.firing = np.asarray(engine.firing_angles)
        grid = np.linspace(0.0, 4 * math.pi, 8192, endpoint=False)
        # the rest of the engine side (throws, free end, flywheel) tops the mean up to the product's
        # rigid inertia: the data is the engine's, the dynamics are this class's
        self.rest = engine_side_inertia(engine) - float(self.mechanism_inertia(grid).mean())

    def _positions(self, theta: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Piston pin height above the crank axis, the rod's centre of gravity (x, y), the rod's angle."""
        s, c = np.sin(theta), np.cos(theta)
        pin = self.r * c + np.sqrt(self.rod**2 - (self.r * s) ** 2)
        share = self.masses.conrod_cg_from_piston_pin_m / self.rod
        centre = np.stack([share * self.r * s, pin + share * (self.r * c - pin)])
        return pin, centre, np.arcsin(self.r * s / self.rod)

    def _rates(self, theta: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """d/dtheta of the positions, by central differences (step 1e-6 rad: error about 1e-12)."""
        h = 1e-6
        ahead, behind = self._positions(theta + h), self._positions(theta - h)
        return tuple((a - b) / (2 * h) for a, b in zip(ahead, behind, strict=True))  # type: ignore[return-value]

    def mechanism_inertia(self, theta: np.ndarray) -> np.ndarray:
        """Every cylinder's piston and rod as an inertia about the crank axis [kg m^2]."""
        total = np.zeros_like(theta)
        for angle in self.firing:
            pin, centre, rod = self._rates(theta - angle)
            total += (
                self.masses.piston_assembly_kg * pin**2
                + self.masses.conrod_kg * (centre**2).sum(axis=0)
                + self.masses.conrod_inertia_kgm2 * rod**2
            )
        return total

    def gas_torque(self, theta: np.ndarray, *, exponent: float = 1.35, charge: float = 1e5) -> np.ndarray:
        """Motored: the charge compressed and expanded polytropically around each firing TDC [N m]."""
        total = np.zeros_like(theta)
        for angle in self.firing:
            own = np.mod(theta - angle + 2 * math.pi, 4 * math.pi) - 2 * math.pi
            pin, _, _ = self._positions(own)
            rate, _, _ = self._rates(own)
            volume = self.clearance + self.area * (self.rod + self.r - pin)
            largest = self.clearance + self.area * 2 * self.r
            pressure = np.where(np.abs(own) < math.pi, charge * (largest / volume) ** exponent, charge)
            total += (pressure - charge) * -self.area * rate
        return total

    def run_up(self, revolutions: int, rpm_from: float, rpm_to: float) -> tuple[np.ndarray, np.ndarray]:
        """Crank angle and time of a run-up by a constant torque: the energy balance, exactly."""
        alpha = np.linspace(0.0, 2 * math.pi * revolutions, revolutions * 2880 + 1)
        inertia = self.rest + self.mechanism_inertia(alpha)
        gas = cumulative_trapezoid(self.gas_torque(alpha), alpha, initial=0.0)
        w0, w1 = rpm_from * math.pi / 30, rpm_to * math.pi / 30
        start = 0.5 * inertia[0] * w0**2
        drive = (0.5 * inertia[-1] * w1**2 - start - gas[-1]) / alpha[-1]
        speed = np.sqrt(2 * (start + drive * alpha + gas) / inertia)
        return alpha, cumulative_trapezoid(1.0 / speed, alpha, initial=0.0)


def _steady(
    rpm: float, orders: dict[float, tuple[float, float]], revolutions: int
) -> tuple[np.ndarray, np.ndarray]:
    """Crank angle and time at a mean speed with the given speed orders: w0 + sum a_k cos(k alpha + phi_k)."""
    alpha = np.linspace(0.0, 2 * math.pi * revolutions, revolutions * 2880 + 1)
    speed = rpm * math.pi / 30 + sum(a * np.cos(k * alpha + phase) for k, (a, phase) in orders.items())
    return alpha, cumulative_trapezoid(1.0 / speed, alpha, initial=0.0)


def _tooth_events(
    alpha: np.ndarray, time: np.ndarray, errors: np.ndarray, jitter: float, rng: np.random.Generator
) -> Channel:
    """The wheel's edge times: tooth k really at k pitch + its error, timed with jitter [s rms]."""
    k = np.arange(1, int(alpha[-1] / PITCH) - 1)
    k = k[np.mod(k, TEETH) < TEETH - MISSING]
    times = np.interp(k * PITCH + errors[np.mod(k, TEETH)], alpha, time) + jitter * rng.standard_normal(
        k.size
    )
    fields = {"teeth": TEETH, "missing_teeth": MISSING, "first_tooth_angle_deg": 0.0}
    return Channel("tooth", "tooth", "s", times, None, fields=fields)


def _tooth_voltage(
    alpha: np.ndarray, time: np.ndarray, errors: np.ndarray, rng: np.random.Generator
) -> Channel:
    """A variable-reluctance sensor's voltage from the same wheel (10 V peak at 1000 rpm, in proportion
    to speed; 10 mV noise), sampled at FS."""
    t = np.arange(int(time[-1] * FS)) / FS
    angle = np.interp(t, time, alpha)
    speed = np.gradient(angle, t)
    one_turn = np.linspace(0.0, 2 * math.pi, 20000)
    scale = 10.0 / np.max(np.abs(_vr_voltage(one_turn, np.full(one_turn.size, 1000 * math.pi / 30))))
    voltage = scale * _vr_voltage(angle, speed, errors=errors) + 0.01 * rng.standard_normal(t.size)
    fields = {"teeth": TEETH, "missing_teeth": MISSING, "first_tooth_angle_deg": 0.0, "sensor": "vr"}
    return Channel("tooth", "tooth", "V", voltage, FS, fields=fields)


def _recording(channel: Channel) -> Recording:
    return Recording("medium-speed-6l32", "2026-11-23T00:00:00Z", (channel,))


# a misfire of one cylinder at 750 rpm: the half orders appear beside the firing harmonics 3 and 6 [rad/s]
MISFIRE = {
    0.5: (0.40, 0.3),
    1.0: (0.18, -1.0),
    1.5: (0.10, 2.0),
    2.0: (0.06, 0.7),
    3.0: (0.16, -2.2),
    6.0: (0.054, 1.1),
}


@pytest.fixture(scope="module")
def engine() -> Engine:
    return load_engine("medium-speed-6l32")


@pytest.fixture(scope="module")
def crank(engine: Engine) -> _Crank:
    return _Crank(engine)


@pytest.fixture(scope="module")
def run_up(crank: _Crank) -> tuple[np.ndarray, np.ndarray]:
    return crank.run_up(300, 150.0, 750.0)


def _orders_off(recording: Recording, correction: object) -> dict[float, float]:
    result = spectra(
        recording, cycle_revolutions=2, channels=[], cycle_phase=0.0, pitch_correction=correction
    )  # type: ignore[arg-type]
    measured = result.spectra["crank speed"]
    return {
        k: abs(abs(measured.amplitude[int(np.argmin(np.abs(measured.orders - k)))]) / a - 1)
        for k, (a, _) in MISFIRE.items()
    }


def test_a_motored_run_up_teaches_every_tooths_error_firing_harmonics_included(
    engine: Engine, run_up: tuple[np.ndarray, np.ndarray], rng: np.random.Generator
) -> None:
    """Issue acceptance (pitch errors of +-0.1 deg, true speed orders within 2 % after the correction):
    learned on the motored run-up (edge times with 0.2 us jitter), every tooth's error comes back
    within 0.002 deg (measured: 3.4e-4 deg at most). A later fired recording of the same wheel at
    750 rpm, one cylinder misfiring, then gives every speed order within 2 % of the truth, the firing
    harmonics 3 and 6 included (measured: 0.5 % at most, order 6); uncorrected, orders 2, 3 and 6 are
    off by 12, 46 and 60 %. Without the model's inertia share, the learned errors carry the
    reciprocating parts' fluctuation (0.06 deg at order 3) and order 3 comes out 126 % off."""
    errors = np.radians(rng.uniform(-0.1, 0.1, TEETH))
    learning = _recording(_tooth_events(*run_up, errors, 0.2e-6, rng))
    learned = learn_pitch_errors_over_speed(learning, inertia_angle_fluctuation(engine))
    assert learned.source == "run-up" and learned.scope == "all" and learned.kept_orders == ()
    truth = errors[: TEETH - MISSING] - errors[: TEETH - MISSING].mean()
    assert np.max(np.abs(np.degrees(learned.errors - truth))) < 0.002
    assert math.degrees(learned.standard_error) < 0.001

    later = _recording(_tooth_events(*_steady(750.0, MISFIRE, 200), errors, 0.2e-6, rng))
    corrected = _orders_off(later, learned)
    assert max(corrected.values()) < 0.02, corrected
    plain = _orders_off(later, "none")
    assert plain[3.0] > 0.05 and max(plain.values()) > 0.1, plain
    without_model = learn_pitch_errors_over_speed(learning)
    assert _orders_off(later, without_model)[3.0] > 0.02


@pytest.mark.parametrize(
    ("jitter", "revolutions", "speeds"), [(0.2e-6, 300, (150.0, 750.0)), (5e-6, 60, (500.0, 750.0))]
)
def test_each_learned_order_is_within_three_of_its_stated_errors(
    engine: Engine,
    crank: _Crank,
    jitter: float,
    revolutions: int,
    speeds: tuple[float, float],
    rng: np.random.Generator,
) -> None:
    """The standard error stated for each whole order of the learned errors is honest both ways: every
    order's error within COVERAGE (3) of it, and where the scatter rules the median order at 0.3 of it
    or more (not stated wildly large).
    Timing jitter of 0.2 us over the wide run-up leaves the first-order speed law's own error (up to
    2.6e-4 deg, 0.44 of the floor RESOLUTION states); 5 us over 60 revolutions from 500 to 750 rpm
    leaves the scatter (measured: 2.2 of it at most, 0.7 to 1.0 in the median)."""
    run = crank.run_up(revolutions, *speeds)
    for _ in range(3):
        errors = np.radians(rng.uniform(-0.1, 0.1, TEETH))
        learning = _recording(_tooth_events(*run, errors, jitter, rng))
        learned = learn_pitch_errors_over_speed(learning, inertia_angle_fluctuation(engine))
        assert learned.order_errors is not None
        truth = errors[: TEETH - MISSING] - errors[: TEETH - MISSING].mean()
        angles = 2 * np.pi * np.arange(TEETH - MISSING) / TEETH
        whole = np.arange(1, learned.order_errors.size + 1)
        off = np.abs((learned.errors - truth) @ np.exp(-1j * np.outer(angles, whole))) * 2 / angles.size
        ratio = off / learned.order_errors
        assert ratio.max() < COVERAGE
        assert np.median(ratio) > (0.3 if jitter > 1e-6 else 0.02)


@pytest.mark.slow
def test_a_vr_wheel_over_the_run_up_teaches_the_errors_its_zero_crossings_carry(
    engine: Engine, run_up: tuple[np.ndarray, np.ndarray], rng: np.random.Generator
) -> None:
    """The same wheel read by a VR sensor (a waveform written in these tests, 10 mV of noise): its
    zero crossings sit where the wheel's teeth and their neighbours' overlapping fields put them, a
    fixed angle per tooth, which is what the run-up teaches. The later fired recording through the
    same VR sensor gives its speed orders within 2 % (measured: 1.5 % at most, order 6: the crossings
    beside the gap, where the field is flat, move by up to 0.025 deg between 200 and 750 rpm, which no
    fixed error describes); uncorrected, orders 2, 3 and 6 are 76, 45 and 35 % off."""
    errors = np.radians(rng.uniform(-0.1, 0.1, TEETH))
    learned = learn_pitch_errors_over_speed(
        _recording(_tooth_voltage(*run_up, errors, rng)), inertia_angle_fluctuation(engine)
    )
    later = _recording(_tooth_voltage(*_steady(750.0, MISFIRE, 200), errors, rng))
    corrected = _orders_off(later, learned)
    assert max(corrected.values()) < 0.02, corrected
    assert _orders_off(later, "none")[6.0] > 0.2


def test_a_run_at_one_speed_is_refused_with_the_speeds_it_spans(rng: np.random.Generator) -> None:
    alpha, time = _steady(750.0, MISFIRE, 40)
    with pytest.raises(
        SignalError, match=r"changes by a factor of 1.25 or more .* spans 7\d\d.\d to 7\d\d.\d rpm"
    ):
        learn_pitch_errors_over_speed(_recording(_tooth_events(alpha, time, np.zeros(TEETH), 0.0, rng)))


def test_calibrate_learns_the_pitch_errors_on_the_run_given_and_says_so(
    tmp_path: Path,
    run_up: tuple[np.ndarray, np.ndarray],
    rng: np.random.Generator,
    capsys: pytest.CaptureFixture[str],
) -> None:
    """engine-monitor calibrate --pitch-from RUN: the baseline stores the errors learned on the run
    (every order, none left to the engine), and says where they came from and their size."""
    errors = np.radians(rng.uniform(-0.1, 0.1, TEETH))
    run = write_hdf5(_recording(_tooth_events(*run_up, errors, 0.2e-6, rng)), tmp_path / "run-up.h5")
    healthy = simulate(load_scene(ROOT / "recordings" / "scenes" / "6l32-baseline.toml")).recording
    baseline = write_hdf5(healthy, tmp_path / "baseline.h5")
    out = tmp_path / "baseline.json"
    assert main(["calibrate", str(baseline), "--pitch-from", str(run), "-o", str(out)]) == 0
    told = capsys.readouterr().err
    assert "learned on the run" in told and "run-up.h5" in told and "standard error" in told
    stored = json.loads(out.read_text())["tooth_pitch"]
    assert stored["learned_on"] == "run-up" and stored["kept_orders"] == []
    truth = errors[: TEETH - MISSING] - errors[: TEETH - MISSING].mean()
    assert np.max(np.abs(np.asarray(stored["errors_deg"]) - np.degrees(truth))) < 0.002
    # each whole order's standard error is kept, and read back
    assert len(stored["order_errors_deg"]) == (TEETH - MISSING) // 2
    pitch = Baseline.from_document(json.loads(out.read_text())).pitch
    assert pitch is not None and pitch.order_errors is not None
    np.testing.assert_allclose(np.degrees(pitch.order_errors), stored["order_errors_deg"], rtol=1e-12)


def test_the_models_inertia_fluctuation_matches_the_energy_balance(engine: Engine, crank: _Crank) -> None:
    """With no gas and no load the crank keeps J(theta) omega^2 constant; the angle it runs ahead of
    uniform rotation (the integral of omega / mean speed - 1 over the angle, the mean speed being a
    revolution over its time) is what :func:`inertia_angle_fluctuation` predicts from the model's
    inertia torque to first order: within 0.2 % of its peak to peak of 0.12 deg (measured: 0.02 %;
    the first-order theory leaves terms of the order of the inertia ratio's square, about 1e-3)."""
    theta = np.linspace(0.0, 2 * math.pi, 4097)
    slowness = np.sqrt(crank.rest + crank.mechanism_inertia(theta))  # 1 / omega, to a constant
    time = cumulative_trapezoid(slowness, theta, initial=0.0)
    ahead = theta - 2 * math.pi * time / time[-1]
    ahead -= ahead[:-1].mean()
    predicted = inertia_angle_fluctuation(engine)(theta)
    assert np.ptp(predicted) == pytest.approx(math.radians(0.118), rel=0.05)
    assert np.max(np.abs(predicted - ahead)) < 0.002 * np.ptp(ahead)
