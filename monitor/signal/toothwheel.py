"""Tooth-wheel decoding: gap detection, tooth angles, speed per tooth, spacing errors.

A wheel of ``teeth`` equally spaced positions with ``missing`` teeth left out
(60-2 is common) gives one long interval per revolution, about
``missing + 1`` tooth pitches.  Each interval is compared with the running
median of the nine around it; a ratio above ``missing + 0.5`` marks the gap
(halfway between a gap and the double interval a single lost tooth leaves,
so a lost tooth is repaired rather than taken for the gap).  The
first tooth after the gap is at the angle the channel states (from TDC of
cylinder 1), every following tooth one pitch further, so each edge gets an
absolute crank angle.  A revolution must hold ``teeth - missing`` edges; one
edge too few (a lost tooth) or too many (a spurious pulse) is repaired and
reported, anything else is an error naming the revolution.

Timing point.  A Hall sensor (or an optical pick-up) gives square pulses:
each tooth is timed at the mid level of its rising edge.  A
variable-reluctance (VR) sensor gives a zero-mean voltage, the rate of
change of the magnetic flux, whose amplitude grows with speed: each tooth is
timed where the voltage falls through zero (the tooth's centre passing the
sensor), with an arming threshold that follows the local amplitude (see
:func:`monitor.signal.pulses.detect_edges`).  A VR sensor wired with
reversed polarity is timed on the wrong flank, between the teeth: its gap
then shows as two intervals of about two pitches instead of one of three
(1-1-2-2-1 instead of 1-1-3-1 on a 60-2 wheel).  :func:`decode_tooth_signal`
recognises this, decodes the inverted signal and says so, the way engine
controllers tell their users to swap the sensor's wires.

A wheel's own tooth-spacing errors are estimated and corrected in
:mod:`monitor.signal.pitch`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import Any, Literal

import numpy as np
import numpy.typing as npt
from scipy.ndimage import median_filter

from monitor.errors import SignalError
from monitor.signal.pulses import detect_edges
from monitor.signal.wheels import WheelPattern, decode_pattern, infer_pattern
from monitor.types import FloatArray

__all__ = [
    "ToothSensor",
    "ToothWheelDecoding",
    "decode_encoder",
    "decode_tooth_signal",
    "decode_tooth_wheel",
    "infer_tooth_sensor",
    "tooth_edges",
]

ToothSensor = Literal["hall", "vr"]


@dataclass(frozen=True)
class ToothWheelDecoding:
    """Tooth edges with their crank angles.

    Attributes
    ----------
    times : ndarray
        Edge times after repair [s].
    angles : ndarray
        Crank angle of each edge, increasing, from TDC of cylinder 1 [rad].
    tooth_index : ndarray of int
        Position of each edge on the wheel, 0 for the first tooth after the gap.
    gap_times : ndarray
        Time of the first edge after each gap [s].
    teeth, missing : int
        The wheel.
    inserted, removed : ndarray
        Times of edges inserted (lost teeth) and removed (spurious pulses) [s].
    revolutions : int
        Complete revolutions between the first and the last gap.
    sensor : str
        The sensor kind whose timing point was used ("hall", "vr"), or "" for edge times given.
    reversed_polarity : bool
        True when the waveform was decoded inverted (a VR sensor wired the wrong way round).
    notes : tuple of str
        What a user should know about the decoding (an inferred sensor kind, reversed polarity).
    pattern : WheelPattern or None
        A wheel of several gaps (its teeth then at the pattern's positions); None for one gap.
    """

    times: FloatArray
    angles: FloatArray
    tooth_index: npt.NDArray[np.int64]
    gap_times: FloatArray
    teeth: int
    missing: int
    inserted: FloatArray = field(default_factory=lambda: np.empty(0))
    removed: FloatArray = field(default_factory=lambda: np.empty(0))
    revolutions: int = 0
    sensor: str = ""
    reversed_polarity: bool = False
    notes: tuple[str, ...] = ()
    pattern: WheelPattern | None = None

    @property
    def pitch(self) -> float:
        """Angle between tooth positions [rad]."""
        return 2 * math.pi / self.teeth

    def speed_per_tooth(self) -> tuple[FloatArray, FloatArray]:
        """Instantaneous angular speed from tooth to tooth.

        Returns
        -------
        time, speed : ndarray
            Interval mid-times [s] and mean speed over each interval [rad/s].
        """
        dt = np.diff(self.times)
        return 0.5 * (self.times[1:] + self.times[:-1]), np.diff(self.angles) / dt


def decode_tooth_wheel(
    edge_times: npt.ArrayLike,
    *,
    teeth: int,
    missing: int,
    first_tooth_angle: float = 0.0,
    gap_ratio: float | None = None,
    pattern: WheelPattern | None = None,
) -> ToothWheelDecoding:
    """Crank angles of tooth-wheel edges.

    Parameters
    ----------
    edge_times : array_like
        One edge per tooth, increasing [s].
    teeth : int
        Tooth positions on the wheel, including the missing ones (60 for 60-2).
    missing : int
        Teeth left out to make the gap, >= 1.
    first_tooth_angle : float, optional
        Crank angle of the first tooth after the gap, from TDC of cylinder 1 [rad].
    gap_ratio : float, optional
        Interval over the running median of nine intervals that marks the gap;
        default ``missing + 0.5`` [-].
    pattern : WheelPattern, optional
        A wheel of several gaps, of ``teeth`` positions and ``missing`` teeth in all
        (:mod:`monitor.signal.wheels`); default: one gap.

    Returns
    -------
    ToothWheelDecoding

    Raises
    ------
    SignalError
        Without at least two gaps, or with a revolution that has neither the
        right number of edges nor one too few or too many; or when the edges
        show another wheel than the one declared (one tooth inserted or removed
        in half the revolutions or more, or revolutions that do not fit): the
        message names the wheel they show.
    """
    t = np.asarray(edge_times, dtype=np.float64)
    if pattern is not None and (
        pattern.extra or len(pattern.gaps) > 1 or (pattern.positions, pattern.missing) != (teeth, missing)
    ):  # a wheel one gap does not describe (or a declaration at odds with itself: refused there)
        return _decoded_pattern(t, pattern, teeth, missing, first_tooth_angle)
    if teeth < 3 or not 1 <= missing < teeth - 1:
        raise SignalError(f"tooth wheel {teeth}-{missing}: expected teeth >= 3 and 1 <= missing < teeth - 1")
    if t.ndim != 1 or t.size < 2 * teeth or np.any(np.diff(t) <= 0) or not np.all(np.isfinite(t)):
        raise SignalError(
            f"{t.size} edge times: expected at least two revolutions ({2 * teeth}) of finite, "
            "increasing times"
        )
    threshold = missing + 0.5 if gap_ratio is None else gap_ratio
    per_rev = teeth - missing
    try:
        arr, gaps, inserted, removed = _repaired(t, threshold, teeth, missing)
    except SignalError as error:
        raise SignalError(f"{error}{_shown(t, WheelPattern.one_gap(teeth, missing))}") from None
    if 2 * (len(inserted) + len(removed)) >= max(gaps.size - 1, 1) and (
        shown := _shown(t, WheelPattern.one_gap(teeth, missing))
    ):
        raise SignalError(
            f"tooth wheel {teeth}-{missing}: {len(inserted) + len(removed)} teeth inserted or removed in "
            f"{gaps.size - 1} revolutions, the same every revolution{shown}"
        )
    arr, gaps, trimmed = _trim_ends(arr, gaps, per_rev)
    index = np.empty(arr.size, dtype=np.int64)
    revolution = np.empty(arr.size, dtype=np.int64)
    first = int(gaps[0])
    # position on the wheel of every edge, counting from the first gap (edges before it count backwards)
    offsets = np.arange(arr.size) - first
    rev_of = np.floor_divide(offsets, per_rev)
    index[:] = np.mod(offsets, per_rev)
    revolution[:] = rev_of
    # teeth positions skip the missing ones: index 0 .. per_rev - 1 after the gap
    angles = first_tooth_angle + 2 * math.pi * (revolution + index / teeth)
    return ToothWheelDecoding(
        times=arr,
        angles=angles,
        tooth_index=index,
        gap_times=arr[gaps],
        teeth=teeth,
        missing=missing,
        inserted=np.asarray(inserted),
        removed=np.asarray(removed),
        revolutions=int(gaps.size - 1),
        notes=(
            (
                f"{trimmed} edge(s) before the first gap or after the last did not fit the wheel (a "
                "tooth lost there, or the signal fading): dropped",
            )
            if trimmed
            else ()
        ),
    )


def _shown(t: FloatArray, declared: WheelPattern) -> str:
    """What the edges show where it is another wheel than the one declared (else empty)."""
    found = infer_pattern(t)
    if found is None or found.same_as(declared):
        return ""
    return (
        f"; the edges show a {found.name} wheel ({found.spelled}: {found.teeth} teeth, gaps of "
        f"{', '.join(str(g) for g in found.gaps)}), not the {declared.name} declared: declare the "
        f"channel's pattern = {found.name!r} (and teeth = {found.positions}, missing_teeth = {found.missing})"
    )


def _decoded_pattern(
    t: FloatArray, pattern: WheelPattern, teeth: int, missing: int, first_tooth_angle: float
) -> ToothWheelDecoding:
    """The decoding of a wheel of several gaps (:func:`monitor.signal.wheels.decode_pattern`)."""
    if (pattern.positions, pattern.missing) != (teeth, missing):
        raise SignalError(
            f"wheel pattern {pattern.name} ({pattern.spelled}) has {pattern.positions} positions and "
            f"{pattern.missing} missing teeth: the channel states teeth = {teeth}, missing_teeth = {missing}"
        )
    try:
        times, angles, tooth = decode_pattern(t, pattern, first_tooth_angle=first_tooth_angle)
    except SignalError as error:
        raise SignalError(f"{error}{_shown(t, pattern)}") from None
    starts = times[tooth == 0]
    return ToothWheelDecoding(
        times=times,
        angles=angles,
        tooth_index=tooth,
        gap_times=starts,
        teeth=teeth,
        missing=missing,
        revolutions=max(int(starts.size) - 1, 0),
        pattern=pattern,
    )


def _repaired(
    t: FloatArray, threshold: float, teeth: int, missing: int
) -> tuple[FloatArray, npt.NDArray[np.int64], list[float], list[float]]:
    """The edges with every revolution between two gaps made whole: a lost tooth put back, a spurious
    edge dropped, one revolution at a time; the gaps; the times inserted and removed.

    Raises
    ------
    SignalError
        Without two gaps, or for a revolution more than one edge off.
    """
    per_rev = teeth - missing
    arr = t
    inserted: list[float] = []
    removed: list[float] = []
    while True:
        gaps = _find_gaps(arr, threshold)
        if gaps.size < 2:
            raise SignalError(
                f"found {gaps.size} tooth-wheel gap(s): expected one per revolution of a "
                f"{teeth}-{missing} wheel; "
                "check the wheel description and the edge direction"
            )
        counts = np.diff(gaps)
        bad = np.flatnonzero(counts != per_rev)
        if bad.size == 0:
            return arr, gaps, inserted, removed
        k = int(bad[0])
        start, stop = int(gaps[k]), int(gaps[k + 1])  # edge indices: first tooth after gap k .. after gap k+1
        if counts[k] == per_rev - 1:  # a lost tooth: inside the revolution, or next to one of its gaps
            new, position = _lost_tooth(arr, start, stop, missing)
            arr = np.insert(arr, position, new)  # rare: a copy per repair
            inserted.append(float(new))
        elif counts[k] == per_rev + 1:  # a spurious edge: drop the one that leaves the most even spacing
            segment = arr[start - 1 : stop + 1]
            best = min(
                range(1, segment.size - 1),
                key=lambda j: float(np.std(np.diff(np.delete(segment, j))[1:-1])),
            )
            removed.append(float(segment[best]))
            arr = np.delete(arr, start - 1 + best)
        else:
            raise SignalError(
                f"revolution starting at t = {arr[start]:.6g} s has {counts[k]} edges: expected {per_rev} "
                f"for a {teeth}-{missing} wheel (one lost or one extra tooth can be repaired, not more)"
            )


def _lost_tooth(arr: FloatArray, start: int, stop: int, missing: int) -> tuple[float, int]:
    """Where the tooth lost from the revolution of edges ``start`` to ``stop`` was: its time and the
    index it goes in at.

    Inside the revolution where an interval is double, else just before the next gap or just after
    this one, where that gap is a tooth too long.
    """
    segment = arr[start : stop + 1]
    ordinary = np.diff(segment)[:-1]  # the last interval is the next gap
    pitch = float(np.median(ordinary))
    after = (arr[stop] - arr[stop - 1]) / pitch
    before = (arr[start] - arr[start - 1]) / pitch
    if ordinary.max() / pitch > 1.5:  # a double interval inside: split it
        i = start + int(np.argmax(ordinary))
        return 0.5 * (arr[i] + arr[i + 1]), i + 1
    if after > missing + 1.5:  # the last tooth before the next gap is lost
        return arr[stop - 1] + pitch, stop
    if before > missing + 1.5:  # the first tooth after this revolution's gap is lost
        return arr[start] - pitch, start
    raise SignalError(
        f"revolution starting at t = {arr[start]:.6g} s is one tooth short, but neither an "
        "interval inside it nor its gaps is long enough to show where"
    )


def _trim_ends(
    times: FloatArray, gaps: npt.NDArray[np.int64], per_rev: int
) -> tuple[FloatArray, npt.NDArray[np.int64], int]:
    """Edges before the first gap and after the last, kept only while they fit the wheel.

    Those edges are not checked by a revolution's count: from the gap outwards each is kept while its
    interval stays within 1.5 of the neighbouring revolution's median tooth interval, and no more than
    a revolution's teeth; the rest are dropped (a tooth lost at an end would shift every angle beyond
    it by a pitch).
    """
    first, last = int(gaps[0]), int(gaps[-1])
    lead_pitch = float(np.median(np.diff(times[first : int(gaps[1])])))
    tail_pitch = float(np.median(np.diff(times[int(gaps[-2]) : last])))
    # before the first gap: the tooth before it closes the gap's long interval, then ordinary ones
    start = first - 1 if first > 0 else first
    # (a record that opens on the first tooth after a gap holds a whole revolution before its first gap)
    while start > 0 and first - start < per_rev and times[start] - times[start - 1] < 1.5 * lead_pitch:
        start -= 1
    stop = last
    while (
        stop < times.size - 1
        and stop - last < per_rev - 1
        and times[stop + 1] - times[stop] < 1.5 * tail_pitch
    ):
        stop += 1
    trimmed = start + (times.size - 1 - stop)
    return times[start : stop + 1], gaps - start, trimmed


def infer_tooth_sensor(signal: npt.ArrayLike) -> ToothSensor:
    """The sensor kind a tooth-wheel waveform looks like: "vr" if it swings about its median, else "hall".

    Parameters
    ----------
    signal : array_like
        A stretch of the waveform holding several revolutions [V].

    Returns
    -------
    {"vr", "hall"}

    Notes
    -----
    A VR sensor's voltage is zero-mean: its median sits near the middle of its
    range (within 15 % of the range between the 1st and 99th percentiles).  A Hall
    sensor's square pulses spend their time at two rails, so the median sits at
    one of them, half the range from the middle.
    """
    x = np.asarray(signal, dtype=np.float64)
    low, median, high = np.percentile(x, [1.0, 50.0, 99.0])
    if not high > low:
        raise SignalError("tooth-wheel signal is flat: no teeth to time")
    return "vr" if abs(median - 0.5 * (low + high)) < 0.15 * (high - low) else "hall"


def decode_tooth_signal(
    signal: Any,
    sample_rate: float,
    *,
    teeth: int,
    missing: int,
    first_tooth_angle: float = 0.0,
    start_time: float = 0.0,
    sensor: ToothSensor | None = None,
    polarity: Literal["normal", "reversed"] | None = None,
    pattern: WheelPattern | None = None,
) -> ToothWheelDecoding:
    """Crank angles of the teeth in a tooth-wheel waveform, timed as its sensor kind needs.

    Parameters
    ----------
    signal : array_like or sliceable, shape (n,)
        The sensor's waveform [V]; an h5py dataset or a reader by slices is read in blocks.
    sample_rate : float
        [Hz].
    teeth, missing : int
        The wheel (60 and 2 for 60-2).
    first_tooth_angle : float, optional
        Crank angle of the first tooth after the gap at the sensor's timing point, from TDC of
        cylinder 1 [rad].
    start_time : float, optional
        Time of the first sample [s].
    sensor : {"hall", "vr"}, optional
        The timing point: "hall" the mid level of each tooth's rising edge, "vr" the downward zero
        crossing at each tooth's centre. Default: inferred from the waveform
        (:func:`infer_tooth_sensor`), and said in the notes.
    polarity : {"normal", "reversed"}, optional
        How the sensor is wired. Default: "normal", and for a VR sensor whose waveform does not
        decode, "reversed" if the inverted waveform does (said in the notes).
    pattern : WheelPattern, optional
        A wheel of several gaps (:func:`decode_tooth_wheel`).

    Returns
    -------
    ToothWheelDecoding

    Raises
    ------
    SignalError
        If the waveform decodes neither way.
    """
    notes: list[str] = []
    if sensor is None:
        n = int(signal.shape[0]) if hasattr(signal, "shape") else len(signal)
        sensor = infer_tooth_sensor(np.asarray(signal[: min(n, 1 << 20)]))
        notes.append(
            f"sensor kind {sensor!r} inferred from the waveform (state the channel's 'sensor' to fix it)"
        )
    if sensor not in ("hall", "vr"):
        raise SignalError(f"tooth-wheel sensor {sensor!r}: expected 'hall' or 'vr'")

    def attempt(reversed_: bool) -> ToothWheelDecoding:
        edges = tooth_edges(signal, sample_rate, sensor, reversed_=reversed_, start_time=start_time)
        return decode_tooth_wheel(
            edges, teeth=teeth, missing=missing, first_tooth_angle=first_tooth_angle, pattern=pattern
        )

    if polarity is not None:
        decoding = attempt(polarity == "reversed")
        return replace(decoding, sensor=sensor, reversed_polarity=polarity == "reversed", notes=tuple(notes))
    try:
        decoding = attempt(False)
    except SignalError as normal:
        if sensor != "vr":
            raise
        try:
            decoding = attempt(True)
        except SignalError:
            raise normal from None
        notes.append(
            "the VR sensor is wired with reversed polarity (its gap shows as two intervals of about two "
            "pitches): decoded inverted; swap the sensor's two wires, or state polarity = 'reversed'"
        )
        return replace(decoding, sensor=sensor, reversed_polarity=True, notes=tuple(notes))
    return replace(decoding, sensor=sensor, notes=tuple(notes))


def tooth_edges(
    signal: Any, sample_rate: float, sensor: ToothSensor, *, reversed_: bool = False, start_time: float = 0.0
) -> FloatArray:
    """Each tooth's time at its sensor's timing point (see :func:`decode_tooth_signal`).

    Parameters
    ----------
    signal : array_like or sliceable, shape (n,)
        The sensor's waveform [V].
    sample_rate : float
        [Hz].
    sensor : {"hall", "vr"}
        "hall": the mid level of each rising edge; "vr": each downward zero crossing.
    reversed_ : bool, optional
        The sensor wired the other way round: the opposite edges or crossings.
    start_time : float, optional
        Time of the first sample [s].

    Returns
    -------
    ndarray
        The times, increasing [s].
    """
    if sensor == "vr":
        # reversed wiring inverts the voltage: the tooth centres are its upward zero crossings
        edges = detect_edges(
            signal,
            sample_rate,
            start_time=start_time,
            timing="zero-crossing",
            direction="rising" if reversed_ else "falling",
        )
    else:
        edges = detect_edges(
            signal, sample_rate, start_time=start_time, direction="falling" if reversed_ else "rising"
        )
    return np.asarray(edges.times, dtype=np.float64)


def _find_gaps(times: FloatArray, threshold: float) -> npt.NDArray[np.int64]:
    """Indices of the first edge after each gap interval (interval over the running median of 9).

    The median mirrors the intervals at the record's ends, so a gap in the first or last interval
    is measured against its neighbours, not against copies of itself.
    """
    dt = np.diff(times)
    reference = median_filter(dt, size=min(9, dt.size), mode="mirror")
    return (np.flatnonzero(dt / reference > threshold) + 1).astype(np.int64)


def decode_encoder(
    edge_times: npt.ArrayLike,
    index_times: npt.ArrayLike,
    *,
    pulses: int,
    first_pulse_angle: float = 0.0,
) -> ToothWheelDecoding:
    """Crank angles of an encoder's pulses, counted from its once-per-revolution index.

    Parameters
    ----------
    edge_times : array_like
        One edge per encoder pulse, increasing [s].
    index_times : array_like
        The index pulse's edges, one per revolution [s].
    pulses : int
        Pulses per revolution.
    first_pulse_angle : float, optional
        Crank angle of the encoder edge the index marks (the one nearest it, where the index falls
        within half a pulse of an edge), from TDC of cylinder 1 [rad].

    Returns
    -------
    ToothWheelDecoding
        As a wheel of ``pulses`` teeth with none missing (``tooth_index`` 0 for the pulse at the
        index).

    Raises
    ------
    SignalError
        If the pulses between consecutive indexes are not ``pulses`` (a lost or an extra pulse, a
        wrong pulse count), or the index does not fall at the same pulse every revolution.

    Notes
    -----
    Each index's place among the encoder edges is counted in pulses; the index falls at the same
    fraction of a pulse every revolution (within its jitter), so the edge it marks is its place less
    the circular mean of those fractions, rounded: an index gated on one pulse or lying half way
    between two is read alike. Every revolution must then hold exactly ``pulses`` edges; an index
    that alone strays (jitter over half a pulse) is left out, and only the edges between the first
    and the last agreeing index are kept.
    """
    t = np.asarray(edge_times, dtype=np.float64)
    index = np.asarray(index_times, dtype=np.float64)
    if pulses < 2:
        raise SignalError(f"encoder pulses per revolution = {pulses}: expected at least 2")
    if t.ndim != 1 or t.size < 2 * pulses or np.any(np.diff(t) <= 0) or not np.all(np.isfinite(t)):
        raise SignalError(
            f"{t.size} encoder edge times: expected at least two revolutions ({2 * pulses}) of finite, "
            "increasing times"
        )
    index = index[(index >= t[0]) & (index <= t[-1])]
    if index.size < 2:
        raise SignalError(
            f"encoder: {index.size} index pulse(s) inside the encoder's span: expected one per revolution"
        )
    # each index's place among the encoder edges, in pulses (edge k at k): the index sits at the same
    # fraction of a pulse every revolution (gated on one pulse, or anywhere between two), so the edge
    # it marks is round(place - that fraction's circular mean)
    before = np.clip(np.searchsorted(t, index, side="right") - 1, 0, t.size - 2)
    place = before + (index - t[before]) / (t[before + 1] - t[before])
    fraction = float(np.angle(np.mean(np.exp(2j * math.pi * place))) / (2 * math.pi))
    fraction = fraction + 1.0 if fraction < -0.25 else fraction  # half way between two: the one before
    picked = np.round(place - fraction).astype(np.int64)
    picked = picked[(picked >= 0) & (picked < t.size)]
    # where every pulse is counted, each index marks a whole number of revolutions of edges from the
    # first: an index that alone strays (jitter over half a pulse) is left out; two in a row, or edges
    # between kept indexes that are not whole revolutions, are a lost or an extra pulse
    half = pulses // 2
    residue = np.mod(picked - picked[0] + half, pulses) - half
    values, votes = np.unique(residue, return_counts=True)
    kept = residue == values[np.argmax(votes)]
    strays = np.flatnonzero(~kept)
    counts = np.diff(picked[kept])
    if np.any(np.diff(strays) == 1) or np.any(np.mod(counts, pulses) != 0) or np.any(counts == 0):
        k = int(np.flatnonzero(np.diff(picked) != pulses)[0])
        raise SignalError(
            f"encoder: {picked[k + 1] - picked[k]} pulses between the index pulses at t = "
            f"{t[picked[k]]:.6g} s and {t[picked[k + 1]]:.6g} s: expected {pulses} per revolution (a lost "
            "or an extra pulse; check pulses_per_revolution and the index channel)"
        )
    notes = []
    if not kept[0] or not kept[-1]:
        notes.append(
            "encoder: the index at the start or the end of the record disagrees with the others (a pulse "
            "lost or added there, or index jitter): the pulses beyond the next index were dropped"
        )
    picked = picked[kept]
    # only the edges between the first and the last index are checked: the ends outside are dropped
    t = t[picked[0] : picked[-1] + 1]
    picked = picked - picked[0]
    first = int(picked[0])
    offsets = np.arange(t.size) - first
    revolution = np.floor_divide(offsets, pulses)
    tooth = np.mod(offsets, pulses)
    angles = first_pulse_angle + 2 * math.pi * (revolution + tooth / pulses)
    gaps = np.flatnonzero(tooth == 0)
    return ToothWheelDecoding(
        times=t,
        angles=angles,
        tooth_index=tooth.astype(np.int64),
        gap_times=t[gaps],
        teeth=pulses,
        missing=0,
        revolutions=int(max(gaps.size - 1, 0)),
        sensor="encoder",
        notes=tuple(notes),
    )
