"""The named sources' orders: engine torque, main-bearing forces, cylinder pressures.

Order domain, quasi-static.  Every force and torque of the engine is a sum
of orders of the crank (cycle) angle whose coefficients depend on the mean
speed ``Omega`` as ``A + Omega^2 B``: gas forces and weights do not depend
on it, inertia forces grow with its square (the angular acceleration of a
slow trend is left out). Each named source contributes its coefficients,
cylinder by cylinder (the gas part of cylinder ``c`` scaled by its faults),
phase-shifted by the firing angles as in :mod:`monitor.model.crankshaft`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from pydantic import BaseModel

from monitor.errors import SceneError
from monitor.fourier import order_coefficients
from monitor.model.banks import slave_cylinders, to_engine_frame
from monitor.model.crankshaft import EngineModel, GasModel
from monitor.model.engine import Engine
from monitor.model.forces import crank_train_forces
from monitor.model.gas import gas_force
from monitor.scene.effects import (
    ExternalTorqueParams,
    GasParams,
    InertiaParams,
    LeakingCylinderParams,
    MisfireParams,
    UnbalanceParams,
    WeakCylinderParams,
    named,
)
from monitor.scene.model import Scene
from monitor.scene.synthesis import MAX_ORDER
from monitor.types import ComplexArray, FloatArray

__all__ = ["Orders", "Sources", "external_torque_orders", "sources_of"]


@dataclass(frozen=True)
class Orders:
    """Coefficients ``A + Omega^2 B`` of one quantity's orders (complex, peak)."""

    orders: FloatArray
    a: ComplexArray  # shape (..., n_orders)
    b: ComplexArray

    def at(self, speed: FloatArray | float) -> ComplexArray:
        w2 = np.asarray(speed, dtype=np.float64) ** 2
        return np.asarray(self.a + np.multiply.outer(w2, self.b) if np.ndim(w2) else self.a + w2 * self.b)


@dataclass
class Sources:
    """The named sources' orders: engine torque, bearing forces (x, y), cylinder pressures."""

    orders: FloatArray
    torque: Orders | None = None
    bearing: Orders | None = None  # shape (n_bearings, 2, n_orders)
    pressure: FloatArray | None = None  # (n_cylinders, grid) absolute [Pa] over each cylinder's cycle
    grid: FloatArray | None = None
    gas_scale: list[float] = field(default_factory=list)
    charge_scale: list[float] = field(default_factory=list)
    cylinder_torque: Orders | None = None  # shape (n_cylinders, n_orders): each throw's own
    gas_model: str = "none"  # the pressure model used ("parametric" when cylinder faults are named)
    external: ComplexArray | None = None  # the external torque's orders (speed-independent)


def sources_of(scene: Scene, engine: Engine, evaluated: list[str]) -> Sources | None:
    """Order coefficients of every named source (None if none is named: nothing is computed).

    Parameters
    ----------
    scene : Scene
        The scene: its load and the named sources (inertia, gas, unbalance, external_torque) and
        cylinder faults (misfire, weak_cylinder, leaking_cylinder).
    engine : Engine
        The simulated engine (cylinders, firing angles, cycle, bearings).
    evaluated : list of str
        The effects evaluated so far; each source and fault evaluated here is appended.

    Returns
    -------
    Sources or None
        Engine torque [N m] and main-bearing forces [N] as orders of the crank angle
        (``A + Omega^2 B``), and the cylinders' pressures [Pa] over their cycle, as far as the named
        sources give them.

    Raises
    ------
    SceneError
        For a gas scale of another length than the cylinders, a cylinder or throw the engine does
        not have, or cylinder faults with the measured gas model.
    """
    inertia = named(scene, "inertia")
    gas = named(scene, "gas")
    unbalance = named(scene, "unbalance")
    external = named(scene, "external_torque")
    n = engine.cylinders
    if isinstance(gas, GasParams) and gas.scale is not None and len(gas.scale) != n:
        raise SceneError(f"effect 'gas': scale has {len(gas.scale)} values; the engine has {n} cylinders")
    if inertia is None and gas is None and unbalance is None:
        if external is None:
            return None
        evaluated.append("external_torque")
        orders = np.arange(round(MAX_ORDER * engine.cycle_revolutions) + 1) / engine.cycle_revolutions
        speed_free = np.zeros(orders.size, dtype=np.complex128)
        outside = external_torque_orders(external, orders)
        torque = Orders(orders, outside, speed_free)
        return Sources(orders, torque=torque, gas_scale=[1.0] * n, charge_scale=[1.0] * n, external=outside)
    gas_scale, charge_scale = _cylinder_scales(scene, engine, gas, evaluated)
    model = _engine_model(engine, inertia, gas, faulted=any(s != 1.0 for s in gas_scale + charge_scale))
    stacked, pressure = _cylinder_forces(
        scene, engine, model, inertia, gas, gas_scale, charge_scale, evaluated
    )
    oc = order_coefficients(stacked, cycle_revolutions=engine.cycle_revolutions, max_order=MAX_ORDER)
    orders = oc.orders
    # each cylinder's own coefficients delayed by its firing angle (model.crankshaft.phase_shift's rule)
    shifts = np.exp(-1j * np.multiply.outer(engine.firing_angles, orders))
    coefficients = oc.coefficients * shifts[:, None, None, :]  # (n_cyl, 2, 3, n_orders)
    torque = Orders(orders, coefficients[:, 0, 0].sum(axis=0), coefficients[:, 1, 0].sum(axis=0))
    # each throw's forces in the engine's frame (a V engine's cylinders lean with their banks)
    throw_a = to_engine_frame(coefficients[:, 0, 1:3], engine.cylinder_axes)  # (n_cyl, 2, n_orders)
    throw_b = to_engine_frame(coefficients[:, 1, 1:3], engine.cylinder_axes)
    if unbalance is not None:
        assert isinstance(unbalance, UnbalanceParams)
        evaluated.append("unbalance")
        c = unbalance.throw
        if not 1 <= c <= engine.throws:
            raise SceneError(f"effect 'unbalance': throw {c} does not exist (the engine has {engine.throws})")
        # U w^2 (sin, cos) of the throw's angle from the vertical plus the offset: order 1 of the crank
        # angle; the throw's first cylinder (A bank on a V) is at its TDC, its own axis, at its firing angle
        throw_angle = engine.cylinder_axes[c - 1] - engine.firing_angles[c - 1]
        phase = unbalance.angle_deg * math.pi / 180 + throw_angle
        k1 = int(np.argmin(np.abs(orders - 1.0)))
        throw_b[c - 1, 0, k1] += unbalance.kgm * -1j * np.exp(1j * phase)
        throw_b[c - 1, 1, k1] += unbalance.kgm * np.exp(1j * phase)
    share = engine.bearing_share
    bearing = Orders(
        orders, np.einsum("bc,cko->bko", share, throw_a), np.einsum("bc,cko->bko", share, throw_b)
    )
    has_cylinders = inertia is not None or gas is not None
    per_cylinder = Orders(orders, coefficients[:, 0, 0], coefficients[:, 1, 0]) if has_cylinders else None
    external_torque: ComplexArray | None = None
    if external is not None:
        evaluated.append("external_torque")
        external_torque = external_torque_orders(external, orders)
        torque = Orders(orders, torque.a + external_torque, torque.b)
    return Sources(
        orders,
        gas_model=model.gas if gas is not None else "none",
        cylinder_torque=per_cylinder,
        external=external_torque,
        torque=torque if (has_cylinders or external is not None) else None,
        bearing=bearing,
        pressure=pressure,
        grid=model.crank_angle,
        gas_scale=gas_scale,
        charge_scale=charge_scale,
    )


def _cylinder_number(engine: Engine, cylinder: int | str, effect: str) -> int:
    """A cylinder a scene names, as its number (1-based index): ``3`` in line, ``"B3"`` (or its number)
    on a V engine."""
    names = engine.cylinder_names
    if isinstance(cylinder, str):
        if cylinder not in names:
            raise SceneError(
                f"effect {effect!r}: cylinder {cylinder!r} does not exist (the engine's cylinders: "
                f"{', '.join(names)})"
            )
        return names.index(cylinder) + 1
    if not 1 <= cylinder <= len(names):
        raise SceneError(
            f"effect {effect!r}: cylinder {cylinder} does not exist (the engine has {len(names)})"
        )
    return cylinder


def _cylinder_scales(
    scene: Scene, engine: Engine, gas: BaseModel | None, evaluated: list[str]
) -> tuple[list[float], list[float]]:
    """Each cylinder's heat-release and charge-pressure scale: the gas source's, times its faults'."""
    n = engine.cylinders
    gas_scale = list(gas.scale) if isinstance(gas, GasParams) and gas.scale is not None else [1.0] * n
    charge_scale = [1.0] * n
    for effect, params in (
        ("misfire", named(scene, "misfire")),
        ("weak_cylinder", named(scene, "weak_cylinder")),
        ("leaking_cylinder", named(scene, "leaking_cylinder")),
    ):
        if params is None:
            continue
        evaluated.append(effect)
        cylinders = (
            params.cylinders if isinstance(params, MisfireParams) else [params.cylinder]  # type: ignore[attr-defined]
        )
        for named_cylinder in cylinders:
            c = _cylinder_number(engine, named_cylinder, effect)
            if isinstance(params, MisfireParams):
                gas_scale[c - 1] = 0.0
            elif isinstance(params, WeakCylinderParams):
                gas_scale[c - 1] *= params.scale
            elif isinstance(params, LeakingCylinderParams):
                charge_scale[c - 1] = params.compression
    return gas_scale, charge_scale


def _engine_model(
    engine: Engine, inertia: BaseModel | None, gas: BaseModel | None, *, faulted: bool
) -> EngineModel:
    """The crank-train model of the named sources (parametric gas when a cylinder fault scales it)."""
    rod_model = inertia.rod_model if isinstance(inertia, InertiaParams) else "rigid"
    kinematics = inertia.kinematics if isinstance(inertia, InertiaParams) else "exact"
    gas_model: GasModel = "none"
    if isinstance(gas, GasParams):
        gas_model = gas.model
        if faulted:
            if gas_model == "measured":
                raise SceneError(
                    "cylinder faults scale the parametric cycle's heat release and charge pressure: "
                    "set gas.model = 'parametric' (or 'auto')"
                )
            gas_model = "parametric"
    return EngineModel(
        engine,
        grid_size=1024,
        rod_model=rod_model,
        kinematics=kinematics,
        gas=gas_model,
    )


def _cylinder_forces(
    scene: Scene,
    engine: Engine,
    model: EngineModel,
    inertia: BaseModel | None,
    gas: BaseModel | None,
    gas_scale: list[float],
    charge_scale: list[float],
    evaluated: list[str],
) -> tuple[FloatArray, FloatArray | None]:
    """Each cylinder's torque and pin forces (x, y) as ``A + w^2 B`` over its cycle, and its pressure.

    Returns the rows (n_cylinders, 2 (A, B), 3 (torque, x, y), grid) and the absolute pressures
    (n_cylinders, grid) [Pa] (None without gas).
    """
    n = engine.cylinders
    rod_model = model.rod_model
    kin, train = model.kinematics, model.train
    load = scene.operating_point.load
    ambient = model.ambient_pressure
    slaves = slave_cylinders(n, engine.vee)  # an articulated rod's slaves move otherwise (their own rows)

    def rows(speed: float, force: FloatArray | float, gravity: float, slave: bool = False) -> FloatArray:
        if slave:
            return model.slave_rows(speed, force, gravity)[[2, 4, 5]]  # torque, pin force x and y
        f = crank_train_forces(
            kin, train, crank_speed=speed, gas_force=force, rod_model=rod_model, gravity=gravity
        )
        return np.stack([f.torque, f.pin_force_x, f.pin_force_y])

    parts: list[tuple[FloatArray, FloatArray]] = []  # per cylinder: (A rows, B rows) over the cycle grid
    zero = np.zeros((3, model.grid_size))
    inertia_a = {False: zero, True: zero}  # a slider-crank's, a slave's
    inertia_b = {False: zero, True: zero}
    if inertia is not None:
        evaluated.append("inertia")
        unb_x, unb_y = model.unbalance_force(1.0)
        for slave in {False, bool(slaves.any())}:
            base = rows(1.0, 0.0, model.gravity, slave)
            twice = rows(2.0, 0.0, model.gravity, slave)
            inertia_b[slave] = (twice - base) / 3.0  # forces a + w^2 b at w = 1 and 2
            inertia_a[slave] = base - inertia_b[slave]
            inertia_b[slave] = inertia_b[slave] + np.stack([np.zeros_like(unb_x), unb_x, unb_y])
    pressure = None
    if gas is not None:
        evaluated.append("gas")
        if model.gas == "parametric":
            assert model._cycle is not None and model._setup.gas_basis is not None
            basis = {False: model._setup.gas_basis}
            if model._slave is not None and model._slave.gas_basis is not None:
                basis[True] = model._slave.gas_basis  # on the slave's own volume, a master's fuel
            charge, heat = model._cycle.charge_pressure(load), model._cycle.heat_release(load)
            pressure = np.stack(
                [
                    charge_scale[c] * charge * basis[bool(slaves[c])][0]
                    + gas_scale[c] * heat * basis[bool(slaves[c])][1]
                    for c in range(n)
                ]
            )
        else:
            pressure = np.stack(
                [model.slave_pressure(load) if slaves[c] else model.cylinder_pressure(load) for c in range(n)]
            )
    for c in range(n):
        slave = bool(slaves[c])
        a_rows = inertia_a[slave].copy()
        if pressure is not None:
            f_gas = gas_force(pressure[c], engine.piston_area, ambient)
            # the gas part alone (linear in it)
            a_rows += rows(1.0, f_gas, 0.0, slave) - rows(1.0, 0.0, 0.0, slave)
        parts.append((a_rows, inertia_b[slave]))
    return np.stack([np.stack([a, b]) for a, b in parts]), pressure  # (n_cyl, 2, 3, grid)


def external_torque_orders(params: BaseModel, orders: FloatArray) -> ComplexArray:
    """The external torque's coefficients on the grid of orders (speed-independent) [N m].

    Parameters
    ----------
    params : ExternalTorqueParams
        The ``external_torque`` effect: its orders, each with an amplitude [N m] and a phase [deg].
    orders : ndarray
        The grid of orders, shape (n_orders,) [-]: multiples of one over the cycle's revolutions.

    Returns
    -------
    ndarray of complex
        Complex peak amplitude at each order of the grid, shape (n_orders,) [N m]; 0 where none is given.

    Raises
    ------
    SceneError
        If an order is not on the grid (not a multiple of its step, or above its highest).
    """
    assert isinstance(params, ExternalTorqueParams)
    out = np.zeros(orders.size, dtype=np.complex128)
    for item in params.orders:
        i = int(np.argmin(np.abs(orders - item.order)))
        if abs(orders[i] - item.order) > 1e-9:
            step = orders[1] - orders[0]
            raise SceneError(
                f"effect 'external_torque': order {item.order:g} is not a multiple of {step:g} "
                f"(the engine's cycle) or above {orders[-1]:g}"
            )
        out[i] += item.amplitude_nm * np.exp(1j * math.radians(item.phase_deg))
    return out
