"""The crank angle against time: the mean speed's trend and the speed's fluctuation.

The mean speed follows the scene's trend. With ``crank_speed`` (rigid) named, the engine side of
the shaft line (free end, throws with their reciprocating parts at their mean, flywheel) turns as
one rigid body of inertia ``J``: the kinetic energy balance gives
``omega(theta)^2 = Omega^2 + (2 / J) integral (T - T_mean) dtheta``, exact for the rigid body at a
steady mean speed, and the time at each angle is ``integral dtheta / omega`` (Simpson on 512 points
per revolution); sample times are mapped back to angles by interpolation of that table. Without it
the crank turns at the trend's speed. The shaft-line and variable-inertia models give the tooth
wheel's lead over the mean rotation instead.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from monitor.errors import SceneError
from monitor.fourier import order_coefficients
from monitor.model.engine import Engine
from monitor.model.inertia import engine_side_inertia, throw_node_names
from monitor.scene.effects import CrankSpeedParams, ExternalTorqueParams, GasParams, named
from monitor.scene.model import Scene
from monitor.scene.sources import Sources
from monitor.scene.steps import joined
from monitor.scene.synthesis import MAX_ORDER, CycleTable, synthesise
from monitor.torsion.shaft_line import shaft_line_of
from monitor.torsion.time_response import harmonic_content
from monitor.torsion.time_response import simulate as respond
from monitor.torsion.variable_inertia import HarmonicExcitation, crank_of_engine, gas_excitation
from monitor.types import FloatArray

__all__ = ["FINE", "Crank", "crank_motion"]

FINE = 512  # points per revolution of the angle-time table


def _mean_speed(scene: Scene) -> Callable[[FloatArray], FloatArray]:
    op = scene.operating_point
    w0 = op.speed_rpm * math.pi / 30
    trend = op.trend
    if trend.kind == "ramp":
        assert trend.to_rpm is not None
        w1 = trend.to_rpm * math.pi / 30
        return lambda t: w0 + (w1 - w0) * np.clip(t / scene.duration_s, 0.0, 1.0)
    if trend.kind == "sine":
        return lambda t: w0 * (1 + trend.amplitude * np.sin(2 * np.pi * t / trend.period_s))
    return lambda t: np.full_like(t, w0)


@dataclass(frozen=True)
class Crank:
    """The crank's angle-time table: angles on a fine grid and the times they are reached."""

    angle: FloatArray
    time: FloatArray
    speed: Callable[[FloatArray], FloatArray]

    def angle_at(self, t: FloatArray) -> FloatArray:
        return np.interp(t, self.time, self.angle)

    def time_at(self, angle: FloatArray) -> FloatArray:
        return np.interp(angle, self.angle, self.time)


def crank_motion(
    scene: Scene,
    engine: Engine,
    sources: Sources | None,
    evaluated: list[str],
    expected: dict[str, Any],
    *,
    steps: Sequence[tuple[float, Sources]] = (),
) -> Crank:
    """The crank's angle-time table over the scene (and a second beyond), by the named speed model.

    Parameters
    ----------
    scene : Scene
        The scene: its duration [s], operating point (mean speed and its trend) and ``crank_speed``
        effect, if named (rigid, shaft_line or variable_inertia).
    engine : Engine
        The simulated engine (its inertias and shaft line, for the speed models).
    sources : Sources or None
        The named sources' torque orders (:func:`~monitor.scene.sources.sources_of`); needed by the
        rigid and shaft-line models, None if no source is named.
    evaluated : list of str
        The effects evaluated so far; ``"crank_speed"`` is appended when it is.
    expected : dict
        The truth's expected orders; the crank speed's (``"crank speed"``) or the free angular
        vibration's (``"crank angular vibration"``) are added when ``crank_speed`` is named.
    steps : sequence of (float, Sources), optional
        The load steps' times [s] and the sources from each on (:mod:`monitor.scene.steps`): the rigid
        crank's speed takes the sources of the epoch each angle is reached in (the truth: the first's).

    Returns
    -------
    Crank
        Crank angles [rad] on a fine grid (:data:`FINE` points per revolution), the times they are
        reached [s], and the mean speed against time [rad/s].

    Raises
    ------
    SceneError
        If the speed model cannot be evaluated for the scene or engine (the message says what to change).
    """
    mean = _mean_speed(scene)
    span = scene.duration_s + 1.0  # a second beyond the end, so the last samples have angles
    coarse_t = np.linspace(0.0, span, max(2, int(span * 200)) + 1)
    coarse_w = mean(coarse_t)
    coarse_a = np.concatenate([[0.0], np.cumsum(0.5 * (coarse_w[1:] + coarse_w[:-1]) * np.diff(coarse_t))])
    revolutions = coarse_a[-1] / (2 * math.pi)
    count = 2 * math.ceil(revolutions * FINE / 2) + 1  # odd, for Simpson
    angle = np.linspace(0.0, coarse_a[-1], count)
    omega_mean = np.interp(np.interp(angle, coarse_a, coarse_t), coarse_t, coarse_w)
    omega = omega_mean
    crank_speed = named(scene, "crank_speed")
    if isinstance(crank_speed, CrankSpeedParams) and crank_speed.model == "shaft_line":
        evaluated.append("crank_speed")
        assert sources is not None
        lead = _shaft_line_lead(scene, engine, sources, angle, omega_mean, expected)
        time = np.interp(angle - lead, coarse_a, coarse_t)
        return Crank(angle, time, lambda t: mean(np.asarray(t, dtype=np.float64)))
    if isinstance(crank_speed, CrankSpeedParams) and crank_speed.model == "variable_inertia":
        evaluated.append("crank_speed")
        return _variable_inertia_crank(scene, engine, crank_speed, angle, omega_mean, mean, expected)
    if crank_speed is not None:
        evaluated.append("crank_speed")
        assert sources is not None  # check_effects saw to a torque source
        omega = _rigid_speed(engine, sources, angle, omega_mean, expected)
        if steps:
            omegas = [omega] + [_rigid_speed(engine, s, angle, omega_mean, {}) for _, s in steps]
            starts = [0.0] + [t for t, _ in steps]
            omega = joined(starts, omegas, np.interp(angle, coarse_a, coarse_t))
    slowness = 1.0 / omega
    h = angle[1] - angle[0]
    # Simpson over pairs of intervals, trapezoid halves for the odd points in between
    time = np.empty(angle.size)
    time[0] = 0.0
    pairs = h / 3 * (slowness[:-2:2] + 4 * slowness[1:-1:2] + slowness[2::2])
    time[2::2] = np.cumsum(pairs)
    mid = h / 12 * (5 * slowness[:-2:2] + 8 * slowness[1:-1:2] - slowness[2::2])  # first half of each pair
    time[1::2] = time[:-2:2] + mid
    return Crank(angle, time, lambda t: mean(np.asarray(t, dtype=np.float64)))


def _rigid_speed(
    engine: Engine, sources: Sources, angle: FloatArray, omega_mean: FloatArray, expected: dict[str, Any]
) -> FloatArray:
    """The rigid engine side's speed at each angle [rad/s] (kinetic energy balance), and its truth."""
    assert sources.torque is not None
    inertia = _rigid_inertia(engine)
    k = sources.orders
    positive = k > 0
    # the integral of T - T_mean: sum over k > 0 of T_k exp(i k a) / (i k), with T_k = A_k + w^2 B_k
    over_k = np.where(positive, 1.0 / (1j * np.where(positive, k, 1.0)), 0.0)
    integral_a, integral_b = (
        CycleTable.of((part * over_k)[None, :], k, engine.cycle_revolutions, np.zeros(1)).at(angle, angle)
        for part in (sources.torque.a, sources.torque.b)
    )
    energy = omega_mean**2 + (2.0 / inertia) * (integral_a + omega_mean**2 * integral_b)
    if np.any(energy <= 0):
        raise SceneError(
            "the crank would stop within a revolution at this speed (torque fluctuation larger "
            "than the rotating energy): raise the speed"
        )
    omega = np.sqrt(energy)
    # the truth: the speed's orders over one cycle at the mean speed at the start
    R = engine.cycle_revolutions
    cycle: FloatArray = np.arange(1024 * R, dtype=np.float64) * (2 * math.pi / 1024)
    w0 = float(omega_mean[0])
    over_a = synthesise(sources.torque.a[positive] / (1j * k[positive]), k[positive], cycle)
    over_b = synthesise(sources.torque.b[positive] / (1j * k[positive]), k[positive], cycle)
    steady = np.sqrt(w0**2 + (2.0 / inertia) * (over_a + w0**2 * over_b))
    oc = order_coefficients(steady, cycle_revolutions=R, max_order=MAX_ORDER)
    expected["crank speed"] = {
        "orders": oc.orders.tolist(),
        "amplitude": np.abs(oc.coefficients).tolist(),
        "phase_deg": np.degrees(np.angle(oc.coefficients)).tolist(),
        "unit": "rad/s",
        "speed_rpm": w0 * 30 / math.pi,
    }
    return np.asarray(omega)


def _shaft_line_lead(
    scene: Scene,
    engine: Engine,
    sources: Sources,
    angle: FloatArray,
    omega_mean: FloatArray,
    expected: dict[str, Any],
) -> FloatArray:
    """The tooth wheel's angle lead over the mean rotation, from the shaft line's forced response [rad].

    Tabulated on a grid of mean speeds over the trend (241 for a run-up: a resonance is sharp) and
    interpolated linearly in speed; order by order ``Re Theta_k exp(i k theta)`` (first order in it).
    """

    if engine.shaft_line is None:
        raise SceneError(f"crank_speed (shaft_line) needs the [shaft_line] of engine {engine.id!r}")
    line = shaft_line_of(engine)
    wheel = engine.shaft_line.tooth_wheel or line.node_names[0]
    probe = line.index(wheel)
    throws = [line.index(name) for name in throw_node_names(engine)]
    external = named(scene, "external_torque")
    where = None
    if isinstance(external, ExternalTorqueParams):
        default = (
            engine.shaft_line.driven_end[-1].name if engine.shaft_line.driven_end else line.node_names[-1]
        )
        name = external.element or default
        if name not in line.node_names:
            raise SceneError(
                f"effect 'external_torque': element {name!r} is not on the shaft line; elements: "
                f"{', '.join(line.node_names)}"
            )
        where = line.index(name)
    lo, hi = float(omega_mean.min()), float(omega_mean.max())
    speeds = np.array([lo]) if hi - lo <= 1e-9 * hi else np.linspace(lo, hi, 241)
    k = sources.orders
    table = np.zeros((speeds.size, k.size), dtype=np.complex128)
    for i, w in enumerate(speeds):
        torque = np.zeros((len(line.nodes), k.size), dtype=np.complex128)
        if sources.cylinder_torque is not None:
            np.add.at(torque, throws, sources.cylinder_torque.at(w))  # a V's two cylinders on one throw
        if where is not None and sources.external is not None:
            torque[where] += sources.external
        for j in np.flatnonzero(k > 0):
            table[i, j] = line.harmonic_response(float(k[j] * w), torque[:, j])[0][probe]
    lead = CycleTable.of(table, k, engine.cycle_revolutions, speeds).at(angle, omega_mean)
    start_speed = float(omega_mean[0])
    at_start = np.array(
        [
            np.interp(start_speed, speeds, table[:, j].real)
            + 1j * np.interp(start_speed, speeds, table[:, j].imag)
            for j in range(k.size)
        ]
    )
    fluctuation = 1j * k * start_speed * at_start
    fluctuation[0] = start_speed
    expected["crank speed"] = {
        "orders": k.tolist(),
        "amplitude": np.abs(fluctuation).tolist(),
        "phase_deg": np.degrees(np.angle(fluctuation)).tolist(),
        "unit": "rad/s",
        "speed_rpm": start_speed * 30 / math.pi,
        "element": wheel,
        "resonance_table": {
            "speed_rpm": (speeds * 30 / math.pi).tolist(),
            "angle_rad_by_order": {
                f"{o:g}": np.abs(table[:, j]).tolist() for j, o in enumerate(k) if o > 0 and o <= 12
            },
        },
    }
    return lead


def _variable_inertia_crank(
    scene: Scene,
    engine: Engine,
    params: CrankSpeedParams,
    angle: FloatArray,
    omega_mean: FloatArray,
    mean: Callable[[FloatArray], FloatArray],
    expected: dict[str, Any],
) -> Crank:
    """The crank's angle ``tau + gamma(tau)`` against the flywheel's ``tau = Omega t`` (paper 002 eq. 6)."""

    if scene.operating_point.trend.kind != "constant":
        raise SceneError("crank_speed (variable_inertia) is for a constant speed: remove the trend")
    if "inertia" not in scene.effects:
        raise SceneError(
            "crank_speed (variable_inertia) is driven by the reciprocating parts' inertia: "
            "add inertia to [effects]"
        )
    if engine.shaft_line is None:
        raise SceneError(f"crank_speed (variable_inertia) needs the [shaft_line] of engine {engine.id!r}")
    faults = [name for name in ("misfire", "weak_cylinder", "leaking_cylinder") if name in scene.effects]
    gas = named(scene, "gas")
    if faults or (isinstance(gas, GasParams) and gas.scale is not None):
        raise SceneError(
            "crank_speed (variable_inertia) is one equivalent crank driven by one healthy cylinder's gas "
            f"torque: remove {', '.join(faults) or 'gas.scale'} or use the rigid or shaft_line model"
        )
    w = float(omega_mean[0])
    excitation = (
        gas_excitation(engine, w, load=scene.operating_point.load, max_order=MAX_ORDER)
        if "gas" in scene.effects
        else HarmonicExcitation()
    )
    crank = dataclasses.replace(crank_of_engine(engine, w), zeta=params.damping, excitation=excitation)
    initial = (params.initial_twist_rad, 0.0)
    response = respond(crank, angle, initial=initial, form="linear", integrator="periodic")
    crank_angle = angle + response.gamma
    if not np.all(np.isfinite(crank_angle)) or np.any(1.0 + response.gamma_prime <= 0):
        raise SceneError(
            f"the variable-inertia crank (epsilon {crank.epsilon:.3g}, r {crank.r:.3g}) does not settle: "
            "it is in an unstable range; raise the damping or change the speed"
        )
    truth: dict[str, Any] = {"speed_rpm": w * 30 / math.pi, "epsilon": crank.epsilon, "r": crank.r}
    if params.damping == 0.0 and not excitation.orders:
        # a free vibration: its principal order and sidebands (the Floquet analysis of paper 002 Table 2)
        content = harmonic_content(crank, initial=initial)
        truth |= {
            "principal_order": float(content["principal_order"]),
            "orders": np.asarray(content["orders"]).tolist(),
            "amplitude": np.asarray(content["amplitudes"]).tolist(),
            "unit": "rad",
        }
        expected["crank angular vibration"] = truth
    else:
        # the steady speed's orders in the crank's own angle over the last whole cycle
        R = engine.cycle_revolutions
        cycle = 2 * math.pi * R
        cycles = math.floor(crank_angle[-1] / cycle)
        if cycles < 2:
            raise SceneError(
                "crank_speed (variable_inertia) needs two whole cycles or more: lengthen the scene"
            )
        on_cycle = (cycles - 1) * cycle + np.arange(FINE * R) * (cycle / (FINE * R))
        steady = w * (1.0 + np.interp(on_cycle, crank_angle, response.gamma_prime))
        oc = order_coefficients(steady, cycle_revolutions=R, max_order=MAX_ORDER)
        truth |= {
            "orders": oc.orders.tolist(),
            "amplitude": np.abs(oc.coefficients).tolist(),
            "phase_deg": np.degrees(np.angle(oc.coefficients)).tolist(),
            "unit": "rad/s",
        }
        expected["crank speed"] = truth
    return Crank(crank_angle, angle / w, lambda t: mean(np.asarray(t, dtype=np.float64)))


def _rigid_inertia(engine: Engine) -> float:
    """The engine side of the shaft line as one rigid body [kg m^2] (see ``engine_side_inertia``)."""

    if engine.shaft_line is None:
        raise SceneError(
            f"effect 'crank_speed' (rigid) needs the inertias of engine {engine.id!r}: add its [shaft_line]"
        )
    return engine_side_inertia(engine)
