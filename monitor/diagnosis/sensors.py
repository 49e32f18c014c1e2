"""Sensor faults: vibration channels that cannot be trusted are findings of their own, and left out.

A clipped, dead or implausibly scaled accelerometer says nothing about the
engine, and analysing it would either stop the diagnosis or mislead it. Each
vibration channel is screened before the analysis:

- **unusable samples**: clipped at its measuring range, NaN or Inf (the
  recording's quality spans, :class:`monitor.io.recording.QualitySpan`);
- **dead**: no spread above a few of its own quantisation steps (a broken
  cable, an unpowered sensor, a channel left at its offset);
- **implausible level**: with a baseline, an rms velocity more than
  :data:`LEVEL_RATIO` times above or below the baseline's while the other
  sensors agree with theirs (a gain or unit error: m/s² read as g is 9.81
  times off); without one, an rms acceleration above
  :data:`MOST_ACCELERATION` m/s² (a main bearing does not shake at 100 g).

A faulty channel becomes a warning on the sensor, and the rest of the
recording is diagnosed without it. Channels a user leaves out
(``--exclude-channel``) are not screened and not analysed.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from monitor.errors import DiagnosisError, FormatError
from monitor.io.recording import Channel, Recording, quality_spans

__all__ = ["LEVEL_RATIO", "MOST_ACCELERATION", "SensorFault", "level_faults", "screen_sensors", "without"]

LEVEL_RATIO = 5.0  # rms velocity further from the baseline's than this factor, the others agreeing [-]
AGREEING = 2.0  # the other sensors within this factor of their baseline rms [-]
MOST_ACCELERATION = 1000.0  # rms acceleration no main bearing reaches [m/s^2]
DEAD_STEPS = 4  # fewer distinct values than this in the channel's samples: dead [-]
_SAMPLES = 1 << 18  # samples looked at for a dead channel, spread over it


@dataclass(frozen=True)
class SensorFault:
    """A vibration channel left out of the diagnosis, and why.

    Attributes
    ----------
    channel : str
    fault : str
        "unusable samples", "dead" or "implausible level".
    detail : str
        What was measured, in a user's words.
    """

    channel: str
    fault: str
    detail: str


def _is_vibration(channel: Channel) -> bool:
    return channel.kind in ("acceleration", "velocity") and not channel.is_events


_BLOCK = 1 << 20  # samples read at a time


@dataclass
class _Look:
    """What one pass over a channel's samples saw."""

    unusable: str | None = None
    values: np.ndarray | None = None  # distinct values seen, up to DEAD_STEPS of them
    count: int = 0
    total: float = 0.0
    squares: float = 0.0

    @property
    def rms(self) -> float:
        if self.count == 0:
            return math.nan
        mean = self.total / self.count
        return math.sqrt(max(self.squares / self.count - mean**2, 0.0))


def _look(channel: Channel) -> _Look:
    """One pass over the channel by contiguous blocks (a channel in a file is read by slices, and a
    block with clipped or non-finite samples is refused there).

    A file's reader fills one reused buffer (``read_into``) and checks each block itself (against the
    channel's range when it is the reader's); samples held in memory are checked here.  Sums are
    taken in float64 whatever the samples' dtype.
    """
    look = _Look()
    if channel.mask is not None:
        look.unusable = _spans(channel)
        return look
    n = int(channel.data.shape[0])
    distinct: np.ndarray = np.empty(0)
    data: Any = channel.data
    reader = hasattr(data, "read_into") and data.dtype in (np.float32, np.float64)
    buffer = np.empty(min(n, _BLOCK), dtype=data.dtype) if reader else None
    rate = float(channel.sample_rate or 1.0)
    for start in range(0, n, _BLOCK):
        try:
            if buffer is not None:
                block = buffer[: min(n, start + _BLOCK) - start]
                data.read_into(start, block)
            else:  # in its own dtype: a float32 sample at a limit stored in float64 is at it to float32's
                block = np.asarray(channel.data[start : min(n, start + _BLOCK)])  # precision, not float64's
        except FormatError as error:  # a file's reader refuses the block
            look.unusable = str(error).split(": ", 1)[-1]
            return look
        spans: list[Any] = []
        if buffer is None or data.limits != channel.range:  # the reader's own check did not judge this range
            spans, _ = quality_spans(
                block, rate, start_offset=channel.start_offset + start / rate, limits=channel.range
            )
        if spans:
            first = spans[0]
            look.unusable = (
                f"{first.reason} samples from {first.start:.3f} s"
                + (
                    f" (range {channel.range[0]:g} to {channel.range[1]:g} {channel.unit})"
                    if channel.range
                    else ""
                )
                + (", and more" if len(spans) > 1 else "")
            )
            return look
        if distinct.size < DEAD_STEPS:
            distinct = np.unique(np.concatenate([distinct, np.unique(block)[: DEAD_STEPS + 1]]))
        look.count += block.size
        look.total += float(np.add.reduce(block, dtype=np.float64))
        look.squares += float(np.einsum("i,i->", block, block, dtype=np.float64, casting="same_kind"))
    look.values = distinct
    return look


def _spans(channel: Channel) -> str:
    spans = channel.quality
    reasons = sorted({q.reason for q in spans}) or ["unusable"]
    masked = 0 if channel.mask is None else int(np.count_nonzero(channel.mask))
    share = masked / max(int(channel.data.shape[0]), 1)
    where = f", the first at {spans[0].start:.3f} s" if spans else ""
    limits = ""
    if channel.range is not None:
        limits = f" (range {channel.range[0]:g} to {channel.range[1]:g} {channel.unit})"
    return f"{', '.join(reasons)} samples in {len(spans)} span(s), {100 * share:.2g} % of them{where}{limits}"


def screen_sensors(
    recording: Recording,
    *,
    exclude: tuple[str, ...] | list[str] = (),
) -> tuple[Recording, list[SensorFault], list[str]]:
    """The recording without its faulty or excluded vibration channels, with the faults found.

    Parameters
    ----------
    recording : Recording
    exclude : sequence of str, optional
        Channel names the user leaves out.

    Returns
    -------
    recording : Recording
        Without the excluded and the faulty vibration channels.
    faults : list of SensorFault
    notes : list of str
        What was left out at the user's request.

    Raises
    ------
    DiagnosisError
        If an excluded channel is not in the recording.
    """
    names = {c.name for c in recording.channels}
    unknown = [name for name in exclude if name not in names]
    if unknown:
        raise DiagnosisError(
            f"--exclude-channel {', '.join(unknown)}: no such channel; the recording has "
            + ", ".join(sorted(names))
        )
    faults: list[SensorFault] = []
    for channel in recording.channels:
        if channel.name in exclude or not _is_vibration(channel):
            continue
        look = _look(channel)
        if look.unusable is not None:
            faults.append(SensorFault(channel.name, "unusable samples", look.unusable))
        elif look.values is not None and look.values.size < DEAD_STEPS:
            shown = ", ".join(f"{v:.4g}" for v in look.values)
            faults.append(
                SensorFault(
                    channel.name,
                    "dead",
                    f"{look.values.size} distinct value(s) in {look.count} samples ({shown} {channel.unit}): "
                    "the sensor or its cable is dead",
                )
            )
        elif channel.kind == "acceleration" and channel.unit == "m/s^2":
            rms = look.rms
            if rms > MOST_ACCELERATION:
                faults.append(
                    SensorFault(
                        channel.name,
                        "implausible level",
                        f"{rms:.4g} m/s^2 rms, more than a main bearing reaches ({MOST_ACCELERATION:g}): "
                        "is the unit or the gain right?",
                    )
                )
    notes = [f"{name}: left out at the user's request" for name in exclude]
    return without(recording, [*exclude, *(f.channel for f in faults)]), faults, notes


def without(recording: Recording, names: list[str] | tuple[str, ...]) -> Recording:
    """The recording without the named channels.

    Parameters
    ----------
    recording : Recording
    names : sequence of str
        Channels to leave out (names not in the recording are ignored).

    Returns
    -------
    Recording
    """
    return replace(recording, channels=tuple(c for c in recording.channels if c.name not in names))


def level_faults(baseline_rms: dict[str, float], measured_rms: dict[str, float]) -> list[SensorFault]:
    """Sensors whose rms velocity left the baseline's by :data:`LEVEL_RATIO` while the others agree.

    Parameters
    ----------
    baseline_rms, measured_rms : dict of str to float
        Each sensor's rms velocity on the baseline and on this recording [mm/s].

    Returns
    -------
    list of SensorFault
    """
    ratios = {
        name: measured_rms[name] / baseline_rms[name]
        for name in measured_rms
        if name in baseline_rms
        and math.isfinite(baseline_rms[name])
        and baseline_rms[name] > 0
        and math.isfinite(measured_rms[name])
        and measured_rms[name] > 0
    }
    out = []
    for name, ratio in ratios.items():
        others = [r for n, r in ratios.items() if n != name]
        if others and (ratio >= LEVEL_RATIO or ratio <= 1 / LEVEL_RATIO):
            if all(1 / AGREEING <= r <= AGREEING for r in others):
                out.append(
                    SensorFault(
                        name,
                        "implausible level",
                        f"rms velocity {ratio:.3g} times the baseline's while the other sensors are "
                        f"within {AGREEING:g} times theirs: a gain or unit error (m/s^2 read as g is "
                        "9.81 times off)?",
                    )
                )
    return out
