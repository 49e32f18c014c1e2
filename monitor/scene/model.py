"""The scene file: an engine, an operating point, sensors and the effects to simulate.

A scene is a TOML file::

    engine = "man-b-w-7k98mc"          # a bundled engine, or a path relative to the scene file
    duration_s = 20.0
    seed = 1                           # default noise seed (the command line may override it)

    [operating_point]
    speed_rpm = 104.0
    load = 1.0                         # fraction of rated IMEP
    trend = { kind = "ramp", to_rpm = 110.0 }   # or "constant" (default) or "sine"

    [[sensors]]
    name = "mb3-vertical"
    kind = "acceleration"
    location = "main bearing 3"
    direction = "vertical"

    [effects]
    inertia = {}
    gas = {}
    bearing_vibration = {}
    misfire = { cylinders = [4] }

Every table is checked: an unknown field or effect is refused with the list
of the known ones, a value out of range names its field and the range.
Which effects exist, what each needs and gives, is in
:mod:`monitor.scene.effects`.
"""

from __future__ import annotations

import tomllib
from pathlib import Path
from typing import Annotated, Any, Literal

from pydantic import BaseModel, ConfigDict, Field, ValidationError, model_validator

from monitor.errors import ModelError

__all__ = ["OperatingPoint", "Scene", "SceneError", "Sensor", "Trend", "load_scene", "parse_scene"]


class SceneError(ModelError):
    """A scene that cannot be simulated as written (names what is wrong and what is expected)."""


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


class OperatingPoint(_Strict):
    """Mean speed, load and the speed's trend."""

    speed_rpm: Annotated[float, Field(gt=0, le=3000, description="mean crank speed at the start [rpm]")]
    load: Annotated[float, Field(ge=0, le=1.1, description="fraction of rated IMEP")] = 1.0
    trend: Trend = Field(default_factory=Trend)


_DEFAULT_UNITS = {
    "acceleration": "m/s^2",
    "velocity": "mm/s",
    "keyphasor": "V",
    "tooth": "V",
    "cam": "V",
    "speed": "rpm",
    "pressure": "bar",
}


class Sensor(_Strict):
    """One sensor of the simulated recording (one channel)."""

    name: Annotated[str, Field(pattern=r"^[A-Za-z0-9][A-Za-z0-9 ._-]*$")]
    kind: Literal["acceleration", "velocity", "keyphasor", "tooth", "cam", "pressure"]
    location: str = ""
    direction: Literal["vertical", "horizontal", "axial", ""] = ""
    sample_rate_hz: Annotated[float, Field(gt=0, le=1e6)] = 25600.0
    representation: Literal["waveform", "events"] = "waveform"
    range: tuple[float, float] | None = None
    teeth: Annotated[int, Field(ge=3, le=720)] = 60
    missing_teeth: Annotated[int, Field(ge=1)] = 2
    first_tooth_angle_deg: float = 0.0
    pulse_angle_deg: float = 0.0
    cam_angle_deg: float = 0.0
    cylinder: Annotated[int, Field(ge=1)] | None = None

    @property
    def unit(self) -> str:
        """The channel's unit."""
        if self.kind in ("keyphasor", "tooth", "cam") and self.representation == "events":
            return "s"
        return _DEFAULT_UNITS[self.kind]

    @property
    def bearing(self) -> int | None:
        """The main bearing (1-based) named by ``location`` ("main bearing 3"), if any."""
        words = self.location.lower().split()
        if len(words) == 3 and words[:2] == ["main", "bearing"] and words[2].isdigit():
            return int(words[2])
        return None

    @model_validator(mode="after")
    def _consistent(self) -> Sensor:
        if self.representation == "events" and self.kind not in ("keyphasor", "tooth", "cam"):
            raise ValueError(f"a {self.kind} sensor is a waveform; events are for keyphasor, tooth or cam")
        if self.kind == "tooth" and self.missing_teeth >= self.teeth - 1:
            raise ValueError("missing_teeth must be less than teeth - 1")
        if self.kind == "pressure" and self.cylinder is None:
            raise ValueError("a pressure sensor needs the cylinder it is on (cylinder = N)")
        if self.range is not None and not self.range[0] < self.range[1]:
            raise ValueError(f"range {self.range}: expected [minimum, maximum] with minimum < maximum")
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
        names = [s.name for s in self.sensors]
        doubles = sorted({n for n in names if names.count(n) > 1})
        if doubles:
            raise ValueError(f"sensor names must be unique; repeated: {', '.join(doubles)}")
        return self


def _fields_at(loc: tuple[int | str, ...]) -> list[str]:
    """The known fields of the table an unknown field was found in."""
    model: type[BaseModel] = Scene
    if loc[:1] == ("sensors",):
        model = Sensor
    elif loc[:2] == ("operating_point", "trend"):
        model = Trend
    elif loc[:1] == ("operating_point",):
        model = OperatingPoint
    return [name for name in model.model_fields if name != "source_dir"]


def parse_scene(data: dict[str, Any], *, origin: str = "scene", source_dir: Path | None = None) -> Scene:
    """Validate a scene given as a dictionary (the TOML's content).

    Parameters
    ----------
    data : dict
    origin : str, optional
        Where it came from, for messages.
    source_dir : Path, optional
        Folder that relative engine paths are resolved against.

    Returns
    -------
    Scene

    Raises
    ------
    SceneError
        Naming every field that is wrong, with what is expected.
    """
    try:
        scene = Scene.model_validate({**data, "source_dir": source_dir})
    except ValidationError as error:
        lines = []
        for problem in error.errors():
            where = ".".join(str(p) for p in problem["loc"]) or "(top level)"
            if problem["type"] == "extra_forbidden":
                lines.append(f"{where}: unknown field (fields: {', '.join(_fields_at(problem['loc']))})")
            else:
                lines.append(f"{where}: {problem['msg']}")
        raise SceneError(f"{origin}: " + "; ".join(lines)) from None
    for sensor in scene.sensors:
        if sensor.representation == "waveform" and scene.duration_s * sensor.sample_rate_hz < 16:
            raise SceneError(
                f"{origin}: sensor {sensor.name!r}: duration_s = {scene.duration_s:g} s at sample_rate_hz = "
                f"{sensor.sample_rate_hz:g} gives fewer than 16 samples; lengthen the scene"
            )
    from monitor.scene.effects import check_effects

    check_effects(scene, origin=origin)
    return scene


def load_scene(path: str | Path) -> Scene:
    """Read and validate a scene file.

    Parameters
    ----------
    path : str or Path
        A ``.toml`` scene.

    Returns
    -------
    Scene

    Raises
    ------
    SceneError
        For a file that cannot be read or parsed, or a scene that is not valid.
    """
    source = Path(path)
    try:
        data = tomllib.loads(source.read_text(encoding="utf-8"))
    except OSError as error:
        raise SceneError(f"{source}: cannot read: {error.strerror}") from None
    except tomllib.TOMLDecodeError as error:
        raise SceneError(f"{source}: not valid TOML: {error}") from None
    return parse_scene(data, origin=str(source), source_dir=source.parent)
