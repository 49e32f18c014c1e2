"""A four-stroke's cycle phase from a once-per-cycle cam pulse, glitches and stray pulses left out.

A four-stroke's crank angle map knows the revolution, not the cycle: cylinder 1's firing TDC lies at
angle 0 or at 2 pi of it. A cam pulse at a known cycle angle after that TDC tells which: each pulse's
angle on the map, against the stated one, gives a shift of 0 or 2 pi (within 90 deg; the other
half-cycle is 360 deg away). A real capture holds more than the cam's pulses: sub-microsecond
glitches that a logic analyser or an event logger records as pulses, a pulse induced by the ignition,
a tooth of a cam wheel with more than one. Each is a pulse that does not agree: not within 90 deg of
the stated angle, or a second one in a cycle that already has one (the nearer to the stated angle is
kept). The shift is the one most pulses agree on; the others are dropped and counted. A phase is
refused only where the pulses that agree are fewer than :data:`AGREEING` of them all (no consistent
majority), and the refusal names those that disagree.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from monitor.errors import SignalError
from monitor.signal.anglemap import AngleMap
from monitor.types import FloatArray

__all__ = ["AGREEING", "CamPhase", "cycle_phase_from_cam"]

AGREEING = 0.75  # the share of the cam pulses that must agree on one phase for it to be taken [-]
IN_PLACE = math.pi / 2  # a pulse this near the stated angle (or 360 deg from it) agrees with a phase [rad]
_NAMED = 8  # disagreeing pulses named in a message, at most


@dataclass(frozen=True)
class CamPhase:
    """The cycle phase the cam pulses give, and the pulses left out.

    Attributes
    ----------
    shift : float
        0 or 2 pi: added to the map's angles, angle 0 is cylinder 1's firing TDC [rad].
    pulses : int
        The cam pulses inside the map's span [-].
    dropped : ndarray
        The times of those that did not agree (glitches, stray pulses) [s].
    """

    shift: float
    pulses: int
    dropped: FloatArray

    def note(self, channel: str) -> str | None:
        """What a user should know of the pulses left out (None when every pulse agreed)."""
        if self.dropped.size == 0:
            return None
        return (
            f"cam {channel!r}: {self.dropped.size} of {self.pulses} pulses dropped, not once a cycle at the "
            f"stated angle (glitches or stray pulses, at {_times(self.dropped)}): the cycle phase is the "
            f"{self.pulses - self.dropped.size} others'"
        )


def cycle_phase_from_cam(angle_map: AngleMap, cam_times: npt.ArrayLike, *, cam_angle: float) -> CamPhase:
    """The shift (0 or 2 pi) that most once-per-cycle cam pulses at ``cam_angle`` agree on.

    Parameters
    ----------
    angle_map : AngleMap
        Map whose angle 0 (mod 2 pi) is a TDC of cylinder 1.
    cam_times : array_like
        Cam pulse times [s]; those outside the map's span are not used.
    cam_angle : float
        Cycle angle of the cam pulse after cylinder 1's firing TDC, 0..4 pi [rad].

    Returns
    -------
    CamPhase

    Raises
    ------
    SignalError
        Without a cam pulse inside the map's span, or when fewer than :data:`AGREEING` of the pulses
        agree on one phase (the message names those that do not).
    """
    times = np.asarray(cam_times, dtype=np.float64)
    angles = angle_map.angle_at(times)
    inside = np.isfinite(angles)
    times, angles = times[inside], angles[inside]
    if angles.size == 0:
        raise SignalError("cycle phase: no cam pulse inside the mapped span")
    offset = np.mod(cam_angle - angles, 4 * math.pi)  # 0 or 2 pi for a pulse exactly in place
    half = np.round(offset / (2 * math.pi))
    in_place = np.abs(offset - 2 * math.pi * half) < IN_PLACE
    shift_of = np.mod(half, 2).astype(np.int64)  # 0: shift 0, 1: shift 2 pi
    best: tuple[int, npt.NDArray[np.bool_]] | None = None
    for shift in (0, 1):
        agree = _once_a_cycle(angles + 2 * math.pi * shift, cam_angle, in_place & (shift_of == shift))
        if best is None or int(agree.sum()) > int(best[1].sum()):
            best = (shift, agree)
    assert best is not None
    shift, agree = best
    if agree.sum() < AGREEING * angles.size:
        off = times[~agree]
        raise SignalError(
            f"cycle phase: {int(agree.sum())} of {angles.size} cam pulses fall once a cycle at the stated "
            f"angle ({math.degrees(cam_angle):.1f} deg) with one phase, expected at least "
            f"{100 * AGREEING:.0f} %; those that do not: {_times(off)} (their cycle angles "
            f"{_degrees(angles[~agree] + 2 * math.pi * shift)}): check the cam channel and its cam_angle_deg"
        )
    return CamPhase(float(2 * math.pi * shift), int(angles.size), times[~agree])


def _once_a_cycle(
    angles: FloatArray, cam_angle: float, candidate: npt.NDArray[np.bool_]
) -> npt.NDArray[np.bool_]:
    """Of the candidate pulses (cycle angles once shifted), the one nearest ``cam_angle`` in each cycle."""
    cycle = 4 * math.pi
    index = np.floor((angles - cam_angle) / cycle + 0.5)  # the cycle whose stated angle is nearest
    distance = np.abs(angles - cam_angle - cycle * index)
    keep = np.zeros(angles.size, dtype=bool)
    for k in np.unique(index[candidate]):
        members = np.flatnonzero(candidate & (index == k))
        keep[members[np.argmin(distance[members])]] = True
    return keep


def _times(times: FloatArray) -> str:
    """Up to :data:`_NAMED` times, and how many more."""
    shown = ", ".join(f"{t:.6f} s" for t in times[:_NAMED])
    return shown + (f" and {times.size - _NAMED} more" if times.size > _NAMED else "")


def _degrees(angles: FloatArray) -> str:
    """Up to :data:`_NAMED` cycle angles in degrees, 0..720."""
    shown = ", ".join(f"{math.degrees(a) % 720:.1f}" for a in angles[:_NAMED])
    return shown + (" ..." if angles.size > _NAMED else "") + " deg"
