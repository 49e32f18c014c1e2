"""A baseline over operating points: healthy calibrations at several loads, and the reference between them.

One :class:`~monitor.diagnosis.baseline.Baseline` holds at the operating point it was calibrated at
(its speed, load and the cylinders' strengths there).  An engine that runs at several loads is
calibrated on a healthy recording at each (``engine-monitor calibrate A.h5 B.h5 C.h5 --load ...``);
:class:`OperatingPoints` keeps those points, ordered by load, and gives the reference at a later
recording's own load (:meth:`OperatingPoints.reference_at`).

The points are one family along one dimension, the load: an engine on a generator keeps its speed
and changes its load; one on a fixed-pitch propeller changes both along its propeller curve, where
the speed follows the load.  Either way the reference is interpolated by load.  The sensors'
transfers are interpolated only between points at comparable speeds (within the bearings' speed
tolerance): a transfer holds at the frequencies of its orders at its point's speed, and a structural
mode between two points' frequencies makes the straight line between them meaningless.  Between
points further apart in speed (a propeller curve) the nearest point's transfers are used, their
errors widened by the interpolation's uncertainty, and a recording whose speed lies further than that
tolerance from the nearest point's has its bearing orders left uncompared, as against a single point.

Between two points each quantity the diagnosis takes from the baseline (the cylinders' reference
strengths, the crank-speed model's calibration factors, each sensor's transfer and rms velocity) is
interpolated linearly in load.  How well a straight line describes the quantity between two points
is not known from two points: the interpolation's own uncertainty is taken as the difference
between the linear interpolation and the nearest point (the two natural readings of two
calibrations, a straight line and a step, disagree by that much; it is nothing at a calibrated point
and at most half the change across the gap midway), added in quadrature to the transfers' and the
factors' standard errors.  Outside the calibrated loads the nearest point is used and the
uncertainty is the change a straight line through the two nearest points would make out there: an
extrapolation says so in the notes.

A document of several points has the format :data:`POINTS_FORMAT`; a single-point document (the
format :data:`~monitor.diagnosis.baseline.BASELINE_FORMAT`, every baseline written before) reads as
one point, and one point is written in that format still.
"""

from __future__ import annotations

import itertools
import json
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np

from monitor.diagnosis.balance import CrankCalibration
from monitor.diagnosis.baseline import BASELINE_FORMAT, Baseline, SensorBaseline
from monitor.diagnosis.bearings import SPEED_TOLERANCE
from monitor.diagnosis.impact_reference import between, loudest
from monitor.errors import DiagnosisError

__all__ = [
    "LOAD_UNCERTAINTY",
    "POINTS_FORMAT",
    "OperatingPoints",
    "Reference",
    "read_baseline",
]

POINTS_FORMAT = "engine-monitor baseline 2"
"""The format of a document of several operating points (each point a single-point document)."""

LOAD_UNCERTAINTY = 0.10
"""Standard uncertainty of a load a user states, as a fraction of rated [-].

A stated load comes from an engine log's load reading or the governor's fuel index, which tell the
power delivered to within about 10 % of rated (fuel index to power through the fuel's heating value
and the engine's efficiency; a shaft-power meter is better, but rare on the engines monitored)."""

_SAME = 1e-9  # loads closer than this are one point [-]


@dataclass(frozen=True)
class Reference:
    """The baseline at one load: interpolated between calibrated points, or the nearest one.

    Attributes
    ----------
    baseline : Baseline
        The reference the diagnosis uses (its transfers' and factors' errors include the
        interpolation's uncertainty).
    load : float
        The load it is at [-].
    lower, upper : float
        The calibrated loads it lies between (equal at or beyond a calibrated point) [-].
    extrapolated : bool
        Whether the load lies outside the calibrated range (the nearest point used).
    relative_uncertainty : float
        The interpolation's uncertainty of the sensors' transfers over all their orders, relative to
        the transfer's size over them, largest over the sensors [-].
    transfers_at : float or None
        Between points whose speeds differ by more than the bearings' speed tolerance: the load of
        the nearest point, whose transfers (and speed) the reference keeps [-]; else None.
    """

    baseline: Baseline
    load: float
    lower: float
    upper: float
    extrapolated: bool
    relative_uncertainty: float
    transfers_at: float | None = None

    def note(self) -> str:
        """What the reference is, in a sentence of the diagnosis' notes."""
        if self.extrapolated:
            return (
                f"the load {self.load:.2f} lies outside the calibrated loads {self.lower:.2f} to "
                f"{self.upper:.2f}: the nearest point's reference is used (extrapolation), its "
                f"uncertainty widened by up to {100 * self.relative_uncertainty:.0f} %"
            )
        if self.lower == self.upper:
            return f"the reference is the point calibrated at load {self.lower:.2f}"
        said = (
            f"the reference is interpolated at load {self.load:.2f} between the points calibrated at "
            f"{self.lower:.2f} and {self.upper:.2f} (its own uncertainty "
            f"{100 * self.relative_uncertainty:.0f} % of the transfers)"
        )
        if self.transfers_at is None:
            return said
        return (
            f"{said}; the sensors' transfers are the point at {self.transfers_at:.2f}'s, at its speed "
            f"(the points' speeds are more than {100 * SPEED_TOLERANCE:g} % apart: a structure's response "
            "between them is no straight line)"
        )


@dataclass(frozen=True)
class OperatingPoints:
    """Healthy calibrations of one engine at several loads, ordered by load.

    Attributes
    ----------
    points : tuple of Baseline
        At least one, of one engine, at distinct loads, by increasing load.
    """

    points: tuple[Baseline, ...]

    def __post_init__(self) -> None:
        if not self.points:
            raise DiagnosisError("a baseline needs at least one calibrated point")
        engines = {p.engine_id for p in self.points}
        if len(engines) > 1:
            raise DiagnosisError(f"the points are of several engines {sorted(engines)}: calibrate one engine")
        loads = [p.load for p in self.points]
        if any(b - a <= _SAME for a, b in itertools.pairwise(loads)):
            raise DiagnosisError(
                f"the points' loads {loads} are not distinct and increasing: give each recording its own load"
            )

    @classmethod
    def of(cls, baselines: list[Baseline] | tuple[Baseline, ...]) -> OperatingPoints:
        """The points of these baselines, ordered by load.

        Parameters
        ----------
        baselines : sequence of Baseline

        Returns
        -------
        OperatingPoints
        """
        return cls(tuple(sorted(baselines, key=lambda b: b.load)))

    @property
    def engine_id(self) -> str:
        """The engine the points are of."""
        return self.points[0].engine_id

    @property
    def loads(self) -> list[float]:
        """The calibrated loads [-]."""
        return [p.load for p in self.points]

    @property
    def source(self) -> str:
        """The points' recordings, named."""
        return " + ".join(p.source or f"load {p.load:g}" for p in self.points)

    def to_document(self) -> dict[str, Any]:
        """The JSON document: a single point in the single-point format, several as :data:`POINTS_FORMAT`."""
        if len(self.points) == 1:
            return self.points[0].to_document()
        return {
            "format": POINTS_FORMAT,
            "engine_id": self.engine_id,
            "interpolated_by": "load",
            "points": [p.to_document() for p in self.points],
        }

    def write(self, path: str | Path) -> Path:
        """Write the JSON document (whole or not at all: through a temporary file)."""
        target = Path(path)
        temporary = target.with_name(target.name + ".partial")
        temporary.write_text(json.dumps(self.to_document(), indent=1) + "\n")
        temporary.replace(target)
        return target

    @classmethod
    def from_document(cls, document: dict[str, Any], *, origin: str = "baseline") -> OperatingPoints:
        """Read a document of either format (a single-point one as one point).

        Raises
        ------
        DiagnosisError
            For another format or a missing field.
        """
        if document.get("format") == BASELINE_FORMAT:
            return cls((Baseline.from_document(document, origin=origin),))
        if document.get("format") != POINTS_FORMAT:
            raise DiagnosisError(
                f"{origin}: format {document.get('format')!r}, expected {POINTS_FORMAT!r} or "
                f"{BASELINE_FORMAT!r} (write it with 'engine-monitor calibrate')"
            )
        points = document.get("points")
        if not isinstance(points, list) or not points:
            raise DiagnosisError(f"{origin}: not a complete baseline document (no points)")
        return cls.of(
            [Baseline.from_document(p, origin=f"{origin}, point {i + 1}") for i, p in enumerate(points)]
        )

    def reference_at(self, load: float, *, within: tuple[float, float] | None = None) -> Reference:
        """The reference at a load: interpolated between the two points around it, else the nearest.

        Parameters
        ----------
        load : float
            [-]
        within : tuple of float, optional
            The loads the recording may be at, for the impact profiles [-]: each sensor's is then
            bin by bin the loudest over them (:func:`~monitor.diagnosis.impact_reference.loudest` of
            the profiles at ``load``, at the span's ends and at the calibrated points inside it).
            Default: the profile at ``load`` alone.

        Returns
        -------
        Reference
        """
        reference = self._reference_at(load)
        if within is None or len(self.points) == 1:
            return reference
        low, high = sorted(within)
        loads = [low, high, *(p.load for p in self.points if low < p.load < high)]
        others = [self._reference_at(at).baseline.sensors for at in loads]
        sensors = {
            name: replace(
                s,
                high_frequency=loudest(
                    [s.high_frequency, *(o[name].high_frequency for o in others if name in o)]
                ),
            )
            for name, s in reference.baseline.sensors.items()
        }
        return replace(reference, baseline=replace(reference.baseline, sensors=sensors))

    def _reference_at(self, load: float) -> Reference:
        loads = np.asarray(self.loads)
        if len(self.points) == 1:
            only = self.points[0]
            return Reference(only, only.load, only.load, only.load, False, 0.0)
        if load <= loads[0] or load >= loads[-1]:
            i, j = (0, 1) if load <= loads[0] else (len(loads) - 1, len(loads) - 2)
            near, far = self.points[i], self.points[j]
            if abs(load - loads[i]) <= _SAME:  # at the end point itself
                return Reference(near, near.load, near.load, near.load, False, 0.0)
            # the change a straight line through the two nearest points makes out there
            weight = (load - near.load) / (far.load - near.load)
            reference = _blend(near, far, weight, near, uncertainty_only=True)
            return Reference(
                replace(reference.baseline, load=load),
                load,
                float(loads[0]),
                float(loads[-1]),
                True,
                reference.relative_uncertainty,
            )
        j = int(np.searchsorted(loads, load))
        low, high = self.points[j - 1], self.points[j]
        weight = (load - low.load) / (high.load - low.load)
        nearest = low if weight <= 0.5 else high
        reference = _blend(low, high, weight, nearest, uncertainty_only=False)
        apart = None if _comparable_speeds(low, high) else nearest.load
        source = (
            f"{_name(low)} and {_name(high)} interpolated at load {load:.2f}"
            if apart is None
            else f"{_name(nearest)} (its transfers, at load {load:.2f})"
        )
        between = replace(reference.baseline, load=load, source=source)
        return Reference(between, load, low.load, high.load, False, reference.relative_uncertainty, apart)

    def mean_strength_at(self, load: float) -> float:
        """The calibrated points' median strength over the cylinders, interpolated at a load (clamped) [-].

        Parameters
        ----------
        load : float
            [-]

        Returns
        -------
        float
        """
        medians = [float(np.median(p.strengths)) for p in self.points]
        return float(np.interp(load, self.loads, medians))


@dataclass(frozen=True)
class _Blend:
    baseline: Baseline
    relative_uncertainty: float


def _between(a: Any, b: Any, weight: float) -> Any:
    return (1 - weight) * np.asarray(a) + weight * np.asarray(b)


def _name(point: Baseline) -> str:
    """A calibrated point as the notes name it: its recording, else its load."""
    return point.source or f"the point calibrated at load {point.load:.2f}"


def _comparable_speeds(a: Baseline, b: Baseline) -> bool:
    """Whether two points' speeds lie within the bearings' speed tolerance of each other."""
    return abs(b.speed_rpm / a.speed_rpm - 1.0) <= SPEED_TOLERANCE


def _blend(
    low: Baseline, high: Baseline, weight: float, nearest: Baseline, *, uncertainty_only: bool
) -> _Blend:
    """``low`` and ``high`` interpolated at ``weight`` (0 at low); the uncertainty its distance from
    ``nearest``.  With ``uncertainty_only`` the values stay the nearest's and only the errors grow; so
    do the sensors' transfers and the speed between points whose speeds are not comparable."""
    fixed = uncertainty_only or not _comparable_speeds(low, high)
    sensors = {}
    worst = 0.0
    for name, s in nearest.sensors.items():
        other = (high if nearest is low else low).sensors.get(name)
        if other is None or other.orders.shape != s.orders.shape or not np.allclose(other.orders, s.orders):
            sensors[name] = s
            continue
        lo, hi = (s, other) if nearest is low else (other, s)
        line = _between(lo.transfer, hi.transfer, weight)
        spread = np.abs(line - s.transfer)
        size = float(np.linalg.norm(s.transfer))  # over the orders, as the sensor's orders weigh them
        if size > 0:
            worst = max(worst, float(np.linalg.norm(spread)) / size)
        transfer = s.transfer if fixed else line
        error = s.transfer_error if fixed else _between(lo.transfer_error, hi.transfer_error, weight)
        rms = (
            s.velocity_rms if uncertainty_only else float(_between(lo.velocity_rms, hi.velocity_rms, weight))
        )
        sensors[name] = SensorBaseline(
            channel=s.channel,
            kind=s.kind,
            unit=s.unit,
            bearing=s.bearing,
            direction=s.direction,
            sample_rate=s.sample_rate,
            orders=s.orders,
            transfer=np.asarray(transfer, dtype=np.complex128),
            transfer_error=np.asarray(np.hypot(error, spread), dtype=np.float64),
            high_frequency=(
                s.high_frequency
                if uncertainty_only
                else between(lo.high_frequency, hi.high_frequency, weight)
            ),
            velocity_rms=rms,
        )
    strengths = nearest.strengths
    speed = nearest.speed_rpm
    if not uncertainty_only and len(low.strengths) == len(high.strengths):
        strengths = [float(v) for v in _between(low.strengths, high.strengths, weight)]
    if not fixed:  # the speed the transfers hold at
        speed = float(_between(low.speed_rpm, high.speed_rpm, weight))
    crank = _blend_crank(low.crank, high.crank, weight, nearest.crank, uncertainty_only=uncertainty_only)
    baseline = replace(nearest, speed_rpm=speed, strengths=strengths, sensors=sensors, crank=crank)
    return _Blend(baseline, worst)


def _blend_crank(
    low: CrankCalibration | None,
    high: CrankCalibration | None,
    weight: float,
    nearest: CrankCalibration | None,
    *,
    uncertainty_only: bool,
) -> CrankCalibration | None:
    """The crank-speed model's factors interpolated where both points calibrated the same orders."""
    if (
        low is None
        or high is None
        or nearest is None
        or low.transfer != high.transfer
        or low.orders.shape != high.orders.shape
        or not np.allclose(low.orders, high.orders)
    ):
        return nearest
    factor = _between(low.factor, high.factor, weight)
    inertia = _between(low.inertia_factor, high.inertia_factor, weight)
    factor_error = np.hypot(
        nearest.factor_error if uncertainty_only else _between(low.factor_error, high.factor_error, weight),
        np.abs(factor - nearest.factor),
    )
    inertia_error = np.hypot(
        nearest.inertia_factor_error
        if uncertainty_only
        else _between(low.inertia_factor_error, high.inertia_factor_error, weight),
        np.abs(inertia - nearest.inertia_factor),
    )
    return CrankCalibration(
        nearest.transfer,
        nearest.orders,
        np.asarray(nearest.factor if uncertainty_only else factor, dtype=np.complex128),
        np.asarray(factor_error, dtype=np.float64),
        np.asarray(nearest.inertia_factor if uncertainty_only else inertia, dtype=np.complex128),
        np.asarray(inertia_error, dtype=np.float64),
    )


def read_baseline(path: str | Path) -> OperatingPoints:
    """Read a baseline JSON file of either format.

    Parameters
    ----------
    path : str or Path

    Returns
    -------
    OperatingPoints

    Raises
    ------
    DiagnosisError
        For a file that cannot be read or is no baseline.
    """
    source = Path(path)
    try:
        document = json.loads(source.read_text())
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as error:
        raise DiagnosisError(f"{source}: cannot read the baseline ({error})") from error
    if not isinstance(document, dict):
        raise DiagnosisError(f"{source}: not a baseline document")
    return OperatingPoints.from_document(document, origin=str(source))
