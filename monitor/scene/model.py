"""The scene file: an engine, an operating point, sensors and the effects to simulate.

A scene is a TOML file::

    engine = "man-b-w-7k98mc"          # a bundled engine, or a path relative to the scene file
    duration_s = 20.0
    seed = 1                           # default noise seed (the command line may override it)

    [operating_point]
    speed_rpm = 104.0
    load = 1.0                         # fraction of rated IMEP
    trend = { kind = "ramp", to_rpm = 110.0 }   # or "constant" (default) or "sine"
    load_steps = [{ time_s = 8.0, load = 0.5 }]  # the load from then on (none by default)

    [[sensors]]
    name = "mb3-vertical"
    kind = "acceleration"
    location = "main bearing 3"
    direction = "vertical"

    [[sensors]]
    name = "crank wheel"
    kind = "tooth"                     # 60-2 by default
    signal = "vr"                      # or "pulse" (default), "hall"

    [effects]
    inertia = {}
    gas = {}
    bearing_vibration = {}
    misfire = { cylinders = [4] }

Every table is checked: an unknown field or effect is refused with the list
of the known ones, a value out of range names its field and the range.
Which effects exist, what each needs and gives, is in
:mod:`monitor.scene.effects`; a file is read by :mod:`monitor.scene.loading`.
"""

from __future__ import annotations

import itertools
import math
from pathlib import Path
from typing import Annotated, Any, Literal

from pydantic import BaseModel, ConfigDict, Field, model_validator

__all__ = [
    "PULSE_KINDS",
    "LoadStep",
    "OperatingPoint",
    "Scene",
    "Sensor",
    "Trend",
]


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)


class Trend(_Strict):
    """How the mean crank speed moves over the recording.

    ``constant``: at ``speed_rpm``; ``ramp``: linearly from ``speed_rpm`` to
    ``to_rpm`` (a run-up or run-down); ``sine``: ``speed_rpm (1 + amplitude
    sin(2 pi t / period_s))``.
    """

    kind: Literal["constant", "ramp", "sine"] = "constant"
    to_rpm: Annotated[float, Field(gt=0, le=3000)] | None = None
    amplitude: Annotated[float, Field(ge=0, lt=0.5)] = 0.0
    period_s: Annotated[float, Field(gt=0)] = 60.0

    @model_validator(mode="after")
    def _complete(self) -> Trend:
        if self.kind == "ramp" and self.to_rpm is None:
            raise ValueError("a ramp needs to_rpm, the speed at the end of the recording [rpm]")
        return self


class LoadStep(_Strict):
    """A step of the load inside the recording: from ``time_s`` on, the engine runs at ``load``.

    The gas pressure's heat release (and the charge pressure, by the engine's cycle) changes at
    that time; the mean speed keeps its trend, as a governor holds it (see :mod:`monitor.scene.steps`).
    """

    time_s: Annotated[float, Field(gt=0, description="time of the step from the recording's start [s]")]
    load: Annotated[float, Field(ge=0, le=1.1, description="fraction of rated IMEP from then on")]


class OperatingPoint(_Strict):
    """Mean speed, load, the speed's trend and the load's steps."""

    speed_rpm: Annotated[float, Field(gt=0, le=3000, description="mean crank speed at the start [rpm]")]
    load: Annotated[float, Field(ge=0, le=1.1, description="fraction of rated IMEP")] = 1.0
    trend: Trend = Field(default_factory=Trend)
    load_steps: list[LoadStep] = Field(default_factory=list)

    @model_validator(mode="after")
    def _ordered(self) -> OperatingPoint:
        times = [step.time_s for step in self.load_steps]
        if any(b <= a for a, b in itertools.pairwise(times)):
            raise ValueError(
                f"load_steps: times {', '.join(f'{t:g}' for t in times)} s must increase (one step at a time)"
            )
        return self

    def loads(self) -> list[tuple[float, float]]:
        """The load's epochs: (start time [s], load [-]), the first from 0 at ``load``."""
        return [(0.0, self.load)] + [(step.time_s, step.load) for step in self.load_steps]

    @property
    def top_rpm(self) -> float:
        """The highest mean speed of the trend [rpm]."""
        if self.trend.kind == "ramp" and self.trend.to_rpm is not None:
            return max(self.speed_rpm, self.trend.to_rpm)
        if self.trend.kind == "sine":
            return self.speed_rpm * (1.0 + self.trend.amplitude)
        return self.speed_rpm


_DEFAULT_UNITS = {
    "acceleration": "m/s^2",
    "velocity": "mm/s",
    "keyphasor": "V",
    "tooth": "V",
    "encoder": "V",
    "cam": "V",
    "speed": "rpm",
    "pressure": "bar",
}


#: Sensor kinds that give pulses (a waveform, or their edge times as events).
PULSE_KINDS = ("keyphasor", "tooth", "encoder", "cam")


class Sensor(_Strict):
    """One sensor of the simulated recording (one channel).

    A tooth wheel's ``signal`` is how its sensor shows the teeth: ``pulse`` (flat-bottomed pulses, the
    default), ``hall`` (square pulses timed at the mid level of their rising edge) or ``vr`` (a
    variable-reluctance voltage, zero-mean, growing with speed, timed where it falls through zero at
    each tooth's centre; ``vr_peak_v_at_1000_rpm`` scales it, ``polarity = "reversed"`` swaps its two
    wires). ``unstated`` leaves the ``sensor`` or ``polarity`` attribute out of the recording, as a
    real export that does not state it. An ``encoder`` gives ``pulses_per_revolution`` square pulses,
    the one at ``first_pulse_angle_deg`` nearest its index: a keyphasor sensor of the scene
    (``index_channel``, default the scene's first keyphasor).
    """

    name: Annotated[str, Field(pattern=r"^[A-Za-z0-9][A-Za-z0-9 ._-]*$")]
    kind: Literal["acceleration", "velocity", "keyphasor", "tooth", "encoder", "cam", "pressure"]
    location: str = ""
    direction: Literal["vertical", "horizontal", "axial", ""] = ""
    sample_rate_hz: Annotated[float, Field(gt=0, le=1e6)] = 25600.0
    representation: Literal["waveform", "events"] = "waveform"
    range: tuple[float, float] | None = None
    teeth: Annotated[int, Field(ge=3, le=720)] = 60
    missing_teeth: Annotated[int, Field(ge=1)] = 2
    first_tooth_angle_deg: float = 0.0
    signal: Literal["pulse", "hall", "vr"] = "pulse"
    vr_peak_v_at_1000_rpm: Annotated[float, Field(gt=0, le=1000)] = 10.0
    polarity: Literal["normal", "reversed"] = "normal"
    unstated: list[Literal["sensor", "polarity"]] = Field(default_factory=list)
    pulses_per_revolution: Annotated[int, Field(ge=2, le=100000)] = 360
    first_pulse_angle_deg: float = 0.0
    index_channel: str | None = None
    pulse_angle_deg: float = 0.0
    cam_angle_deg: float = 0.0
    cylinder: Annotated[int, Field(ge=1)] | None = None

    @property
    def unit(self) -> str:
        """The channel's unit."""
        if self.kind in PULSE_KINDS and self.representation == "events":
            return "s"
        return _DEFAULT_UNITS[self.kind]

    @property
    def bearing(self) -> int | None:
        """The main bearing (1-based) named by ``location`` ("main bearing 3"), if any."""
        words = self.location.lower().split()
        if len(words) == 3 and words[:2] == ["main", "bearing"] and words[2].isdigit():
            return int(words[2])
        return None

    @property
    def pulses(self) -> int:
        """Pulse positions per revolution of a tooth wheel (teeth, including the missing) or an encoder."""
        return self.pulses_per_revolution if self.kind == "encoder" else self.teeth

    @model_validator(mode="after")
    def _consistent(self) -> Sensor:
        if self.representation == "events" and self.kind not in PULSE_KINDS:
            raise ValueError(
                f"a {self.kind} sensor is a waveform; events are for keyphasor, tooth, encoder or cam"
            )
        if self.kind == "tooth" and self.missing_teeth >= self.teeth - 1:
            raise ValueError("missing_teeth must be less than teeth - 1")
        if self.kind == "pressure" and self.cylinder is None:
            raise ValueError("a pressure sensor needs the cylinder it is on (cylinder = N)")
        if self.range is not None and not self.range[0] < self.range[1]:
            raise ValueError(f"range {self.range}: expected [minimum, maximum] with minimum < maximum")
        if self.signal != "pulse" and self.kind != "tooth":
            raise ValueError(f"signal = {self.signal!r} is a tooth wheel's; this sensor is a {self.kind}")
        if self.signal != "pulse" and self.representation == "events":
            raise ValueError(
                f"signal = {self.signal!r} shapes a waveform; events are the timing points themselves "
                "(use representation = 'waveform', or leave signal out)"
            )
        if self.polarity == "reversed" and self.signal != "vr":
            raise ValueError("polarity = 'reversed' swaps a VR sensor's wires: it needs signal = 'vr'")
        if self.unstated and self.signal == "pulse":
            raise ValueError(
                "unstated names attributes of a hall or vr tooth wheel (signal = 'hall' or 'vr')"
            )
        if self.index_channel is not None and self.kind != "encoder":
            raise ValueError("index_channel is an encoder's (the keyphasor sensor holding its index)")
        return self


class Scene(_Strict):
    """A whole scene (see the module docstring)."""

    engine: str
    duration_s: Annotated[float, Field(gt=0, le=3600, description="[s]")]
    seed: int = 0
    operating_point: OperatingPoint
    sensors: list[Sensor] = Field(min_length=1)
    effects: dict[str, dict[str, Any]] = Field(default_factory=dict)
    source_dir: Path | None = Field(default=None, exclude=True)

    @model_validator(mode="after")
    def _unique(self) -> Scene:
        late = [step.time_s for step in self.operating_point.load_steps if step.time_s >= self.duration_s]
        if late:
            raise ValueError(
                f"operating_point.load_steps: time_s = {late[0]:g} s is not inside the recording "
                f"(duration_s = {self.duration_s:g} s)"
            )
        names = [s.name for s in self.sensors]
        doubles = sorted({n for n in names if names.count(n) > 1})
        if doubles:
            raise ValueError(f"sensor names must be unique; repeated: {', '.join(doubles)}")
        keyphasors = {s.name: s for s in self.sensors if s.kind == "keyphasor"}
        for sensor in self.sensors:
            if sensor.kind != "encoder":
                continue
            if sensor.index_channel is not None and sensor.index_channel not in keyphasors:
                raise ValueError(
                    f"encoder {sensor.name!r}: index_channel {sensor.index_channel!r} is not a keyphasor "
                    f"sensor of the scene; keyphasors: {', '.join(keyphasors) or 'none'}"
                )
            index = keyphasors.get(sensor.index_channel or next(iter(keyphasors), ""))
            if index is None:
                continue  # an encoder without an index: the product refuses it, as it should
            pitch = 360.0 / sensor.pulses_per_revolution
            if (
                abs(math.remainder(index.pulse_angle_deg - sensor.first_pulse_angle_deg, 360.0))
                > 0.25 * pitch
            ):
                nearest = sensor.first_pulse_angle_deg + pitch * round(
                    math.remainder(index.pulse_angle_deg - sensor.first_pulse_angle_deg, 360.0) / pitch
                )
                raise ValueError(
                    f"encoder {sensor.name!r}: first_pulse_angle_deg = {sensor.first_pulse_angle_deg:g} is "
                    f"the pulse nearest the index, but the index {index.name!r} is at pulse_angle_deg = "
                    f"{index.pulse_angle_deg:g}, more than a quarter pulse ({0.25 * pitch:g} deg) from it: "
                    f"set first_pulse_angle_deg = {nearest:g} or move the index"
                )
        return self
