"""A validation case: the run of one engine at one operating point, and the population of cases."""

from __future__ import annotations

import math
from collections.abc import Iterator
from dataclasses import dataclass, field
from datetime import UTC, datetime, timedelta
from typing import Any

import numpy as np

from monitor.io.recording import Recording
from validation.simulator.channels import (
    angle_channels,
    bearing_channel,
    structural_response,
    velocity_mm_s,
    worn_bearing_bursts,
)
from validation.simulator.crank import CrankRun, LoadStep, operating_load, run_crank
from validation.simulator.description import engine_description
from validation.simulator.engine import SimEngine
from validation.simulator.gas import (
    CHARGE_LAWS,
    HEAT_LEVELS,
    HEAT_STEP,
    CycleTable,
    cycle_table,
    rated_of_seed,
)
from validation.simulator.installation import (
    Installation,
    random_installation,
    sensor_mix,
    without_bearing_sensors,
)
from validation.simulator.kinematics import bearing_split
from validation.simulator.operating import OperatingPoint, draw_operating_point, law_range
from validation.simulator.scenario import Scenario, draw_scenario
from validation.simulator.shared import NOISE_STREAM, TWIN_WORD, FloatArray
from validation.simulator.vee_engine import engine_of_seed


@dataclass(frozen=True)
class Case:
    """One validation case.

    Attributes
    ----------
    seed : int
        The seed of its noise and cycle variation (and, for a case from :func:`random_case`, of
        everything; a healthy twin's engine comes from ``truth["engine_seed"]``).
    engine_toml : str
        The perturbed engine description given to the product.
    recording : Recording
        The simulated recording; its ``engine_id`` is the description's id.
    load_given : float
        The load the product is told: the true load times 0.9-1.1 [-].
    truth : dict
        ``class`` (one of :data:`FAULT_CLASSES`), ``cylinder``, ``bearing``, ``channel``,
        ``strength``, ``true_load`` and the details of the simulation (see :func:`random_case`).
    """

    seed: int
    engine_toml: str
    recording: Recording
    load_given: float
    truth: dict[str, Any] = field(hash=False)


def _simulate(
    engine_seed: int,
    noise_seed: int,
    *,
    twin: bool,
    duration_s: float,
    fault: str | None,
    operating: str | OperatingPoint = "baseline point",
    vee: bool = False,
) -> Case:
    """A case: ``engine_seed`` gives engine, installation, description, operating point and fault.

    ``operating`` a class of :data:`~validation.simulator.operating.OPERATING_CLASSES` (or
    "random") draws the point; an :class:`OperatingPoint` is a healthy twin's, at that point.
    ``vee`` takes the seed's V engine (:func:`~validation.simulator.vee_engine.random_vee_engine`).
    """
    if not (math.isfinite(duration_s) and duration_s >= 1.0):
        raise ValueError(f"duration_s = {duration_s!r}: expected a duration of at least 1 s")
    if noise_seed < 0:
        raise ValueError(f"seed = {noise_seed}: expected an integer >= 0")
    engine = engine_of_seed(engine_seed, vee)
    install = random_installation(engine)
    toml_text = engine_description(engine)
    if isinstance(operating, OperatingPoint):  # a healthy twin, or a healthy run, at the point given
        point = operating
        drawn = draw_scenario(engine, install, engine_seed, fault)
        scenario = Scenario(load=point.loads[0], given_ratio=drawn.given_ratio, fault="healthy")
    else:
        point, scenario = draw_operating_point(engine, install, engine_seed, fault, operating)
    if point.crank_only:
        install = without_bearing_sensors(install)
    words = [noise_seed, NOISE_STREAM, TWIN_WORD] if twin else [noise_seed, NOISE_STREAM]
    rng = np.random.default_rng(np.random.SeedSequence(words))
    n = engine.cylinders
    factors = np.ones(n)
    if scenario.cylinder is not None:
        factors[scenario.cylinder - 1] = scenario.factor
    tables = [_operating_table(engine, engine_seed, load, point.charge_law) for load in point.loads]
    run, pre = _run(engine, install, tables, point, factors, duration_s, rng)
    count = len(install.sensor_bearings)
    clean, _ = structural_response(run, install, pre, duration_s)
    data = _with_hum_and_noise(clean, install, rng)
    truth: dict[str, Any] = {
        "class": scenario.fault,
        "cylinder": _cylinder_name(engine, scenario.cylinder),
        "bearing": None,
        "channel": None,
        "strength": None,
        "sensor_fault": None,
    }
    # the structure's own vibration, against which a zone finding is judged (not a fault: a healthy
    # engine near a structural resonance vibrates as it does)
    truth["velocity_mm_s"] = {
        install.channel_name(s): round(float(v), 3)
        for s, v in enumerate(velocity_mm_s(clean, install.sample_rate))
    }
    if scenario.fault == "worn_bearing":
        bursts, details = worn_bearing_bursts(
            run, engine.cycle_angle, install, scenario, pre, duration_s, rng, planar=engine.is_vee
        )
        data += bursts
        truth.update(details)
    elif scenario.fault == "weak":
        truth.update(strength=1 - scenario.factor, weak_factor=scenario.factor)
    elif scenario.fault == "misfire":
        truth.update(strength=1.0)
    channels = []
    for s in range(count):
        channel, details = bearing_channel(data[s], s, install, scenario, rng)
        channels.append(channel)
        truth.update(details)
    channels.extend(angle_channels(engine, install, run, pre, duration_s, rng))
    # within 70 days of 2026-01-01 whatever the seed (the same dates as before for seeds below 100 000):
    # a recording dated after the machine's clock is refused, so no seed may date one in the future
    start = datetime(2026, 1, 1, tzinfo=UTC) + timedelta(minutes=engine_seed % 100_000)
    if twin:
        start -= timedelta(days=1, minutes=noise_seed % 1000)
    recording = Recording(
        engine_id=engine.ident,
        start_time=start.strftime("%Y-%m-%dT%H:%M:%SZ"),
        channels=tuple(channels),
        notes=f"validation simulator: engine seed {engine_seed}, noise seed {noise_seed}",
    )
    ran = _what_ran(engine, install, tables[0], run, pre, duration_s, scenario.given_ratio)
    true_load = float(ran["true_load"])
    truth.update(ran)
    truth.update(
        engine_seed=engine_seed,
        noise_seed=noise_seed,
        twin=twin,
        duration_s=duration_s,
        scenario_load=scenario.load,
        operating_class=point.kind,
        baseline_load=scenario.load,
        test_loads=list(point.loads),
        step_time_s=point.step_fraction * duration_s if len(point.loads) > 1 else None,
        charge_law=point.charge_law,
        crank_only=point.crank_only,
    )
    if engine.is_vee:
        truth.update(
            vee=True, cylinder_index=scenario.cylinder, cylinder_names=engine.cylinder_names, rods=engine.rods
        )
    return Case(
        seed=noise_seed if twin else engine_seed,
        engine_toml=toml_text,
        recording=recording,
        load_given=true_load * scenario.given_ratio,
        truth=truth,
    )


def _cylinder_name(engine: SimEngine, cylinder: int | None) -> int | str | None:
    """A faulty cylinder as the truth names it: its number in line, its name (``"B3"``) on a V."""
    if cylinder is None or not engine.is_vee:
        return cylinder
    return engine.cylinder_names[cylinder - 1]


def _operating_table(engine: SimEngine, engine_seed: int, load: float, charge_law: str) -> CycleTable:
    """The cycle table at the healthy operating speed (propeller: where the rated curve meets the load)."""
    rated_net = engine.rated_indicated_torque - engine.friction_torque
    if engine.load_type == "propeller":
        net = load * engine.rated_indicated_torque - engine.friction_torque
        speed_guess = engine.rated_speed * math.sqrt(max(net, 0.05 * rated_net) / rated_net)
    else:
        speed_guess = engine.rated_speed
    return cycle_table(
        engine,
        speed=speed_guess,
        charge_pressure=CHARGE_LAWS[charge_law](engine, load),
        fuel=HEAT_STEP * np.arange(HEAT_LEVELS),
        heat_reference=rated_of_seed(engine_seed, engine.is_vee)[0],
    )


def _run(
    engine: SimEngine,
    install: Installation,
    tables: list[CycleTable],
    point: OperatingPoint,
    factors: FloatArray,
    duration_s: float,
    rng: np.random.Generator,
) -> tuple[CrankRun, float]:
    """The crank's run over the recording and the time before it starts [s] (the start settling)."""
    n = engine.cylinders
    table, load = tables[0], point.loads[0]
    load_model, fuel, speed0 = operating_load(engine, table, load, factors)
    after = [
        operating_load(engine, t, value, factors)
        for t, value in zip(tables[1:], point.loads[1:], strict=True)
    ]
    slowest = min([speed0] + [speed for _, _, speed in after])
    # cycle-to-cycle scatter of the heat release that gives the engine's peak-pressure scatter
    healthy = table.fuel_for(load * engine.rated_imep)
    fired = float(np.interp(healthy, table.fuel, table.peak_pressure))
    rise = float(np.interp(healthy * 1.02, table.fuel, table.peak_pressure)) - fired
    heat_scatter = min(engine.peak_pressure_scatter / max(rise / (0.02 * fired), 1e-3), 0.04)

    def variation(_: int) -> FloatArray:
        return np.asarray(1 + np.clip(rng.normal(0.0, heat_scatter, n), -4 * heat_scatter, 4 * heat_scatter))

    fs = install.sample_rate
    pre = math.ceil(max(0.5, 2 * engine.cycle_angle / speed0) * fs) / fs
    split = bearing_split(engine.cylinder_positions, engine.bearing_positions, engine.throw_bearings)
    pure = split[[b - 1 for b in install.sensor_bearings]]
    revolutions_per_second = slowest / (2 * math.pi)
    ppr = (
        720 if fs / revolutions_per_second <= 720 else int(360 * math.ceil(fs / revolutions_per_second / 360))
    )
    run = run_crank(
        engine,
        table,
        load_model,
        fuel=fuel,
        end_time=pre + duration_s + 0.05,
        initial_speed=speed0,
        fault_factors=factors,
        variation=variation,
        mixes=np.vstack([sensor_mix(engine, install.crosstalk), pure]),
        # a V engine's bearing loads turn in the plane: their horizontal too, for a worn bearing's knocks
        horizontal_mixes=pure if engine.is_vee else None,
        points_per_revolution=ppr,
        step=(
            LoadStep(pre + point.step_fraction * duration_s, after[0][0], after[0][1], tables[1])
            if after
            else None
        ),
    )
    return run, pre


def _with_hum_and_noise(clean: FloatArray, install: Installation, rng: np.random.Generator) -> FloatArray:
    """The bearing sensors' accelerations with mains hum (random phases) and broadband noise."""
    count, span = clean.shape
    tt = np.arange(span) / install.sample_rate
    phase = rng.uniform(0, 2 * math.pi, (count, 2))
    data = np.empty((count, span))
    for s in range(count):
        hum = install.hum[s] * (
            np.sin(2 * math.pi * install.hum_frequency * tt + phase[s, 0])
            + 0.3 * np.sin(6 * math.pi * install.hum_frequency * tt + phase[s, 1])
        )
        data[s] = clean[s] + hum + rng.normal(0.0, install.noise[s], span)
    return data


def _what_ran(
    engine: SimEngine,
    install: Installation,
    table: CycleTable,
    run: CrankRun,
    pre: float,
    duration_s: float,
    given_ratio: float,
) -> dict[str, Any]:
    """The truth of what ran inside the recording: load, speed, pressures of whole cycles ending in it."""
    ends = np.cumsum(engine.cycle_angle / run.cycle_speed)
    inside = (ends - engine.cycle_angle / run.cycle_speed >= pre) & (ends <= pre + duration_s)
    if not inside.any():
        inside = ends > pre
    imep = run.imep[:, inside]
    peak = np.interp(run.fuel[:, inside], table.fuel, table.peak_pressure)
    # a step's loads: the cycles of each side inside the recording, the two after the step left out
    firing = np.arange(ends.size)
    sides = [inside & (firing < run.step_firing), inside & (firing >= run.step_firing + 2)]
    segment_loads = [float(run.imep[:, side].mean() / engine.rated_imep) for side in sides if side.any()]
    in_span = (run.time >= pre) & (run.time <= pre + duration_s)
    covered = run.time[in_span]
    mean_speed = run.step * (covered.size - 1) / float(covered[-1] - covered[0])
    return {
        "true_load": float(imep.mean() / engine.rated_imep),
        "segment_loads": segment_loads,
        # each whole cycle inside the recording: its start from the recording's [s] and mean load [-]
        "cycle_start_s": [float(v) for v in (ends - engine.cycle_angle / run.cycle_speed)[inside] - pre],
        "cycle_loads": [float(v) for v in run.imep[:, inside].mean(axis=0) / engine.rated_imep],
        "load_given_ratio": given_ratio,
        "load_type": engine.load_type,
        "mean_speed_rpm": mean_speed * 30 / math.pi,
        "speed_rpm": mean_speed * 30 / math.pi,  # the same, under a shorter name
        "rated_speed_rpm": engine.rated_speed * 30 / math.pi,
        "cycle": "two-stroke" if engine.cycle_revolutions == 1 else "four-stroke",
        "cylinders": engine.cylinders,
        "engine_class": engine.engine_class,
        "firing_order": list(engine.firing_order),
        "imep_bar": [float(v) / 1e5 for v in imep.mean(axis=1)],
        "peak_pressure_bar": [float(v) / 1e5 for v in peak.mean(axis=1)],
        "peak_pressure_scatter": [float(v) for v in peak.std(axis=1) / peak.mean(axis=1)],
        "sensor_bearings": list(install.sensor_bearings),
        "sample_rate_hz": install.sample_rate,
    }


def random_case(
    seed: int,
    *,
    duration_s: float,
    fault: str | None = "random",
    operating: str | OperatingPoint = "baseline point",
    vee: bool = False,
) -> Case:
    """Simulate one validation case.

    Parameters
    ----------
    seed : int
        Everything comes from it (>= 0).
    duration_s : float
        Length of the recording [s] (>= 1).
    fault : str or None, optional
        "random" (each of :data:`FAULT_CLASSES` equally likely; no misfire on a single-cylinder
        engine), None or "healthy", one class, or "sensor_fault:KIND" to choose the sensor fault
        (clipped, dead_flat, dead_noise, unit_x1000, unit_per_9.81).
    operating : str or OperatingPoint, optional
        One of :data:`~validation.simulator.operating.OPERATING_CLASSES` (default "baseline point":
        the case runs where its healthy twin does), or "random": a class off the baseline's point
        (:func:`~validation.simulator.operating.draw_operating_point`); or a point, where the
        engine then runs healthy (``fault`` only draws the load told).
    vee : bool, optional
        A V engine (:func:`~validation.simulator.vee_engine.random_vee_engine`) instead of the
        seed's in-line one.

    Returns
    -------
    Case
        ``truth`` holds ``class``, ``cylinder`` (misfire, weak), ``bearing`` and ``channel`` (worn
        bearing, sensor fault), ``strength`` (misfire 1, weak 1 - factor, worn bearing the burst
        amplitude over the noise, sensor fault the clip level over the peak, the unit factor, or 0
        for a dead channel), ``sensor_fault`` (clipped, dead_flat, dead_noise, unit_x1000,
        unit_per_9.81), ``true_load`` (mean IMEP of all cylinders over the rated IMEP), the mean
        speed (``mean_speed_rpm``, also ``speed_rpm``), ``cycle``, ``cylinders``, the IMEP and peak
        pressure of every cylinder, the reversal angles and bursts of a worn bearing, and the seeds;
        on a V engine ``cylinder`` is the name (``"B3"``), ``cylinder_index`` its 1-based index in the
        order ``A1..Am, B1..Bm``, and ``vee`` is True;
        and where it ran: ``operating_class``, ``baseline_load`` (the twin's), ``test_loads`` (the
        healthy engine's, drawn), ``segment_loads`` (as run, each side of a step), ``step_time_s``
        (from the recording's start; None without a step), ``charge_law`` and ``crank_only``.

    Raises
    ------
    ValueError
        For a negative seed, a duration under 1 s or an unknown fault.
    SimulationError
        For a misfire asked of a single-cylinder engine.
    """
    return _simulate(seed, seed, twin=False, duration_s=duration_s, fault=fault, operating=operating, vee=vee)


def healthy_twin(case: Case, *, seed: int, load: float | None = None) -> Case:
    """The same engine and installation, healthy, with another noise and cycle-variation seed.

    Parameters
    ----------
    case : Case
        A case from :func:`random_case` (or a twin).
    seed : int
        Seed of the twin's noise and cycle-to-cycle variation (>= 0).
    load : float, optional
        The twin's load (mean IMEP over rated) [-]; by default the baseline's. A propeller engine
        runs it at the speed its curve gives (:func:`law_loads` gives the law's range).

    Returns
    -------
    Case
        Same description, engine id, installation, charge law and duration as ``case``, healthy,
        at the load asked (by default the baseline's: the case's own for a case at the baseline's
        point): the baseline a user would calibrate on.
    """
    truth = case.truth
    point = OperatingPoint(
        "baseline point",
        (float(truth["baseline_load"]) if load is None else float(load),),
        charge_law=str(truth["charge_law"]),
        crank_only=bool(truth["crank_only"]),
    )
    return _simulate(
        int(truth["engine_seed"]),
        seed,
        twin=True,
        duration_s=float(truth["duration_s"]),
        fault=None,
        operating=point,
        vee=bool(truth.get("vee", False)),
    )


def law_loads(case: Case) -> tuple[float, float]:
    """The lowest and highest load of the law the case's engine runs along (propeller or generator).

    Parameters
    ----------
    case : Case

    Returns
    -------
    tuple of float
        As :func:`~validation.simulator.operating.law_range` [-].
    """
    return law_range(engine_of_seed(int(case.truth["engine_seed"]), bool(case.truth.get("vee", False))))


def population(
    n: int,
    *,
    durations: tuple[float, ...] = (10.0, 30.0, 60.0),
    first_seed: int = 0,
    operating: str = "baseline point",
) -> Iterator[Case]:
    """Random cases of seeds ``first_seed .. first_seed + n - 1``, durations in turn.

    Parameters
    ----------
    n : int
        Number of cases.
    durations : tuple of float, optional
        Recording lengths, used in turn [s].
    first_seed : int, optional
        Seed of the first case.
    operating : str, optional
        As :func:`random_case` takes it.

    Yields
    ------
    Case
    """
    if not durations:
        raise ValueError("durations: expected at least one duration [s]")
    for i in range(n):
        yield random_case(first_seed + i, duration_s=durations[i % len(durations)], operating=operating)
