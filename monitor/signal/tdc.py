"""Top dead centre from cylinder pressure: checking and finding an angle reference's offset.

An angle reference states the crank angle of its timing point (a tooth
wheel's first tooth after the gap, an encoder's index pulse, a keyphasor
pulse) after TDC of cylinder 1.  A real export rarely says it, and a wrong
value shifts every phase the product reports (by the error times the order).
Cylinder pressure tells where TDC is:

- **Motored** (no combustion: a coast-down, a run with the fuel cut off): the
  compression peak lies just before TDC, by the *thermodynamic loss angle*
  (heat flows to the walls and gas leaks past the rings while the piston is
  near TDC, so the pressure turns down before the volume does).  The loss
  angle is about 0.5 to 1 deg of crank for engines of every size
  (Heywood, *Internal Combustion Engine Fundamentals*, 2nd ed., 2018, on
  TDC determination from motored pressure; measured values of 0.4 to 1.0 deg
  are reported for car and truck engines); the product takes 0.7 deg unless
  told.  TDC is at the peak's angle plus the loss angle.
- **Fired**: the peak follows TDC by the combustion's own timing (about 5 to
  20 deg for diesel engines at load, 10 to 25 deg for spark ignition), so it
  cannot place TDC, but a peak far outside -10 to +45 deg of firing TDC says
  the angle reference's stated angle is wrong.

Each cycle's peak is found on the samples and refined by a parabola through
the largest sample and its two neighbours (in crank angle, through the
angle map).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt

from monitor.errors import SignalError
from monitor.signal.anglemap import AngleMap
from monitor.types import FloatArray

__all__ = ["LOSS_ANGLE", "PLAUSIBLE_FIRED_PEAK", "PressurePeaks", "pressure_peaks"]

LOSS_ANGLE = math.radians(0.7)  # motored compression peak before TDC [rad]
#: Window of crank angle around firing TDC where a fired cylinder's pressure peak can plausibly be [rad].
PLAUSIBLE_FIRED_PEAK = (math.radians(-10.0), math.radians(45.0))


@dataclass(frozen=True)
class PressurePeaks:
    """Where a cylinder's pressure peaks, cycle by cycle, relative to its TDC.

    Attributes
    ----------
    angles : ndarray
        Peak angle of each cycle after the cylinder's TDC as the angle map places it [rad].
    pressures : ndarray
        Peak pressure of each cycle, in the channel's unit.
    """

    angles: FloatArray
    pressures: FloatArray

    @property
    def median(self) -> float:
        """Median peak angle after TDC [rad]."""
        return float(np.median(self.angles))

    @property
    def spread(self) -> float:
        """Half the range between the 16th and 84th percentiles of the peak angles (a robust std) [rad]."""
        low, high = np.percentile(self.angles, [16.0, 84.0])
        return float(0.5 * (high - low))

    def tdc_offset(self, *, loss_angle: float = LOSS_ANGLE) -> float:
        """For a motored recording: how far the map's TDC lies after the true TDC [rad].

        Add it to the angle reference's stated angle (``first_tooth_angle_deg``,
        ``pulse_angle_deg``, ``first_pulse_angle_deg``) to put the map's TDC at the true one.

        Parameters
        ----------
        loss_angle : float, optional
            The thermodynamic loss angle: the motored peak's lead on TDC [rad].

        Returns
        -------
        float
        """
        # the peak sits loss_angle before true TDC: true TDC is at map angle median + loss_angle; a map
        # whose angles grow by d puts it at 0 when d = -(median + loss_angle)
        return -(self.median + loss_angle)


def pressure_peaks(
    angle_map: AngleMap,
    pressure: npt.ArrayLike,
    sample_rate: float,
    *,
    start_time: float = 0.0,
    tdc_angle: float = 0.0,
    period: float = 4 * math.pi,
    window: float = math.radians(90.0),
    max_cycles: int | None = None,
    four_stroke: bool = False,
) -> PressurePeaks:
    """Each cycle's pressure peak near a cylinder's TDC, in crank angle after that TDC.

    Parameters
    ----------
    angle_map : AngleMap
        Crank (cycle) angle against time.
    pressure : array_like
        The cylinder's pressure waveform [Pa, bar or V: any unit].
    sample_rate : float
        [Hz].
    start_time : float, optional
        Time of the first sample [s].
    tdc_angle : float, optional
        The cylinder's (firing) TDC in the map's angle, e.g. its firing angle [rad].
    period : float, optional
        Angle between the TDCs searched: 4 pi (four-stroke firing TDCs, once the cycle phase is
        known), or 2 pi (two-stroke, or every revolution of a motored four-stroke; the lower peaks of
        the gas-exchange TDCs are then dropped, see ``four_stroke``) [rad].
    window : float, optional
        Half-width of the search window around each TDC [rad].
    max_cycles : int, optional
        Search only the first this many TDCs (a quick check of a long recording).
    four_stroke : bool, optional
        With ``period`` 2 pi: the engine is a four-stroke searched every revolution (motored, phase
        unknown); only the revolutions whose peaks stand out (the compressions) are kept.

    Returns
    -------
    PressurePeaks

    Raises
    ------
    SignalError
        With fewer than three TDCs whose windows the recording covers.
    """
    p: Any = (
        pressure if hasattr(pressure, "shape") and hasattr(pressure, "__getitem__") else np.asarray(pressure)
    )
    t0, t1 = float(angle_map.times[0]), float(angle_map.times[-1])
    first_sample = max(0, math.ceil((t0 - start_time) * sample_rate))
    last_sample = min(p.shape[0] - 1, math.floor((t1 - start_time) * sample_rate))
    if last_sample - first_sample < 16:
        raise SignalError("pressure channel: it does not overlap the angle map")
    a0, a1 = float(angle_map.angles[0]), float(angle_map.angles[-1])
    first = math.ceil((a0 + window - tdc_angle) / period)
    last = math.floor((a1 - window - tdc_angle) / period)
    if max_cycles is not None:
        last = min(last, first + max_cycles - 1)
    centres = tdc_angle + period * np.arange(first, last + 1)
    if centres.size < 3:
        raise SignalError(
            f"pressure channel: {centres.size} TDC(s) inside the recording: expected at least 3"
        )
    angles, peaks = [], []
    for centre in centres:
        lo_t, hi_t = angle_map.time_at(np.array([centre - window, centre + window]))
        lo = max(first_sample, math.ceil((lo_t - start_time) * sample_rate))
        hi = min(last_sample, math.floor((hi_t - start_time) * sample_rate))
        if hi - lo < 3:
            continue
        x = np.asarray(p[lo : hi + 1], dtype=np.float64)
        i = int(np.argmax(x))
        i = min(max(i, 1), x.size - 2)
        times = start_time + (lo + i + np.array([-1.0, 0.0, 1.0])) / sample_rate
        theta = angle_map.angle_at(times) - centre
        a, b, _ = np.polyfit(theta, x[i - 1 : i + 2], 2)
        top = -b / (2 * a) if a < 0 else theta[1]
        angles.append(float(np.clip(top, theta[0], theta[2])))
        peaks.append(float(x[i]))
    if len(angles) < 3:
        raise SignalError("pressure channel: fewer than three TDC windows hold samples")
    peak_angles, peak_values = np.asarray(angles), np.asarray(peaks)
    if period < 3 * math.pi and four_stroke:  # every revolution: keep the compression TDCs' higher peaks
        high = peak_values > 0.5 * (np.min(peak_values) + np.max(peak_values))
        if np.count_nonzero(high) < 3:
            raise SignalError(
                f"pressure channel: {np.count_nonzero(high)} compression peak(s) stand out among "
                f"{peak_values.size} revolutions: expected at least 3 (a longer motored run)"
            )
        peak_angles, peak_values = peak_angles[high], peak_values[high]
    return PressurePeaks(peak_angles, peak_values)
