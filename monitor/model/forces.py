"""Forces in the crank train of one cylinder: inertia, gas, and their decomposition.

Frame and signs (the section frame of :mod:`monitor.model.kinematics`): ``y`` along
the cylinder axis towards the head, ``x`` across it, the crank pin at
``R (sin a, cos a)``.  The cylinder stands vertically above the crankshaft, so
gravity acts along ``-y`` (towards the crank).

- ``piston_force`` F: resultant along the cylinder axis on the piston pin,
  positive towards the crank: gas force plus the reciprocating inertia
  force plus the reciprocating weight (paper 004 eq. 5-6, Fig. 5).
- ``guide_force`` N: force of the liner or crosshead guide on the piston
  along ``+x`` (004 eq. 8: ``N = F tan beta``); the guide carries ``-N``.
- ``rod_force`` S: force along the rod axis, positive in compression (004
  eq. 9).  Two-mass: ``S = F / cos beta`` in the massless rod; rigid rod: the
  axial component of the force the rod exerts on the crank pin.  ``F`` and
  ``S`` therefore mean slightly different things in the two models (the
  two-mass ``F`` includes the rod's piston-pin share); the forces on the
  crank pin, ``T``, ``K``, the torque and ``N`` are the same physical
  quantities in both and are what the models are compared on.
- ``tangential_force`` T: force on the crank pin in the direction of
  rotation (004 eq. 10); ``torque = T R`` drives the crankshaft (004 eq. 15).
- ``radial_force`` K: force on the crank pin towards the crankshaft axis,
  including the rotating rod mass (004 eq. 11-12, with eq. 12's brackets
  restored: ``K = S cos(alpha + beta) + F_bo``, ``F_bo = -m_bo R omega^2``).
- ``pin_force_x``, ``pin_force_y``: the same force on the crank pin as a
  vector in the section frame.

Two models of the connecting rod are siblings here:

- ``"two-mass"``: the classic split (004: "25 % at the piston pin, 75 % at the
  crank pin", in general by the centre of gravity): mass ``m_r (1 - k)``
  reciprocates with the piston, ``m_r k`` rotates with the crank pin, where
  ``k`` is the centre of gravity's distance from the piston pin over ``L``.
  It keeps mass and centre of gravity but sets the moment of inertia to
  ``m_r k (1 - k) L^2``.
- ``"rigid"``: the rod as a rigid body with its mass, centre of gravity and
  moment of inertia ``I_G``, solved by Newton-Euler (piston: along ``x`` and
  ``y``; rod: force and moment about ``G``).  The two agree exactly when
  ``I_G = m_r k (1 - k) L^2`` (a test), and otherwise differ by the rod's
  inertia torque ``(I_G - m_r k (1 - k) L^2) beta''``.

References
----------
004: Kluczyk, eq. 5-15.  003: Zubaydi et al., eq. 2-8 (rod centre-of-gravity
acceleration and inertia force).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import numpy as np
import numpy.typing as npt

from monitor.errors import ModelError
from monitor.model.engine import Engine
from monitor.model.kinematics import (
    check_crank_speed,
    check_rod_ratio,
    piston_x_derivatives,
    piston_x_derivatives_approx,
    rod_angle_derivatives,
)
from monitor.types import FloatArray

__all__ = [
    "STANDARD_GRAVITY",
    "CrankKinematics",
    "CrankTrain",
    "CrankTrainForces",
    "RodModel",
    "crank_kinematics",
    "crank_train_forces",
]

RodModel = Literal["rigid", "two-mass"]
KinematicsModel = Literal["exact", "approx"]

#: Standard acceleration of gravity [m/s^2].
STANDARD_GRAVITY = 9.80665
#: Smallest rod ratio of a crank train with a connecting rod [-].
MIN_ROD_RATIO = 1e-3


@dataclass(frozen=True)
class CrankTrain:
    """Parameters of one cylinder's crank train, SI.

    Attributes
    ----------
    crank_radius : float
        R [m].
    rod_ratio : float
        lambda = R / L [-].
    piston_mass : float
        Piston assembly (with piston rod and crosshead on a crosshead engine) [kg].
    rod_mass : float
        Connecting rod [kg].
    rod_cg_fraction : float
        Rod centre of gravity from the piston pin over L [-].
    rod_inertia : float
        Rod moment of inertia about its centre of gravity [kg m^2].
    """

    crank_radius: float
    rod_ratio: float
    piston_mass: float
    rod_mass: float
    rod_cg_fraction: float
    rod_inertia: float

    def __post_init__(self) -> None:
        check_rod_ratio(self.rod_ratio)
        if self.rod_ratio < MIN_ROD_RATIO:
            raise ModelError(
                f"rod_ratio = {self.rod_ratio!r}: expected >= {MIN_ROD_RATIO:g} for a crank train "
                "with a connecting rod (a rod over 1000 crank radii long is not one)"
            )
        for name in ("crank_radius", "piston_mass", "rod_mass", "rod_inertia"):
            value = getattr(self, name)
            if not (np.isfinite(value) and value > 0):
                raise ModelError(f"{name} = {value!r}: expected a positive, finite value")
        if not 0.0 <= self.rod_cg_fraction <= 1.0:
            raise ModelError(f"rod_cg_fraction = {self.rod_cg_fraction!r}: expected 0..1")

    @classmethod
    def of(cls, engine: Engine) -> CrankTrain:
        """The crank train of an engine description (all cylinders alike)."""
        m = engine.masses
        return cls(
            engine.crank_radius,
            engine.rod_ratio,
            m.piston_assembly_kg,
            m.conrod_kg,
            engine.conrod_cg_fraction,
            m.conrod_inertia_kgm2,
        )

    @property
    def rod_length(self) -> float:
        """L [m]."""
        return self.crank_radius / self.rod_ratio

    @property
    def reciprocating_mass(self) -> float:
        """Piston plus the rod's piston-pin share (two-mass split) [kg]."""
        return self.piston_mass + self.rod_mass * (1.0 - self.rod_cg_fraction)

    @property
    def rotating_rod_mass(self) -> float:
        """The rod's crank-pin share (two-mass split) [kg]."""
        return self.rod_mass * self.rod_cg_fraction

    @property
    def two_mass_inertia(self) -> float:
        """Moment of inertia the two-mass split implies, m k (1 - k) L^2 [kg m^2]."""
        k = self.rod_cg_fraction
        return self.rod_mass * k * (1.0 - k) * self.rod_length**2


@dataclass(frozen=True)
class CrankKinematics:
    """Angle-only kinematics of a crank train, reusable for any crank speed.

    Attributes
    ----------
    crank_angle : ndarray
        alpha [rad].
    dx, d2x : ndarray
        Piston displacement derivatives dx/da [m/rad], d2x/da2 [m/rad^2].
    beta, dbeta, d2beta : ndarray
        Rod angle [rad] and its derivatives [-], [1/rad].
    model : {"exact", "approx"}
        Piston kinematics used (the rod angle is always exact).
    """

    crank_angle: FloatArray
    dx: FloatArray
    d2x: FloatArray
    beta: FloatArray
    dbeta: FloatArray
    d2beta: FloatArray
    model: KinematicsModel


def crank_kinematics(
    crank_angle: npt.ArrayLike,
    crank_radius: float,
    rod_ratio: float,
    *,
    model: KinematicsModel = "exact",
) -> CrankKinematics:
    """Evaluate the angle-only kinematics once, for reuse at any speed.

    Parameters
    ----------
    crank_angle : array_like
        alpha [rad].
    crank_radius : float
        R [m].
    rod_ratio : float
        lambda [-].
    model : {"exact", "approx"}
        Exact piston kinematics (paper 000 eq. 6-10) or the two-term approximation (eq. 5-9).

    Returns
    -------
    CrankKinematics
    """
    check_rod_ratio(rod_ratio)
    if model == "exact":
        _, dx, d2x = piston_x_derivatives(crank_angle, crank_radius, rod_ratio)
    elif model == "approx":
        _, dx, d2x = piston_x_derivatives_approx(crank_angle, crank_radius, rod_ratio)
    else:
        raise ModelError(f"kinematics model = {model!r}: expected 'exact' or 'approx'")
    beta, dbeta, d2beta = rod_angle_derivatives(crank_angle, rod_ratio)
    alpha = np.asarray(crank_angle, dtype=np.float64)
    return CrankKinematics(alpha, dx, d2x, beta, dbeta, d2beta, model)


@dataclass(frozen=True)
class CrankTrainForces:
    """Forces of one crank train over crank angle (see the module docstring for signs).

    Every array has the shape of the crank angle; forces [N], torque [N m].
    ``inertia_force_x``/``_y`` is the inertia force of the moving parts
    (piston and rod; not the crank throw) acting on the engine through the
    bearings: what the free forces of the engine add up.
    """

    crank_angle: FloatArray
    gas_force: FloatArray
    piston_force: FloatArray
    guide_force: FloatArray
    rod_force: FloatArray
    tangential_force: FloatArray
    radial_force: FloatArray
    torque: FloatArray
    pin_force_x: FloatArray
    pin_force_y: FloatArray
    inertia_force_x: FloatArray
    inertia_force_y: FloatArray


def crank_train_forces(
    kinematics: CrankKinematics,
    train: CrankTrain,
    *,
    crank_speed: npt.ArrayLike,
    crank_acceleration: npt.ArrayLike = 0.0,
    gas_force: npt.ArrayLike = 0.0,
    rod_model: RodModel = "rigid",
    gravity: float = STANDARD_GRAVITY,
) -> CrankTrainForces:
    """Forces in one crank train at the given crank speed.

    Parameters
    ----------
    kinematics : CrankKinematics
        From :func:`crank_kinematics` for the same crank radius and rod ratio.
    train : CrankTrain
        Masses and geometry.
    crank_speed : array_like
        omega, broadcast against the crank angle [rad/s].
    crank_acceleration : array_like, optional
        domega/dt [rad/s^2].
    gas_force : array_like, optional
        Gas force on the piston, positive towards the crank [N].
    rod_model : {"rigid", "two-mass"}
        Connecting rod as a rigid body or as the classic two-mass split.
    gravity : float, optional
        Acceleration of gravity along ``-y``; 0 leaves the weights out [m/s^2].

    Returns
    -------
    CrankTrainForces

    Notes
    -----
    Two-mass (004 eq. 5-15 with weights and a varying speed)::

        F = F_g - m_rec a_p + m_rec g,   N = F tan b,   S = F / cos b
        pin force = S (sin b, -cos b) - m_rot a_B + (0, -m_rot g)

    Rigid rod (Newton-Euler; P the force of the rod on the piston, u the unit
    vector from piston pin to crank pin, ``u x V = u_x V_y - u_y V_x``)::

        P_y = -m_p a_p + F_g + m_p g
        u x P = [I_G b'' - (L - l_A) u x m_r (a_G + g y)] / L
        pin force = -(m_r a_G + P + m_r g y)

    Then ``T = pin . (cos a, -sin a)``, ``K = -pin . (sin a, cos a)``, ``M = T R``.
    """
    if rod_model not in ("rigid", "two-mass"):
        raise ModelError(f"rod_model = {rod_model!r}: expected 'rigid' or 'two-mass'")
    if rod_model == "rigid" and kinematics.model != "exact":
        raise ModelError(
            "rod_model = 'rigid' needs the exact kinematics; the two-term approximation is "
            "defined for the classic two-mass model only"
        )
    omega, omega_dot = check_crank_speed(crank_speed, crank_acceleration)
    f_gas = np.broadcast_to(np.asarray(gas_force, dtype=np.float64), kinematics.crank_angle.shape)
    if f_gas.size and not np.all(np.isfinite(f_gas)):
        raise ModelError("gas_force contains NaN or Inf: expected finite forces [N]")
    alpha = kinematics.crank_angle
    radius = train.crank_radius
    w2 = omega * omega
    a_piston = kinematics.d2x * w2 + kinematics.dx * omega_dot  # towards the crank
    sin_a, cos_a = np.sin(alpha), np.cos(alpha)
    sin_b, cos_b = np.sin(kinematics.beta), np.cos(kinematics.beta)
    # crank-pin acceleration a_B
    bx = radius * (-w2 * sin_a + omega_dot * cos_a)
    by = radius * (-w2 * cos_a - omega_dot * sin_a)

    if rod_model == "two-mass":
        m_rec, m_rot = train.reciprocating_mass, train.rotating_rod_mass
        piston_force = f_gas - m_rec * a_piston + m_rec * gravity
        rod_force_axial = piston_force / cos_b
        guide = piston_force * sin_b / cos_b
        pin_x = rod_force_axial * sin_b - m_rot * bx
        pin_y = -rod_force_axial * cos_b - m_rot * by - m_rot * gravity
        inertia_x = -m_rot * bx
        inertia_y = m_rec * a_piston - m_rot * by  # -m a along y; a_piston points along -y
    else:
        m_p, m_r, k = train.piston_mass, train.rod_mass, train.rod_cg_fraction
        length = train.rod_length
        ay_pin = -a_piston  # piston-pin acceleration along y
        gx = k * bx
        gy = (1.0 - k) * ay_pin + k * by
        beta_ddot = kinematics.d2beta * w2 + kinematics.dbeta * omega_dot
        p_y = m_p * ay_pin + f_gas + m_p * gravity
        # u = (sin b, -cos b); u x V = sin b V_y + cos b V_x
        vx, vy = m_r * gx, m_r * (gy + gravity)
        u_cross_p = (train.rod_inertia * beta_ddot - (1.0 - k) * length * (sin_b * vy + cos_b * vx)) / length
        p_x = (u_cross_p - sin_b * p_y) / cos_b
        piston_force = p_y * 1.0  # force of the rod on the piston along y = what pushes the pin
        guide = -p_x
        pin_x = -(vx + p_x)
        pin_y = -(vy + p_y)
        rod_force_axial = pin_x * sin_b - pin_y * cos_b
        inertia_x = -m_r * gx
        inertia_y = -(m_p * ay_pin + m_r * gy)

    tangential = pin_x * cos_a - pin_y * sin_a
    radial = -(pin_x * sin_a + pin_y * cos_a)
    shape = alpha.shape
    return CrankTrainForces(
        crank_angle=alpha,
        gas_force=np.array(f_gas),
        piston_force=np.broadcast_to(piston_force, shape).copy(),
        guide_force=np.broadcast_to(guide, shape).copy(),
        rod_force=np.broadcast_to(rod_force_axial, shape).copy(),
        tangential_force=np.broadcast_to(tangential, shape).copy(),
        radial_force=np.broadcast_to(radial, shape).copy(),
        torque=np.broadcast_to(tangential * radius, shape).copy(),
        pin_force_x=np.broadcast_to(pin_x, shape).copy(),
        pin_force_y=np.broadcast_to(pin_y, shape).copy(),
        inertia_force_x=np.broadcast_to(inertia_x, shape).copy(),
        inertia_force_y=np.broadcast_to(inertia_y, shape).copy(),
    )
