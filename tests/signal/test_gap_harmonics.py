"""A 60-2 wheel's gap filled from the cycle's shape when that shape is a many-cylinder engine's.

Once a baseline's pitch errors are taken out, what is left of a 16-cylinder V four-stroke's speed is
its firing harmonics, up to the 48th harmonic of the cycle (order 24). The gap filling
(:meth:`monitor.signal.anglemap.AngleMap.with_gaps_filled`) must find a number of harmonics that
follows them, on every recording of the engine alike: when it filled the gap on some recordings and
not on others, the whole crank-speed orders moved between healthy runs of one engine by many
standard errors and the cylinder balance of a healthy V16 came out inconclusive.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from benchmarks.diagnosed import case_engine
from monitor.diagnosis import calibrate
from monitor.diagnosis.at_point import diagnose_at_point
from monitor.diagnosis.operating_points import OperatingPoints
from monitor.signal.anglemap import AngleMap
from validation.simulator import healthy_twin, random_case

TEETH = 60
PITCH = 2 * math.pi / TEETH
CYCLE = 4 * math.pi  # a four-stroke's cycle [rad]
SPEED = 822 * math.pi / 30  # [rad/s]
JITTER = 0.2e-6  # tooth timing noise [s]
REVOLUTIONS = 136  # 10 s at 822 rpm


def _v16_map(seed: int) -> tuple[AngleMap, FloatPair]:
    """A 60-2 wheel's pulses on a V16-like speed: firing harmonics 4 to 24 (cycle harmonics 8 to 48)
    strong, every half order faintly; the true times of the missing teeth beside it.

    The slowness's harmonics above the 38th carry two thirds of its variance (on the simulated V16
    that showed the fault, over half): a fit of a quarter or a third of the places' number of
    harmonics leaves more than :data:`monitor.signal.anglemap.REPEATING` of it unexplained."""
    rng = np.random.default_rng(seed)
    shape = np.random.default_rng(1)  # the engine: one shape for every recording
    harmonics = np.arange(1, 49)
    amplitude = np.select([harmonics >= 40, harmonics % 8 == 0], [2e-3, 1e-3], 1e-5)
    amplitude[(harmonics % 8 != 0)] = 1e-5
    phase = shape.uniform(0, 2 * math.pi, harmonics.size)

    def time_at(angle: np.ndarray) -> np.ndarray:
        # slowness (1 + sum a_h cos(h angle / 2 + phase_h)) / SPEED, integrated in closed form
        waves = (amplitude * 2 / harmonics) * np.sin(np.multiply.outer(angle, harmonics / 2) + phase)
        return np.asarray((angle + waves.sum(axis=-1)) / SPEED)

    every = np.arange(REVOLUTIONS * TEETH) * PITCH
    present = np.mod(np.arange(every.size), TEETH) < TEETH - 2
    times = time_at(every[present]) + rng.normal(0.0, JITTER, int(present.sum()))
    return AngleMap(times, every[present]), (every[~present], time_at(every[~present]))


FloatPair = tuple[np.ndarray, np.ndarray]


@pytest.mark.parametrize("seed", range(5))
def test_the_gap_is_filled_alike_on_every_recording(seed: int) -> None:
    """Five recordings of one engine, only the timing noise drawn anew: each gets its missing teeth,
    and where they are put, averaged over the cycles at each missing place (what the whole orders
    see), is within 0.45 us of the truth; the spline alone is 0.9 to 1.05 us off at two of the four
    places. With only a quarter, a third and nearly a half of the places' number of harmonics tried,
    two of these five recordings were left unfilled and one filled 0.6 us off."""
    angle_map, (missing, truth) = _v16_map(seed)
    filled = angle_map.with_gaps_filled(CYCLE, harmonics=TEETH * 2)
    inner = (missing > 2 * CYCLE) & (missing < angle_map.angles[-1] - 2 * CYCLE)
    assert filled.times.size - angle_map.times.size >= int(inner.sum()), "the gap was left unfilled"
    at = np.searchsorted(filled.angles, missing[inner] - 1e-9)  # each missing tooth's point
    assert np.allclose(filled.angles[at], missing[inner], rtol=0, atol=1e-9)
    place = np.rint(np.mod(missing[inner], CYCLE) / PITCH)
    error = filled.times[at] - truth[inner]
    spline = np.interp(missing[inner], angle_map.angles, angle_map.times) - truth[inner]
    systematic = np.array([error[place == p].mean() for p in np.unique(place)])
    alone = np.array([spline[place == p].mean() for p in np.unique(place)])
    assert np.abs(systematic).max() < 0.45e-6 < 0.8e-6 < np.abs(alone).max(), (systematic, alone)


@pytest.mark.parametrize(("seed", "seconds"), [(300070, 10.0), (300049, 30.0)])
def test_healthy_v16_runs_fit_each_others_baseline(seed: int, seconds: float) -> None:
    """The validation simulator's V16s (written apart from the product): a healthy run diagnosed
    against another healthy run's baseline fits the crank-speed model (reduced chi-square below 5;
    they read 100 to 130 when the gap was filled on one run and not the other) and is healthy."""
    case = random_case(seed, duration_s=seconds, vee=True)
    engine = case_engine(case.engine_toml)
    first, second = (healthy_twin(case, seed=seed + k * 1_000_000) for k in (1, 2))
    points = OperatingPoints.of([calibrate(first.recording, engine, load=first.load_given)])
    diagnosis = diagnose_at_point(second.recording, engine, points=points, load=second.load_given)
    assert diagnosis.balance is not None
    assert diagnosis.balance.chi2_reduced < 5.0, diagnosis.notes
    assert diagnosis.status == "healthy", diagnosis.notes
