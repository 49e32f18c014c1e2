"""Where a case runs against its baseline: the operating-point class, its loads, the charge law and sensors.

A fleet calibrates an engine once, at one operating point, and then records it wherever it runs.
The healthy twin a case is diagnosed against runs at the scenario's load (the baseline's point);
the case itself runs at a point of its operating-point class:

- "baseline point": the baseline's load (the population as it was first drawn);
- "propeller curve": a propeller engine at 60-100 % of its rated speed, its load on the curve
  through the rated point (net torque proportional to speed squared, power to speed cubed);
- "constant speed": a generator at 25-100 % load, at its rated speed;
- "load step": two loads of the engine's law (propeller curve or constant speed), the second from
  a random time inside the recording on;
- "crank speed only": an engine with its angle sensors alone (no bearing accelerometer), at a load
  of its law.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from validation.simulator.engine import SimEngine
from validation.simulator.gas import CHARGE_LAWS
from validation.simulator.installation import Installation
from validation.simulator.scenario import Scenario, draw_scenario
from validation.simulator.shared import POINT_STREAM

#: The operating-point classes of a case.
OPERATING_CLASSES: tuple[str, ...] = (
    "baseline point",
    "propeller curve",
    "constant speed",
    "load step",
    "crank speed only",
)
#: A weak cylinder's heat release at "80 %" off the baseline's point (besides 50-70 %) [-].
WEAK_80 = 0.8


@dataclass(frozen=True)
class OperatingPoint:
    """Where a case runs.

    Attributes
    ----------
    kind : str
        One of :data:`OPERATING_CLASSES`.
    loads : tuple of float
        The healthy engine's load (mean IMEP over rated) of the run, and after the step of a
        "load step" [-].
    step_fraction : float
        Where in the recording the load steps, a fraction of its length [-] (NaN without a step).
    charge_law : str
        The charge pressure against load, a key of :data:`~validation.simulator.gas.CHARGE_LAWS`.
    crank_only : bool
        Angle sensors only.
    """

    kind: str
    loads: tuple[float, ...]
    step_fraction: float = math.nan
    charge_law: str = "turbocharged"
    crank_only: bool = False


def propeller_load(engine: SimEngine, speed_fraction: float) -> float:
    """The load of a propeller engine at a speed on the curve through its rated point.

    Parameters
    ----------
    engine : SimEngine
    speed_fraction : float
        Speed over rated speed [-].

    Returns
    -------
    float
        Mean IMEP over rated IMEP of a healthy engine at that speed [-].

    Notes
    -----
    The net torque follows the propeller law, ``T_i L - T_f = (T_i - T_f) s^2`` (the brake power
    ``s^3``), ``T_i`` the rated indicated torque, ``T_f`` the friction torque, ``s`` the speed
    fraction: ``L = (s^2 (T_i - T_f) + T_f) / T_i``.
    """
    rated = engine.rated_indicated_torque
    friction = engine.friction_torque
    return float((speed_fraction**2 * (rated - friction) + friction) / rated)


def law_range(engine: SimEngine) -> tuple[float, float]:
    """The loads the engine's law runs it between: its propeller curve at 60-100 % speed, or 25-100 %.

    Parameters
    ----------
    engine : SimEngine

    Returns
    -------
    tuple of float
        The lowest and the highest load (mean IMEP over rated) a case off the baseline's point is
        drawn at [-] (a misfiring or weak generator engine's may be capped lower).
    """
    if engine.load_type == "propeller":
        return propeller_load(engine, 0.6), propeller_load(engine, 1.0)
    return 0.25, 1.0


def _law_load(engine: SimEngine, rng: np.random.Generator) -> float:
    """A load of the engine's law: on the propeller curve at 60-100 % speed, or 25-100 % at rated speed."""
    if engine.load_type == "propeller":
        return propeller_load(engine, float(rng.uniform(0.6, 1.0)))
    return float(rng.uniform(0.25, 1.0))


def draw_operating_point(
    engine: SimEngine, install: Installation, seed: int, fault: str | None, kind: str
) -> tuple[OperatingPoint, Scenario]:
    """The operating point and the scenario of a case (the point from its own stream).

    Parameters
    ----------
    engine : SimEngine
    install : Installation
        The engine's full installation (before a crank-speed-only case drops its bearing sensors).
    seed : int
        The case's seed.
    fault : str or None
        As :func:`~validation.simulator.scenario.draw_scenario` takes it.
    kind : str
        One of :data:`OPERATING_CLASSES`, or "random": one off the baseline's point, the engine's
        own law (propeller curve or constant speed), a load step or crank speed only, equally likely.

    Returns
    -------
    point : OperatingPoint
    scenario : Scenario
        Its ``load`` the baseline's. Off the baseline's point: a crank-speed-only case's bearing
        or sensor fault redrawn among the others, a weak cylinder's heat release 80 % or 50-70 %
        (equally likely).
    """
    scenario = draw_scenario(engine, install, seed, fault)
    if kind == "baseline point":
        return OperatingPoint(kind, (scenario.load,)), scenario
    rng = np.random.default_rng(np.random.SeedSequence([seed, POINT_STREAM]))
    own = "propeller curve" if engine.load_type == "propeller" else "constant speed"
    if kind == "random":
        kind = (own, "load step", "crank speed only")[int(rng.integers(3))]
    if kind not in OPERATING_CLASSES or (kind in ("propeller curve", "constant speed") and kind != own):
        raise ValueError(
            f"operating = {kind!r}: expected 'random' or one of {', '.join(OPERATING_CLASSES)} that fits "
            f"a {engine.load_type} engine"
        )
    crank_only = kind == "crank speed only"
    if crank_only and scenario.fault in ("worn_bearing", "sensor_fault") and fault == "random":
        choices = ["healthy", "weak"] + (["misfire"] if engine.cylinders > 1 else [])
        scenario = draw_scenario(engine, install, seed, choices[int(rng.integers(len(choices)))])
    weak_80 = rng.random() < 0.5
    if scenario.fault == "weak":
        scenario = replace(scenario, factor=WEAK_80 if weak_80 else float(rng.uniform(0.5, 0.7)))
    loads = [_law_load(engine, rng) for _ in range(2 if kind == "load step" else 1)]
    if engine.load_type == "generator" and scenario.fault in ("misfire", "weak"):
        # the governor makes the other cylinders carry the load: keep the fuel within 1.3 x rated
        most = 1.3 * (engine.cylinders - 1 + scenario.factor) / engine.cylinders
        loads = [min(load, most) for load in loads]
    point = OperatingPoint(
        kind,
        tuple(loads),
        step_fraction=float(rng.uniform(0.3, 0.7)) if kind == "load step" else math.nan,
        charge_law=tuple(CHARGE_LAWS)[int(rng.integers(len(CHARGE_LAWS)))],
        crank_only=crank_only,
    )
    return point, scenario
