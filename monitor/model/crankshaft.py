"""The multi-cylinder crankshaft: phasing, engine torque, main-bearing forces, free forces.

Every cylinder's crank train is the same function of its own crank angle
``alpha_c = alpha - phi_c`` (``phi_c`` its firing angle, see
:mod:`monitor.model.engine`), so a quantity of cylinder ``c`` has the order
coefficients of cylinder 1 times ``exp(-j k phi_c)``: the phase shift is
exact and costs one complex multiplication per order.  Four-stroke gas
quantities repeat over two revolutions (half orders); inertia quantities
repeat every revolution.

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

import warnings
from dataclasses import dataclass
from typing import Literal

import numpy as np

from monitor.errors import DataQualityWarning, ModelError
from monitor.fourier import cycle_grid
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
