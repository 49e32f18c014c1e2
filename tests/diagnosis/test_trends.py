"""Trends: the quantities of each diagnosis, the CUSUM drift rule, and the store's trend points."""

from __future__ import annotations

import json
import math
import shutil
from datetime import UTC, datetime, timedelta
from pathlib import Path

import numpy as np
import pytest
import sqlalchemy as sa
from hypothesis import given, settings
from hypothesis import strategies as st

from monitor.diagnosis.trends import (
    DECISION,
    REFERENCE,
    ROBUST_SIGMAS,
    cusum,
    drift,
    judged,
    reference,
    trend_points,
)

ROOT = Path(__file__).resolve().parents[2]
SAMPLES = ROOT / "recordings" / "samples"
#: the bundled samples of in-line engines, whose counts and verdicts these tests know (a V engine's
#: sample, 12v32-misfire-b3, is diagnosed in tests/cli/test_cli_vee.py)
IN_LINE = ("7k98mc-baseline.h5", "7k98mc-misfire-cyl4.h5", "6l32-misfire-cyl3.h5")
NIGHTS = [datetime(2026, 1, 1, 2, tzinfo=UTC) + timedelta(days=n) for n in range(400)]


def _siegmund(shift: float, decision: float = DECISION) -> float:
    """One side's average run length after a shift of ``shift`` sigmas (Siegmund's approximation)."""
    d, b = shift - REFERENCE, decision + 1.166
    return (math.exp(-2 * d * b) + 2 * d * b - 1) / (2 * d * d)


def _run_length(z: np.ndarray, decision: float = DECISION) -> int:
    upper, lower = cusum(z)
    crossed = np.flatnonzero((upper > decision) | (lower > decision))
    return int(crossed[0]) + 1 if crossed.size else z.size + 1


def test_the_sums_by_hand() -> None:
    """S+ and S- after each value, K = 0.5, worked by hand: all exact binary fractions."""
    upper, lower = cusum([0.0, 1.0, 2.0, -1.0, -3.0])
    np.testing.assert_array_equal(upper, [0.0, 0.5, 2.0, 0.5, 0.0])
    np.testing.assert_array_equal(lower, [0.0, 0.0, 0.0, 0.5, 3.0])


def test_the_run_length_in_control_is_siegmunds() -> None:
    """Independent standard normal values, mean and spread known, H = 4 (the product's 9 would take tens
    of thousands of values a run): the mean run length to a false finding is Siegmund's 169 for the two
    sides. 400 runs: the mean's standard error is about 5 % (run lengths are nearly exponential), so
    0.8 to 1.25 of it holds at four of them."""
    rng = np.random.default_rng(20261126)
    lengths = [_run_length(rng.standard_normal(3000), 4.0) for _ in range(400)]
    expected = 1.0 / (2.0 / _siegmund(0.0, 4.0))
    assert 0.8 * expected < np.mean(lengths) < 1.25 * expected


@pytest.mark.parametrize("shift", [1.0, 2.0, 3.0])
def test_a_known_shift_is_found_after_siegmunds_delay(shift: float) -> None:
    """A shift of 1, 2, 3 sigmas from the first value, the product's H: found after Siegmund's 18.3, 6.5,
    4.0 values on average (2000 runs: the mean's standard error is under 2 %; the approximation itself is
    good to a few per cent at these shifts, so within 10 %)."""
    rng = np.random.default_rng(int(10 * shift))
    lengths = [_run_length(shift + rng.standard_normal(300)) for _ in range(2000)]
    assert np.mean(lengths) == pytest.approx(_siegmund(shift), rel=0.1)


def test_standardised_values_in_control_are_standard_normal() -> None:
    """Gaussian values of any mean and spread, standardised by their own history (lagged): mean 0 and
    spread 1 over 400 series (each u is Student's t mapped to the normal). The values of a series share
    their estimates, so the 20 000 are not independent: within 0.04 and 0.03, a few times the 0.007 of
    independent ones."""
    from monitor.diagnosis.trends import standardised

    rng = np.random.default_rng(11)
    u = standardised(50.0 + 3.0 * rng.standard_normal((400, 60)))[:, 10:].ravel()  # 400 series at once
    assert u.size == 20_000 and abs(u.mean()) < 0.04 and abs(u.std() - 1.0) < 0.03


def test_a_step_is_found_with_when_it_began_and_its_size() -> None:
    """Ten baseline nights at 1.00 +- 0.02, then a step down to 0.90 (five sigmas): found within three
    nights of the step, dated from the step (the night after the last zero of the sum, give or take
    one), the shift within two standard errors of the mean of the nights since (0.02 / sqrt(n))."""
    rng = np.random.default_rng(7)
    values = np.r_[1.0 + 0.02 * rng.standard_normal(10), 0.9 + 0.02 * rng.standard_normal(10)]
    found = drift(NIGHTS[:20], values, quantity="cylinder 4 strength", unit="-")
    assert found is not None and found.direction == "down"
    assert NIGHTS[10] <= found.found_at <= NIGHTS[14]
    assert abs((found.since - NIGHTS[10]).days) <= 1
    nights = (found.found_at - found.since).days + 1
    assert abs(found.shift - (-0.1)) < 2 * 0.02 * math.sqrt(2 / nights) + 0.02
    assert "cylinder 4 strength fell by" in found.summary and "since" in found.summary


def test_no_drift_without_a_change_or_after_the_baseline_period_alone() -> None:
    rng = np.random.default_rng(3)
    steady = 5.0 + 0.1 * rng.standard_normal(40)
    assert drift(NIGHTS[:40], steady) is None
    assert drift(NIGHTS[:10], steady[:10]) is None  # nothing after the baseline period
    # a baseline that did not move at all: the spread's floor (1 % of the mean) keeps noise of 0.1 % quiet
    flat = np.r_[np.full(10, 2.0), 2.0 + 0.002 * rng.standard_normal(30)]
    assert drift(NIGHTS[:40], flat) is None


def test_a_misfire_among_the_first_recordings_does_not_hide_a_falling_cylinder() -> None:
    """A cylinder's strength at 1.00 +- 0.015 (the nightly spread of the simulated 7K98MC's strengths,
    tests/diagnosis/test_trend_series.py), one misfire (0.05) among its first ten recordings, then falling
    to 0.67
    over four recordings. The plain mean and spread of the ten are widened to some 0.3 by the misfire,
    a drop of 0.33 is then about one sigma and the rule would need a dozen more recordings; with the
    misfire left out of the estimates the drop is twenty sigmas and found within the four, dated from
    its first recording, against the healthy 1.00 +- 0.015."""
    rng = np.random.default_rng(4)
    first = 1.0 + 0.015 * rng.standard_normal(10)
    first[3] = 0.05  # a misfire
    values = np.r_[first, np.linspace(1.0, 0.67, 5)[1:]]
    assert np.std(first, ddof=1) > 0.25  # the widened reference, as seen (0.298)
    found = drift(NIGHTS[:14], values, quantity="cylinder 4 strength", unit="-")
    assert found is not None and found.direction == "down"
    assert found.since == NIGHTS[10] and found.found_at <= NIGHTS[13]
    # the misfire is not in the reference: 1.00 within three standard errors of a mean of nine (0.015 / 3)
    assert abs(found.baseline_mean - 1.0) < 3 * 0.015 / 3
    assert found.baseline_sigma < 0.03


@settings(max_examples=60, deadline=None)
@given(
    seed=st.integers(0, 2**16),
    size=st.integers(9, 60),
    where=st.floats(0.0, 1.0),
    outlier=st.floats(-1e6, 1e6),
    centre=st.floats(-100.0, 100.0),
    scale=st.floats(1e-3, 1e3),
)
def test_one_outlier_cannot_widen_the_reference_beyond_its_band(
    seed: int, size: int, where: float, outlier: float, centre: float, scale: float
) -> None:
    """``size`` Gaussian values (no two equal, so their MAD is not zero) and one more anywhere, ``outlier``
    sigmas off: the spread of the c = size + 1 values is bounded by the clean values alone.

    The bound: with one value added, the median stays between the clean values' order statistics
    lo = y((n-1)//2) and hi = y(n//2 + 2) (1-based, n = size), and the MAD (the median of c deviations) is
    at most the (c//2 + 1)-th smallest of the clean values' deviations from that median, which moves by at
    most |m - lo| as the centre m does, so MAD <= M = D(c//2 + 1; lo) + (hi - lo). Every value kept lies
    within k 1.4826 c / (c - 0.8) MAD of the median, and at least ceil(c / 2) are kept (those within the
    MAD), so their standard deviation is at most k 1.4826 c / (c - 0.8) M sqrt(m / (m - 1)),
    m = ceil(c / 2); or the spread's floor, 1 % of the location. The outlier can add nothing beyond it,
    however far (the plain standard deviation grows with it without bound)."""
    rng = np.random.default_rng(seed)
    clean = centre + scale * rng.standard_normal(size)
    values = np.insert(clean, int(where * size), centre + scale * outlier)
    c, ordered = size + 1, np.sort(clean)
    lo, hi = ordered[(size - 1) // 2 - 1], ordered[size // 2 + 1]
    mad = np.sort(np.abs(clean - lo))[c // 2] + (hi - lo)
    m = (c + 1) // 2
    bound = ROBUST_SIGMAS * 1.4826 * c / (c - 0.8) * mad * math.sqrt(m / (m - 1))
    found = reference(values)
    # 1e-9: the sums' rounding, far above double precision's 1e-16 and far below what the bound allows
    assert float(found.spread) <= max(bound, 0.01 * abs(float(found.location))) * (1 + 1e-9)


@settings(max_examples=40, deadline=None)
@given(
    seed=st.integers(0, 2**16),
    size=st.integers(9, 60),
    where=st.floats(0.0, 1.0),
    far=st.floats(1e3, 1e9),
    side=st.sampled_from([-1.0, 1.0]),
)
def test_an_outlier_beyond_the_band_weighs_the_same_however_far(
    seed: int, size: int, where: float, far: float, side: float
) -> None:
    """A misfire's size does not matter: a value ``far`` sigmas off (beyond the band of ROBUST_SIGMAS
    robust sigmas for any of these samples, whose MAD is a few sigmas at most) is left out, and moved ten
    times farther it leaves the reference as it was (the order statistics, so the band and the values
    kept, are the same); the plain mean and spread follow it. Equal to 1e-12: the same values summed
    alike."""
    rng = np.random.default_rng(seed)
    clean = rng.standard_normal(size)
    near, further = (np.insert(clean, int(where * size), side * d) for d in (far, 10 * far))
    a, b = reference(near), reference(further)
    assert float(a.count) <= size and float(a.count) == float(b.count)
    assert float(a.location) == pytest.approx(float(b.location), rel=1e-12, abs=1e-12)
    assert float(a.spread) == pytest.approx(float(b.spread), rel=1e-12)
    plain_near, plain_further = (
        reference(near, robust_sigmas=math.inf),
        reference(further, robust_sigmas=math.inf),
    )
    assert float(plain_further.spread) > 5 * float(plain_near.spread)


def test_series_on_leading_axes_are_standardised_each_as_alone() -> None:
    """Values of several series at once (the benchmark's way: each history's median by a partition) give
    each series' own u as one series alone does (the product's way: its history kept sorted as it grows),
    to 1e-12 (the same sums taken in another order differ by some 1e-14). A band narrower than one MAD
    could keep nothing and is refused."""
    from monitor.diagnosis.trends import standardised

    rng = np.random.default_rng(12)
    values = 3.0 + rng.standard_normal((4, 40))
    values[2, 5] = -50.0  # one series with a fault in its baseline period
    together = standardised(values)
    for row, u in zip(values, together, strict=True):
        np.testing.assert_allclose(u, standardised(row), rtol=1e-12, atol=1e-12)
        np.testing.assert_allclose(
            standardised(row[None, :], robust_sigmas=3.0)[0], standardised(row, robust_sigmas=3.0), atol=1e-12
        )
    with pytest.raises(ValueError, match=r"robust_sigmas: 0.5; expected at least 1"):
        standardised(values, robust_sigmas=0.5)


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 2**16), scale=st.floats(1e-3, 1e3), step=st.floats(-6.0, 6.0))
def test_the_rule_does_not_depend_on_the_unit_and_a_mirror_swaps_the_direction(
    seed: int, scale: float, step: float
) -> None:
    """Values scaled by any positive factor give the same finding (the spread and its floor scale
    alike); values negated give the same nights, the other direction."""
    rng = np.random.default_rng(seed)
    values = np.r_[3.0 + 0.1 * rng.standard_normal(10), 3.0 + 0.1 * step + 0.1 * rng.standard_normal(15)]
    found = drift(NIGHTS[:25], values)
    scaled = drift(NIGHTS[:25], scale * values)
    mirrored = drift(NIGHTS[:25], -values)
    if found is None:
        assert scaled is None and mirrored is None
        return
    assert scaled is not None and mirrored is not None
    assert (scaled.found_at, scaled.since, scaled.direction) == (found.found_at, found.since, found.direction)
    assert scaled.shift == pytest.approx(scale * found.shift, rel=1e-9)
    assert (mirrored.found_at, mirrored.since) == (found.found_at, found.since)
    assert {mirrored.direction, found.direction} == {"up", "down"}


def test_the_quantities_of_a_document() -> None:
    """Each quantity from its place in the document; the operating point is not judged, the crank speed's
    channel is summed up by the cylinders, missing and non-finite values are left out."""
    document = {
        "speed_rpm": 104.0,
        "load": 0.75,
        "cylinder_balance": {
            "relative": [1.01, float("nan"), 0.5],
            "relative_standard_error": [0.06, 0.05, 0.07],
        },
        "channels": {
            "crank speed": {"deviation_of_largest": [3.0]},
            "mb2-vertical": {"orders": [1.0, 2.0, 4.0], "deviation_of_largest": [0.01, 0.2, 0.05]},
        },
        "impacts": {
            "mb2-vertical": [{"score": 1.2, "standard_error": 0.1}, {"score": 1.9, "standard_error": 0.2}]
        },
        "velocity_rms": {"mb2-vertical": {"value_mm_s": 0.34, "standard_error_mm_s": 0.001}},
    }
    points = {p.quantity: p for p in trend_points(document)}
    assert set(points) == {
        "speed",
        "load",
        "cylinder 1 strength",
        "cylinder 3 strength",
        "mb2-vertical order deviation",
        "mb2-vertical order 1 deviation",
        "mb2-vertical order 2 deviation",
        "mb2-vertical order 4 deviation",
        "mb2-vertical impact",
        "mb2-vertical rms velocity",
    }
    assert (points["cylinder 3 strength"].value, points["cylinder 3 strength"].standard_error) == (0.5, 0.07)
    assert points["mb2-vertical order deviation"].value == 0.2
    assert (points["mb2-vertical impact"].value, points["mb2-vertical impact"].standard_error) == (1.9, 0.2)
    assert points["mb2-vertical rms velocity"].unit == "mm/s"
    assert points["mb2-vertical order 4 deviation"].value == 0.05
    assert not judged("speed") and not judged("load") and judged("cylinder 1 strength")
    assert judged("mb2-vertical order deviation") and not judged("mb2-vertical order 2 deviation")
    assert trend_points({}) == []


def test_the_store_keeps_each_diagnosis_quantities_per_fleet_and_fills_in_older_results(
    tmp_path: Path, store_url: str
) -> None:
    """A batch writes each diagnosis's quantities with its result; another fleet's trend is empty; points
    lost (results stored before the table) are filled in again, the same."""
    from monitor.diagnosis import ANALYSIS_VERSION
    from monitor.jobs.batch import run_batch
    from monitor.store import open_store
    from monitor.store.schema import trend_points as table
    from monitor.store.trends import fill_trend_points, read_trend

    folder = tmp_path / "recordings"
    folder.mkdir()
    for name in ("7k98mc-baseline.h5", "7k98mc-misfire-cyl4.h5"):
        shutil.copy(SAMPLES / name, folder / name)
    store = open_store(store_url)
    try:
        ships, others = store.create_fleet("ships"), store.create_fleet("others")
        run_batch(store, ships, path=folder, workers=1)
        with store.transaction() as c:
            rows = read_trend(c, ships, "man-b-w-7k98mc", analysis_version=ANALYSIS_VERSION)
            assert read_trend(c, others, "man-b-w-7k98mc", analysis_version=ANALYSIS_VERSION) == []
        by_recording: dict[int, dict[str, float]] = {}
        for row in rows:
            by_recording.setdefault(row.recording_id, {})[row.quantity] = row.value
        assert len(by_recording) == 2
        misfire = next(r for r in store.recordings(ships) if r.filename == "7k98mc-misfire-cyl4.h5")
        document = store.result(misfire.id, ANALYSIS_VERSION, "diagnosis")
        assert document is not None
        assert by_recording[misfire.id]["cylinder 4 strength"] == document["cylinder_balance"]["relative"][3]
        assert rows[0].recorded_at.tzinfo is not None
        with store.transaction() as c:
            c.execute(sa.delete(table))
            assert fill_trend_points(c, ships) == 2 and fill_trend_points(c, ships) == 0
            again = read_trend(c, ships, "man-b-w-7k98mc", analysis_version=ANALYSIS_VERSION)
        assert [(r.recording_id, r.quantity, r.value) for r in again] == [
            (r.recording_id, r.quantity, r.value) for r in rows
        ]
    finally:
        store.close()


def test_the_trend_command(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """The summary table, --json, --quantity, --plot, and a clear error for an engine without diagnoses."""
    from monitor.cli import main

    folder = tmp_path / "recordings"
    folder.mkdir()
    for name in ("7k98mc-baseline.h5", "7k98mc-misfire-cyl4.h5"):
        shutil.copy(SAMPLES / name, folder / name)
    data = str(tmp_path / "data")
    assert main(["batch", str(folder), "--data", data, "--workers", "1"]) in (0, 1, 2)
    capsys.readouterr()
    assert main(["trend", "man-b-w-7k98mc", "--data", data]) == 0
    text = capsys.readouterr().out
    assert (
        "2 diagnosed recordings" in text and "cylinder 4 strength" in text and "trend findings: none" in text
    )
    plot = tmp_path / "trend.png"
    assert (
        main(
            ["trend", "man-b-w-7k98mc", "--data", data, "--json", "--quantity", "speed", "--plot", str(plot)]
        )
        == 0
    )
    document = json.loads(capsys.readouterr().out)
    assert list(document["quantities"]) == ["speed"] and len(document["quantities"]["speed"]["points"]) == 2
    assert document["rule"]["decision_sigmas"] == DECISION
    assert plot.stat().st_size > 10_000
    assert main(["trend", "no-such-engine", "--data", data]) == 2
    assert "no diagnosis of engine 'no-such-engine' in fleet 'local'" in capsys.readouterr().err
    assert main(["trend", "man-b-w-7k98mc", "--data", data, "--since", "yesterday"]) == 2
    assert "--since 'yesterday': expected a date" in capsys.readouterr().err


def test_the_fleet_summary_gives_each_engine_its_latest_verdict(tmp_path: Path, store_url: str) -> None:
    """Each engine with a diagnosis, its latest recording by recording time (not upload order), the counts
    of alarms and warnings; another fleet sees none of it."""
    from monitor.diagnosis import ANALYSIS_VERSION
    from monitor.jobs.batch import run_batch
    from monitor.store import open_store
    from monitor.store.trends import fleet_summary

    folder = tmp_path / "recordings"
    folder.mkdir()
    for name in IN_LINE:
        shutil.copy(SAMPLES / name, folder / name)
    store = open_store(store_url)
    try:
        ships, others = store.create_fleet("ships"), store.create_fleet("others")
        run_batch(store, ships, path=folder, workers=2)
        with store.transaction() as c:
            summary = {s.engine_id: s for s in fleet_summary(c, ships, analysis_version=ANALYSIS_VERSION)}
            assert fleet_summary(c, others, analysis_version=ANALYSIS_VERSION) == []
    finally:
        store.close()
    assert set(summary) == {"man-b-w-7k98mc", "medium-speed-6l32"}
    big = summary["man-b-w-7k98mc"]
    assert (big.recordings, big.alarms) == (2, 1)
    # the two 7K98MC samples start at the same time: the later stored (higher id) is the latest
    assert big.latest_filename in ("7k98mc-baseline.h5", "7k98mc-misfire-cyl4.h5")
    assert big.latest_status == ("alarm" if big.latest_filename.startswith("7k98mc-misfire") else "healthy")
    assert summary["medium-speed-6l32"].latest_status == "alarm"


def test_trend_reads_the_stores_only_fleet_and_names_the_fleets_when_there_are_more(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Without --fleet, ``trend`` reads the store's only fleet (the service's, of ``keys create --fleet``,
    not the batch's default 'local'); with several, it says which there are and to choose with --fleet."""
    from monitor.cli import main
    from monitor.store import default_url, open_store

    folder = tmp_path / "recordings"
    folder.mkdir()
    shutil.copy(SAMPLES / "7k98mc-baseline.h5", folder / "7k98mc-baseline.h5")
    data = str(tmp_path / "data")
    assert main(["batch", str(folder), "--data", data, "--workers", "1", "--fleet", "my-fleet"]) == 0
    capsys.readouterr()
    assert main(["trend", "man-b-w-7k98mc", "--data", data]) == 0
    assert "engine man-b-w-7k98mc (fleet my-fleet): 1 diagnosed recordings" in capsys.readouterr().out
    store = open_store(default_url(Path(data)))
    try:
        store.create_fleet("other")
    finally:
        store.close()
    assert main(["trend", "man-b-w-7k98mc", "--data", data]) == 2
    said = capsys.readouterr().err
    assert "the store holds the fleets 'my-fleet', 'other': choose one with --fleet" in said
    assert main(["trend", "man-b-w-7k98mc", "--data", data, "--fleet", "my-fleet"]) == 0
    capsys.readouterr()
    assert main(["trend", "man-b-w-7k98mc", "--data", data, "--fleet", "nobody"]) == 2
    assert "--fleet 'nobody': no such fleet in the store; its fleets: 'my-fleet', 'other'" in (
        capsys.readouterr().err
    )
