"""Thirty nights of one engine through the nightly batch: the trend finds the change before the alarm.

The series (a 7K98MC, 10 s a night at rated speed, each night its own noise
seed and start time): cylinder 4 loses 6 % of its heat release a night from
night 20, and main bearing 5 wears from night 11, its knocks' severity rising
by 0.004 a night. Every night is diagnosed by ``batch`` against a baseline
calibrated on another healthy recording, so each night's status is the
single-recording diagnosis's. The night each trend finding is due is worked
out here again from the rule as docs/trends.md states it (the median absolute
deviation, Student's t and the normal quantile from scipy.stats, not the
product's code), on the values the store holds.
"""

from __future__ import annotations

import copy
import math
import tomllib
from dataclasses import replace
from datetime import UTC, datetime, timedelta
from pathlib import Path

import numpy as np
import pytest
from scipy import stats

from monitor.diagnosis import ANALYSIS_VERSION, Baseline, calibrate
from monitor.diagnosis.trends import drift
from monitor.io.hdf5 import read_hdf5, write_hdf5
from monitor.jobs.batch import run_batch
from monitor.model.engine import bundled_engines, load_engine
from monitor.scene import simulate
from monitor.scene.loading import parse_scene
from monitor.store import open_store
from monitor.store.trends import read_trend

ROOT = Path(__file__).resolve().parents[2]
SCENES = ROOT / "recordings" / "scenes"
NIGHTS = 30
FIRST_NIGHT = datetime(2026, 10, 1, 2, 0, tzinfo=UTC)


def _scale(night: int) -> float:
    """Cylinder 4's heat release on a night (1-based): 6 % less a night from night 20."""
    return max(0.0, 1.0 - 0.06 * (night - 19)) if night >= 20 else 1.0


def _severity(night: int) -> float:
    """Main bearing 5's knocks on a night: from night 11, 0.004 more a night."""
    return 0.004 * (night - 10) if night > 10 else 0.0


def _rule_night(
    values: list[float],
    *,
    baseline: int = 10,
    lag: int = 10,
    k: float = 0.5,
    h: float = 9.0,
    band: float = 5.0,
) -> int | None:
    """The 1-based night the rule of docs/trends.md makes its finding on, worked out from its text."""
    upper = lower = 0.0
    for n in range(baseline, len(values)):
        history = np.array(values[: max(baseline, n - lag)])
        c = history.size
        robust = stats.median_abs_deviation(history, scale="normal") * c / (c - 0.8)
        kept = history[np.abs(history - np.median(history)) <= band * robust] if robust > 0 else history
        m = float(kept.mean())
        s = max(float(kept.std(ddof=1)), 0.01 * abs(m))
        t = (values[n] - m) / (s * math.sqrt(1 + 1 / kept.size))
        u = float(np.clip(stats.norm.ppf(stats.t.cdf(t, df=kept.size - 1)), -8, 8))
        upper, lower = max(0.0, upper + u - k), max(0.0, lower - u - k)
        if upper > h or lower > h:
            return n + 1
    return None


@pytest.fixture(scope="module")
def series(tmp_path_factory: pytest.TempPathFactory) -> dict[str, object]:
    """The 30 nights written, calibrated and diagnosed by the batch; the store's trend and statuses."""
    folder = tmp_path_factory.mktemp("nights")
    template = tomllib.loads((SCENES / "7k98mc-weak-cyl4.toml").read_text(encoding="utf-8"))
    template["duration_s"] = 10.0
    for night in range(1, NIGHTS + 1):
        data = copy.deepcopy(template)
        data["effects"]["weak_cylinder"] = {"cylinder": 4, "scale": _scale(night)}
        if _severity(night) > 0:
            data["effects"]["worn_bearing"] = {"bearing": 5, "severity": _severity(night)}
        recording = simulate(parse_scene(data, source_dir=SCENES), seed=1000 + night).recording
        when = FIRST_NIGHT + timedelta(days=night - 1)
        write_hdf5(
            replace(recording, start_time=when.strftime("%Y-%m-%dT%H:%M:%SZ")),
            folder / f"night-{night:02d}.h5",
        )
    healthy = copy.deepcopy(template)
    healthy["effects"]["weak_cylinder"] = {"cylinder": 4, "scale": 1.0}
    engine = load_engine(bundled_engines()["man-b-w-7k98mc"])
    reference = tmp_path_factory.mktemp("reference") / "healthy.h5"
    write_hdf5(simulate(parse_scene(healthy, source_dir=SCENES), seed=7).recording, reference)
    baseline: Baseline = calibrate(read_hdf5(reference), engine, source=reference.name)
    store = open_store(f"sqlite:///{tmp_path_factory.mktemp('store') / 'store.db'}")
    try:
        fleet = store.create_fleet("ships")
        summary = run_batch(
            store, fleet, path=folder, baselines={engine.id: baseline.to_document()}, workers=2
        )
        assert summary.diagnosed == NIGHTS and not summary.failed
        alarms: dict[int, set[str]] = {}  # each night's subjects of alarm findings
        for row in store.recordings(fleet, limit=100):
            document = store.result(row.id, ANALYSIS_VERSION, "diagnosis")
            assert document is not None
            alarms[int(row.filename[6:8])] = {
                f["subject"] for f in document["findings"] if f["severity"] == "alarm"
            }
        with store.transaction() as c:
            points = read_trend(c, fleet, engine.id, analysis_version=ANALYSIS_VERSION)
    finally:
        store.close()
    by_quantity: dict[str, list[float]] = {}
    times: dict[str, list[datetime]] = {}
    for p in points:
        by_quantity.setdefault(p.quantity, []).append(p.value)
        times.setdefault(p.quantity, []).append(p.recorded_at)
    return {"alarms": alarms, "values": by_quantity, "times": times}


@pytest.mark.parametrize(
    ("quantity", "subject"),
    [("cylinder 4 strength", "cylinder 4"), ("mb5-vertical impact", "main bearing 5")],
)
def test_the_trend_finds_the_change_before_the_single_recording_alarm(
    series: dict[str, object], quantity: str, subject: str
) -> None:
    """The trend finding on the night the rule gives, dated from the change, before the first night the
    single-recording diagnosis raises an alarm on the same cylinder or bearing."""
    alarms: dict[int, set[str]] = series["alarms"]  # type: ignore[assignment]
    values: list[float] = series["values"][quantity]  # type: ignore[index]
    times: list[datetime] = series["times"][quantity]  # type: ignore[index]
    assert len(values) == NIGHTS and times == sorted(times)  # one a night, by recording time
    nights = [night for night, subjects in alarms.items() if subject in subjects]
    assert nights, f"no alarm on {subject} in {NIGHTS} nights: 'before' would mean nothing"
    alarm = min(nights)
    found = drift(times, values, quantity=quantity)
    assert found is not None, f"{quantity}: no trend finding in {NIGHTS} nights ({values})"
    night = (found.found_at - FIRST_NIGHT).days + 1
    assert night == _rule_night(values), (quantity, night, values)
    assert night < alarm, (quantity, night, alarm)
    change = 20 if quantity.startswith("cylinder") else 11
    assert change <= (found.since - FIRST_NIGHT).days + 1 <= night  # dated from the change, not before
    assert found.direction == ("down" if quantity.startswith("cylinder") else "up")


def test_the_nights_before_any_change_raise_no_trend_finding(series: dict[str, object]) -> None:
    """Through night 10 (the baseline period) nothing is judged, and the quantities that do not change at
    all over the 30 nights raise no finding."""
    values: dict[str, list[float]] = series["values"]  # type: ignore[assignment]
    times: dict[str, list[datetime]] = series["times"]  # type: ignore[assignment]
    for quantity in (
        "cylinder 1 strength",
        "cylinder 2 strength",
        "cylinder 7 strength",
        "mb2-vertical rms velocity",
    ):
        assert drift(times[quantity], values[quantity], quantity=quantity) is None, (
            quantity,
            values[quantity],
        )
