"""The gap filler's cycle shape: one QR of the largest design serves every candidate harmonic count.

Checked against a route that shares none of it: for each candidate, a plain weighted least-squares fit
(``numpy.linalg.lstsq``) of the shape in the shape's own coefficient order, and its leave-one-out score
found by refitting with each place left out in turn. The chosen count must be the one with the least
score, and the fit at every place the same.
"""

from __future__ import annotations

import math

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from monitor.signal.anglemap import _CyclePlaces, _fit_cycle_shape, _interval_means


def _places(seed: int, n: int, cycle: float) -> _CyclePlaces:
    rng = np.random.default_rng(seed)
    start = np.sort(rng.uniform(0.0, cycle, n))
    mean = 1.0 + 0.01 * np.sin(3 * start) + 0.004 * np.cos(7 * start) + 0.002 * rng.normal(size=n)
    return _CyclePlaces(
        which=np.arange(n),
        count=rng.integers(1, 40, n),
        mean=mean,
        start=start,
        width=rng.uniform(0.005, 0.05, n),
    )


def _left_one_out(places: _CyclePlaces, h_count: int, cycle: float) -> tuple[float, np.ndarray]:
    """The weighted leave-one-out score of ``h_count`` harmonics by refitting n times, and the full fit
    at every place."""
    w = 2 * math.pi / cycle * np.arange(1, h_count + 1)
    design = _interval_means(places.start, places.start + places.width, w)
    root = np.sqrt(places.count.astype(np.float64))
    a, b = design * root[:, None], places.mean * root
    score = 0.0
    for i in range(b.size):
        keep = np.arange(b.size) != i
        fit, *_ = np.linalg.lstsq(a[keep], b[keep], rcond=None)
        score += float((a[i] @ fit - b[i]) ** 2)
    full, *_ = np.linalg.lstsq(a, b, rcond=None)
    return score, design @ full


@settings(max_examples=15, deadline=None)
@given(
    st.integers(0, 10_000),
    st.integers(40, 120),
    st.sampled_from([2 * math.pi, 4 * math.pi]),
    st.lists(st.integers(1, 12), min_size=1, max_size=5, unique=True),
)
def test_the_chosen_count_and_fit_are_those_of_plain_refits(
    seed: int, n: int, cycle: float, candidates: list[int]
) -> None:
    places = _places(seed, n, cycle)
    found = _fit_cycle_shape(places, sorted(candidates), cycle)
    assert found is not None
    shape, fitted = found
    scores = {h: _left_one_out(places, h, cycle) for h in candidates}
    best = min(scores, key=lambda h: scores[h][0])
    # two counts whose scores differ by less than rounding may be chosen either way
    if abs(scores[best][0] - scores[shape.w.size][0]) > 1e-9 * scores[best][0]:
        assert shape.w.size == best, {h: s for h, (s, _) in scores.items()}
    # the fit at every place, of a slowness near 1: the two factorisations agree to rounding's 1e-9
    np.testing.assert_allclose(fitted, scores[shape.w.size][1], rtol=0, atol=1e-9)
    # the shape's coefficients in its own order: its integral over a place is the place's fitted mean
    x0, x1 = places.start, places.start + places.width
    np.testing.assert_allclose((shape.integral(x1) - shape.integral(x0)) / places.width, fitted, atol=1e-9)
