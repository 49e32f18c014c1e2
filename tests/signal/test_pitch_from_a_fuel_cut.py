"""Tooth-pitch errors learned on a real fuel cut, and the bounds the crank-speed orders then carry.

../shared/external/tue-4gb10 (skipped where absent): the single-cylinder 4GB10 rig's 60-2 wheel
(the tooth after the gap is weak), a fuel cut from full load on E5 (E5FULLOAD4EngineOff: about 2000
to 1500 rpm in 0.5 s, still compressing), a motored coast-down (ENGINEOFF4: 1460 to 1175 rpm) and
steady fired runs at no, half and full load (2940 to 3200 rpm). TDC comes from the coast-down's
compression peaks (benchmarks/rig_4gb10.py).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from benchmarks.rig_4gb10 import first_tooth_angle
from monitor.cli import main
from monitor.io.hdf5 import write_hdf5
from monitor.io.recording import Channel, Recording
from monitor.signal.measure import SPEED_CHANNEL, SpectrumResult, spectra
from monitor.signal.pitch import PitchCorrection, estimate_pitch_errors
from monitor.signal.pitch_uncertainty import COVERAGE
from monitor.signal.reference import (  # the product's own decoding
    _wheel_channel,
    _wheel_decoding,
    learn_pitch_errors_over_speed,
)
from tests.conftest import shared_path

FIRED = ("E10NOLOAD1", "E10HALFLOAD1", "E10HALFLOAD2", "E10FULLLOAD1", "E10FULLLOAD2", "E0NOLOAD1")
CUT = "E5FULLOAD4EngineOff"


@pytest.fixture(scope="module")
def folder() -> Path:
    return shared_path("external", "tue-4gb10")


@pytest.fixture(scope="module")
def wheel_angle(folder: Path) -> float:
    return first_tooth_angle(folder)


def _run(folder: Path, stem: str, wheel_angle: float) -> Recording:
    """The rig's export (time, tooth wheel [V], pressure [V]) as a recording, written here."""
    _, tooth, pressure = np.loadtxt(folder / f"{stem}.txt").T
    fields = {"teeth": 60, "missing_teeth": 2, "first_tooth_angle_deg": wheel_angle}
    return Recording(
        "kluczyk-1cyl-4stroke",
        "2026-11-27T00:00:00Z",
        (
            Channel("tooth", "tooth", "V", tooth, 1e5, fields=fields),
            Channel("p1", "pressure", "V", pressure, 1e5, fields={"cylinder": 1}),
        ),
    )


@pytest.fixture(scope="module")
def runs(folder: Path, wheel_angle: float) -> dict[str, Recording]:
    return {stem: _run(folder, stem, wheel_angle) for stem in (*FIRED, CUT, "ENGINEOFF4")}


@pytest.fixture(scope="module")
def fuel_cut(runs: dict[str, Recording]) -> PitchCorrection:
    return learn_pitch_errors_over_speed(runs[CUT])


def _speed(recording: Recording, correction: PitchCorrection | str = "estimate") -> SpectrumResult:
    return spectra(
        recording,
        cycle_revolutions=2,
        channels=[],
        max_order=24,
        pitch_correction=correction,  # type: ignore[arg-type]
    )


def test_a_short_fuel_cut_is_learned_with_a_line_in_the_speed_and_says_how_well_order_by_order(
    fuel_cut: PitchCorrection,
) -> None:
    """Eleven revolutions between 1960 and 1535 rpm: a line in ``1 / speed^2`` extrapolates to the
    wheel's errors with a standard error of 0.23 deg a tooth (the square's, extrapolating from so
    short a span, was 1.8 deg and made the corrected orders 6 to 8 read 7 to 9 rad/s). The first
    orders follow the compression least well: order 1 is learned to about 0.16 deg, orders 3 to 12 to
    0.01 to 0.03 deg."""
    assert fuel_cut.source == "run-up" and fuel_cut.revolutions == 11
    assert math.degrees(fuel_cut.standard_error) < 0.3
    assert fuel_cut.order_errors is not None and fuel_cut.order_errors.size == 29
    first, rest = np.degrees(fuel_cut.order_errors[0]), np.degrees(fuel_cut.order_errors[2:12])
    assert 0.1 < first < 0.25 and rest.max() < 0.03
    assert first > 4 * rest.max()


def test_the_weak_tooth_after_the_gap_lags_by_a_time_so_its_error_grows_with_speed(
    runs: dict[str, Recording],
) -> None:
    """Where the tooth after the gap is read, each revolution, against a parabola through the two
    teeth on each side of it (time to angle): +1.26 deg from its place at about 1340 rpm (the
    coast-down), +1.44 at 1790 (the fuel cut), +2.06 to 2.11 at 2940 to 3200 (the fired runs). About
    0.45 deg per 1000 rpm: an edge that lags by some 75 us, not a tooth out of place. A correction
    learned at one speed is wrong there at another, which is why the gap's neighbours are estimated
    again on every recording."""

    def lead(recording: Recording) -> tuple[float, float]:
        decoding = _wheel_decoding(recording, _wheel_channel(recording))
        first = np.flatnonzero(decoding.tooth_index == 0)
        first = first[(first >= 2) & (first + 2 < decoding.times.size)]
        around = np.array([-4.0, -3.0, 1.0, 2.0])  # pitches from where the tooth should be
        places, speeds = [], []
        for i in first:
            times = decoding.times[[i - 2, i - 1, i + 1, i + 2]]
            places.append(6.0 * np.polyval(np.polyfit(times, around, 2), decoding.times[i]))
            speeds.append(1.0 / (decoding.times[i + 2] - decoding.times[i + 1]))  # rpm: a pitch is 1/60 turn
        return float(np.mean(places)), float(np.mean(speeds))

    slow, slow_rpm = lead(runs["ENGINEOFF4"])
    middle, middle_rpm = lead(runs[CUT])
    fired = [lead(runs[stem]) for stem in FIRED]
    assert 1.1 < slow < 1.4 and 1.3 < middle < 1.6
    assert all(1.95 < place < 2.2 for place, _ in fired)
    rate = (np.mean([place for place, _ in fired]) - slow) / (np.mean([s for _, s in fired]) - slow_rpm)
    assert 0.35e-3 < rate < 0.55e-3  # deg per rpm
    assert slow_rpm < middle_rpm < min(s for _, s in fired)


def test_the_fuel_cut_corrected_and_the_uncorrected_orders_agree_within_their_stated_bounds(
    runs: dict[str, Recording], fuel_cut: PitchCorrection
) -> None:
    """Issue acceptance on the real rig: on each fired run, every whole order's reading corrected with
    the errors learned on the fuel cut and its reading without differ by no more than the two
    systematic bounds printed beside them (the unlearned errors', the learning's own); measured: 0.89
    of the sum at most (order 2). The half orders carry no bound either way. The gap's neighbours are
    estimated again on the fired run, and the notes say so. Order 1 is what the fuel cut teaches worst:
    its bound corrected is larger than uncorrected."""
    worst = 0.0
    for stem in FIRED:
        plain, corrected = (_speed(runs[stem], c).spectra[SPEED_CHANNEL] for c in ("estimate", fuel_cut))
        assert plain.systematic is not None and corrected.systematic is not None
        whole = (plain.orders > 0) & np.isclose(plain.orders, np.round(plain.orders))
        apart = np.abs(plain.amplitude - corrected.amplitude)[whole]
        allowed = (plain.systematic + corrected.systematic)[whole]
        worst = max(worst, float(np.max(apart / allowed)))
        assert not plain.systematic[~whole].any() and not corrected.systematic[~whole].any()
        assert corrected.systematic[plain.orders == 1.0] > plain.systematic[plain.orders == 1.0]
    assert worst < 1.0
    notes = _speed(runs[FIRED[0]], fuel_cut).reference.notes
    assert any("re-estimated on this recording" in note and "tooth 0" in note for note in notes), notes


def test_the_errors_left_in_by_one_steady_run_are_covered_on_another(runs: dict[str, Recording]) -> None:
    """The wheel learned tooth by tooth on one fired run (orders 1 to 5 left to the engine) and applied
    to another changes each order from 6 to 24 by less than the uncorrected reading's bound. The
    wheel's errors are not quite independent: its order 16 stands at 2.3 to 2.8 times the scale of
    independent errors, which is why the bound is 3 times it. Errors learned over speed keep their gap
    teeth within the speeds they were learned at; a steady run's keep them at any."""
    pairs = (("E10NOLOAD1", "E10HALFLOAD1"), ("E10NOLOAD1", "E10FULLLOAD1"), ("E10FULLLOAD1", "E0NOLOAD1"))
    for teacher, pupil in pairs:
        decoding = _wheel_decoding(runs[teacher], _wheel_channel(runs[teacher]))
        learned = estimate_pitch_errors(decoding, kept_orders=[1, 2, 3, 4, 5], scope="all")
        plain = _speed(runs[pupil]).spectra[SPEED_CHANNEL]
        corrected = _speed(runs[pupil], learned).spectra[SPEED_CHANNEL]
        assert plain.systematic is not None
        high = (plain.orders >= 6) & np.isclose(plain.orders, np.round(plain.orders))
        ratio = np.abs(plain.amplitude - corrected.amplitude)[high] / plain.systematic[high]
        assert ratio.max() < 1.0
        sixteen = int(np.flatnonzero(plain.orders[high] == 16.0)[0])
        assert 2.0 < COVERAGE * ratio[sixteen] < 3.0
    # learned over speed, the errors keep their gap teeth on a recording within the speeds they were
    # learned at (here: the fuel cut's own), and have them read again at another (the fired runs')
    cut = learn_pitch_errors_over_speed(runs[CUT])
    own = spectra(runs[CUT], cycle_revolutions=2, channels=[], max_order=6, pitch_correction=cut)
    assert not any("re-estimated" in note for note in own.reference.notes), own.reference.notes
    # a steady run's, learned tooth by tooth, keeps them at any speed
    decoding = _wheel_decoding(runs["E10NOLOAD1"], _wheel_channel(runs["E10NOLOAD1"]))
    learned = estimate_pitch_errors(decoding, kept_orders=[1, 2, 3, 4, 5], scope="all")
    far = spectra(runs[CUT], cycle_revolutions=2, channels=[], max_order=6, pitch_correction=learned)
    assert not any("re-estimated" in note for note in far.reference.notes), far.reference.notes


def test_spectrum_learns_on_the_run_given_and_refuses_one_whose_speed_hardly_changes(
    runs: dict[str, Recording], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """engine-monitor spectrum RECORDING --pitch-from RUN: says what it learned and how well, and the
    systematic column then holds what the learning leaves; a coast-down from 1460 to 1175 rpm is
    refused with the speeds it spans and what is needed."""
    fired = write_hdf5(runs["E10HALFLOAD1"], tmp_path / "fired.h5")
    cut = write_hdf5(runs[CUT], tmp_path / "cut.h5")
    assert (
        main(["spectrum", str(fired), "--channel", "tooth", "--orders", "1,1.5,2", "--pitch-from", str(cut)])
        == 0
    )
    out, err = capsys.readouterr()
    assert "tooth-pitch errors learned on" in err and "cut.h5" in err and "at orders 1 to 3" in err
    assert "systematic" in out and "learned on the run" in out
    assert "re-estimated on this recording" in out
    short = write_hdf5(runs["ENGINEOFF4"], tmp_path / "coast.h5")
    assert main(["spectrum", str(fired), "--pitch-from", str(short)]) == 2
    said = capsys.readouterr().err
    assert "--pitch-from" in said and "coast.h5" in said and "1.25" in said
