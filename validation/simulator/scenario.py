"""What a case simulates: the operating point and the fault, drawn from the operation stream."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from validation.simulator.engine import SimEngine
from validation.simulator.installation import Installation
from validation.simulator.shared import OPERATION_STREAM, SimulationError

#: The fault classes of a case.
FAULT_CLASSES: tuple[str, ...] = ("healthy", "misfire", "weak", "worn_bearing", "sensor_fault")


@dataclass(frozen=True)
class Scenario:
    """What a case simulates: the operating point and the fault (drawn from the operation stream)."""

    load: float
    given_ratio: float
    fault: str
    cylinder: int | None = None
    factor: float = 1.0
    bearing_choice: float = 0.0
    burst_frequency: float = 0.0
    burst_cycles: float = 0.0
    burst_size: float = 0.0
    neighbour: float = 0.0
    sensor: int | None = None
    sensor_fault: str | None = None
    clip_fraction: float = 0.0


_SENSOR_FAULTS = ("clipped", "dead_flat", "dead_noise", "unit_x1000", "unit_per_9.81")


def draw_scenario(engine: SimEngine, install: Installation, seed: int, fault: str | None) -> Scenario:
    rng = np.random.default_rng(np.random.SeedSequence([seed, OPERATION_STREAM]))
    load = float(rng.uniform(0.45, 0.95))
    given_ratio = float(rng.uniform(0.9, 1.1))
    choices = [c for c in FAULT_CLASSES if not (c == "misfire" and engine.cylinders == 1)]
    drawn = choices[int(rng.integers(len(choices)))]
    forced_sensor_fault = None
    if fault == "random":
        kind = drawn
    elif fault is None:
        kind = "healthy"
    elif fault in FAULT_CLASSES:
        kind = fault
    elif fault.startswith("sensor_fault:") and fault.split(":", 1)[1] in _SENSOR_FAULTS:
        kind, forced_sensor_fault = "sensor_fault", fault.split(":", 1)[1]
    else:
        raise ValueError(
            f"fault = {fault!r}: expected 'random', None, one of {', '.join(FAULT_CLASSES)}, or "
            f"'sensor_fault:KIND' with KIND one of {', '.join(_SENSOR_FAULTS)}"
        )
    if kind == "misfire" and engine.cylinders == 1:
        raise SimulationError(
            f"seed {seed}: the engine has a single cylinder, which cannot run with a permanent misfire; "
            "choose another seed or fault"
        )
    cylinder = int(rng.integers(1, engine.cylinders + 1))
    factor = float(rng.uniform(0.5, 0.8))
    bearing_choice = float(rng.random())
    burst_frequency = float(rng.uniform(2000.0, min(8000.0, 0.4 * install.sample_rate)))
    burst_cycles = float(rng.uniform(4, 10))
    burst_size = float(rng.uniform(3, 6))
    neighbour = float(rng.uniform(0.15, 0.35))
    sensor = int(rng.integers(len(install.sensor_bearings)))
    sensor_fault = _SENSOR_FAULTS[int(rng.integers(len(_SENSOR_FAULTS)))]
    if forced_sensor_fault is not None:
        sensor_fault = forced_sensor_fault
    clip_fraction = float(rng.uniform(0.25, 0.5))
    factor = 0.0 if kind == "misfire" else factor if kind == "weak" else 1.0
    if engine.load_type == "generator" and kind in ("misfire", "weak"):
        # the governor makes the other cylinders carry the load: keep the fuel within 1.3 x rated
        load = min(load, 1.3 * (engine.cylinders - 1 + factor) / engine.cylinders)
    return Scenario(
        load=load,
        given_ratio=given_ratio,
        fault=kind,
        cylinder=cylinder if kind in ("misfire", "weak") else None,
        factor=factor,
        bearing_choice=bearing_choice,
        burst_frequency=burst_frequency,
        burst_cycles=burst_cycles,
        burst_size=burst_size,
        neighbour=neighbour,
        sensor=sensor if kind == "sensor_fault" else None,
        sensor_fault=sensor_fault if kind == "sensor_fault" else None,
        clip_fraction=clip_fraction,
    )
