"""The multi-cylinder crankshaft: phasing, engine torque, main-bearing forces, free forces.

Every cylinder's crank train is the same function of its own crank angle
``alpha_c = alpha - phi_c`` (``phi_c`` its firing angle, see
:mod:`monitor.model.engine`), so a quantity of cylinder ``c`` has the order
coefficients of cylinder 1 times ``exp(-j k phi_c)``: the phase shift is
exact and costs one complex multiplication per order.  Four-stroke gas
quantities repeat over two revolutions (half orders); inertia quantities
repeat every revolution.

Articulated rods.  On a V engine with master-and-slave rods the trailing
bank's cylinders (the slaves) are another function of their own crank angle,
the same for all of them: :meth:`EngineModel.slave_rows` gives it over the
grid of a slave's nominal crank angle (from where its crank points along its
bore, a bank angle after its master's TDC, which its firing angle names),
through :class:`monitor.model.articulated.ArticulatedRod` at the master's
crank angle a bank angle on, and turned from the master's axes into the
slave's.  Its cycle is timed from its own TDC, ``tdc_offset`` off the
nominal one, on its own volume; it burns the fuel a master burns at the load.
The slave's rod is the two-mass rod whatever ``rod_model`` says (its
rigid-body inertia torque is left out).

Main bearings.  Crank throw ``c`` carries the force of its rod on the crank
pin plus the centrifugal force of its net unbalance (crank pin and webs less
counterweights, ``U_c omega^2`` outwards along the crank).  Its two main
bearings share that force by the lever rule, as if the crankshaft were cut
at every bearing (statically determinate: the classical "split crankshaft"
assumption; the continuous, statically indeterminate shaft spreads some load
to the next bearings, which this model leaves out).  The force reported for
bearing ``b`` is the force the crankshaft exerts on it, in the section frame.

Free forces and moments.  Gas forces are internal (the head takes the
opposite of the piston's push) and so are guide forces with their bearing
reactions; what shakes the engine on its foundation is the sum of the
inertia forces of the moving parts (piston, rod, throw unbalance), and their
moments about the engine's middle along the crankshaft.

References
----------
004: Kluczyk (single-cylinder forces, extended here to n cylinders).
000: Murawski (orders of the inertia forces; 24 gas-force orders of two-stroke engines).
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass, replace
from typing import Literal

import numpy as np

from monitor.errors import DataQualityWarning, ModelError
from monitor.fourier import cycle_grid
from monitor.model.articulated import ArticulatedRod
from monitor.model.banks import slave_masses
from monitor.model.engine import Engine
from monitor.model.forces import (
    STANDARD_GRAVITY,
    CrankTrain,
    CrankTrainForces,
    RodModel,
    crank_kinematics,
    crank_train_forces,
)
from monitor.model.gas import ParametricCycle, gas_force, read_pressure_trace, resample_trace
from monitor.model.kinematics import check_crank_speed
from monitor.types import ComplexArray, FloatArray

__all__ = [
    "EngineModel",
    "GasModel",
    "phase_shift",
]

GasModel = Literal["auto", "parametric", "measured", "none"]


def phase_shift(coefficients: ComplexArray, orders: FloatArray, angles: FloatArray) -> ComplexArray:
    """Coefficients of copies of a quantity delayed by ``angles``: ``Q_k exp(-j k phi)``.

    Parameters
    ----------
    coefficients : ndarray, shape (..., n_orders)
        Order coefficients of the quantity of cylinder 1.
    orders : ndarray, shape (n_orders,)
        The orders k [-].
    angles : ndarray, shape (n_cylinders,)
        Firing angle of each cylinder [rad].

    Returns
    -------
    ndarray, shape (n_cylinders, ..., n_orders)
    """
    rotation = np.exp(-1j * np.multiply.outer(angles, orders))  # (n_cyl, n_orders)
    expand = (slice(None),) + (None,) * (coefficients.ndim - 1) + (slice(None),)
    return coefficients[None, ...] * rotation[expand]


@dataclass(frozen=True)
class _Setup:
    alpha: FloatArray
    gas_basis: tuple[FloatArray, FloatArray] | None
    measured_pressure: FloatArray | None


@dataclass(frozen=True)
class _Slave:
    """An articulated rod's slave cylinder over the grid of its own crank angle (module docstring)."""

    rod: ArticulatedRod
    master_angle: FloatArray  # the master's crank angle at each of the grid's [rad]
    gas_basis: tuple[FloatArray, FloatArray] | None  # on the slave's own volume, from its own TDC
    measured_pressure: FloatArray | None
    reciprocating_mass: float  # the slave piston and its rod's piston-pin share [kg]
    knuckle_mass: float  # the slave rod's knuckle-pin share [kg]


class EngineModel:
    """An engine's crank-train model, set up once, evaluated at any operating point.

    Parameters
    ----------
    engine : Engine
        The engine description.
    grid_size : int, optional
        Samples per revolution of the angular grid (the cycle has this times
        the revolutions per cycle).  Must resolve the orders asked for; the
        order results state the aliasing error this grid leaves.
    rod_model : {"rigid", "two-mass"}
        Connecting-rod model.
    kinematics : {"exact", "approx"}
        Piston kinematics ("approx" only with the two-mass rod).
    gas : {"auto", "parametric", "measured", "none"}
        Cylinder-pressure source: "auto" takes the measured trace if the
        description has one, else the parametric cycle; "none" gives inertia only.
    gravity : float, optional
        Acceleration of gravity [m/s^2]; 0 leaves the weights out.
    """

    def __init__(
        self,
        engine: Engine,
        *,
        grid_size: int = 1024,
        rod_model: RodModel = "rigid",
        kinematics: Literal["exact", "approx"] = "exact",
        gas: GasModel = "auto",
        gravity: float = STANDARD_GRAVITY,
    ) -> None:
        if grid_size < 16 or grid_size % 2:
            raise ModelError(
                f"grid_size = {grid_size!r}: expected an even number >= 16 samples per revolution"
            )
        self.engine = engine
        self.train = CrankTrain.of(engine)
        self.rod_model: RodModel = rod_model
        self.gravity = gravity
        self.cycle_revolutions = engine.cycle_revolutions
        self.grid_size = grid_size * self.cycle_revolutions
        alpha = cycle_grid(self.grid_size, self.cycle_revolutions)
        self.kinematics = crank_kinematics(alpha, engine.crank_radius, engine.rod_ratio, model=kinematics)
        if rod_model == "rigid" and kinematics != "exact":
            raise ModelError(
                "kinematics = 'approx' is defined for rod_model = 'two-mass' only (the classic model)"
            )
        if gas == "auto":
            gas = "measured" if engine.pressure_trace is not None else "parametric"
        self.gas: GasModel = gas
        self._cycle: ParametricCycle | None = None
        basis = None
        measured = None
        if gas == "parametric":
            self._cycle = ParametricCycle.of(engine)
            basis = self._cycle.basis(alpha)
        elif gas == "measured":
            angle, pressure = read_pressure_trace(engine)
            measured = resample_trace(angle, pressure, alpha, cycle_revolutions=self.cycle_revolutions)
        elif gas != "none":
            raise ModelError(f"gas = {gas!r}: expected 'auto', 'parametric', 'measured' or 'none'")
        self._setup = _Setup(alpha, basis, measured)
        self._ambient = (engine.combustion.ambient_pressure_bar if engine.combustion else 1.013) * 1e5
        self._slave = self._slave_setup(alpha)

    def _slave_setup(self, alpha: FloatArray) -> _Slave | None:
        """The slave cylinder's grid, gas basis and masses (None without articulated rods)."""
        rod, vee = self.engine.articulated, self.engine.vee
        if rod is None or vee is None:
            return None
        stroke = rod.stroke()
        own = alpha - stroke.tdc_offset  # from the slave's own TDC, where its cycle is timed
        basis = measured = None
        if self._cycle is not None:
            cycle = replace(
                self._cycle, displacement=lambda theta: rod.slave_displacement(theta + stroke.tdc_angle)
            )
            basis = cycle.basis(own)
        elif self.gas == "measured":
            angle, pressure = read_pressure_trace(self.engine)
            measured = resample_trace(angle, pressure, own, cycle_revolutions=self.cycle_revolutions)
        reciprocating, knuckle = slave_masses(vee, self.engine.masses.piston_assembly_kg)
        return _Slave(rod, alpha + rod.bank_angle, basis, measured, reciprocating, knuckle)

    @property
    def ambient_pressure(self) -> float:
        """Around the engine, what the gas force is measured from [Pa]."""
        return self._ambient

    @property
    def articulated(self) -> bool:
        """Whether the engine's trailing bank hangs on articulated rods (:meth:`slave_rows`)."""
        return self._slave is not None

    def slave_pressure(self, load: float) -> FloatArray:
        """Absolute pressure of a slave cylinder over the grid, from its nominal firing TDC [Pa].

        Its cycle is timed from its own TDC, ``tdc_offset`` away, on its own volume; it burns the fuel
        a master cylinder burns at the load (the same heat released), so its own stroke gives it a
        little more or less work. A measured trace is the master's, from the slave's own TDC.
        """
        slave = self._slave
        if slave is None:
            raise ModelError(f"engine {self.engine.id!r} has no articulated rods: it has no slave cylinders")
        if slave.gas_basis is not None:
            assert self._cycle is not None
            a, b = slave.gas_basis
            return self._cycle.charge_pressure(load) * a + self._cycle.heat_release(load) * b
        if slave.measured_pressure is not None:
            return slave.measured_pressure
        return np.full_like(self._setup.alpha, self._ambient)

    def slave_rows(self, crank_speed: float, gas_force: FloatArray | float, gravity: float) -> FloatArray:
        """A slave cylinder's inertia force, torque, gas torque and crank-pin force over the grid.

        Parameters
        ----------
        crank_speed : float
            omega [rad/s].
        gas_force : ndarray or float
            On the slave piston over the grid (from its nominal firing TDC), towards the crank [N].
        gravity : float
            [m/s^2] (:meth:`monitor.model.articulated.ArticulatedRod.slave_train_forces`).

        Returns
        -------
        ndarray, shape (6, grid)
            Inertia force across and along the slave's own axis [N], torque [N m], the gas force's
            torque [N m], crank-pin force across and along the slave's axis [N]: the rows of
            :func:`monitor.model.predicted.predict_orders`, without the throw's unbalance.
        """
        slave = self._slave
        if slave is None:
            raise ModelError(f"engine {self.engine.id!r} has no articulated rods: it has no slave cylinders")
        forces = slave.rod.slave_train_forces(
            slave.master_angle,
            crank_speed=crank_speed,
            gas_force=gas_force,
            reciprocating_mass=slave.reciprocating_mass,
            knuckle_mass=slave.knuckle_mass,
            gravity=gravity,
        )
        gas = slave.rod.slave_loads(slave.master_angle, forces.gas_force)
        g = slave.rod.bank_angle
        cos_g, sin_g = math.cos(g), math.sin(g)

        def own(x: FloatArray, y: FloatArray) -> list[FloatArray]:  # the master's frame into the slave's
            return [x * cos_g - y * sin_g, x * sin_g + y * cos_g]

        loads = forces.loads
        return np.stack(
            [
                *own(forces.inertia_force_x, forces.inertia_force_y),
                loads.torque,
                gas.torque,
                *own(loads.pin_force_x, loads.pin_force_y),
            ]
        )

    @property
    def crank_angle(self) -> FloatArray:
        """The model's crank-angle grid over one cycle [rad]."""
        return self._setup.alpha

    def cylinder_pressure(self, load: float) -> FloatArray:
        """Absolute pressure of one cylinder over the grid, from its firing TDC [Pa]."""
        setup = self._setup
        if self.gas == "parametric":
            assert self._cycle is not None and setup.gas_basis is not None
            a, b = setup.gas_basis
            return self._cycle.charge_pressure(load) * a + self._cycle.heat_release(load) * b
        if self.gas == "measured":
            assert setup.measured_pressure is not None
            trace = self.engine.pressure_trace
            if trace is not None and trace.load is not None and abs(trace.load - load) > 0.05:
                warnings.warn(
                    f"the measured pressure trace was taken at load {trace.load:g}, used as is for "
                    f"load {load:g}; give a trace at this load or use gas='parametric'",
                    DataQualityWarning,
                    stacklevel=2,
                )
            return setup.measured_pressure
        return np.full_like(setup.alpha, self._ambient)

    def cylinder_forces(self, crank_speed: float, load: float) -> CrankTrainForces:
        """Forces of cylinder 1 over the cycle grid at a constant crank speed.

        Parameters
        ----------
        crank_speed : float
            omega [rad/s].
        load : float
            Fraction of rated IMEP, 0..1.1 [-].

        Returns
        -------
        CrankTrainForces
            Over :attr:`crank_angle` (cylinder 1's crank angle from its firing TDC).
        """
        if not 0.0 <= load <= 1.1:
            raise ModelError(f"load = {load!r}: expected 0 <= load <= 1.1 (fraction of rated IMEP)")
        f_gas = gas_force(self.cylinder_pressure(load), self.engine.piston_area, self._ambient)
        return crank_train_forces(
            self.kinematics,
            self.train,
            crank_speed=crank_speed,
            gas_force=f_gas,
            rod_model=self.rod_model,
            gravity=self.gravity,
        )

    def unbalance_force(self, crank_speed: float) -> tuple[FloatArray, FloatArray]:
        """Centrifugal force of cylinder 1's share of its throw's unbalance over the grid (x, y) [N].

        The whole throw's in line; half on a V, whose two cylinders on a throw each carry half of it
        (both see the same crank pin, so their halves, turned into the engine's frame, add to the
        throw's).
        """
        omega, _ = check_crank_speed(crank_speed)
        u = self.engine.net_crank_unbalance * omega**2 * self.engine.throws / self.engine.cylinders
        alpha = self._setup.alpha
        return u * np.sin(alpha), u * np.cos(alpha)
