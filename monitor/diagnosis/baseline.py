"""A healthy baseline's calibration: per sensor, the structure's transfer and its impact profile.

Calibrated once on a healthy recording of an engine (:func:`monitor.diagnosis.calibrate`)
and stored as a small JSON document (``engine-monitor calibrate``), then
reused for every later recording of the same engine and sensor layout.

For each vibration sensor on a main bearing: the transfer ``H_k = X_k / F_k``
from the bearing force to the sensor's orders with its standard error, the
high-frequency power profile over the cycle, and the overall rms velocity;
beside them the operating point and cylinder strengths it was calibrated at,
and the tooth wheel's pitch errors learned on it (applied to later recordings
of the same wheel, so that a short recording is corrected as well as a long
one and every recording the same way).
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from monitor.diagnosis.analysis import bearing_sensors
from monitor.diagnosis.balance import CrankCalibration
from monitor.errors import DiagnosisError
from monitor.io.recording import Recording
from monitor.model.engine import Engine
from monitor.signal.impact import HighFrequencyPower
from monitor.signal.pitch import PitchCorrection
from monitor.types import ComplexArray, FloatArray

__all__ = ["BASELINE_FORMAT", "Baseline", "SensorBaseline"]

BASELINE_FORMAT = "engine-monitor baseline 1"


@dataclass(frozen=True)
class SensorBaseline:
    """One sensor's calibration.

    Attributes
    ----------
    channel : str
    kind : str
        "acceleration" or "velocity".
    unit : str
    bearing : int
        The main bearing it sits on (1-based).
    direction : str
        "vertical" (the force's y) or "horizontal" (x).
    sample_rate : float
        [Hz]
    orders : ndarray
    transfer : ndarray, complex
        ``H_k`` [unit / N].
    transfer_error : ndarray
        Standard error of ``H_k`` [unit / N].
    high_frequency : HighFrequencyPower or None
        None for a transfer given in the engine file.
    velocity_rms : float
        [mm/s] (NaN for a transfer given in the engine file).
    """

    channel: str
    kind: str
    unit: str
    bearing: int
    direction: str
    sample_rate: float
    orders: FloatArray
    transfer: ComplexArray
    transfer_error: FloatArray
    high_frequency: HighFrequencyPower | None
    velocity_rms: float


@dataclass(frozen=True)
class Baseline:
    """A healthy recording's calibration of an engine's sensors.

    Attributes
    ----------
    engine_id : str
    speed_rpm : float
        Mean crank speed of the baseline [rpm].
    load : float
        Load the model was evaluated at [-].
    strengths : list of float
        The baseline's estimated cylinder strengths (all 1 when they could not be estimated).
    samples_per_cycle : int
        Of the angle-domain grid (the impact profiles' bins).
    sensors : dict of str to SensorBaseline
    source : str
        The baseline recording's file name.
    pitch : PitchCorrection or None
        The tooth wheel's (or encoder's) pitch errors learned on the baseline.
    pitch_channel : str
        The channel they belong to.
    crank : CrankCalibration or None
        The crank-speed model calibrated on the baseline at the orders where the cylinders add up.
    """

    engine_id: str
    speed_rpm: float
    load: float
    strengths: list[float]
    samples_per_cycle: int
    sensors: dict[str, SensorBaseline]
    source: str
    pitch: PitchCorrection | None = None
    pitch_channel: str = ""
    crank: CrankCalibration | None = None

    def check_layout(self, recording: Recording, engine: Engine) -> None:
        """Raise a :class:`~monitor.errors.DiagnosisError` where the baseline is of another engine, or lacks
        a bearing sensor of the recording (or has it on another bearing, direction, unit or sampling rate).
        """
        if self.engine_id != engine.id:
            raise DiagnosisError(
                f"the baseline is of engine {self.engine_id!r}, the recording of {engine.id!r}: "
                "calibrate a baseline of this engine"
            )
        missing = []
        for channel, b in bearing_sensors(recording, engine):
            known = self.sensors.get(channel.name)
            rate = float(channel.sample_rate or 0.0)
            if known is None:
                missing.append(f"{channel.name!r} (not in the baseline)")
            elif (known.bearing, known.direction, known.unit, known.sample_rate) != (
                b,
                channel.direction,
                channel.unit,
                rate,
            ):
                missing.append(
                    f"{channel.name!r} (baseline: main bearing {known.bearing} {known.direction}, "
                    f"{known.unit}, {known.sample_rate:g} Hz; recording: main bearing {b} "
                    f"{channel.direction}, {channel.unit}, {rate:g} Hz)"
                )
        if missing:
            raise DiagnosisError(
                f"the baseline {self.source or ''} lacks the recording's channel layout: "
                + ", ".join(missing)
                + f"; baseline channels: {', '.join(sorted(self.sensors)) or 'none'}"
            )

    def pitch_for(self, recording: Recording) -> PitchCorrection | None:
        """The pitch errors learned on the baseline, where they belong to the recording's angle-reference
        wheel (the same channel, a tooth wheel or encoder of as many pulses); else None."""
        if self.pitch is None:
            return None
        channel = {c.name: c for c in recording.channels}.get(self.pitch_channel)
        if channel is None or channel.kind not in ("tooth", "encoder"):
            return None
        present = (
            int(channel.fields["teeth"]) - int(channel.fields["missing_teeth"])
            if channel.kind == "tooth"
            else int(channel.fields["pulses_per_revolution"])
        )
        return self.pitch if self.pitch.errors.size == present else None

    def to_document(self) -> dict[str, Any]:
        """The JSON document (complex numbers as [re, im] pairs)."""
        return {
            "format": BASELINE_FORMAT,
            "engine_id": self.engine_id,
            "speed_rpm": self.speed_rpm,
            "load": self.load,
            "strengths": list(self.strengths),
            "samples_per_cycle": self.samples_per_cycle,
            "source": self.source,
            "tooth_pitch": None
            if self.pitch is None
            else {
                "channel": self.pitch_channel,
                "errors_deg": np.degrees(self.pitch.errors).tolist(),
                "kept_orders": list(self.pitch.kept_orders),
                "revolutions": self.pitch.revolutions,
                "scope": self.pitch.scope,
                "learned_on": "run-up" if self.pitch.source == "run-up" else "baseline",
                "order_errors_deg": None
                if self.pitch.order_errors is None
                else np.degrees(self.pitch.order_errors).tolist(),
                "speeds_rpm": [s * 30 / math.pi for s in self.pitch.speeds],
            },
            "crank_speed_model": None
            if self.crank is None
            else {
                "transfer": self.crank.transfer,
                "orders": self.crank.orders.tolist(),
                "combustion_factor": [[z.real, z.imag] for z in self.crank.factor.tolist()],
                "factor_error": self.crank.factor_error.tolist(),
                "inertia_factor": [[z.real, z.imag] for z in self.crank.inertia_factor.tolist()],
                "inertia_factor_error": self.crank.inertia_factor_error.tolist(),
            },
            "sensors": {
                name: {
                    "kind": s.kind,
                    "unit": s.unit,
                    "bearing": s.bearing,
                    "direction": s.direction,
                    "sample_rate_hz": s.sample_rate,
                    "orders": s.orders.tolist(),
                    "transfer": [[z.real, z.imag] for z in s.transfer.tolist()],
                    "transfer_error": s.transfer_error.tolist(),
                    "high_frequency_mean": s.high_frequency.mean.tolist() if s.high_frequency else None,
                    "high_frequency_std": s.high_frequency.std.tolist() if s.high_frequency else None,
                    "high_frequency_cycles": s.high_frequency.cycles if s.high_frequency else 0,
                    "high_frequency_band_hz": list(s.high_frequency.band_hz) if s.high_frequency else None,
                    "high_frequency_varying": (
                        s.high_frequency.varying.tolist()
                        if s.high_frequency is not None and s.high_frequency.varying is not None
                        else None
                    ),
                    "velocity_rms_mm_s": s.velocity_rms,
                }
                for name, s in self.sensors.items()
            },
        }

    def write(self, path: str | Path) -> Path:
        """Write the JSON document (whole or not at all: through a temporary file)."""
        target = Path(path)
        temporary = target.with_name(target.name + ".partial")
        temporary.write_text(json.dumps(self.to_document(), indent=1) + "\n")
        temporary.replace(target)
        return target

    def to_toml(self) -> str:
        """The transfers as ``[[sensor_transfers]]`` tables for the engine file (``SensorTransfer``)."""
        lines = [
            f"# sensor transfers calibrated on {self.source or 'a healthy recording'} of {self.engine_id} "
            f"at {self.speed_rpm:.2f} rpm, load {self.load:g}",
        ]
        for name, s in self.sensors.items():
            keep = np.abs(s.transfer) > 0
            lines += [
                "",
                "[[sensor_transfers]]",
                f"channel = {json.dumps(name)}",
                f"bearing = {s.bearing}",
                f"direction = {json.dumps(s.direction)}",
                f"unit = {json.dumps(s.unit)}",
                f"speed_rpm = {self.speed_rpm:.6g}",
                f"orders = [{', '.join(f'{k:g}' for k in s.orders[keep])}]",
                f"magnitude = [{', '.join(f'{v:.6e}' for v in np.abs(s.transfer[keep]))}]",
                f"phase_deg = [{', '.join(f'{v:.3f}' for v in np.degrees(np.angle(s.transfer[keep])))}]",
                f"magnitude_error = [{', '.join(f'{v:.3e}' for v in s.transfer_error[keep])}]",
            ]
        return "\n".join(lines) + "\n"

    @classmethod
    def from_engine(cls, engine: Engine) -> Baseline | None:
        """The transfers given in the engine file, as a baseline without impact profiles (None if none)."""
        if not engine.sensor_transfers:
            return None
        speeds = {t.speed_rpm for t in engine.sensor_transfers}
        if len(speeds) > 1:
            raise DiagnosisError(
                f"engine {engine.id!r}: sensor_transfers at different speeds {sorted(speeds)}: "
                "give them at one speed"
            )
        sensors = {}
        for t in engine.sensor_transfers:
            magnitude = np.asarray(t.magnitude, dtype=np.float64)
            error = np.asarray(
                t.magnitude_error if t.magnitude_error is not None else np.zeros(magnitude.size)
            )
            sensors[t.channel] = SensorBaseline(
                channel=t.channel,
                kind="",
                unit=t.unit,
                bearing=t.bearing,
                direction=t.direction,
                sample_rate=0.0,
                orders=np.asarray(t.orders, dtype=np.float64),
                transfer=magnitude * np.exp(1j * np.radians(np.asarray(t.phase_deg))),
                transfer_error=error,
                high_frequency=None,
                velocity_rms=math.nan,
            )
        return cls(
            engine_id=engine.id,
            speed_rpm=speeds.pop(),
            load=1.0,
            strengths=[1.0] * engine.cylinders,
            samples_per_cycle=0,
            sensors=sensors,
            source=f"the sensor transfers of engine file {engine.id}",
        )

    @classmethod
    def from_document(cls, document: dict[str, Any], *, origin: str = "baseline") -> Baseline:
        """Read a document written by :meth:`to_document`.

        Raises
        ------
        DiagnosisError
            For another format or a missing field.
        """
        if document.get("format") != BASELINE_FORMAT:
            raise DiagnosisError(
                f"{origin}: format {document.get('format')!r}, expected {BASELINE_FORMAT!r} "
                "(write it with 'engine-monitor calibrate')"
            )
        try:
            stored = document.get("tooth_pitch")
            pitch = (
                PitchCorrection(
                    np.radians(np.asarray(stored["errors_deg"], dtype=np.float64)),
                    tuple(int(k) for k in stored["kept_orders"]),
                    int(stored["revolutions"]),
                    source="run-up" if stored.get("learned_on") == "run-up" else "baseline",
                    scope=str(stored["scope"]),
                    order_errors=None
                    if stored.get("order_errors_deg") is None  # absent before they were stated
                    else np.radians(np.asarray(stored["order_errors_deg"], dtype=np.float64)),
                    speeds=tuple(float(s) * math.pi / 30 for s in stored.get("speeds_rpm", ())),
                )
                if stored
                else None
            )
            # absent from baselines written before it, and one factor on the whole model in those
            # written before the gap was shared between the model's parts: not used
            model = document.get("crank_speed_model")
            crank = (
                CrankCalibration(
                    str(model["transfer"]),
                    np.asarray(model["orders"], dtype=np.float64),
                    np.asarray(model["combustion_factor"], dtype=np.float64).reshape(-1, 2)
                    @ np.array([1.0, 1j]),
                    np.asarray(model["factor_error"], dtype=np.float64),
                    np.asarray(model["inertia_factor"], dtype=np.float64).reshape(-1, 2)
                    @ np.array([1.0, 1j]),
                    np.asarray(model["inertia_factor_error"], dtype=np.float64),
                )
                if model and "combustion_factor" in model and "inertia_factor" in model
                else None
            )
            sensors = {}
            for name, s in document["sensors"].items():
                profile = (
                    HighFrequencyPower(
                        np.asarray(s["high_frequency_mean"], dtype=np.float64),
                        np.asarray(s["high_frequency_std"], dtype=np.float64),
                        int(s["high_frequency_cycles"]),
                        float(s["sample_rate_hz"]),
                        # absent from baselines written before the profile was band-passed: no reference
                        tuple(s.get("high_frequency_band_hz") or (math.nan, math.nan)),
                        # the baseline's speed: the reference's rings are carried from it to a recording's
                        float(document["speed_rpm"]),
                        # absent from baselines written before the varying part was measured: the
                        # impacts are then judged on the whole power alone
                        varying=(
                            None
                            if s.get("high_frequency_varying") is None
                            else np.asarray(s["high_frequency_varying"], dtype=np.float64)
                        ),
                    )
                    if s["high_frequency_mean"] is not None
                    else None
                )
                pairs = np.asarray(s["transfer"], dtype=np.float64).reshape(-1, 2)
                sensors[name] = SensorBaseline(
                    channel=name,
                    kind=str(s["kind"]),
                    unit=str(s["unit"]),
                    bearing=int(s["bearing"]),
                    direction=str(s["direction"]),
                    sample_rate=float(s["sample_rate_hz"]),
                    orders=np.asarray(s["orders"], dtype=np.float64),
                    transfer=pairs[:, 0] + 1j * pairs[:, 1],
                    transfer_error=np.asarray(s["transfer_error"], dtype=np.float64),
                    high_frequency=profile,
                    velocity_rms=float(s["velocity_rms_mm_s"]),
                )
            return cls(
                engine_id=str(document["engine_id"]),
                speed_rpm=float(document["speed_rpm"]),
                load=float(document["load"]),
                strengths=[float(v) for v in document["strengths"]],
                samples_per_cycle=int(document["samples_per_cycle"]),
                sensors=sensors,
                source=str(document.get("source", "")),
                pitch=pitch,
                pitch_channel=str(stored["channel"]) if stored else "",
                crank=crank,
            )
        except (KeyError, TypeError, ValueError) as error:
            raise DiagnosisError(f"{origin}: not a complete baseline document ({error!r})") from error

    @classmethod
    def read(cls, path: str | Path) -> Baseline:
        """Read a baseline JSON file."""
        source = Path(path)
        try:
            document = json.loads(source.read_text())
        except (OSError, UnicodeDecodeError, json.JSONDecodeError) as error:
            raise DiagnosisError(f"{source}: cannot read the baseline ({error})") from error
        if not isinstance(document, dict):
            raise DiagnosisError(f"{source}: not a baseline document")
        return cls.from_document(document, origin=str(source))
