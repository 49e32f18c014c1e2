"""The diagnosis' decision rules on engines unlike the bundled ones, each against an independent route.

- The inertia a torque meets through a stiff driven end: the two-mass closed form, and its limits.
- The crank-speed model calibrated on a healthy baseline: an engine file whose firing harmonic is off
  by 40 % and 35 deg still gives a healthy engine all strengths at 1 and a misfire its 0; the
  calibration survives the baseline's JSON.
- The knock span: a narrow knock of a few bins that a window's mean would dilute is found where it
  is; white noise alone is not named at the family's false-alarm rate.
- A tooth-pitch correction larger than any wheel's machining is left out with a note.
"""

from __future__ import annotations

import math
import re
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from benchmarks.diagnosed import case_engine
from monitor.diagnosis import calibrate, diagnose
from monitor.diagnosis.analysis import engine_orders
from monitor.diagnosis.balance import CrankCalibration, cylinder_balance
from monitor.diagnosis.baseline import Baseline
from monitor.diagnosis.bearings import FAMILY_FALSE_ALARM, impact_score, span_score, window_bins
from monitor.diagnosis.rigid_speed import predicted_speed
from monitor.errors import ModelError
from monitor.io import read_recording
from monitor.model.engine import Engine, bundled_engines, load_engine
from monitor.model.inertia import engine_side_inertia, engine_side_inertia_at
from monitor.model.predicted import CylinderParts, combine_cylinders, cylinder_parts
from monitor.signal.impact import HighFrequencyPower
from monitor.signal.spectrum import OrderSpectrum
from tests.diagnosis.test_diagnosis_physics import _model, _parts
from validation.simulator import healthy_twin, random_case

ENGINE = "medium-speed-6l32"
SAMPLES = Path(__file__).resolve().parents[2] / "recordings" / "samples"


def _engine() -> Engine:
    return load_engine(bundled_engines()[ENGINE])


def _stiff(engine: Engine, stiffness: float) -> Engine:
    """The engine with every driven-end shaft at the given stiffness [N m/rad]."""
    line = engine.shaft_line
    assert line is not None
    driven = [e.model_copy(update={"stiffness_to_previous_nm_per_rad": stiffness}) for e in line.driven_end]
    return engine.model_copy(update={"shaft_line": line.model_copy(update={"driven_end": driven})})


def _speed_spectrum(orders: np.ndarray, amplitude: np.ndarray, standard_error: float) -> OrderSpectrum:
    blocks = 50
    zeros = np.zeros(orders.size)
    return OrderSpectrum(
        orders, amplitude, zeros, zeros, np.full(orders.size, standard_error * 7.0710678), blocks, 1
    )


# --- the inertia a torque meets ------------------------------------------------------------------


def test_a_stiff_driven_end_follows_the_engine_side_as_the_two_mass_closed_form_says() -> None:
    """One driven-end element beyond the flywheel on a shaft of stiffness k, inertia J_d, no damping:
    J(w) = J_e + J_d k / (k - w^2 J_d), the closed form of the two masses (the engine side driven).
    Below the mode it tends to J_e + J_d, far above (where the rule leaves the driven end out) J_e."""
    base = _engine()
    line = base.shaft_line
    assert line is not None
    names = [e.kind for e in line.driven_end]
    assert names[0] == "flywheel" and len(names) >= 2, names
    beyond = line.driven_end[1:]
    k = 1e10
    engine = _stiff(base, k)
    stiff_line = engine.shaft_line
    assert stiff_line is not None
    single = [
        stiff_line.driven_end[0],
        stiff_line.driven_end[1].model_copy(
            update={"absolute_damping_nms_per_rad": 0.0, "relative_damping_nms_per_rad": 0.0}
        ),
    ]
    engine = engine.model_copy(update={"shaft_line": stiff_line.model_copy(update={"driven_end": single})})
    J_e, J_d = engine_side_inertia(engine), single[1].inertia_kgm2
    w = np.array([1.0, 10.0, 100.0])
    mode = math.sqrt(k * (1 / J_e + 1 / J_d))
    assert w.max() < mode  # a stiff coupling: the rule takes the driven end in
    expected = J_e + J_d * k / (k - w**2 * J_d)
    np.testing.assert_allclose(engine_side_inertia_at(engine, w), expected, rtol=1e-12)
    assert engine_side_inertia_at(engine, [1e-3])[0].real == pytest.approx(J_e + J_d, rel=1e-9)
    assert beyond  # the bundled engine's own coupling is flexible: its mode lies among the orders
    flexible = engine_side_inertia_at(base, [2 * math.pi * 12.5 * k for k in (0.5, 1, 3, 6)])
    np.testing.assert_allclose(flexible, engine_side_inertia(base), rtol=0, atol=0)


def test_frequencies_must_be_positive() -> None:

    with pytest.raises(ModelError, match="positive"):
        engine_side_inertia_at(_engine(), [0.0, 1.0])


# --- the crank-speed model calibrated on a baseline --------------------------------------------


def _gapped(parts: CylinderParts, engine: Engine, strengths: np.ndarray, gap: complex) -> np.ndarray:
    """The engine torque with the combustion's firing harmonics multiplied by ``gap``: an engine
    file whose gas model is off where the cylinders add up."""
    firing = engine.cylinders / engine.cycle_revolutions
    harmonic = np.isclose(np.mod(parts.orders / firing + 0.5, 1.0), 0.5) & (parts.orders > 0)
    off = replace(parts, combustion=np.where(harmonic, gap, 1.0) * parts.combustion)
    return combine_cylinders(off, engine, strengths).engine_torque


def test_a_baseline_calibrates_a_firing_harmonic_the_engine_file_has_wrong() -> None:
    """The 'engine' has its combustion's firing harmonics at 60 % of what the engine file's gas model
    says, 90 deg later. Without calibration a misfire of cylinder 4 reads a meaningless share;
    calibrated on a healthy recording at 750 rpm, a later healthy one reads 1 +- 2 % for every
    cylinder, and a misfire at 712 rpm (5 % slower, as a propeller slows: the inertia torque 10 %
    smaller, which the calibration must not carry over) reads 0 +- 5 %, the others 1 +- 5 %. The
    calibration's combustion factor is the gap put in within 1 % (the inertia torque takes a small
    share of it: its 10 % uncertainty against the combustion's 100 %). Noise-free speed orders with a
    stated error of 1e-4 rad/s."""

    engine = _engine()
    parts = _parts(ENGINE)
    n, R = engine.cylinders, engine.cycle_revolutions
    inertia, mean_speed = engine_side_inertia(engine), 750 * math.pi / 30
    gap = 0.6 * np.exp(-1j * math.radians(90.0))

    def speed_of(strengths: np.ndarray, at: CylinderParts, speed: float) -> OrderSpectrum:
        torque = _gapped(at, engine, strengths, gap)
        return _speed_spectrum(at.orders, predicted_speed(torque, at.orders, inertia, speed, R), 1e-4)

    healthy = speed_of(np.ones(n), parts, mean_speed)
    plain = cylinder_balance(healthy, engine, parts)
    misfire = np.ones(n)
    misfire[3] = 0.0
    slower = 0.95 * mean_speed
    slow_parts = cylinder_parts(_model(ENGINE), crank_speed=slower, load=parts.load)
    slow_misfire = speed_of(misfire, slow_parts, slower)
    assert abs(cylinder_balance(slow_misfire, engine, slow_parts).relative[3]) > 0.2
    calibration = plain.calibration()
    firing = n / R
    np.testing.assert_allclose(calibration.orders, [firing])  # only where the cylinders add up
    np.testing.assert_allclose(calibration.factor, [gap], rtol=0.01)
    again = cylinder_balance(healthy, engine, parts, calibration=calibration)
    np.testing.assert_allclose(again.strength, 1.0, atol=0.02)
    assert again.chi2_reduced < 1
    found = cylinder_balance(slow_misfire, engine, slow_parts, calibration=calibration)
    np.testing.assert_allclose(found.strength, misfire, atol=0.05)
    assert found.relative[3] < 0.05

    with pytest.raises(Exception, match="transfer"):
        cylinder_balance(healthy, engine, parts, calibration=replace(calibration, transfer="shaft-line"))


def test_the_calibration_survives_the_baseline_document(tmp_path: Path) -> None:
    """Written and read back: orders, complex factors and their errors exactly (JSON keeps doubles);
    a document written before the calibration existed, or with one factor on the whole model (before
    the gap was shared between the model's parts), reads as none."""
    calibration = CrankCalibration(
        "rigid",
        np.array([3.0, 6.0]),
        np.array([1.2 - 0.3j, 0.9 + 0.1j]),
        np.array([0.01, 0.02]),
        np.array([1.01 + 0.02j, 0.98 - 0.01j]),
        np.array([0.001, 0.002]),
    )
    baseline = Baseline("e", 750.0, 1.0, [1.0] * 6, 128, {}, "b.h5", crank=calibration)
    read = Baseline.read(baseline.write(tmp_path / "b.json"))
    assert read.crank is not None
    np.testing.assert_array_equal(read.crank.orders, calibration.orders)
    np.testing.assert_array_equal(read.crank.factor, calibration.factor)
    np.testing.assert_array_equal(read.crank.factor_error, calibration.factor_error)
    np.testing.assert_array_equal(read.crank.inertia_factor, calibration.inertia_factor)
    np.testing.assert_array_equal(read.crank.inertia_factor_error, calibration.inertia_factor_error)
    document = baseline.to_document()
    document["crank_speed_model"]["factor"] = document["crank_speed_model"].pop("combustion_factor")
    del document["crank_speed_model"]["inertia_factor"]
    assert Baseline.from_document(document).crank is None
    del document["crank_speed_model"]
    assert Baseline.from_document(document).crank is None


# --- the knock span -------------------------------------------------------------------------------


def _profile(mean: np.ndarray, cycles: int, relative_spread: float) -> HighFrequencyPower:
    return HighFrequencyPower(mean, relative_spread * mean, cycles, 25600.0)


def test_a_narrow_knock_is_found_where_a_window_mean_would_dilute_it(rng: np.random.Generator) -> None:
    """1024 bins over a four-stroke cycle, 200 cycles, each bin's power spread 100 % over the cycles
    (so a bin's mean is known to 7 %). A knock doubles the power of 3 bins (2 deg) at 100 deg, inside
    the window of a reversal at 90 deg: its span scores about 2, far beyond chance, at its angle; the
    window's mean power rises by 5 % only (the old measure). The same profile without the knock scores
    below the significance needed."""
    bins, cycles = 1024, 200
    reference = np.full(bins, 1.0)
    quiet = reference * (1 + rng.standard_normal(bins) / math.sqrt(cycles))
    knocked = quiet.copy()
    at = int(100.0 / 720.0 * bins)
    knocked[at - 1 : at + 2] += 1.0
    reversal = np.radians([90.0])
    score = impact_score(_profile(knocked, cycles, 1.0), reversal, 3, 2, _profile(reference, cycles, 1.0))
    assert score.score == pytest.approx(2.0, abs=0.3)
    assert score.significance > score.significance_needed + 3
    assert score.angle_deg == pytest.approx(100.0, abs=1.5)

    mask = window_bins(reversal, bins, 2)
    assert knocked[mask].mean() / reference[mask].mean() < 1.1
    calm = impact_score(_profile(quiet, cycles, 1.0), reversal, 3, 2, _profile(reference, cycles, 1.0))
    assert calm.significance < calm.significance_needed


def test_noise_alone_is_significant_at_about_the_family_rate(rng: np.random.Generator) -> None:
    """400 profiles of normal noise at the stated per-bin error against an exact reference: the share
    whose loudest span reaches the significance needed is FAMILY_FALSE_ALARM within its binomial
    spread (at most 2 of 400 where 0.04 are expected at 1e-4: a normal approximation of the bins'
    power that held would leave even 1 rare)."""
    bins, cycles, trials = 1024, 100, 400
    reference = _profile(np.ones(bins), cycles, 1.0)
    reversals = np.radians([30.0, 250.0, 470.0])
    hits = 0
    for _ in range(trials):
        mean = 1.0 + rng.standard_normal(bins) / math.sqrt(cycles)
        s = impact_score(HighFrequencyPower(mean, np.ones(bins), cycles, 25600.0), reversals, 1, 2, reference)
        hits += s.significance >= s.significance_needed
    assert hits <= 2, (hits, FAMILY_FALSE_ALARM)


def test_span_score_reads_the_span_at_an_angle() -> None:
    """The span centred at an angle, against the reference's same bins: a doubled 3-bin span reads 2."""
    bins = 1024
    mean = np.ones(bins)
    at = int(100.0 / 720.0 * bins)
    mean[at - 1 : at + 2] = 2.0
    profile = _profile(mean, 10, 0.1)
    assert span_score(
        profile, (at + 0.5) * 720.0 / bins, 2, _profile(np.ones(bins), 10, 0.1)
    ) == pytest.approx(2.0)
    assert span_score(profile, 400.0, 2, _profile(np.ones(bins), 10, 0.1)) == pytest.approx(1.0)


# --- tooth-pitch errors no wheel has ----------------------------------------------------------------


def test_a_pitch_correction_no_wheel_has_is_not_learned() -> None:
    """A single-cylinder four-stroke at about 1000 rpm (validation case 525): its firing pulse drives
    the crank at orders above those left to the engine, and the 'errors' a steady recording would
    learn reach degrees, where a wheel's machining is hundredths. They were applied and failed the
    half-pitch check; now they are not learned (what the baseline keeps is within a tenth of a pitch),
    and the recording is diagnosed (the spectra's own estimate says in a note when it leaves one out)."""
    from monitor.signal.reference import PLAUSIBLE_PITCH_ERROR

    case = random_case(525, duration_s=10.0)
    engine = case_engine(case.engine_toml)
    twin = healthy_twin(case, seed=525 + 1_000_000)
    from monitor.signal.reference import learn_pitch_errors

    harmonics = engine_orders(engine, twin.recording, firing_only=True)
    assert harmonics is not None
    assert learn_pitch_errors(twin.recording, engine_orders=harmonics) is None
    baseline = calibrate(twin.recording, engine, load=twin.load_given)
    assert baseline.pitch is None or baseline.pitch.largest <= PLAUSIBLE_PITCH_ERROR * 2 * math.pi / 60
    diagnosis = diagnose(case.recording, engine, baseline=baseline, load=case.load_given)
    assert diagnosis.status in ("healthy", "warning", "alarm", "inconclusive")


@pytest.mark.parametrize(
    ("engine_id", "expected"),
    [
        # each bank an in-line six every 120 deg, B 55 deg behind: the banks add at every third order,
        # at order 3 to |cos(82.5 deg)| = 0.13 of the twelve cylinders (above ADD_UP = 0.05), and cancel
        # to round-off at every other order
        ("medium-speed-12v32", list(range(3, 25, 3))),
        # each bank every 90 deg, the other 60 deg apart: orders 4, 8, ... (order 4 at |cos 120 deg| = 0.5)
        ("high-speed-16v170", list(range(4, 25, 4))),
        # the in-line six: the multiples of cylinders / revolutions, as before
        ("medium-speed-6l32", list(range(3, 25, 3))),
    ],
)
def test_the_firing_harmonics_left_to_the_engine_are_where_its_cylinders_add_up(
    engine_id: str, expected: list[int]
) -> None:
    """engine_orders on a 60-tooth wheel (orders up to 0.4 x 60): the uneven V12's order 3 is kept, as
    a threshold of 0.14 or more would lose it; a threshold at round-off would keep every order."""
    recording = read_recording(SAMPLES / "12v32-misfire-b3.h5")
    assert engine_orders(load_engine(engine_id), recording, firing_only=True) == expected


def test_cylinders_firing_nearly_together_are_named_as_the_crank_speed_cannot_part() -> None:
    """The validation simulator's V engines (their bank angle near a multiple of the banks' firing
    interval): a V16 of 89.5 deg fires eight pairs 0.5 deg apart, named with orders up to 8; a V20 of
    77 deg fires ten pairs 5.0 deg apart, whose phases part by 5 deg x k: under TOGETHER (45 deg) up to
    order 8.5, not at order 10 (the V20's highest, n / 2); an even 54 deg V16 has no such pair."""
    from monitor.diagnosis.analysis import firing_together
    from monitor.diagnosis.shares import TOGETHER
    from validation.simulator.description import engine_description
    from validation.simulator.vee_engine import engine_of_seed

    def engine(seed: int) -> Engine:
        return case_engine(engine_description(engine_of_seed(seed, True)))

    v16 = firing_together(engine(300046), 8.0)
    pairs = re.findall(r"([AB]\d+) and ([AB]\d+) \((\d+\.\d) deg\)", v16)
    assert len(pairs) == 8 and {a[0] + b[0] for a, b, _ in pairs} == {"AB"}, v16
    assert {apart for *_, apart in pairs} == {"0.5"}
    v20 = engine(300058)
    assert math.degrees(TOGETHER) == 45.0
    assert firing_together(v20, 8.5).count(" deg)") == 10
    assert firing_together(v20, 10.0) == ""
    assert firing_together(engine(300070), 8.0) == ""
