"""Calibrate a baseline on several healthy recordings, one operating point each: the use case
``engine-monitor calibrate A.h5 B.h5 ...`` and the service's calibration of stored recordings share.

Each recording is calibrated at its own load (:func:`monitor.diagnosis.calibrate`): the load given
for it, else the load estimated from its crank-speed orders against the model
(:mod:`monitor.diagnosis.load_estimate`: a healthy recording's cylinders at the model's strengths),
else rated.  The points are kept together, ordered by load
(:class:`monitor.diagnosis.operating_points.OperatingPoints`).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from contextlib import ExitStack
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from monitor.diagnosis import calibrate
from monitor.diagnosis.at_point import diagnose_at_point
from monitor.diagnosis.operating_points import OperatingPoints
from monitor.diagnosis.zones import DEFAULT_BOUNDARIES_MM_S, healthy_zone_notes
from monitor.errors import DiagnosisError
from monitor.io import open_recording
from monitor.jobs.analyse import FLEET_ENGINE_MISSING, recording_engine

__all__ = ["Calibrated", "calibrate_recordings"]


@dataclass(frozen=True)
class Calibrated:
    """The points calibrated, and how each one's load was found.

    Attributes
    ----------
    points : OperatingPoints
    notes : list of str
        A line for each recording whose load was estimated, and for each of its vibration channels
        already in zone C or D (:func:`monitor.diagnosis.zones.healthy_zone_notes`).
    """

    points: OperatingPoints
    notes: list[str] = field(default_factory=list)


def calibrate_recordings(
    paths: Sequence[str | Path],
    *,
    loads: Sequence[float] | None = None,
    engine: str | Path | dict[str, Any] | None = None,
    names: Sequence[str] | None = None,
    cycle_phase: float | None = None,
    pitch_from: str | Path | None = None,
    exclude: Sequence[str] = (),
    engine_missing: str = FLEET_ENGINE_MISSING,
    progress: Callable[[float], None] | None = None,
) -> Calibrated:
    """Calibrate one point on each healthy recording, at its load.

    Parameters
    ----------
    paths : sequence of str or Path
        The healthy recordings, each at a steady speed and its own load.
    loads : sequence of float, optional
        Each recording's load, in the same order [-]; default: estimated (one recording: rated, as
        a single baseline always was).
    engine : str, Path or dict, optional
        The engine given (:func:`monitor.jobs.analyse.recording_engine`).
    names : sequence of str, optional
        The recordings' names kept in the points (default: the files').
    cycle_phase : float, optional
        Four-stroke without a cam: the angle reference's shift [rad].
    pitch_from : str or Path, optional
        A run of changing speed to learn the wheel's pitch errors on.
    exclude : sequence of str, optional
        Channels left out.
    engine_missing : str, optional
        What the error says of an engine nobody described.
    progress : callable, optional
        Told the fraction of the resampling done over all recordings, from 0 to 1 [-].

    Returns
    -------
    Calibrated

    Raises
    ------
    DiagnosisError
        For loads not one a recording, a recording whose load cannot be estimated, or two at one load.
    """
    if not paths:
        raise DiagnosisError("calibrate needs at least one healthy recording")
    if loads is not None and len(loads) != len(paths):
        raise DiagnosisError(
            f"{len(loads)} loads for {len(paths)} recordings: give one --load per recording, in the same "
            "order, or none to have them estimated"
        )
    labels = list(names) if names is not None else [Path(p).name for p in paths]
    baselines, notes = [], []
    with ExitStack() as stack:
        run = None if pitch_from is None else stack.enter_context(open_recording(pitch_from))
        for i, path in enumerate(paths):
            with open_recording(path) as recording:
                chosen = recording_engine(recording, engine, missing=engine_missing)
                kept = [n for n in exclude if n in {c.name for c in recording.channels}]
                load = loads[i] if loads is not None else 1.0
                if loads is None and len(paths) > 1:
                    load, note = _estimated(recording, chosen, labels[i], cycle_phase, kept)
                    notes.append(note)

                def told(fraction: float, done: int = i) -> None:
                    if progress is not None:
                        progress((done + fraction) / len(paths))

                baselines.append(
                    calibrate(
                        recording,
                        chosen,
                        load=load,
                        source=labels[i],
                        cycle_phase=cycle_phase,
                        pitch_from=run,
                        exclude=kept,
                        progress=told,
                    )
                )
                baseline = baselines[-1]
                limits = chosen.vibration_limits
                notes += healthy_zone_notes(
                    {name: s.velocity_rms for name, s in baseline.sensors.items()},
                    limits.zone_boundaries_mm_s if limits is not None else DEFAULT_BOUNDARIES_MM_S,
                    stated=limits is not None,
                    label=labels[i],
                )
    return Calibrated(OperatingPoints.of(baselines), notes)


def _estimated(
    recording: Any, engine: Any, label: str, cycle_phase: float | None, exclude: list[str]
) -> tuple[float, str]:
    """A healthy recording's load, estimated against the model's strengths, with a line saying so."""
    diagnosis = diagnose_at_point(recording, engine, cycle_phase=cycle_phase, exclude=exclude)
    point = diagnosis.operating_point
    if point.get("load_estimated") is None:
        raise DiagnosisError(
            f"{label}: its load cannot be estimated from its crank-speed orders: give each recording's "
            "load with --load"
        )
    load, error = float(point["load_estimated"]), float(point["load_estimated_standard_error"])
    return load, f"{label}: load estimated {load:.2f} +- {error:.2f} (against the model's strengths)"
