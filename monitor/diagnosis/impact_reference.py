"""The baseline's high-frequency profile carried to a recording's operating point, for the impact score.

A bearing's knock is judged against the same sensor's high-frequency profile on its healthy baseline
(:mod:`monitor.diagnosis.bearings`). Between the baseline's operating point and the recording's, two
things change that are no knock:

Speed.  The structure rings for a time, not an angle: the rings that follow the engine's own events
(combustion, valves, piston slap) end ``6 n t`` degrees after an event fixed in crank angle, ``t``
seconds after it. Between the baseline's speed ``n0`` and the recording's ``n`` a ring's tail moves by
up to ``6 |n - n0| RING_S`` degrees, and a tail that reaches further into a knock window reads as a
knock. Each of the baseline's bins is taken as the loudest within that angle either side
(:func:`widened`); at the baseline's own speed nothing changes.

Level.  The engine's own noise grows with its forces, so with the load and the speed: a recording
above its baseline's point is louder wherever the engine's own events ring, while a sensor's own
noise floor stays. A sensor's bins are put in classes by the baseline's power (each class twice the
power of the one below, from the sensor's median up) and each class's level is the median over its
bins of the recording's power over the baseline's: a knock lifts a few bins, not a class's median.
No class is raised beyond the engine's level, the median over the bearing sensors of their loudest
classes' levels (:func:`engine_level`), so that a knock that fills a small class on one sensor cannot
raise its own reference. A reference bin is raised by its class's level, never lowered: a quieter
engine is judged against the baseline as it is.

A bin's power is the sensor's floor and the engine's events above it, and only the events grow: a bin
whose events stood a little above the floor on the baseline (an event's flank, in the lowest class,
whose median the floor's bins set) grows by the engine's level on its events' part, ``1 + (level - 1)
(median - floor) / power`` with the floor the baseline's median and ``median`` the baseline's over the
:data:`FLOOR_MEDIAN_BINS` bins about it (:func:`floor_raise`), where its class's level would leave it.
Seed 200215 of the validation population (a healthy engine at 97 % load against one point at 50 %, the
engine 3.9 times as loud) read a reversal window on such a flank 1.6 times its class-raised reference, a
bearing warning; raised by its events' part it reads 1.0. The events are read over several bins because
half the floor's bins stand above its median by their cycles' scatter alone: raised by each one's own
excess, a floor window's reference at an engine ten times as loud grows with them and hides a knock
(heard in at most 6 of 30 drawn profiles, at least 22 of 30 read over the median's bins: tests/diagnosis/
test_impact_floor.py), and V engine seeds 310010 and 310040 (worn bearings, 31-32 % faster than their one
calibrated point) went unheard. An event's rise and decay are runs longer than the median's span, which
keeps them whole; a margin of the bin's own scatter instead would take an event's faint first bins for
the floor and hear them as knocks at a louder engine.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, replace

import numpy as np
import numpy.typing as npt
from scipy.ndimage import median_filter

from monitor.signal.impact import HIGH_FREQUENCY_BIN_SECONDS, HighFrequencyPower
from monitor.types import FloatArray

__all__ = [
    "CLASS_BINS",
    "FLOOR_MEDIAN_BINS",
    "RING_CLASS",
    "RING_S",
    "MatchedProfiles",
    "between",
    "class_levels",
    "engine_level",
    "floor_raise",
    "loudest",
    "reference_profile",
    "widened",
]

#: How long after an event the structure still rings in the impact band [s]: an amplitude time
#: constant of a 1 kHz resonance, the band's lowest, at 1.6 % of critical damping
#: (``1 / (2 pi 1000 0.016)``; the ring's power has fallen to a seventh). A longer allowance hides
#: knocks near the engine's own events (tests/diagnosis/test_speed_change_reference.py).
RING_S = 0.01
#: Bins a class needs for its median to tell its level (fewer: it takes the class's below) [-].
CLASS_BINS = 8
#: The lowest class whose level speaks for the engine's own events: four times the sensor's median.
EVENT_CLASS = 2
#: The lowest class whose bins ring on at another speed (:func:`widened`): twice the sensor's median,
#: where :func:`class_levels` begins to tell events from the floor [-].
RING_CLASS = 1
#: Bins a bin's events above the floor are read over (:func:`floor_raise`): the most, in an odd count,
#: that span no more than half a ring's :data:`RING_S` at the longest bins
#: (:data:`~monitor.signal.impact.HIGH_FREQUENCY_BIN_SECONDS`), so an event's rise and decay pass whole:
#: 9 bins, 4.5 ms (the 1e-9 keeps a quotient of exactly 10 from rounding down) [-].
FLOOR_MEDIAN_BINS = int(RING_S / 2 / HIGH_FREQUENCY_BIN_SECONDS + 1e-9) // 2 * 2 - 1
#: A reference raised by this much or more is noted in the diagnosis [-].
LOUDER = 1.1


@dataclass(frozen=True)
class MatchedProfiles:
    """A sensor's profile and the reference it is scored against, on common bins.

    Attributes
    ----------
    profile : HighFrequencyPower
        The recording's.
    reference : HighFrequencyPower or None
        The baseline's, widened by ``moved_deg`` and raised class by class up to ``level``; None where
        the baseline cannot serve (another sampling rate or band, bins that do not divide).
    level : float
        The highest a reference bin was raised by [-] (1: not raised).
    moved_deg : float
        The crank angle the speed change moves a ring's tail by, either side [deg].
    """

    profile: HighFrequencyPower
    reference: HighFrequencyPower | None
    level: float = 1.0
    moved_deg: float = 0.0

    def notes(self, channel: str) -> list[str]:
        """What the diagnosis says of a reference raised by :data:`LOUDER` or more (else nothing)."""
        if self.level < LOUDER:
            return []
        return [
            f"{channel}: the engine's own high-frequency noise up to {self.level:.2f} x the baseline's "
            "(its load and speed): impacts judged against the baseline raised to it"
        ]


def _common(
    baseline: HighFrequencyPower | None, profile: HighFrequencyPower
) -> tuple[HighFrequencyPower, HighFrequencyPower | None]:
    """Both on the coarser one's bins, or the profile and None where the baseline cannot serve."""
    if baseline is None or baseline.sample_rate != profile.sample_rate or baseline.band_hz != profile.band_hz:
        return profile, None
    fine, coarse = sorted((baseline.mean.size, profile.mean.size), reverse=True)
    if fine % coarse:
        return profile, None
    return profile.coarsened(coarse), baseline.coarsened(coarse)


def class_levels(recording: FloatArray, baseline: FloatArray) -> tuple[npt.NDArray[np.int64], FloatArray]:
    """Each bin's class by the baseline's power, and each class's level (module docstring).

    Parameters
    ----------
    recording, baseline : ndarray
        The two profiles' mean power on common bins [unit^2].

    Returns
    -------
    classes : ndarray of int
        0 for bins at or below the baseline's median, ``k`` for bins ``2**k`` times above it.
    levels : ndarray
        Per class (index), the median of the recording's power over the baseline's; a class with
        fewer than :data:`CLASS_BINS` bins takes the level of the class below [-].
    """
    median = float(np.median(baseline))
    if not median > 0.0:
        return np.zeros(baseline.size, dtype=np.int64), np.ones(1)
    classes = np.floor(np.log2(np.maximum(baseline / median, 1.0))).astype(np.int64)
    levels = np.ones(int(classes.max()) + 1)
    for k in range(levels.size):
        here = classes == k
        if here.sum() >= CLASS_BINS:
            levels[k] = float(np.median(recording[here] / baseline[here]))
        elif k > 0:
            levels[k] = levels[k - 1]
    return classes, levels


def floor_raise(baseline: FloatArray, level: float, width: int = FLOOR_MEDIAN_BINS) -> FloatArray:
    """Each bin's raise when its events above the sensor's floor grow by ``level`` and the floor stays.

    A bin's events are read from the median of the baseline over ``width`` bins about it (the bins close
    on themselves over the cycle): an event's ring rises and decays over more bins than that, and the
    median keeps such a run as it is, while a bin that stands above the floor by its cycles' scatter
    alone, among bins that do not, is taken as the floor.

    Parameters
    ----------
    baseline : ndarray
        The baseline's mean power per bin [unit^2]; its median is taken as the floor.
    level : float
        How much louder the engine's events are [-].
    width : int, optional
        Bins the events are read over (:data:`FLOOR_MEDIAN_BINS`; 1: each bin alone) [-].

    Returns
    -------
    ndarray
        ``1 + (level - 1) e`` with ``e = (median - floor) / power``, between 0 and 1; all 1 for a level
        of 1 or less (or not finite), or a floor of nothing [-].
    """
    floor = float(np.median(baseline))
    if not (math.isfinite(level) and level > 1.0 and floor > 0.0):
        return np.ones(baseline.size)
    around = median_filter(baseline, size=min(width, baseline.size), mode="wrap")
    events = np.clip((around - floor) / np.maximum(baseline, floor), 0.0, 1.0)
    return np.asarray(1.0 + (level - 1.0) * events, dtype=np.float64)


def engine_level(pairs: Iterable[tuple[HighFrequencyPower | None, HighFrequencyPower]]) -> float:
    """How much louder the engine's own events are than on the baseline: the median over the sensors.

    Each sensor that has a class of events (:data:`EVENT_CLASS` or above, with :data:`CLASS_BINS` bins)
    speaks with its loudest such class's level.

    Parameters
    ----------
    pairs : iterable of (HighFrequencyPower or None, HighFrequencyPower)
        Each bearing sensor's baseline profile (None: none) and recording profile.

    Returns
    -------
    float
        [-]; NaN where no sensor speaks.
    """
    said = []
    for baseline, profile in pairs:
        recording, reference = _common(baseline, profile)
        if reference is None:
            continue
        classes, levels = class_levels(recording.mean, reference.mean)
        told = [k for k in range(EVENT_CLASS, levels.size) if (classes == k).sum() >= CLASS_BINS]
        if told:
            said.append(levels[max(told)])
    return float(np.median(said)) if said else math.nan


def between(
    low: HighFrequencyPower | None, high: HighFrequencyPower | None, weight: float
) -> HighFrequencyPower | None:
    """A sensor's profile between two calibrated points: each bin's power interpolated linearly in load.

    The engine's own events grow with the load; a recording between two points is judged against the
    power its load puts between theirs, at the speed interpolated with it, where one point's profile
    alone would miss an event that grows towards the other (or expect one that has not yet grown).

    Parameters
    ----------
    low, high : HighFrequencyPower or None
        The sensor's profile at the lower and the higher point.
    weight : float
        Where the load lies between them (0 at ``low``, 1 at ``high``) [-].

    Returns
    -------
    HighFrequencyPower or None
        On the coarser one's bins, its spread the cycles' spreads interpolated the same way, its
        cycles the fewer; the nearer point's profile where the two cannot be compared (another
        sampling rate or band, bins that do not divide).
    """
    nearest = low if weight <= 0.5 else high
    if low is None or high is None:
        return nearest
    high_on, low_on = _common(low, high)
    if low_on is None:
        return nearest

    def line(a: FloatArray, b: FloatArray) -> FloatArray:
        return np.asarray((1.0 - weight) * a + weight * b, dtype=np.float64)

    varying = (
        None if low_on.varying is None or high_on.varying is None else line(low_on.varying, high_on.varying)
    )
    return replace(
        high_on,
        mean=line(low_on.mean, high_on.mean),
        std=line(low_on.std, high_on.std),
        cycles=min(low_on.cycles, high_on.cycles),
        speed_rpm=float(line(np.asarray(low_on.speed_rpm), np.asarray(high_on.speed_rpm))),
        varying=varying,
        speeds_rpm=_speeds([low_on, high_on]),
    )


def _speeds(profiles: Sequence[HighFrequencyPower]) -> tuple[float, float]:
    """The lowest and the highest speed of the profiles' spans (NaN where one is not known)."""
    ends = [end for p in profiles for end in p.speed_span()]
    if not all(math.isfinite(end) for end in ends):
        return (math.nan, math.nan)
    return (min(ends), max(ends))


def loudest(profiles: Sequence[HighFrequencyPower | None]) -> HighFrequencyPower | None:
    """Bin by bin the loudest of a sensor's profiles at several loads (with that bin's spread).

    A recording whose load is known only within a span is judged against the loudest its engine's own
    events get over the span: an event that grows with the load may be as loud as at the span's top.

    Parameters
    ----------
    profiles : sequence of HighFrequencyPower or None
        The first is the profile at the load used; the others at the span's ends and the calibrated
        points within it.

    Returns
    -------
    HighFrequencyPower or None
        On the first profile's bins (the others coarsened to them, or left out where they cannot be:
        another sampling rate or band, bins that do not divide); the first itself where it is None.
    """
    first = profiles[0] if profiles else None
    if first is None:
        return None
    means, stds, varying, used = [first.mean], [first.std], [first.varying], [first]
    for other in profiles[1:]:
        if other is None or other.mean.size < first.mean.size:
            continue
        mine, theirs = _common(other, first)
        if theirs is None or mine.mean.size != first.mean.size:
            continue
        means.append(theirs.mean)
        stds.append(theirs.std)
        varying.append(theirs.varying)
        used.append(theirs)
    if len(means) == 1:
        return first
    stacked = np.stack(means)
    pick = np.argmax(stacked, axis=0)
    column = np.arange(first.mean.size)
    # the varying part's loudest on its own: none where a profile lacks it
    known = [v for v in varying if v is not None]
    most = np.max(np.stack(known), axis=0) if len(known) == len(varying) else None
    return replace(
        first,
        mean=stacked[pick, column],
        std=np.stack(stds)[pick, column],
        varying=most,
        speeds_rpm=_speeds(used),
    )


def reference_profile(
    baseline: HighFrequencyPower | None,
    profile: HighFrequencyPower,
    cycle_revolutions: int,
    engine: float = math.nan,
) -> MatchedProfiles:
    """A sensor's profile and its baseline's on common bins, carried to the recording's speed and level.

    The baseline serves if it was taken at the same sampling rate and band; the finer of the two is
    coarsened to the other's bins when one's count divides the other's (a baseline at another speed
    may have been binned finer or coarser). Then the module docstring's speed and level.

    Parameters
    ----------
    baseline : HighFrequencyPower or None
        The sensor's profile on its healthy baseline.
    profile : HighFrequencyPower
        The sensor's profile in the recording.
    cycle_revolutions : int
        Of the engine's cycle (the profiles' bins span it).
    engine : float, optional
        The engine's level [-] (:func:`engine_level`); NaN (default): the sensor's own classes alone.

    Returns
    -------
    MatchedProfiles
    """
    profile, reference = _common(baseline, profile)
    if reference is None:
        return MatchedProfiles(profile, None)
    classes, levels = class_levels(profile.mean, reference.mean)
    if math.isfinite(engine):
        # a class as loud as the engine's events: at least the engine's level, at most it in any class
        levels[EVENT_CLASS:] = np.maximum(levels[EVENT_CLASS:], engine)
        levels = np.minimum(levels, max(engine, 1.0))
    # the events' part of each bin grows by the engine's level (none told: by its class's alone)
    raise_by = np.maximum(np.maximum(levels[classes], 1.0), floor_raise(reference.mean, engine))
    varying = None if reference.varying is None else raise_by * reference.varying
    reference = replace(
        reference, mean=raise_by * reference.mean, std=raise_by * reference.std, varying=varying
    )
    moved_deg = 6.0 * abs(profile.speed_rpm - reference.speed_rpm) * RING_S
    if math.isfinite(moved_deg):
        reference = widened(reference, moved_deg, cycle_revolutions)
    else:
        moved_deg = 0.0
    return MatchedProfiles(profile, reference, float(raise_by.max()), moved_deg)


def widened(profile: HighFrequencyPower, angle_deg: float, cycle_revolutions: int) -> HighFrequencyPower:
    """A profile whose every bin is the loudest event within ``angle_deg`` either side, or its own.

    Only the events' bins (:data:`RING_CLASS` and above) are carried: a ring moves with the speed, the
    sensor's floor does not, and its bins' scatter is no ring. The highest of a dozen floor bins stands
    above their median by that scatter alone; carried, it raised quiet windows' references and hid
    knocks (tests/diagnosis/test_speed_change_reference.py draws such floors; seed 200468 of the
    validation population, a worn bearing across a load step 16 % faster than its baseline, was named
    only once they were no longer carried). A carried bin keeps its spread; the bins close on
    themselves over the cycle; a bin is within the angle when its centre is.

    Parameters
    ----------
    profile : HighFrequencyPower
    angle_deg : float
        Crank angle either side [deg] (>= 0).
    cycle_revolutions : int
        Of the engine's cycle (the profile's bins span it).

    Returns
    -------
    HighFrequencyPower
        The profile itself where the angle is under half a bin.
    """
    bins = profile.mean.size
    reach = int(angle_deg / (360.0 * cycle_revolutions / bins) + 0.5)
    if reach < 1:
        return profile
    reach = min(reach, bins // 2)
    shifts = np.arange(-reach, reach + 1)
    events = profile.mean >= 2.0**RING_CLASS * float(np.median(profile.mean))
    carried = np.where(events, profile.mean, -np.inf)
    means = np.stack([np.roll(carried, int(k)) for k in shifts])
    highest = np.argmax(means, axis=0)
    louder = means[highest, np.arange(bins)] > profile.mean
    source = np.where(louder, (np.arange(bins) - shifts[highest]) % bins, np.arange(bins))
    varying = profile.varying
    if varying is not None:
        moved = np.stack([np.roll(np.where(events, varying, -np.inf), int(k)) for k in shifts])
        varying = np.maximum(varying, np.max(moved, axis=0))
    return replace(profile, mean=profile.mean[source], std=profile.std[source], varying=varying)
