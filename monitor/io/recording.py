"""Recordings: channels of a data acquisition, validated, with their data-quality report.

A recording holds the channels one acquisition produced on one engine:
accelerometers on main bearings, a keyphasor, a crank-speed tooth wheel, a
cam pulse, cylinder pressure.  A channel is either a waveform (samples at a
fixed rate from a start offset) or an event channel (edge times, for pulse
channels recorded by a counter).  Everything a later stage needs to know
about a channel is an attribute of it, validated here once: its kind and
unit, its sensor location and direction, and the fields of its kind (a
tooth wheel's tooth count, missing teeth and the crank angle of its first
tooth after the gap and its sensor kind; an encoder's pulses per
revolution; a keyphasor pulse's angle after TDC of cylinder 1; the cylinder
of a pressure channel).

Data quality.  NaN and Inf samples, and clipped spans (runs of samples at
the limits of the channel's stated measuring range), are found, reported
with their spans in time and masked: the mask travels with the channel, and nothing
downstream averages them in silently.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field
from datetime import datetime
from typing import Any, Literal

import numpy as np
import numpy.typing as npt

from monitor.errors import FormatError
from monitor.io.plausible import rate_problem, start_problem, time_problem
from monitor.names import name_problem
from monitor.types import FloatArray

__all__ = [
    "INFER_PATTERN",
    "INTEGER_FIELDS",
    "KINDS",
    "UNITS",
    "WORD_FIELDS",
    "Channel",
    "QualitySpan",
    "Recording",
    "SampleReader",
    "field_value",
    "quality_spans",
    "refuse_unusable",
]

Kind = Literal["acceleration", "velocity", "keyphasor", "tooth", "encoder", "cam", "speed", "pressure"]

KINDS: tuple[str, ...] = (
    "acceleration",
    "velocity",
    "keyphasor",
    "tooth",
    "encoder",
    "cam",
    "speed",
    "pressure",
)
#: Units accepted per kind (the unit of the stored samples; event channels store times in s).
UNITS: dict[str, tuple[str, ...]] = {
    "acceleration": ("m/s^2", "g", "mm/s^2", "V"),
    "velocity": ("m/s", "mm/s", "V"),
    "keyphasor": ("V", "s"),
    "tooth": ("V", "s"),
    "encoder": ("V", "s"),
    "cam": ("V", "s"),
    "speed": ("rpm", "rad/s", "Hz", "V"),
    "pressure": ("Pa", "kPa", "bar", "MPa", "V"),
}
#: Kind-specific attributes and whether each is required.
KIND_FIELDS: dict[str, dict[str, bool]] = {
    "tooth": {
        "teeth": True,
        "missing_teeth": True,
        "first_tooth_angle_deg": True,
        "sensor": False,
        "polarity": False,
        "pattern": False,
    },
    "encoder": {"pulses_per_revolution": True, "first_pulse_angle_deg": True, "index_channel": False},
    "keyphasor": {"pulse_angle_deg": True},
    "cam": {"cam_angle_deg": True, "pattern": False},
    "pressure": {"cylinder": True},
}
#: A tooth channel's ``pattern`` that has the wheel read off its edges (its teeth then not stated).
INFER_PATTERN = "infer"
#: Kind-specific attributes that are integers, and those that are one of a few words (any other is a float).
INTEGER_FIELDS: tuple[str, ...] = ("teeth", "missing_teeth", "cylinder", "pulses_per_revolution")
WORD_FIELDS: dict[str, tuple[str, ...] | None] = {
    "sensor": ("hall", "vr"),
    "polarity": ("normal", "reversed"),
    "index_channel": None,  # a channel's name
    "pattern": None,  # a wheel of several gaps or teeth: a name or its positions (monitor.signal.wheels)
}
#: The most tooth positions a crank tooth wheel has here (one per 0.1 deg), and the most pulses per
#: revolution of an encoder (2**20, a 20-bit one): beyond them a stated count is a mistake.
MAX_TEETH = 3600
MAX_PULSES = 2**20
#: The shortest run of equal extreme samples reported as clipping.
CLIP_RUN = 5


def field_value(channel: str, key: str, raw: Any) -> float | int | str:
    """A kind-specific attribute as stored (number, or text in MCAP metadata), in its type.

    Parameters
    ----------
    channel : str
        The channel's name, for the message.
    key : str
        The attribute (:data:`KIND_FIELDS`).
    raw : object
        Its stored value.

    Returns
    -------
    int, float or str

    Raises
    ------
    FormatError
        If the value is not of the attribute's type, or not one of its words.
    """
    where = f"channel {channel!r}: attribute {key!r} = {raw!r}"
    if isinstance(raw, bytes):
        raw = raw.decode("utf-8", "replace")
    if key in WORD_FIELDS:
        words = WORD_FIELDS[key]
        text = str(raw)
        if words is not None and text not in words:
            raise FormatError(f"{where}: expected one of {', '.join(words)}")
        return text
    try:
        number = float(raw)
    except (TypeError, ValueError):
        raise FormatError(f"{where}: expected a number") from None
    if key in INTEGER_FIELDS:
        if not (math.isfinite(number) and number == int(number)):
            raise FormatError(f"{where}: expected a whole number")
        return int(number)
    if not math.isfinite(number):
        raise FormatError(f"{where}: expected a finite number")
    return number


@dataclass(frozen=True)
class QualitySpan:
    """A span of unusable samples.

    Attributes
    ----------
    start, stop : float
        Times of the first and the last sample of the span [s].
    samples : int
    reason : {"nan", "inf", "clipped"}
    """

    start: float
    stop: float
    samples: int
    reason: str


@dataclass(frozen=True)
class Channel:
    """One channel of a recording.

    Attributes
    ----------
    name : str
        Unique in the recording (also the HDF5 dataset and the MCAP topic suffix).
    kind : str
        One of :data:`KINDS`.
    unit : str
        Unit of ``data`` (one of :data:`UNITS` for the kind; "s" for event times).
    data : ndarray
        Samples (waveform), or event times [s] (event channel). A channel opened
        in a file (:func:`monitor.io.hdf5.open_hdf5`) holds a reader by slices instead.
    sample_rate : float or None
        [Hz]; None for an event channel.
    start_offset : float
        Time of the first sample after the recording's start [s].
    location : str
        Sensor location, e.g. "main bearing 3", "free end".
    direction : str
        e.g. "vertical", "horizontal", "axial", or "".
    fields : dict
        Kind-specific attributes (:data:`KIND_FIELDS`).
    mask : ndarray of bool or None
        True where a sample is unusable (see ``quality``); None if none is.
    quality : tuple of QualitySpan
    range : (float, float) or None
        The sensor's (or the acquisition's) measuring range, in the channel's unit:
        samples at its limits for several samples in a row are clipped. Without
        it clipping cannot be told from a flat peak and is not judged.
    """

    name: str
    kind: str
    unit: str
    data: np.ndarray
    sample_rate: float | None
    start_offset: float = 0.0
    location: str = ""
    direction: str = ""
    fields: dict[str, float | int | str] = field(default_factory=dict)
    mask: np.ndarray | None = None
    quality: tuple[QualitySpan, ...] = ()
    range: tuple[float, float] | None = None

    def __post_init__(self) -> None:
        where = f"channel {self.name!r}"
        problem = name_problem(self.name, path_step=True)
        if problem is not None:
            raise FormatError(
                f"channel {self.name[:40]!r}: name: {problem}; expected 1 to 200 printable characters "
                "without '/'"
            )
        if self.kind not in KINDS:
            raise FormatError(f"{where}: kind {self.kind!r} is unknown; expected one of {', '.join(KINDS)}")
        if self.unit not in UNITS[self.kind]:
            raise FormatError(
                f"{where}: unit {self.unit!r} is unknown for a {self.kind} channel; "
                f"expected one of {', '.join(UNITS[self.kind])}"
            )
        if self.data.ndim != 1:
            raise FormatError(f"{where}: data has shape {self.data.shape}, expected one dimension")
        if np.dtype(self.data.dtype).kind != "f":
            raise FormatError(
                f"{where}: samples of type {np.dtype(self.data.dtype)}; expected float32 or float64 "
                "(integer ADC counts scaled to the channel's unit first)"
            )
        if self.is_events:
            if self.unit != "s":
                raise FormatError(
                    f"{where}: an event channel stores times; expected unit 's', got {self.unit!r}"
                )
            if self.data.size and (not np.all(np.isfinite(self.data)) or np.any(np.diff(self.data) <= 0)):
                raise FormatError(f"{where}: event times must be finite and increasing")
            if self.data.size and isinstance(self.data, np.ndarray):
                for time in (float(self.data[0]), float(self.data[-1])):  # increasing: the ends bound them
                    problem = time_problem(time)
                    if problem is not None:
                        raise FormatError(f"{where}: an event at {time!r} s: {problem}")
        else:
            rate = self.sample_rate
            problem = "expected a positive rate in Hz" if rate is None else rate_problem(rate)
            if problem is not None:
                raise FormatError(f"{where}: sample_rate_hz = {rate!r}: {problem}")
            if self.unit == "s":
                raise FormatError(f"{where}: unit 's' is for event channels (edge times), not waveforms")
        if self.range is not None and not (
            len(self.range) == 2
            and all(math.isfinite(v) for v in self.range)
            and self.range[0] < self.range[1]
        ):
            raise FormatError(
                f"{where}: range {self.range!r}: expected (minimum, maximum) with minimum < maximum"
            )
        problem = time_problem(self.start_offset)
        if problem is not None:
            raise FormatError(f"{where}: start_offset_s = {self.start_offset!r}: {problem}")
        read_off = self.kind == "tooth" and self.fields.get("pattern") == INFER_PATTERN
        for name, required in KIND_FIELDS.get(self.kind, {}).items():
            if read_off and name in ("teeth", "missing_teeth"):
                if name in self.fields:
                    raise FormatError(
                        f"{where}: {name} = {self.fields[name]!r} with pattern = {INFER_PATTERN!r}: state "
                        "the wheel (teeth, missing_teeth, pattern) or have it read off its edges, not both"
                    )
                continue
            if required and name not in self.fields:
                raise FormatError(f"{where}: a {self.kind} channel needs the attribute {name!r}")
        for name, value in self.fields.items():
            words = WORD_FIELDS.get(name)
            if words is not None and value not in words:
                raise FormatError(
                    f"{where}: attribute {name!r} = {value!r}: expected one of {', '.join(words)}"
                )
        if self.kind == "encoder":
            pulses = self.fields["pulses_per_revolution"]
            if not (isinstance(pulses, int | np.integer) and 2 <= pulses <= MAX_PULSES):
                raise FormatError(
                    f"{where}: pulses_per_revolution = {pulses!r}: expected an integer from 2 to {MAX_PULSES}"
                )
        if self.kind == "tooth" and not read_off:
            teeth, missing = self.fields["teeth"], self.fields["missing_teeth"]
            # a wheel with an extra tooth and no gap (12+1) states its pattern, and no tooth missing
            fewest = 0 if "pattern" in self.fields else 1
            if not (
                isinstance(teeth, int | np.integer)
                and isinstance(missing, int | np.integer)
                and 3 <= teeth <= MAX_TEETH
                and fewest <= missing < teeth - 1
            ):
                raise FormatError(
                    f"{where}: teeth = {teeth!r}, missing_teeth = {missing!r}: expected integers, "
                    f"3 <= teeth <= {MAX_TEETH} and {fewest} <= missing_teeth < teeth - 1"
                    + (" (0 only for a wheel whose pattern has an extra tooth)" if fewest else "")
                )

    @property
    def is_events(self) -> bool:
        """True for an event channel (edge times instead of samples)."""
        return self.sample_rate is None

    @property
    def duration(self) -> float:
        """Time covered by the samples [s] (event channels: first to last event)."""
        if self.is_events:
            return float(self.data[-1] - self.data[0]) if self.data.size > 1 else 0.0
        return self.data.size / float(self.sample_rate)  # type: ignore[arg-type]

    def times(self) -> FloatArray:
        """Time of every sample from the recording's start [s] (events: the event times)."""
        if self.is_events:
            return np.asarray(self.data, dtype=np.float64)
        return self.start_offset + np.arange(self.data.size) / float(self.sample_rate)  # type: ignore[arg-type]

    def checked(self) -> Channel:
        """This channel with its data-quality spans found and masked (see :func:`quality_spans`).

        Pulse channels (keyphasor, tooth, cam) are not judged for clipping: a
        logic-level pulse sits at its rails by design.
        """
        if self.is_events or self.sample_rate is None or not isinstance(self.data, np.ndarray):
            return self  # samples read by slices are checked as they are read
        limits = None if self.kind in ("keyphasor", "tooth", "cam") else self.range
        spans, mask = quality_spans(
            self.data, self.sample_rate, start_offset=self.start_offset, limits=limits
        )
        return dataclasses.replace(self, mask=mask if mask.any() else None, quality=tuple(spans))


def quality_spans(
    data: npt.ArrayLike,
    sample_rate: float,
    *,
    start_offset: float = 0.0,
    limits: tuple[float, float] | None = None,
    clip_run: int = CLIP_RUN,
) -> tuple[list[QualitySpan], npt.NDArray[np.bool_]]:
    """NaN, Inf and clipped spans of a waveform, and the mask of those samples.

    Parameters
    ----------
    data : array_like, shape (n,)
        Samples [the channel's unit].
    sample_rate : float
        [Hz].
    start_offset : float, optional
        Time of the first sample [s].
    limits : (float, float), optional
        The measuring range [the channel's unit]; runs of samples at or beyond a
        limit are clipped. Without limits, clipping is not judged (a quantised
        peak or a flat pulse top is not clipping).
    clip_run : int, optional
        Shortest run of samples at a limit reported as clipped.

    Returns
    -------
    spans : list of QualitySpan
    mask : ndarray of bool
        True at every sample in a span.
    """
    x = np.asarray(data)
    mask = np.zeros(x.size, dtype=bool)
    spans: list[QualitySpan] = []
    if limits is not None:  # a sample stored at a limit (in float32, say) counts as at it
        slack = 4 * float(np.finfo(x.dtype if x.dtype.kind == "f" else np.float64).eps)
        slack *= max(abs(limits[0]), abs(limits[1]))
        limits = (limits[0] + slack, limits[1] - slack)
    if x.size:  # the common case, clean samples inside the range, in two passes (NaN propagates)
        lo, hi = float(np.min(x)), float(np.max(x))
        if math.isfinite(lo) and math.isfinite(hi) and (limits is None or limits[0] < lo <= hi < limits[1]):
            return spans, mask

    def runs(flags: npt.NDArray[np.bool_], reason: str, minimum: int = 1) -> None:
        if not flags.any():
            return
        edges = np.diff(np.concatenate([[0], flags.astype(np.int8), [0]]))
        starts, stops = np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)
        for a, b in zip(starts, stops, strict=True):
            if b - a >= minimum:
                mask[a:b] = True
                spans.append(
                    QualitySpan(
                        start_offset + a / sample_rate,
                        start_offset + (b - 1) / sample_rate,
                        int(b - a),
                        reason,
                    )
                )

    runs(np.isnan(x), "nan")
    runs(np.isinf(x), "inf")
    finite = np.isfinite(x)
    if limits is not None and finite.any():
        runs(finite & (x >= limits[1]), "clipped", clip_run)
        runs(finite & (x <= limits[0]), "clipped", clip_run)
    spans.sort(key=lambda s: s.start)
    return spans, mask


def refuse_unusable(
    where: str,
    block: npt.ArrayLike,
    sample_rate: float,
    *,
    start_offset: float = 0.0,
    limits: tuple[float, float] | None = None,
) -> None:
    """Refuse a slice of a channel read from a file that holds NaN, Inf or clipped samples.

    Parameters
    ----------
    where : str
        The file and channel, for the message.
    block : array_like
        The samples read [the channel's unit].
    sample_rate : float
        [Hz].
    start_offset : float, optional
        Time of the slice's first sample [s].
    limits : (float, float), optional
        The measuring range [the channel's unit] (None: clipping not judged).

    Raises
    ------
    FormatError
        Naming the first unusable span and its time.
    """
    spans, _ = quality_spans(block, sample_rate, start_offset=start_offset, limits=limits)
    if spans:
        first = spans[0]
        raise FormatError(
            f"{where}: unusable samples ({first.reason} {first.start:.3f}-{first.stop:.3f} s"
            f"{', and more' if len(spans) > 1 else ''}): cut them out before analysing the channel"
        )


class SampleReader:
    """A waveform channel's samples in a file, read by contiguous slices and checked as they are read.

    The array-like face the pipeline uses (``shape``, ``size``, ``dtype``,
    slicing, conversion to a whole array); every slice read is refused if it
    holds NaN, Inf or clipped samples (:func:`refuse_unusable`). Subclasses
    read the samples in :meth:`_read`.

    Parameters
    ----------
    where : str
        The file and channel, for messages.
    size : int
        Samples in the channel.
    dtype : numpy dtype
        Their type.
    sample_rate : float
        [Hz].
    start_offset : float
        Time of the first sample [s].
    limits : (float, float) or None
        Measuring range for the clipping check [the channel's unit]; None: not judged.
    """

    def __init__(
        self,
        where: str,
        size: int,
        dtype: Any,
        sample_rate: float,
        start_offset: float,
        limits: tuple[float, float] | None,
    ) -> None:
        self._where = where
        self._size = int(size)
        self._dtype = np.dtype(dtype)
        self._rate = sample_rate
        self._offset = start_offset
        self._limits = limits

    @property
    def shape(self) -> tuple[int, ...]:
        return (self._size,)

    @property
    def ndim(self) -> int:
        return 1

    @property
    def size(self) -> int:
        return self._size

    @property
    def dtype(self) -> np.dtype[Any]:
        return self._dtype

    @property
    def limits(self) -> tuple[float, float] | None:
        """The measuring range every read is checked against for clipping (None: not judged)."""
        return self._limits

    def __len__(self) -> int:
        return self._size

    def __getitem__(self, index: slice) -> np.ndarray:
        if not isinstance(index, slice) or index.step not in (None, 1):
            raise TypeError(f"{self._where}: samples are read by contiguous slices")
        start, stop, _ = index.indices(self._size)
        block = self._read(start, max(start, stop))
        self._check(block, start)
        return block

    def read_into(self, start: int, out: np.ndarray) -> None:
        """Samples ``start`` to ``start + out.size`` into ``out`` (a reused buffer), checked as a slice is.

        Parameters
        ----------
        start : int
            The first sample's index.
        out : ndarray
            Of the channel's dtype, filled whole.

        Raises
        ------
        FormatError
            For a span past the channel's end, or unusable samples.
        """
        stop = start + out.size
        if not 0 <= start <= stop <= self._size:
            raise FormatError(f"{self._where}: samples {start} to {stop} asked, the channel has {self._size}")
        self._read_into(start, out)
        self._check(out, start)

    def _check(self, block: np.ndarray, start: int) -> None:
        """Refuse the samples read from ``start`` on if any is unusable (:func:`refuse_unusable`)."""
        refuse_unusable(
            self._where,
            block,
            self._rate,
            start_offset=self._offset + start / self._rate,
            limits=self._limits,
        )

    def _read(self, start: int, stop: int) -> np.ndarray:
        raise NotImplementedError

    def _read_into(self, start: int, out: np.ndarray) -> None:
        out[:] = self._read(start, start + out.size)

    def __array__(self, dtype: Any = None, copy: Any = None) -> np.ndarray:
        whole = self[:]
        return whole if dtype is None else whole.astype(dtype)


@dataclass(frozen=True)
class Recording:
    """A validated recording.

    Attributes
    ----------
    engine_id : str
        The engine description it belongs to.
    start_time : str
        UTC start, ISO 8601 (``2026-11-22T10:15:00Z``).
    channels : tuple of Channel
    notes : str
    truncated : bool
        True if the file ended early and was read up to its last whole block.
    truth : str
        For a simulated recording, what the simulation put into it (JSON; see
        :mod:`monitor.scene`); "" for a measured one.
    cycle_phase_deg : float or None
        Four-stroke: which revolution of the angle reference holds cylinder 1's firing TDC, as the
        degrees (0 or 360) added to its crank angle, where the acquisition knew it; None if not stated.
    """

    engine_id: str
    start_time: str
    channels: tuple[Channel, ...]
    notes: str = ""
    truncated: bool = False
    truth: str = ""
    cycle_phase_deg: float | None = None

    def __post_init__(self) -> None:
        if not self.engine_id:
            raise FormatError("recording: engine_id is empty; expected the id of an engine description")
        problem = name_problem(self.engine_id)
        if problem is not None:
            raise FormatError(
                f"recording: engine_id {self.engine_id[:40]!r}: {problem}; expected the id of an engine "
                "description, 1 to 200 printable characters"
            )
        try:
            parsed = datetime.fromisoformat(self.start_time.replace("Z", "+00:00"))
        except ValueError:
            raise FormatError(
                f"recording: start_time {self.start_time!r} is not ISO 8601 "
                "(expected e.g. 2026-11-22T10:15:00Z)"
            ) from None
        if parsed.utcoffset() is None or parsed.utcoffset().total_seconds() != 0:  # type: ignore[union-attr]
            raise FormatError(f"recording: start_time {self.start_time!r} must be in UTC (end it with Z)")
        problem = start_problem(parsed)
        if problem is not None:
            raise FormatError(f"recording: start_time {self.start_time!r}: {problem}")
        if self.cycle_phase_deg is not None and self.cycle_phase_deg not in (0.0, 360.0):
            raise FormatError(
                f"recording: cycle_phase_deg = {self.cycle_phase_deg!r}: expected 0 or 360 (degrees)"
            )
        names = [c.name for c in self.channels]
        if len(set(names)) != len(names):
            raise FormatError(
                f"recording: channel names repeat: {sorted(n for n in names if names.count(n) > 1)}"
            )

    def channel(self, name: str) -> Channel:
        """The channel called ``name``."""
        for c in self.channels:
            if c.name == name:
                return c
        raise FormatError(f"no channel {name!r}; channels: {', '.join(c.name for c in self.channels)}")

    def of_kind(self, kind: str) -> list[Channel]:
        """The channels of one kind, in order."""
        return [c for c in self.channels if c.kind == kind]
