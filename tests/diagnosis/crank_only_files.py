"""Crank-speed-only recordings written with h5py directly, as another acquisition system would write them.

Only the crank's angle against time comes from the product (the scene simulator's rigid crank,
:func:`monitor.scene.crank.crank_motion`, with the inertia and gas torques and the misfire it is
told of). Everything a file holds is made here from recordings/FORMAT.md alone, not by the product's
writer: the edge times of a 60-2 tooth wheel with its own pitch errors and a timer's jitter, one
cam pulse per cycle, the root and channel attributes as h5py writes them by default (variable-length
strings, no chunks, no checksums).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path

import h5py
import numpy as np

from monitor.model.engine import bundled_engines, load_engine
from monitor.scene import parse_scene
from monitor.scene.crank import Crank, crank_motion
from monitor.scene.sources import sources_of

ENGINE = "medium-speed-6l32"  # a six-cylinder four-stroke: the cam tells the cycle's phase
TEETH, MISSING = 60, 2
FIRST_TOOTH_DEG = 3.0  # the first tooth after the gap, after cylinder 1's TDC [deg]
CAM_DEG = 40.0  # the cam pulse, after cylinder 1's firing TDC [deg of the 720 deg cycle]
# the wheel's pitch errors, one wheel for every recording: 0.03 deg rms, a machined wheel's size
PITCH_ERRORS_DEG = np.random.default_rng(2811).normal(0.0, 0.03, TEETH - MISSING)
JITTER_S = 0.5e-6  # the edge timer's jitter (rms): a 1 MHz counter's rounding, about


def crank(speed_rpm: float, duration_s: float, misfiring: Sequence[int] = ()) -> Crank:
    """The rigid crank's angle against time at a steady speed and rated load, cylinders misfiring."""
    effects: dict[str, object] = {"inertia": {}, "gas": {}, "crank_speed": {}}
    if misfiring:
        effects["misfire"] = {"cylinders": list(misfiring)}
    scene = parse_scene(
        {
            "engine": ENGINE,
            "duration_s": duration_s,
            "operating_point": {"speed_rpm": speed_rpm, "load": 1.0},
            "sensors": [{"name": "tooth", "kind": "tooth", "representation": "events"}],
            "effects": effects,
        }
    )
    engine = load_engine(bundled_engines()[ENGINE])
    return crank_motion(scene, engine, sources_of(scene, engine, []), [], {})


def write_crank_only(
    path: Path,
    rng: np.random.Generator,
    *,
    speed_rpm: float = 750.0,
    misfiring: Sequence[int] = (),
    duration_s: float = 10.0,
    keyphasor: bool = False,
) -> Path:
    """A recording of a tooth wheel's edge times (or a keyphasor's) and a cam pulse, via h5py."""
    motion = crank(speed_rpm, duration_s, misfiring)
    last = float(motion.angle_at(np.array([duration_s]))[0])
    pitch = 2 * math.pi / TEETH
    first = math.radians(FIRST_TOOTH_DEG)
    k = np.arange(0, math.floor((last - first) / pitch) + 1)
    k = k[np.mod(k, TEETH) < TEETH - MISSING]  # the gap: the wheel's last two positions
    angles = first + k * pitch + np.radians(PITCH_ERRORS_DEG)[np.mod(k, TEETH)]
    teeth = motion.time_at(angles) + rng.normal(0.0, JITTER_S, k.size)
    cycle = 4 * math.pi
    cam = motion.time_at(math.radians(CAM_DEG) + cycle * np.arange(math.floor(last / cycle)))
    with h5py.File(path, "w") as f:
        f.attrs["format"] = "engine-monitor recording"
        f.attrs["format_version"] = 1
        f.attrs["engine_id"] = ENGINE
        f.attrs["start_time"] = "2026-11-27T01:00:00Z"
        channels = f.create_group("channels", track_order=True)
        if keyphasor:  # once a revolution, at the first tooth's angle
            marks = motion.time_at(
                first + 2 * math.pi * np.arange(math.floor((last - first) / (2 * math.pi)))
            )
            once = channels.create_dataset("keyphasor", data=marks)
            once.attrs.update(
                kind="keyphasor", unit="s", representation="events", pulse_angle_deg=FIRST_TOOTH_DEG
            )
        else:
            wheel = channels.create_dataset("crank-teeth", data=teeth)
            wheel.attrs.update(
                kind="tooth",
                unit="s",
                representation="events",
                teeth=TEETH,
                missing_teeth=MISSING,
                first_tooth_angle_deg=FIRST_TOOTH_DEG,
            )
        pulse = channels.create_dataset("cam", data=cam)
        pulse.attrs.update(kind="cam", unit="s", representation="events", cam_angle_deg=CAM_DEG)
    return path
