"""Reading a scene: its TOML file or dictionary validated into a :class:`~monitor.scene.model.Scene`.

Every table is checked (:mod:`monitor.scene.model`), then the effects it names
(:func:`monitor.scene.effects.check_effects`); a scene that is not valid is refused with a
:class:`~monitor.errors.SceneError` naming every field that is wrong, with what is expected.
"""

from __future__ import annotations

import tomllib
from pathlib import Path
from typing import Any

from pydantic import BaseModel, ValidationError

from monitor.errors import SceneError
from monitor.scene.effects import check_effects
from monitor.scene.model import LoadStep, OperatingPoint, Scene, Sensor, Trend
from monitor.scene.steps import check_steps

__all__ = ["load_scene", "parse_scene"]


def _fields_at(loc: tuple[int | str, ...]) -> list[str]:
    """The known fields of the table an unknown field was found in."""
    model: type[BaseModel] = Scene
    if loc[:1] == ("sensors",):
        model = Sensor
    elif loc[:2] == ("operating_point", "trend"):
        model = Trend
    elif loc[:2] == ("operating_point", "load_steps"):
        model = LoadStep
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
    top_rpm = scene.operating_point.top_rpm
    for sensor in scene.sensors:
        if sensor.representation == "waveform" and scene.duration_s * sensor.sample_rate_hz < 16:
            raise SceneError(
                f"{origin}: sensor {sensor.name!r}: duration_s = {scene.duration_s:g} s at sample_rate_hz = "
                f"{sensor.sample_rate_hz:g} gives fewer than 16 samples; lengthen the scene"
            )
        shaped = sensor.kind == "encoder" or (sensor.kind == "tooth" and sensor.signal != "pulse")
        rate = top_rpm / 60.0 * sensor.pulses  # pulse positions passing per second at the top speed [Hz]
        if shaped and sensor.representation == "waveform" and sensor.sample_rate_hz < 4 * rate:
            raise SceneError(
                f"{origin}: sensor {sensor.name!r}: sample_rate_hz = {sensor.sample_rate_hz:g} gives fewer "
                f"than 4 samples per pulse at {top_rpm:g} rpm ({rate:g} pulses per second); raise it to at "
                f"least {4 * rate:g}"
            )
    check_effects(scene, origin=origin)
    check_steps(scene, origin=origin)
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
