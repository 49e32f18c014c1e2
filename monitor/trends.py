"""An engine's condition over time: the quantities of each diagnosis, and the rule that finds drift.

Quantities.  Every stored diagnosis (the ``compare --json`` document) gives,
at the recording's time (its start, not its upload):

- ``speed`` [rpm] and ``load`` [-]: the operating point, shown beside the
  others and not judged;
- ``cylinder N strength`` [-]: each cylinder's strength relative to the
  cylinders that fire alike (1 healthy, 0 misfiring), with its standard error;
- ``<sensor> order deviation`` [-]: the largest over the orders compared of
  ``|measured - predicted| / |largest predicted|`` of a bearing sensor;
- ``<sensor> impact`` [-]: the largest of the sensor's impact scores over the
  bearings it hears, with its standard error;
- ``<sensor> rms velocity`` [mm/s]: with its standard error.

Drift.  Each judged quantity is followed with a two-sided CUSUM (Page, 1954;
Montgomery, *Introduction to Statistical Quality Control*, 7th ed., §9.1)
against its baseline period, the engine's first :data:`BASELINE_RECORDINGS`
recordings: with ``mu`` and ``sigma`` their mean and spread (``sigma`` at
least the median standard error of those values, and at least
:data:`RELATIVE_FLOOR` of ``|mu|``, so a quantity that hardly moved does not
make every later wobble a shift), each later value ``x`` gives
``z = (x - mu) / sigma`` and

    S+ = max(0, S+ + z - K),   S- = max(0, S- - z - K),

a trend finding when either exceeds ``H``. ``K`` = :data:`REFERENCE` (0.5)
tunes it to shifts of one ``sigma``; ``H`` = :data:`DECISION` (5.75) makes,
for independent Gaussian values of known mean and spread, one false finding
per quantity in about 1000 recordings. Siegmund's approximation of a side's
average run length after a shift of ``d`` sigmas (``d = 0``: in control) is

    ARL(d) = (exp(-2 D b) + 2 D b - 1) / (2 D^2),   D = d - K,  b = H + 1.166,

2000 recordings in control for each side (1000 for either), and a shift of
one sigma found after 12 recordings, of two after 4.4, of three after 2.7
(tests/test_trends.py checks these by simulation). With the mean and spread
estimated from the baseline period's ten recordings, false findings are more
frequent than that; docs/trends.md gives the rate the simulation measures.

A finding says what moved (the quantity and its direction), since when (the
recording after the last one at which that side's sum was zero: the
CUSUM's estimate of the change's start) and by how much (the mean of the
values since then less the baseline's, in the quantity's unit and in sigmas).
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from datetime import datetime
from typing import Any

import numpy as np
import numpy.typing as npt

from monitor.types import FloatArray

__all__ = [
    "BASELINE_RECORDINGS",
    "DECISION",
    "JUDGED",
    "REFERENCE",
    "RELATIVE_FLOOR",
    "Drift",
    "TrendPoint",
    "cusum",
    "drift",
    "trend_points",
]

BASELINE_RECORDINGS = 10  # recordings of the baseline period, the engine's first [-]
REFERENCE = 0.5  # K: half the shift, in sigmas, the CUSUM is tuned to [-]
DECISION = 5.75  # H: the decision interval, in sigmas [-]
RELATIVE_FLOOR = 0.01  # sigma at least this share of the baseline's mean magnitude [-]
JUDGED = ("strength", "order deviation", "impact", "rms velocity")  # quantity endings followed for drift


@dataclass(frozen=True)
class TrendPoint:
    """One quantity of one diagnosis.

    Attributes
    ----------
    quantity : str
        Its name (see the module docstring).
    value : float
    standard_error : float or None
        Where the diagnosis gives one.
    unit : str
    """

    quantity: str
    value: float
    standard_error: float | None
    unit: str


def _number(value: Any) -> float | None:
    try:
        number = float(value)
    except (TypeError, ValueError):
        return None
    return number if math.isfinite(number) else None


def trend_points(document: dict[str, Any]) -> list[TrendPoint]:
    """The quantities a diagnosis document gives (see the module docstring).

    Parameters
    ----------
    document : dict
        A diagnosis document (``compare --json``; the service's and the batch's stored result).

    Returns
    -------
    list of TrendPoint
        Missing or non-finite values are left out.
    """
    points: list[TrendPoint] = []

    def add(quantity: str, value: Any, error: Any, unit: str) -> None:
        number = _number(value)
        if number is not None:
            points.append(TrendPoint(quantity, number, _number(error), unit))

    add("speed", document.get("speed_rpm"), None, "rpm")
    add("load", document.get("load"), None, "-")
    balance = document.get("cylinder_balance") or {}
    relative = balance.get("relative") or []
    errors = balance.get("relative_standard_error") or [None] * len(relative)
    for number, (value, error) in enumerate(zip(relative, errors, strict=False), start=1):
        add(f"cylinder {number} strength", value, error, "-")
    for sensor, channel in sorted((document.get("channels") or {}).items()):
        if sensor == "crank speed":  # the cylinders' strengths are its summary
            continue
        deviations = [
            v for v in (_number(d) for d in channel.get("deviation_of_largest") or []) if v is not None
        ]
        if deviations:
            add(f"{sensor} order deviation", max(deviations), None, "-")
    for sensor, scores in sorted((document.get("impacts") or {}).items()):
        scored = [s for s in scores if _number(s.get("score")) is not None]
        if scored:
            top = max(scored, key=lambda s: float(s["score"]))
            add(f"{sensor} impact", top["score"], top.get("standard_error"), "-")
    for sensor, rms in sorted((document.get("velocity_rms") or {}).items()):
        add(f"{sensor} rms velocity", rms.get("value_mm_s"), rms.get("standard_error_mm_s"), "mm/s")
    return points


def judged(quantity: str) -> bool:
    """Whether a quantity is followed for drift (the operating point is not)."""
    return quantity.endswith(JUDGED)


def cusum(z: npt.ArrayLike, *, reference: float = REFERENCE) -> tuple[FloatArray, FloatArray]:
    """The two one-sided CUSUM sums after each standardised value.

    Parameters
    ----------
    z : array_like
        ``(x - mu) / sigma`` of each value, in order [-].
    reference : float, optional
        K [-].

    Returns
    -------
    upper, lower : ndarray
        ``S+`` and ``S-`` after each value (both start at 0) [-].
    """
    standardised = np.asarray(z, dtype=np.float64)
    upper, lower = np.zeros(standardised.size), np.zeros(standardised.size)
    high = low = 0.0
    for n, value in enumerate(standardised.tolist()):
        high = max(0.0, high + value - reference)
        low = max(0.0, low - value - reference)
        upper[n], lower[n] = high, low
    return upper, lower


@dataclass(frozen=True)
class Drift:
    """A quantity that left its baseline period.

    Attributes
    ----------
    quantity : str
    unit : str
    direction : str
        "up" or "down".
    found_at : datetime
        The recording at which the CUSUM crossed the decision interval.
    since : datetime
        The first recording of the change (the one after the sum was last zero).
    shift : float
        Mean of the values from ``since`` to ``found_at`` less the baseline's mean [unit].
    shift_sigmas : float
        The same in the baseline's sigmas [-].
    baseline_mean, baseline_sigma : float
        [unit].
    """

    quantity: str
    unit: str
    direction: str
    found_at: datetime
    since: datetime
    shift: float
    shift_sigmas: float
    baseline_mean: float
    baseline_sigma: float

    @property
    def summary(self) -> str:
        """In words: what moved, since when, by how much."""
        return (
            f"{self.quantity} {'rose' if self.direction == 'up' else 'fell'} by {abs(self.shift):.3g} "
            f"{self.unit} ({abs(self.shift_sigmas):.1f} sigma of its baseline {self.baseline_mean:.3g} "
            f"+- {self.baseline_sigma:.2g}) since {self.since:%Y-%m-%d %H:%M}, "
            f"found on {self.found_at:%Y-%m-%d %H:%M}"
        )


def drift(
    times: Sequence[datetime],
    values: Sequence[float],
    errors: Iterable[float | None] = (),
    *,
    quantity: str = "",
    unit: str = "",
    baseline: int = BASELINE_RECORDINGS,
    decision: float = DECISION,
) -> Drift | None:
    """The first drift of a quantity after its baseline period, or None.

    Parameters
    ----------
    times : sequence of datetime
        Recording times, in order.
    values : sequence of float
        The quantity at each [unit].
    errors : iterable of float or None, optional
        Each value's standard error, where known [unit].
    quantity, unit : str, optional
        For the finding.
    baseline : int, optional
        Recordings of the baseline period (the first ones).
    decision : float, optional
        H [-].

    Returns
    -------
    Drift or None
        None when there are no more recordings than the baseline period's, or no drift.
    """
    x = np.asarray(values, dtype=np.float64)
    if x.size <= baseline or baseline < 2:
        return None
    reference = x[:baseline]
    mu = float(reference.mean())
    known = [e for e in list(errors)[:baseline] if e is not None and math.isfinite(e)]
    sigma = max(
        float(reference.std(ddof=1)),
        float(np.median(known)) if known else 0.0,
        RELATIVE_FLOOR * abs(mu),
        1e-12,
    )
    upper, lower = cusum((x[baseline:] - mu) / sigma)
    found = [
        (int(np.flatnonzero(sums > decision)[0]), sums, direction)
        for sums, direction in ((upper, "up"), (lower, "down"))
        if np.any(sums > decision)
    ]
    if not found:
        return None
    at, sums, direction = min(found, key=lambda f: f[0])
    zeros = np.flatnonzero(sums[:at] == 0.0)
    start = int(zeros[-1]) + 1 if zeros.size else 0
    shift = float(x[baseline + start : baseline + at + 1].mean() - mu)
    return Drift(
        quantity,
        unit,
        direction,
        times[baseline + at],
        times[baseline + start],
        shift,
        shift / sigma,
        mu,
        sigma,
    )
