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

Tooth-spacing errors (a wheel is never perfect) show as the same deviation
of a tooth's interval in every revolution.  Averaging each tooth's share of
the revolution time over many revolutions estimates them; note that a speed
fluctuation synchronous with the revolution (or, on a four-stroke, with two
revolutions) averages in as well, so the estimate is best taken at steady
running with small fluctuation, or on a coast-down, and applied to other
recordings of the same wheel.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
import numpy.typing as npt

from monitor.signal.pulses import SignalError
from monitor.types import FloatArray

__all__ = ["ToothWheelDecoding", "decode_tooth_wheel", "tooth_spacing_errors"]


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

    Returns
    -------
    ToothWheelDecoding

    Raises
    ------
    SignalError
        Without at least two gaps, or with a revolution that has neither the
        right number of edges nor one too few or too many.
    """
    t = np.asarray(edge_times, dtype=np.float64)
    if teeth < 3 or not 1 <= missing < teeth - 1:
        raise SignalError(f"tooth wheel {teeth}-{missing}: expected teeth >= 3 and 1 <= missing < teeth - 1")
    if t.ndim != 1 or t.size < 2 * teeth or np.any(np.diff(t) <= 0) or not np.all(np.isfinite(t)):
        raise SignalError(
            f"{t.size} edge times: expected at least two revolutions ({2 * teeth}) of finite, "
            "increasing times"
        )
    threshold = missing + 0.5 if gap_ratio is None else gap_ratio
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
            break
        k = int(bad[0])
        start, stop = int(gaps[k]), int(gaps[k + 1])  # edge indices: first tooth after gap k .. after gap k+1
        if counts[k] == per_rev - 1:  # a lost tooth: inside the revolution, or next to one of its gaps
            segment = arr[start : stop + 1]
            ordinary = np.diff(segment)[:-1]  # the last interval is the next gap
            pitch = float(np.median(ordinary))
            after = (arr[stop] - arr[stop - 1]) / pitch
            before = (arr[start] - arr[start - 1]) / pitch
            if ordinary.max() / pitch > 1.5:  # a double interval inside: split it
                i = start + int(np.argmax(ordinary))
                new = 0.5 * (arr[i] + arr[i + 1])
                position = i + 1
            elif after > missing + 1.5:  # the last tooth before the next gap is lost
                new = arr[stop - 1] + pitch
                position = stop
            elif before > missing + 1.5:  # the first tooth after this revolution's gap is lost
                new = arr[start] - pitch
                position = start
            else:
                raise SignalError(
                    f"revolution starting at t = {arr[start]:.6g} s is one tooth short, but neither an "
                    "interval inside it nor its gaps is long enough to show where"
                )
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
    )


def _find_gaps(times: FloatArray, threshold: float) -> npt.NDArray[np.int64]:
    """Indices of the first edge after each gap interval (interval over the running median of 9)."""
    from scipy.ndimage import median_filter

    dt = np.diff(times)
    reference = median_filter(dt, size=min(9, dt.size), mode="nearest")
    return (np.flatnonzero(dt / reference > threshold) + 1).astype(np.int64)


def tooth_spacing_errors(decoding: ToothWheelDecoding) -> FloatArray:
    """Angular position error of each tooth, averaged over the complete revolutions.

    Parameters
    ----------
    decoding : ToothWheelDecoding
        With at least one complete revolution.

    Returns
    -------
    ndarray, shape (teeth - missing,)
        Measured minus nominal angle of each tooth after the gap, with the first
        tooth at 0 and the mean error removed [rad].

    Notes
    -----
    Each tooth's time from the first tooth of its revolution, as a share of
    that revolution's time, averaged over revolutions, times 2 pi.  A speed
    fluctuation synchronous with the revolution enters the estimate too (see
    the module docstring).
    """
    per_rev = decoding.teeth - decoding.missing
    starts = np.flatnonzero(decoding.tooth_index == 0)
    complete = [
        s for s in starts if s + per_rev < decoding.times.size and decoding.tooth_index[s + per_rev] == 0
    ]
    if not complete:
        raise SignalError("tooth spacing needs at least one complete revolution")
    shares = np.array(
        [
            (decoding.times[s : s + per_rev] - decoding.times[s])
            / (decoding.times[s + per_rev] - decoding.times[s])
            for s in complete
        ]
    )
    measured = 2 * math.pi * shares.mean(axis=0)
    nominal = 2 * math.pi * np.arange(per_rev) / decoding.teeth
    error = measured - nominal
    return error - error.mean()
