"""Trigger-wheel patterns: declared by name or position by position, decoded, and read off the edges.

A crank wheel has ``positions`` equally spaced places around it, and a tooth at some of them: a run
of missing teeth (a gap) marks the revolution. The common wheels have one gap (60-2, 36-1, 24-1);
others have several of different lengths, so that an engine controller syncs within part of a
revolution (36-2-1, 36-2-1-1); others have a tooth more, between two places (Honda's 12+1: 12 teeth
30 deg apart and one 10 deg after one of them; its 4+1 cam wheel). A cam wheel's positions are
around the cam, once a cycle: a cam channel that states a ``pattern`` marks the cycle with its
position 0. A name says how many are missing in each gap, not how the teeth between are shared out;
those are taken as engine controllers build them (rusEFI's trigger definitions: 36-2-1 has 16 teeth
after its two-tooth gap and 17 after the one-tooth gap; 36-2-1-1 has 11, 11 and 10).
Any other wheel is declared position by position: ``"36: 0-15, 18-34"`` is 36 positions with
teeth at 0 to 15 and 18 to 34; extra teeth follow a plus, at fractional places: 12+1 is
``"12: 0-11 + 0.333"``. Position 0 is the first tooth after the longest gap (the first of them
when two are as long; on a wheel without a gap, the tooth the extra one follows): its crank angle is
the channel's ``first_tooth_angle_deg``.

Decoding (:func:`decode_pattern`). Each interval between edges is taken in crank angle by the time of
the revolution around it (the ``T`` intervals of the teeth present): ``x_k = 2 pi dt_k / (t_{k+T} -
t_k)``, the speed's own change over a revolution aside. The pattern's intervals are laid on them at
every offset over the first two revolutions; the offset that fits best (least squares in the
logarithm) names each edge's tooth, and every interval must then lie within :data:`FIT` of its
tooth's (a lost or a spurious tooth does not, and the message names where). A pattern whose
intervals repeat within a revolution (two equal gaps half a revolution apart) cannot tell the
revolution's halves apart and is refused.

Reading a wheel off its edges (:func:`infer_pattern`). Against the running median of the intervals
(most are one pitch), an interval of ``m + 1`` pitches follows ``m`` missing teeth. For each number of
gaps a revolution may hold, shortest first: the wheel's longest gap is the longest seen in most of
the revolutions; a revolution runs from one such gap to the next; the revolution most of them show,
teeth and gaps, is the wheel. A lost or a spurious tooth changes the revolution it falls in, not the
others; a revolution that is a shorter one repeated is no wheel (lost teeth broke the shorter one).
It is what :mod:`monitor.signal.toothwheel` reports when a wheel declared with one gap shows another
pattern, and what a channel's ``pattern = "infer"`` decodes with.
"""

from __future__ import annotations

import math
import re
from collections import Counter
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
from scipy.ndimage import median_filter

from monitor.errors import SignalError
from monitor.types import FloatArray

__all__ = ["FIT", "NAMED", "WheelPattern", "decode_pattern", "infer_pattern"]

FIT = 0.3  # an interval further than this (relative) from its tooth's breaks the pattern [-]
#: The share of the revolutions a wheel read off the edges must show: a tooth lost in 3 of 30 still
#: reads it, in 8 nothing is read (tests/signal/test_wheels.py) [-].
_MOST = 0.8


@dataclass(frozen=True)
class WheelPattern:
    """A trigger wheel: its positions and the ones with a tooth.

    Attributes
    ----------
    positions : int
        Equally spaced places around the wheel, missing teeth included [-].
    present : tuple of int
        The places with a tooth, increasing, from 0 (the first tooth after the longest gap).
    name : str
        As declared or found: a name (``"36-2-1"``) or position by position (``"36: 0-15, 18-34"``).
    extra : tuple of float
        Teeth between the places, at fractional places (12+1: one a third of a pitch after place 0).
    """

    positions: int
    present: tuple[int, ...]
    name: str
    extra: tuple[float, ...] = ()

    def __post_init__(self) -> None:
        p = np.asarray(self.present)
        x = np.asarray(self.extra, dtype=np.float64)
        if (
            self.positions < 3
            or p.size < 2
            or p[0] != 0
            or np.any(np.diff(p) <= 0)
            or p[-1] >= self.positions
            or (p.size == self.positions and x.size == 0)
            or np.any((x <= 0) | (x >= self.positions) | np.isclose(x, np.round(x)))
        ):
            raise SignalError(
                f"wheel {self.name!r}: expected at least 3 positions, teeth at increasing positions from "
                f"0 (the first tooth after the longest gap) below {self.positions}, at least one missing "
                "or an extra tooth, and extra teeth between the positions"
            )

    @property
    def teeth(self) -> int:
        """The teeth present, extra ones included [-]."""
        return len(self.present) + len(self.extra)

    @property
    def missing(self) -> int:
        """The positions without a tooth [-]."""
        return self.positions - len(self.present)

    @property
    def places(self) -> FloatArray:
        """Every tooth's place around the wheel, extra ones included, increasing [positions]."""
        return np.sort(np.concatenate([np.asarray(self.present, dtype=np.float64), self.extra]))

    @property
    def pitch(self) -> float:
        """The angle between neighbouring positions [rad]."""
        return 2 * math.pi / self.positions

    @property
    def intervals(self) -> FloatArray:
        """From each tooth to the next, around the wheel, extra teeth included [positions]."""
        p = self.places
        return np.diff(np.append(p, self.positions + p[0]))

    @property
    def gaps(self) -> tuple[int, ...]:
        """The runs of missing teeth, in order from position 0 [-]."""
        p = np.asarray(self.present, dtype=np.int64)
        return tuple(int(n) - 1 for n in np.diff(np.append(p, self.positions + p[0])) if n > 1)

    @property
    def angles(self) -> FloatArray:
        """Each tooth's angle after the first tooth, extra teeth included [rad]."""
        return self.places * self.pitch

    @property
    def spelled(self) -> str:
        """Position by position: ``"36: 0-15, 18-34"``, extra teeth after a plus: ``"12: 0-11 + 0.333"``."""
        runs, start = [], self.present[0]
        for previous, current in zip(self.present, (*self.present[1:], -1), strict=True):
            if current != previous + 1:
                runs.append(f"{start}-{previous}" if previous > start else f"{start}")
                start = current
        extra = (" + " + ", ".join(f"{x:.3f}" for x in self.extra)) if self.extra else ""
        return f"{self.positions}: " + ", ".join(runs) + extra

    def same_as(self, other: WheelPattern) -> bool:
        """Whether two declarations are one wheel (their positions and teeth alike)."""
        if (self.positions, self.present, len(self.extra)) != (
            other.positions,
            other.present,
            len(other.extra),
        ):
            return False
        return bool(np.allclose(np.sort(self.extra), np.sort(other.extra), atol=1e-3))

    @classmethod
    def one_gap(cls, positions: int, missing: int) -> WheelPattern:
        """The wheel of ``positions`` with one gap of ``missing`` teeth (60-2)."""
        if not 1 <= missing < positions - 1:
            raise SignalError(
                f"tooth wheel {positions}-{missing}: expected 1 <= missing teeth < positions - 1"
            )
        return cls(positions, tuple(range(positions - missing)), f"{positions}-{missing}")

    @classmethod
    def parse(cls, text: str) -> WheelPattern:
        """A wheel from its declaration: a name (``"60-2"``, ``"36-2-1"``) or ``"N: a-b, c-d, e"``.

        Raises
        ------
        SignalError
            For text that is neither, naming the forms expected.
        """
        spelled = text.strip()
        if spelled in NAMED:
            return NAMED[spelled]
        one = re.fullmatch(r"(\d+)-(\d+)", spelled)
        if one:
            return cls.one_gap(int(one[1]), int(one[2]))
        listed = re.fullmatch(r"(\d+)\s*:\s*([^+]+?)\s*(?:\+\s*(.+))?", spelled)
        if listed:
            present: list[int] = []
            try:
                extra = tuple(float(x) for x in listed[3].split(",")) if listed[3] else ()
            except ValueError:
                extra = (math.nan,)
            for part in listed[2].split(","):
                bounds = re.fullmatch(r"\s*(\d+)\s*(?:-\s*(\d+))?\s*", part)
                if not bounds:
                    break
                low, high = int(bounds[1]), int(bounds[2] if bounds[2] is not None else bounds[1])
                present.extend(range(low, high + 1))
            else:
                if all(math.isfinite(x) for x in extra):
                    return cls(int(listed[1]), tuple(present), spelled, extra)
        raise SignalError(
            f"wheel pattern {text!r}: expected a name ({', '.join(NAMED)}, or N-M for one gap of M teeth "
            "among N positions) or the positions with a tooth, as '36: 0-15, 18-34', extra teeth between "
            "them after a plus, as '12: 0-11 + 0.333' (a third of a pitch after position 0)"
        )


def _named(name: str, runs: list[tuple[int, int]]) -> WheelPattern:
    """A named wheel from its stretches, from position 0: (teeth, then missing) each."""
    present: list[int] = []
    position = 0
    for teeth, missing in runs:
        present.extend(range(position, position + teeth))
        position += teeth + missing
    return WheelPattern(position, tuple(present), name)


#: Wheels with more than one gap, by the names engine controllers give them (rusEFI's trigger wheels:
#: 36-2-1 is two missing, 16 teeth, one missing, 17 teeth; 36-2-1-1 two missing, 11, one, 11, one, 10).
NAMED: dict[str, WheelPattern] = {
    "36-2-1": _named("36-2-1", [(16, 1), (17, 2)]),
    "36-2-1-1": _named("36-2-1-1", [(11, 1), (11, 1), (10, 2)]),
    # Honda's 12+1 crank wheel as engine controllers describe it: 12 teeth 30 deg apart and one more
    # 10 deg after one of them, which is position 0
    "12+1": WheelPattern(12, tuple(range(12)), "12+1", (1.0 / 3.0,)),
    # Honda's 4+1 cam wheel (K-series exhaust cam), rising edges as rusEFI syncs on them: four teeth
    # 90 cam deg apart and one 27.5 cam deg after one of them (rising at 325.5 and 353 deg), which is
    # position 0; falling edges put it 19.5 deg after: declare "4: 0-3 + 0.217" for those
    "4+1": WheelPattern(4, tuple(range(4)), "4+1", (27.5 / 90.0,)),
}


def decode_pattern(
    edge_times: npt.ArrayLike, pattern: WheelPattern, *, first_tooth_angle: float = 0.0
) -> tuple[FloatArray, FloatArray, npt.NDArray[np.int64]]:
    """Each edge's crank angle on a wheel of the pattern (module docstring).

    Parameters
    ----------
    edge_times : array_like
        One edge per tooth, increasing [s]; at least two revolutions.
    pattern : WheelPattern
    first_tooth_angle : float, optional
        Crank angle of the pattern's position 0, from TDC of cylinder 1 [rad].

    Returns
    -------
    times : ndarray
        The edges from the first whose tooth is known [s].
    angles : ndarray
        Their crank angles, increasing [rad].
    tooth : ndarray of int
        Each edge's tooth: its index among the teeth present, 0 at position 0.

    Raises
    ------
    SignalError
        For fewer than two revolutions' edges, a pattern that repeats within a revolution, or an
        interval that does not fit its tooth's (a lost or a spurious tooth: the message gives when).
    """
    t = np.asarray(edge_times, dtype=np.float64)
    n_teeth = pattern.teeth
    if t.ndim != 1 or t.size < 2 * n_teeth + 1 or np.any(np.diff(t) <= 0):
        raise SignalError(
            f"{t.size} edge times: expected at least two revolutions ({2 * n_teeth + 1}) of increasing "
            f"times for wheel {pattern.name}"
        )
    expected = pattern.intervals * pattern.pitch  # [rad], from each tooth to the next
    if any(np.array_equal(expected, np.roll(expected, s)) for s in range(1, n_teeth)):
        raise SignalError(
            f"wheel {pattern.name}: its gaps repeat within a revolution, so its edges cannot tell which "
            "part of the revolution they are in; use the cam or a wheel with one longest gap"
        )
    measured = _in_angle(t, n_teeth)
    logs = np.log(measured[: 2 * n_teeth])  # synced on the first two revolutions, then checked throughout
    cost = [
        float(np.sum((logs - np.log(np.resize(np.roll(expected, -offset), logs.size))) ** 2))
        for offset in range(n_teeth)
    ]
    offset = int(np.argmin(cost))
    tooth = (np.arange(t.size) + offset) % n_teeth
    misfit = np.abs(measured / expected[tooth[:-1]] - 1.0)
    if np.any(misfit > FIT):
        k = int(np.flatnonzero(misfit > FIT)[0])
        raise SignalError(
            f"wheel {pattern.name}: the interval from t = {t[k]:.6g} s is {measured[k] / pattern.pitch:.2f} "
            f"pitches where the pattern has {expected[tooth[k]] / pattern.pitch:.3g} (a tooth lost or a "
            "spurious pulse there)"
        )
    # revolutions counted as on a wheel of one gap (monitor.signal.toothwheel): revolution 0 from the
    # first position 0 the edges show an interval before, the edges before it in revolution -1, so that
    # a cycle phase stated against the map means the same on any wheel
    zero = (n_teeth - offset) % n_teeth or n_teeth
    revolution = np.floor_divide(np.arange(t.size) - zero, n_teeth)
    angles = first_tooth_angle + 2 * math.pi * revolution + pattern.angles[tooth]
    return t, angles, tooth.astype(np.int64)


def _in_angle(t: FloatArray, n_teeth: int) -> FloatArray:
    """Each interval in crank angle: over the time of the revolution centred on it [rad]."""
    dt = np.diff(t)
    revolution = t[n_teeth:] - t[:-n_teeth]  # from edge k to edge k + n_teeth: one revolution
    centre = np.clip(np.arange(dt.size) - n_teeth // 2, 0, revolution.size - 1)
    return 2 * math.pi * dt / revolution[centre]


def infer_pattern(edge_times: npt.ArrayLike) -> WheelPattern | None:
    """The wheel the edges show, where most of their revolutions agree (module docstring).

    Parameters
    ----------
    edge_times : array_like
        One edge per tooth, increasing [s].

    Returns
    -------
    WheelPattern or None
        Named when a known name fits (``"60-2"``, ``"36-2-1"``), else position by position; None
        when the edges show no gap, teeth between the pitches (an extra tooth), or no pattern that
        repeats in most of three revolutions or more.
    """
    t = np.asarray(edge_times, dtype=np.float64)
    if t.ndim != 1 or t.size < 16 or np.any(np.diff(t) <= 0):
        return None
    dt = np.diff(t)
    pitches = dt / median_filter(dt, size=min(15, dt.size), mode="mirror")
    if np.any(pitches < 0.6):
        return None
    long = np.flatnonzero(pitches > 1.5)
    if long.size < 3:
        return None
    missing = np.rint(pitches[long]).astype(np.int64) - 1
    apart = np.diff(long)  # edges from one gap to the next
    shape = [(int(a), int(m)) for a, m in zip(apart, missing[1:], strict=True)]
    for period in range(1, long.size // 3 + 1):
        if len(shape) < 2 * period:
            break
        # one revolution from just after its longest gap: the edges from each gap to the next and the size
        # of the next, as most revolutions show it (a lost or a spurious tooth changes the revolution it
        # is in, not the others), and a wheel only where they hold in most
        # the wheel's longest gap comes once a revolution: the longest seen in most of them
        sizes = Counter(m for _, m in shape)
        once = [m for m, n in sizes.items() if n >= _MOST * len(shape) / period]
        if not once:
            continue
        longest = max(once)
        after_longest = Counter(
            tuple(shape[i : i + period])
            for i in range(len(shape) - period + 1)
            if missing[i] == shape[i + period - 1][1] == longest
            and all(m <= longest for _, m in shape[i : i + period])
        )
        if not after_longest:
            continue
        revolution, count = after_longest.most_common(1)[0]
        if count < max(_MOST * len(shape) / period, 3):
            continue  # not what most revolutions show
        if any(revolution == revolution[k:] + revolution[:k] for k in range(1, period)):
            continue  # a shorter wheel again and again: lost or spurious teeth broke its revolutions
        present: list[int] = []
        position = 0
        for teeth, gap in revolution:
            present.extend(range(position, position + teeth))
            position += teeth + gap
        try:
            return _with_name(WheelPattern(position, tuple(present), ""))
        except SignalError:
            continue  # no wheel (fewer than three positions): a stretch of spurious pulses
    return None


def _with_name(found: WheelPattern) -> WheelPattern:
    """The pattern under its name where one fits, else spelled position by position."""
    for name, known in NAMED.items():
        if known.same_as(found):
            return WheelPattern(found.positions, found.present, name)
    if len(found.gaps) == 1:
        return WheelPattern(found.positions, found.present, f"{found.positions}-{found.missing}")
    return WheelPattern(found.positions, found.present, found.spelled)
