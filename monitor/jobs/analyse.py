"""Analyse one recording: the use case ``compare``, the batch and the service's worker share.

A recording, a choice of engine, a baseline and the analysis options give the
diagnosis and its documents (:func:`analyse`). Each caller states its choices
in its own terms and this module turns them into the same analysis:

- the engine (:func:`recording_engine`): the one given (a file or a bundled id,
  ``--engine``), else the fleet's description of the recording's engine (from
  the store), else the bundled engine of the recording's engine id;
- the baseline (:func:`baseline_of`): a baseline already read, a baseline
  document (from the store, or ``batch --baseline``), a baseline file
  (``.json``, from ``calibrate``), or a healthy recording calibrated on the
  spot with the same options as the diagnosis;
- the options (:class:`AnalysisOptions`): load, transfer, cycle phase, channels
  left out; the batch and the service use the defaults.

A recording that crosses operating points (a load step, a manoeuvre) is
diagnosed per steady segment (:mod:`monitor.diagnosis.segments`): two steady
segments or more, each diagnosed at its own point, the status the worst
segment's; a steady recording's analysis is the whole recording's, unchanged.

The documents are the ones the store keeps (:meth:`Analysis.results`): the
diagnosis (``compare --json``, docs/diagnosis.md) and the measured spectra
(docs/spectrum-json.md). :func:`diagnose_file` is the same analysis in an
analysis process (the batch's pool, a Dask worker, the service's worker), with
its diagnosis plot written beside.
"""

from __future__ import annotations

from collections.abc import Callable
from contextlib import AbstractContextManager, nullcontext
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from monitor.diagnosis import Baseline, Diagnosis, calibrate
from monitor.diagnosis.at_point import diagnose_at_point
from monitor.diagnosis.balance import Transfer
from monitor.diagnosis.diagnose import CyclePhase
from monitor.diagnosis.operating_points import OperatingPoints, read_baseline
from monitor.diagnosis.segments import SegmentDiagnosis, SegmentedDiagnosis, diagnose_segments
from monitor.errors import DiagnosisError, MonitorError
from monitor.io import open_recording
from monitor.io.recording import Recording
from monitor.model.engine import Engine, bundled_engines, load_engine, parse_engine
from monitor.report.diagnosis import segmented_document, segmented_table
from monitor.report.spectrum_json import spectrum_document
from monitor.runtime.progress import Report
from monitor.signal.steady import Transition

__all__ = [
    "DIAGNOSIS",
    "EXIT_STATUS",
    "SPECTRUM",
    "Analysis",
    "AnalysisOptions",
    "analyse",
    "baseline_of",
    "diagnose_file",
    "recording_engine",
]

DIAGNOSIS = "diagnosis"  # the kinds of result an analysis gives, as the store keeps them
SPECTRUM = "spectrum"

EXIT_STATUS = {"healthy": 0, "warning": 1, "alarm": 2, "inconclusive": 3}
"""The exit status of each diagnosis status (``compare``'s, and the batch's worst)."""

FLEET_ENGINE_MISSING = "is neither in the fleet's engines nor bundled: add its description"
"""What :func:`recording_engine` says of an engine nobody described, by default (the service's words)."""


def recording_engine(
    recording: Recording,
    given: str | Path | dict[str, Any] | None = None,
    *,
    missing: str = FLEET_ENGINE_MISSING,
) -> Engine:
    """The engine of a recording: the one given, else the bundled one of the recording's engine id.

    Parameters
    ----------
    recording : Recording
    given : str, Path or dict, optional
        An engine description: a TOML file or a bundled engine's id (``--engine``), or the content of
        one (a fleet's description of the recording's engine, from the store).
    missing : str, optional
        What the error says after ``engine 'ID'`` when nothing was given and the engine is not
        bundled (the remedy in the caller's terms).

    Returns
    -------
    Engine

    Raises
    ------
    DiagnosisError
        When nothing was given and no bundled engine has the recording's engine id.
    """
    if isinstance(given, dict):
        return parse_engine(given, origin=f"engine {recording.engine_id} of the store")
    if given:
        return load_engine(given)
    if recording.engine_id in bundled_engines():
        return load_engine(bundled_engines()[recording.engine_id])
    raise DiagnosisError(f"engine {recording.engine_id!r} {missing}")


@dataclass(frozen=True)
class AnalysisOptions:
    """How a recording is analysed (``compare``'s options; the batch and the service take the defaults).

    Attributes
    ----------
    load : float or None
        The load the engine ran at [-]; None: read from the speed on several points along a
        propeller curve, else estimated from the crank-speed orders against the baseline, else the
        baseline's, else rated (1) (:mod:`monitor.diagnosis.at_point`).
    transfer : {"rigid", "shaft-line"}
        Torque to crank speed: the rigid engine side or the shaft line's receptance.
    cycle_phase : float, "unknown" or None
        Four-stroke without a cam or cylinder-1 pressure: the shift of the angle reference [rad].
    exclude : tuple of str
        Channels left out (sensors known to be faulty).
    segment_loads : tuple of float
        The load of each steady segment, in time order, for a recording that crosses operating
        points [-]; empty: ``load`` for each (:mod:`monitor.diagnosis.segments`).
    """

    load: float | None = None
    transfer: Transfer = "rigid"
    cycle_phase: CyclePhase = None
    exclude: tuple[str, ...] = field(default_factory=tuple)
    segment_loads: tuple[float, ...] = field(default_factory=tuple)


def baseline_of(
    given: OperatingPoints | Baseline | dict[str, Any] | str | Path | None,
    options: AnalysisOptions = AnalysisOptions(),
    *,
    engine: str | Path | dict[str, Any] | None = None,
    engine_missing: str = FLEET_ENGINE_MISSING,
    calibrated: Callable[[str], None] | None = None,
) -> OperatingPoints | None:
    """The baseline of an analysis, from what the caller holds, as its calibrated operating points.

    Parameters
    ----------
    given : OperatingPoints, Baseline, dict, str, Path or None
        Calibrated points or a baseline; a baseline document (``calibrate``'s JSON, of one point or
        several); a baseline file (``.json``, from ``calibrate``); or a healthy recording, calibrated
        here with ``options`` (its load default 1, its cycle phase only if a number, the channels it
        has of those left out).
    options : AnalysisOptions, optional
    engine : str, Path or dict, optional
        The engine given for the healthy recording (:func:`recording_engine`).
    engine_missing : str, optional
        What the error says of an engine nobody described (:func:`recording_engine`).
    calibrated : callable, optional
        Told the healthy recording's path once it was calibrated on.

    Returns
    -------
    OperatingPoints or None

    Raises
    ------
    MonitorError
        If ``given`` names sensor transfers (``.toml``: they belong in the engine file).
    """
    if given is None or isinstance(given, OperatingPoints):
        return given
    if isinstance(given, Baseline):
        return OperatingPoints((given,))
    if isinstance(given, dict):
        return OperatingPoints.from_document(given)
    suffix = Path(given).suffix.lower()
    if suffix == ".toml":
        raise MonitorError(
            f"--baseline {given}: sensor transfers (TOML) belong in the engine file, given "
            "with --engine; --baseline takes a baseline (.json) or a healthy recording"
        )
    if suffix == ".json":
        return read_baseline(given)
    with open_recording(given) as healthy:
        baseline = calibrate(
            healthy,
            recording_engine(healthy, engine, missing=engine_missing),
            load=options.load if options.load is not None else 1.0,
            transfer=options.transfer,
            source=Path(given).name,
            cycle_phase=options.cycle_phase if isinstance(options.cycle_phase, float) else None,
            exclude=[n for n in options.exclude if n in {c.name for c in healthy.channels}],
        )
    if calibrated is not None:
        calibrated(str(given))
    return OperatingPoints((baseline,))


@dataclass(frozen=True)
class Analysis:
    """A recording's diagnosis, with what its documents say of the recording.

    Attributes
    ----------
    name : str
        The recording's name in the documents.
    engine : Engine
        The engine it was diagnosed against.
    diagnosis : Diagnosis
        The whole recording's.
    start_time : str
        When it was recorded (as the recording says).
    truncated : bool
        Whether the file was cut short (diagnosed on what it holds).
    segments : tuple of SegmentDiagnosis
        Each steady segment's diagnosis, when the recording crosses operating points (two or more);
        empty for a steady recording.
    transitions : tuple of Transition
        Between the segments.
    """

    name: str
    engine: Engine
    diagnosis: Diagnosis
    start_time: str = ""
    truncated: bool = False
    segments: tuple[SegmentDiagnosis, ...] = ()
    transitions: tuple[Transition, ...] = ()

    @property
    def segmented(self) -> SegmentedDiagnosis:
        """The diagnosis with its segments (none for a steady recording)."""
        return SegmentedDiagnosis(self.diagnosis, self.segments, self.transitions)

    @property
    def status(self) -> str:
        """The status: "healthy", "warning", "alarm" or "inconclusive" (the worst segment's, if segmented)."""
        return self.segmented.status

    @property
    def exit_status(self) -> int:
        """``compare``'s exit status: 0 healthy, 1 warning, 2 alarm, 3 inconclusive."""
        return EXIT_STATUS[self.status]

    @property
    def title(self) -> str:
        """The diagnosis plot's title: the recording, its engine and its speed."""
        return f"{self.name}: {self.engine.id} at {self.diagnosis.speed_rpm:.1f} rpm"

    def diagnosis_document(self) -> dict[str, Any]:
        """The diagnosis document (``compare --json``, docs/diagnosis.md), with segments if it has them."""
        return segmented_document(self.segmented, recording=self.name)

    def table(self) -> str:
        """The diagnosis as text (``compare``'s tables): the whole recording's, or each segment's."""
        return segmented_table(self.segmented, recording=self.name)

    def spectrum_document(self) -> dict[str, Any]:
        """The measured spectra the diagnosis started from, every order (docs/spectrum-json.md)."""
        return spectrum_document(
            self.diagnosis.spectra,
            recording=self.name,
            engine_id=self.diagnosis.engine_id,
            start_time=self.start_time,
            truncated=self.truncated,
        )

    def results(self) -> dict[str, tuple[str, dict[str, Any]]]:
        """The documents the store keeps, by kind, each with the diagnosis' status."""
        return {
            DIAGNOSIS: (self.status, self.diagnosis_document()),
            SPECTRUM: (self.status, self.spectrum_document()),
        }


def analyse(
    path: str | Path,
    *,
    engine: str | Path | dict[str, Any] | None = None,
    baseline: OperatingPoints | Baseline | dict[str, Any] | str | Path | None = None,
    options: AnalysisOptions = AnalysisOptions(),
    name: str | None = None,
    engine_missing: str = FLEET_ENGINE_MISSING,
    calibrated: Callable[[str], None] | None = None,
    progress: Callable[[], AbstractContextManager[Report]] | None = None,
) -> Analysis:
    """Diagnose a recording file: its engine, its baseline and the options chosen as every caller does.

    Parameters
    ----------
    path : str or Path
        The recording (HDF5 or MCAP).
    engine : str, Path or dict, optional
        The engine given (:func:`recording_engine`); default: the recording's bundled engine.
    baseline : OperatingPoints, Baseline, dict, str, Path or None, optional
        The baseline (:func:`baseline_of`), chosen once the recording's engine is known.
    options : AnalysisOptions, optional
    name : str, optional
        The recording's name in the documents (default: the file's).
    engine_missing : str, optional
        What the error says of an engine nobody described (:func:`recording_engine`).
    calibrated : callable, optional
        Told the healthy recording's path when the baseline was calibrated on one.
    progress : callable, optional
        Opens the diagnosis' progress report (a context yielding ``report(fraction)``).

    Returns
    -------
    Analysis
    """
    with open_recording(path) as recording:
        chosen = recording_engine(recording, engine, missing=engine_missing)
        reference = baseline_of(
            baseline, options, engine=engine, engine_missing=engine_missing, calibrated=calibrated
        )
        with (progress or nullcontext)() as report:
            diagnosis = diagnose_at_point(
                recording,
                chosen,
                points=reference,
                load=options.load,
                transfer=options.transfer,
                cycle_phase=options.cycle_phase,
                exclude=list(options.exclude),
                progress=report,
            )
        segmented = diagnose_segments(
            recording,
            chosen,
            diagnosis,
            baseline=reference,
            load=options.load,
            transfer=options.transfer,
            cycle_phase=options.cycle_phase,
            exclude=list(options.exclude),
            loads=options.segment_loads,
        )
        start_time, truncated = recording.start_time, recording.truncated
    return Analysis(
        name or Path(path).name,
        chosen,
        diagnosis,
        start_time,
        truncated,
        segmented.segments,
        segmented.transitions,
    )


def diagnose_file(
    path: str,
    engine_description: dict[str, Any] | None,
    baseline_document: dict[str, Any] | None,
    plot: str | None = None,
    name: str | None = None,
) -> dict[str, tuple[str, dict[str, Any]]]:
    """Diagnose one recording file (run in an analysis process: the batch's, a Dask worker, the service's).

    Returns the result documents by kind: ``"diagnosis"`` (the ``compare --json`` document) and
    ``"spectrum"`` (the measured order spectra of every channel), each with the status. With
    ``plot``, the diagnosis plot is also written there as PNG (through a temporary file).

    Parameters
    ----------
    path : str
        The recording file.
    engine_description : dict or None
        The engine file's content (a fleet's description from the store); None: the bundled engine.
    baseline_document : dict or None
        A baseline (``engine-monitor calibrate``) for the bearing comparisons.
    plot : str, optional
        Where to write the diagnosis plot (PNG).
    name : str, optional
        The recording's name in the documents (default: the file's).
    """
    analysis = analyse(path, engine=engine_description, baseline=baseline_document, name=name)
    if plot is not None:
        from monitor.report.plots import plot_diagnosis  # matplotlib: only where a plot is drawn

        target = Path(plot)
        partial = target.with_name(target.stem + ".partial.png")
        plot_diagnosis(analysis.diagnosis, partial, title=analysis.title)
        partial.replace(target)
    return analysis.results()
