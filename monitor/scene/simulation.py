"""A scene turned into a recording, evaluating only the effects it names.

The named sources give the engine's forces and torques as orders of the crank angle
(:mod:`monitor.scene.sources`); the crank's angle against time follows from the trend and, if
named, the speed's fluctuation (:mod:`monitor.scene.crank`); each sensor's channel is synthesised
sample by sample with that angle (:mod:`monitor.scene.channels`).
"""

from __future__ import annotations

import dataclasses
import json
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from monitor.errors import SceneError
from monitor.io.recording import Recording
from monitor.model.engine import Engine, bundled_engines, load_engine
from monitor.scene.channels import channel
from monitor.scene.crank import crank_motion
from monitor.scene.effects import WornBearingParams, named
from monitor.scene.model import PULSE_KINDS, Scene
from monitor.scene.sources import sources_of
from monitor.scene.steps import epoch_scenes, joined

__all__ = ["Simulation", "simulate"]


@dataclass(frozen=True)
class Simulation:
    """A simulated recording and what was put into it.

    Attributes
    ----------
    recording : Recording
        With the truth (JSON) in ``recording.truth``.
    truth : dict
        Scene, effects, per-cylinder gas scales, and the expected orders of
        each simulated channel at the mean speed of the recording.
    evaluated : tuple of str
        The effects the simulation evaluated (exactly the ones named).
    """

    recording: Recording
    truth: dict[str, Any]
    evaluated: tuple[str, ...] = field(default=())


def _engine(scene: Scene) -> Engine:
    if scene.engine in bundled_engines():
        return load_engine(bundled_engines()[scene.engine])
    path = Path(scene.engine)
    if not path.is_absolute() and scene.source_dir is not None:
        path = scene.source_dir / path
    if not path.exists():
        raise SceneError(
            f"engine {scene.engine!r} is neither a bundled engine ({', '.join(sorted(bundled_engines()))}) "
            "nor a file"
        )
    return load_engine(path)


def _check_locations(scene: Scene, engine: Engine) -> None:
    """Refuse main bearings the engine does not have, in sensor locations and in worn_bearing."""
    count = engine.bearing_count
    for sensor in scene.sensors:
        words = sensor.location.lower().replace("-", " ").split()
        if words[:2] == ["main", "bearing"] and (sensor.bearing is None or not 1 <= sensor.bearing <= count):
            raise SceneError(
                f"sensor {sensor.name!r}: location {sensor.location!r}: expected 'main bearing N' with N = "
                f"1..{count} (engine {engine.id!r})"
            )
    worn = named(scene, "worn_bearing")
    if isinstance(worn, WornBearingParams) and not 1 <= worn.bearing <= count:
        raise SceneError(
            f"effect 'worn_bearing': bearing {worn.bearing} does not exist (the engine has {count})"
        )


def simulate(
    scene: Scene, *, seed: int | None = None, progress: Callable[[float], None] | None = None
) -> Simulation:
    """Simulate a scene: only the effects it names are evaluated.

    Parameters
    ----------
    scene : Scene
    seed : int, optional
        Noise seed; default: the scene's. The same scene and seed give the same recording.
    progress : callable, optional
        Called with the fraction done [-] after each channel.

    Returns
    -------
    Simulation

    Raises
    ------
    SceneError
        When the scene cannot be simulated as written (the message says what to change).
    """
    engine = _engine(scene)
    seed = scene.seed if seed is None else seed
    _check_locations(scene, engine)
    evaluated: list[str] = []
    sources = sources_of(scene, engine, evaluated)
    # a load step: the sources of each later epoch, joined at the steps (monitor.scene.steps)
    epochs = epoch_scenes(scene)[1:]
    later = [(start, epoch, sources_of(epoch, engine, [])) for start, epoch in epochs]
    expected: dict[str, Any] = {}
    steps = [(start, s) for start, _, s in later if s is not None]
    crank = crank_motion(scene, engine, sources, evaluated, expected, steps=steps)
    channels = []
    for i, sensor in enumerate(scene.sensors):
        made = channel(sensor, i, scene, engine, crank, sources, seed, expected)
        if later and not made.is_events and sensor.kind not in PULSE_KINDS:
            values = [made.data] + [
                channel(sensor, i, epoch, engine, crank, s, seed, {}).data for _, epoch, s in later
            ]
            starts = [0.0] + [start for start, _, _ in later]
            made = dataclasses.replace(
                made, data=joined(starts, values, made.times()).astype(made.data.dtype)
            )
        channels.append(made)
        if progress is not None:
            progress((i + 1) / len(scene.sensors))
    for name in (
        "bearing_vibration",
        "axial_vibration",
        "worn_bearing",
        "noise",
        "keyphasor_faults",
        "tooth_spacing_errors",
        "clipping",
        "gain_error",
    ):
        if name in scene.effects:  # applied channel by channel above
            evaluated.append(name)
    truth = {
        "engine": engine.id,
        "duration_s": scene.duration_s,
        "seed": seed,
        # a scene without steps keeps the truth it always had (no empty load_steps in it)
        "operating_point": scene.operating_point.model_dump(
            exclude=set() if scene.operating_point.load_steps else {"load_steps"}
        ),
        "effects": scene.effects,
        "gas_model": sources.gas_model if sources else "none",
        "cylinder_gas_scale": sources.gas_scale if sources else [1.0] * engine.cylinders,
        "cylinder_charge_scale": sources.charge_scale if sources else [1.0] * engine.cylinders,
        "expected_orders": expected,
    }
    recording = Recording(
        engine_id=engine.id,
        start_time="2026-01-01T00:00:00Z",
        channels=tuple(channels),
        notes=f"simulated scene, seed {seed}",
        truth=json.dumps(truth, sort_keys=True),
    )
    return Simulation(recording, truth, tuple(evaluated))
