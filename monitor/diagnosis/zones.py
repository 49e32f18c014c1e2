"""Overall vibration velocity against evaluation zones, in the style of ISO 10816-6.

ISO 10816-6 (reciprocating machines above 100 kW, measured on the
non-rotating structure) judges the rms vibration velocity over 2 to 1000 Hz
against zone boundaries: A (new machine), B (unrestricted long-term
operation), C (restricted: plan action), D (damaging).  The standard
assigns the boundaries by machine class from a series of severity grades
(1.1, 1.8, 2.8, 4.5, 7.1, 11, 18, 28, 45, 71 ... mm/s), the class being a
matter of agreement between manufacturer and user.

The product's defaults, :data:`DEFAULT_BOUNDARIES_MM_S`, are three
consecutive grades of that series chosen for large engines measured at main
bearing level.  They are the product's own choice, not values quoted from the
standard: set the boundaries agreed for your machine in the engine file's
``[vibration_limits]`` (see :class:`monitor.model.engine.VibrationLimits`).  Zone C
gives a warning, zone D an alarm.

The rms velocity is estimated from periodograms (Hann window, constant
removed) of :data:`SEGMENTS` segments of at least 2 s spread evenly over the
recording, so its cost does not grow with the recording's length; an
acceleration is integrated in the frequency domain (divided by ``2 pi f``).
The spread of the segments' values gives its standard error.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from monitor.errors import SignalError
from monitor.io.recording import Channel

__all__ = [
    "DEFAULT_BAND_HZ",
    "DEFAULT_BOUNDARIES_MM_S",
    "SEGMENTS",
    "VelocityRms",
    "healthy_zone_notes",
    "limits_named",
    "velocity_rms",
    "zone_of",
]

# each unit a channel may be stored in (monitor.io.recording.UNITS), in SI (m/s^2, m/s)
_TO_SI = {
    ("acceleration", "m/s^2"): 1.0,
    ("acceleration", "mm/s^2"): 1e-3,
    ("acceleration", "g"): 9.80665,
    ("velocity", "m/s"): 1.0,
    ("velocity", "mm/s"): 1e-3,
}
DEFAULT_BOUNDARIES_MM_S = (7.1, 11.0, 18.0)  # A/B, B/C, C/D [mm/s rms], the product's defaults
DEFAULT_BAND_HZ = (2.0, 1000.0)
SEGMENTS = 16


@dataclass(frozen=True)
class VelocityRms:
    """Overall rms vibration velocity of a channel.

    Attributes
    ----------
    value : float
        [mm/s rms] over the band.
    error : float
        Standard error from the segments' spread [mm/s].
    band_hz : tuple of float
        The band evaluated (the upper edge capped below the channel's Nyquist frequency) [Hz].
    segments : int
    """

    value: float
    error: float
    band_hz: tuple[float, float]
    segments: int


def velocity_rms(channel: Channel, band_hz: tuple[float, float] = DEFAULT_BAND_HZ) -> VelocityRms:
    """The rms velocity of an acceleration [m/s^2] or velocity [mm/s] channel over a band.

    Parameters
    ----------
    channel : Channel
        A waveform channel of kind "acceleration" (m/s^2, mm/s^2 or g) or "velocity" (m/s or mm/s).
    band_hz : tuple of float, optional
        [Hz].

    Returns
    -------
    VelocityRms

    Raises
    ------
    SignalError
        For another kind of channel, or one shorter than a segment.
    """
    if channel.kind not in ("acceleration", "velocity") or channel.sample_rate is None:
        raise SignalError(f"channel {channel.name!r} ({channel.kind}): expected an acceleration or velocity")
    to_si = _TO_SI.get((channel.kind, channel.unit))
    if to_si is None:
        known = ", ".join(unit for kind, unit in _TO_SI if kind == channel.kind)
        raise SignalError(
            f"channel {channel.name!r} is in {channel.unit!r}: its rms velocity needs one of {known} "
            "(convert the sensor's volts with its sensitivity first)"
        )
    fs = float(channel.sample_rate)
    low, high = band_hz
    high = min(high, 0.45 * fs)
    length = 2 ** math.ceil(math.log2(max(2.0, 4.0 / low) * fs))  # at least 4 / low seconds, 2 s
    n = int(channel.data.shape[0])
    if n < length:
        length = 2 ** int(math.log2(n)) if n >= 256 else 0
        if length == 0:
            raise SignalError(f"channel {channel.name!r} has {n} samples: too short for its rms velocity")
    count = min(SEGMENTS, max(1, n // length))
    starts = np.linspace(0, n - length, count).astype(np.int64)
    freq = np.fft.rfftfreq(length, 1.0 / fs)
    window = np.hanning(length)
    band = (freq >= low) & (freq <= high)
    scale = 2.0 / (fs * float(np.sum(window**2)))  # one-sided power spectral density
    gain = np.zeros(freq.size)
    if channel.kind == "acceleration":  # to m/s^2, integrated, to mm/s
        gain[band] = (to_si * 1e3 / (2 * math.pi * freq[band])) ** 2
    else:  # to m/s, to mm/s
        gain[band] = (to_si * 1e3) ** 2
    values = np.empty(count)
    for i, start in enumerate(starts):
        x = np.asarray(channel.data[int(start) : int(start) + length], dtype=np.float64)
        x = x - x.mean()
        psd = np.abs(np.fft.rfft(x * window)) ** 2 * scale
        values[i] = math.sqrt(float(np.sum(psd * gain)) * (fs / length))
    error = float(values.std(ddof=1) / math.sqrt(count)) if count > 1 else 0.0
    return VelocityRms(float(np.sqrt(np.mean(values**2))), error, (low, high), count)


def zone_of(value: float, boundaries: tuple[float, float, float]) -> str:
    """The evaluation zone of an rms velocity.

    Parameters
    ----------
    value : float
        rms velocity [mm/s].
    boundaries : tuple of float
        The A/B, B/C and C/D boundaries, increasing [mm/s].

    Returns
    -------
    str
        "A", "B", "C" or "D" (a value on a boundary is in the zone above it).
    """
    for zone, limit in zip("ABC", boundaries, strict=True):
        if value < limit:
            return zone
    return "D"


def limits_named(boundaries: tuple[float, float, float], *, stated: bool) -> str:
    """The zone boundaries in words, saying whose they are.

    Parameters
    ----------
    boundaries : tuple of float
        A/B, B/C, C/D [mm/s].
    stated : bool
        Whether the engine file states them (else they are the product's defaults).

    Returns
    -------
    str
    """
    values = "/".join(f"{b:g}" for b in boundaries)
    if stated:
        return f"the engine file's limits {values} mm/s"
    return f"the product's default limits {values} mm/s (state the agreed ones in [vibration_limits])"


def healthy_zone_notes(
    velocity: dict[str, float], boundaries: tuple[float, float, float], *, stated: bool, label: str
) -> list[str]:
    """A line for each channel of a recording calibrated as healthy that is already in zone C or D.

    The zones are absolute: an engine whose healthy state is in zone C (a structural resonance near
    a running speed, limits not agreed for the machine) is judged against them at every later
    recording, so the calibration says so at once, while the limits or the speed can still be
    reviewed, instead of the first compare raising the zone as a finding.

    Parameters
    ----------
    velocity : dict of str to float
        Each vibration channel's rms velocity [mm/s] (NaN where not known).
    boundaries : tuple of float
        A/B, B/C, C/D [mm/s].
    stated : bool
        Whether the engine file states them.
    label : str
        The recording's name.

    Returns
    -------
    list of str
    """
    notes = []
    for name, value in velocity.items():
        if math.isfinite(value) and (zone := zone_of(value, boundaries)) in ("C", "D"):
            notes.append(
                f"{label}: {name} reads {value:.2f} mm/s rms on this healthy recording, zone {zone} of "
                f"{limits_named(boundaries, stated=stated)}: every recording at this point will be "
                f"{'warned' if zone == 'C' else 'alarmed'} on it; review the limits or the running speed"
            )
    return notes
